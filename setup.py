"""ament_python package: builds with colcon in a ROS 2 Jazzy install and with pip in a venv."""
from glob import glob

from setuptools import find_packages, setup

PACKAGE = "littledog_mlsim"

setup(
    name=PACKAGE,
    version="0.1.0",
    packages=find_packages(exclude=["test", "test.*", "benchmarks"]),
    package_data={PACKAGE: ["robot/*.urdf"]},
    data_files=[
        ("share/ament_index/resource_index/packages", [f"resource/{PACKAGE}"]),
        (f"share/{PACKAGE}", ["package.xml"]),
        (f"share/{PACKAGE}/config", glob("config/*.yaml")),
        (f"share/{PACKAGE}/config/effects", glob("config/effects/*.yaml")),
        (f"share/{PACKAGE}/urdf", glob(f"{PACKAGE}/robot/*.urdf")),
    ],
    python_requires=">=3.10",
    install_requires=["setuptools"],
    zip_safe=True,
    maintainer="littledog_mlsim maintainers",
    maintainer_email="maintainers@littledog-mlsim.invalid",
    description="Learned rigid-body simulator of the LittleDog quadruped for ROS 2",
    license="BSD-3-Clause",
    entry_points={
        "console_scripts": [
            "littledog-mlsim = littledog_mlsim.cli:main",
            "sim_node = littledog_mlsim.nodes.sim_node:main",
            "trainer_node = littledog_mlsim.nodes.trainer_node:main",
            "pybullet_node = littledog_mlsim.nodes.pybullet_node:main",
            "bag_player = littledog_mlsim.nodes.bag_player:main",
            "bag_recorder = littledog_mlsim.nodes.bag_recorder:main",
            "topic_echo = littledog_mlsim.nodes.topic_echo:main",
            "viewer_node = littledog_mlsim.nodes.viewer_node:main",
        ],
    },
)
