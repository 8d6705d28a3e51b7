"""ament_python package: builds with colcon in a ROS 2 Jazzy install and with pip in a venv.

The pip route declares every run-time dependency: ``install_requires`` is read from
``requirements.txt`` (one list of pins for ``make``, ``pip install .`` and the wheel), without
the test and build tools, which go to the ``test`` extra. In a sourced ROS 2 environment
(``AMENT_PREFIX_PATH`` set, the colcon route) rclpy and the message packages come from the ROS
install, so the ``ros-jazzy-*`` wheels are left out there.
"""
import os
from glob import glob
from pathlib import Path

from setuptools import find_packages, setup

PACKAGE = "littledog_mlsim"
_TOOLS = ("pytest", "setuptools", "wheel")   # test and build tools: not run-time dependencies


def _requirements() -> tuple[list[str], list[str]]:
    """(run-time requirements, tool requirements) from requirements.txt."""
    run, tools = [], []
    for line in (Path(__file__).parent / "requirements.txt").read_text().splitlines():
        req = line.split("#", 1)[0].strip()
        if not req:
            continue
        name = req.split("[", 1)[0].split("=", 1)[0].split("<", 1)[0].split(">", 1)[0].strip()
        if name.lower() in _TOOLS:
            tools.append(req)
        elif name.startswith("ros-") and os.environ.get("AMENT_PREFIX_PATH"):
            continue
        else:
            run.append(req)
    return run, tools


INSTALL_REQUIRES, TOOLS_REQUIRE = _requirements()

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
    install_requires=INSTALL_REQUIRES,
    extras_require={"test": [r for r in TOOLS_REQUIRE if r.lower().startswith("pytest")]},
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
