"""The main job (``littledog_mlsim/demo.py``) and ``topic_echo`` over real DDS.

The demo's core function runs on a tiny dataset (two F moves: one TrainPool, one TestPool) with
an LR model and a shortened move; it must return finite errors, reproduce the recorded bag
through pybullet_node and the core's rollout through sim_node, and leave no process behind,
also when sim_node fails to start. topic_echo prints, as ROS YAML, messages a publisher in
another process sends (volatile and transient-local). Domains come from the pid, discovery is
localhost-only; every wait is on an event or a process with a timeout.
"""
from __future__ import annotations

import os
import select
import shutil
import signal
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
import yaml

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

from littledog_mlsim.data.bags import read_bag  # noqa: E402
from littledog_mlsim.apps.demo import DemoError, main, run_demo  # noqa: E402
from littledog_mlsim.layout import HOME_POSE, JOINT_NAMES  # noqa: E402
from littledog_mlsim.models.onestep import OneStepModel  # noqa: E402
from littledog_mlsim.nodes import messages as m  # noqa: E402
from littledog_mlsim.nodes.topic_echo import message_to_dict, message_to_yaml  # noqa: E402
from littledog_mlsim.rollout.simulate import prepare_test_move, rollout  # noqa: E402

BIN = Path(sys.executable).parent
# the demo uses DOMAIN and DOMAIN + 1; LITTLEDOG_TEST_DOMAIN_ID picks DOMAIN (as in test_nodes)
DOMAIN = int(os.environ.get("LITTLEDOG_TEST_DOMAIN_ID") or 2 + 2 * ((os.getpid() + 17) % 49))
TIMEOUT = 60.0


def children(pid: int | None = None) -> set[int]:
    """Pids of the live (or unreaped) children of ``pid`` (default: this process)."""
    pid = os.getpid() if pid is None else pid
    out = set()
    for d in Path("/proc").iterdir():
        if not d.name.isdigit():
            continue
        try:
            stat = (d / "stat").read_text()
        except OSError:
            continue
        if int(stat.rsplit(")", 1)[1].split()[1]) == pid:
            out.add(int(d.name))
    return out


def gone(pid: int) -> bool:
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return True
    return False


# ---------------------------------------------------------------------------------------------
# the demo


def test_demo_core_on_tiny_dataset(tiny):
    data, model_path = tiny
    before = children()
    lines: list[str] = []
    r = run_demo(data, model_path, max_steps=60, domain=DOMAIN, log=lines.append,
                 projection="none")
    assert children() == before, "a simulator process survived the demo"
    assert len(r.pids) == 2 and all(gone(p) for p in r.pids)
    assert r.exit_codes == {"sim_node": 0, "pybullet_node": 0}
    assert r.move == "F_01" and r.split == "test" and r.n_steps == 59
    assert r.domains == (DOMAIN, DOMAIN + 1) and r.projection == "no projection"
    assert np.isfinite(r.final_xy_error_m) and np.isfinite(r.mean_joint_error_rad)
    assert r.mean_joint_error_rad > 0
    assert all(np.isfinite(v) for v in r.rms.values())
    assert all(v.shape == (59,) and np.all(np.isfinite(v)) for v in r.per_step.values())
    assert r.final_xy_error_m == pytest.approx(r.per_step["xy_m"][-1])
    # pybullet_node with the move's recording seed replays the bag exactly ...
    assert r.bag_max_diff == 0.0
    # ... and sim_node's published states are the core's rollout from the recorded s_1
    model = OneStepModel.load(model_path)
    tm = prepare_test_move(read_bag(data / "F_01"))
    ref = rollout(model, tm.s0, tm.actions[:59], model.projection("none"))
    np.testing.assert_allclose(r.learned_states, ref, rtol=0, atol=1e-12)
    np.testing.assert_allclose(r.pybullet_states[1:], tm.states[:59], rtol=0, atol=0)
    # the example messages are ros2-topic-echo YAML of the last step
    odom = yaml.safe_load(r.example_odom)
    assert odom["header"]["frame_id"] == "odom" and odom["child_frame_id"] == "base_link"
    assert odom["header"]["stamp"] == {"sec": 0, "nanosec": 600_000_000}
    assert len(odom["pose"]["covariance"]) == 36
    js = yaml.safe_load(r.example_joint_states)
    assert js["name"] == list(JOINT_NAMES) and js["effort"] == []
    np.testing.assert_array_equal(js["position"], r.learned_states[-1, 9:21])
    assert any("replayed 60 lockstep steps" in ln for ln in lines)


def test_demo_bad_model_is_one_line_and_stops_everything(tiny, tmp_path):
    data, model_path = tiny
    bad = tmp_path / "bad_model"
    shutil.copytree(model_path, bad)
    raw = (bad / "arrays.npz").read_bytes()
    (bad / "arrays.npz").write_bytes(raw[: len(raw) // 2])
    before = children()
    with pytest.raises(DemoError) as info:
        run_demo(data, bad, max_steps=10, domain=DOMAIN, log=lambda s: None)
    text = str(info.value)
    assert "\n" not in text and "sim_node exited with status 2" in text and "model" in text
    assert children() == before


def test_demo_main_rejects_unknown_move_before_any_work(tiny, capsys):
    data, _ = tiny
    rc = main(["--data", str(data), "--model", str(data.parent / "never_trained"),
               "--move", "ZZ_00"])
    err = capsys.readouterr().err.strip().splitlines()
    assert rc == 1 and err == [f"demo: error: no move ZZ_00 in {data}/dataset.yaml"]
    assert not (data.parent / "never_trained").exists()


# ---------------------------------------------------------------------------------------------
# topic_echo


def test_message_to_yaml_is_ros2_topic_echo_format():
    q = HOME_POSE
    text = message_to_yaml(m.joint_state_msg(1_230_000_000, q, np.zeros(12)))
    assert text.startswith("header:\n  stamp:\n    sec: 1\n    nanosec: 230000000\n"
                           "  frame_id: ''\nname:\n- front_left_hip_roll\n")
    assert "position:\n- 0.1\n- 1.0\n- -1.55\n" in text and text.endswith("effort: []\n")
    assert message_to_yaml(m.clock_msg(2_500_000_000)) == "clock:\n  sec: 2\n  nanosec: 500000000\n"
    odom = m.odometry_msg(10_000_000, [1.0, 2.0, 0.146], [0, 0, 0, 1], [0.1, 0, 0], [0, 0, 0.01])
    d = message_to_dict(odom)
    assert list(d) == ["header", "child_frame_id", "pose", "twist"]
    assert d["pose"]["pose"]["position"] == {"x": 1.0, "y": 2.0, "z": 0.146}
    assert d["pose"]["covariance"] == [-1.0] + [0.0] * 35          # unknown: -1 in [0]
    assert yaml.safe_load(message_to_yaml(odom)) == d
    short = message_to_yaml(odom, no_arr=True, truncate_length=3)
    assert "  covariance: '<array type: double[36]>'\n" in short
    assert message_to_dict(m.joint_state_msg(0, q), truncate_length=2)["name"] == \
        ["fr...", "fr...", "..."]
    status = yaml.safe_load(message_to_yaml(m.status_msg("sim_node", {"steps": 3})))
    assert status["values"] == [{"key": "steps", "value": "3"}]


PUBLISHER = """
import sys, rclpy
from rclpy.node import Node
from nav_msgs.msg import Odometry
from sensor_msgs.msg import JointState
from littledog_mlsim.layout import HOME_POSE
from littledog_mlsim.nodes import messages as m
from littledog_mlsim.nodes.simulator import QOS, SIM_QOS
rclpy.init()
node = Node("test_publisher")
odom = node.create_publisher(Odometry, "/littledog/odom", QOS)            # volatile
js = node.create_publisher(JointState, "/littledog/joint_states", SIM_QOS)  # transient-local
js.publish(m.joint_state_msg(70_000_000, HOME_POSE, [0.5] * 12))           # once, kept
print("ready", flush=True)
k = 0
def tick():
    global k
    k += 1
    odom.publish(m.odometry_msg(k * 10_000_000, [0.25, -0.5, 0.146], [0, 0, 0, 1],
                                [0.1, 0, 0], [0, 0, 0]))
node.create_timer(0.05, tick)
try:
    rclpy.spin(node)
except Exception:
    pass
"""


def test_topic_echo_prints_messages_of_another_process(tmp_path):
    env = dict(os.environ, ROS_DOMAIN_ID=str(DOMAIN), ROS_AUTOMATIC_DISCOVERY_RANGE="LOCALHOST")
    script = tmp_path / "publisher.py"
    script.write_text(PUBLISHER)
    err = tmp_path / "publisher.err"
    with open(err, "w") as f:
        pub = subprocess.Popen([sys.executable, str(script)], env=env, stdout=subprocess.PIPE,
                               stderr=f, text=True)
    out = {}
    try:
        # topic_echo joins after the publisher is up (the usual order; ~2.5 s discovery)
        ready, _, _ = select.select([pub.stdout], [], [], TIMEOUT)
        assert ready and pub.stdout.readline() == "ready\n", f"publisher: {err.read_text()}"
        for topic, extra in (("/littledog/odom", ["--count", "2"]),
                             ("/littledog/joint_states", ["--once"])):
            r = subprocess.run([str(BIN / "topic_echo"), topic, *extra, "--timeout", "45"],
                               env=env, capture_output=True, text=True, timeout=TIMEOUT)
            assert r.returncode == 0, f"topic_echo {topic}: {r.stderr}"
            out[topic] = r.stdout
    finally:
        pub.send_signal(signal.SIGINT)
        try:
            pub.wait(TIMEOUT)
        except subprocess.TimeoutExpired:
            pub.kill()
            pub.wait()
    docs = out["/littledog/odom"].split("---\n")
    assert len(docs) == 3 and docs[2] == ""        # two messages, each followed by ---
    for doc in docs[:2]:
        odom = yaml.safe_load(doc)
        assert odom["header"]["frame_id"] == "odom"
        assert odom["pose"]["pose"]["position"] == {"x": 0.25, "y": -0.5, "z": 0.146}
        assert odom["twist"]["twist"]["linear"]["x"] == 0.1
    js_text = out["/littledog/joint_states"]
    assert js_text.endswith("---\n") and js_text.count("---\n") == 1
    js = yaml.safe_load(js_text[: -len("---\n")])
    assert js["header"]["stamp"] == {"sec": 0, "nanosec": 70_000_000}   # the kept message
    assert js["name"] == list(JOINT_NAMES)
    assert js["position"] == [float(x) for x in HOME_POSE] and js["velocity"] == [0.5] * 12
