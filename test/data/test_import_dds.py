"""A recording made over real DDS, imported, trained on and served (issue: learn from real bags).

pybullet_node runs in timer mode (sim-time stamps); a controller in this process drives two moves
on its own 100 Hz timer, stamping with its own wall clock and sending its joints in its own order,
with a reset between the moves; a recorder in this process subscribes raw (the exact CDR bytes)
and writes the receive times as bag times, the way ``ros2 bag record`` does. trainer_node
imports the bag itself (``bags`` parameter) and trains an LR model; sim_node loads it and steps.

One ROS domain for the module from the range 120-139, localhost discovery; every wait is on an
event with a timeout.
"""
from __future__ import annotations

import subprocess
import threading
import time
from pathlib import Path

import numpy as np
import pytest

from rosharness import BIN, ENV, Proc, Ros, call_service  # noqa: E402  (first: test domain)
from nav_msgs.msg import Odometry  # noqa: E402
from rclpy.node import Node  # noqa: E402
from rclpy.qos import QoSProfile, ReliabilityPolicy, HistoryPolicy  # noqa: E402
from sensor_msgs.msg import JointState  # noqa: E402
from std_srvs.srv import Trigger  # noqa: E402

from littledog_mlsim.data.dataset import load_moves  # noqa: E402
from littledog_mlsim.data.importer import ImportOptions, import_bags  # noqa: E402
from littledog_mlsim.gait.trot import sample_trot_params, trot_commands  # noqa: E402
from littledog_mlsim.layout import JOINT_NAMES  # noqa: E402
from littledog_mlsim.models.onestep import OneStepModel  # noqa: E402
from waiting import TIMEOUT, wait_until  # noqa: E402

QOS = QoSProfile(history=HistoryPolicy.KEEP_LAST, depth=100,
                 reliability=ReliabilityPolicy.RELIABLE)
CTRL_ORDER = list(reversed(JOINT_NAMES))
N_STEPS = 250            # commands per move (2.5 s)


class Recorder:
    """Raw subscriptions; every message kept as (receive time, exact CDR bytes)."""

    TOPICS = {"/littledog/cmd": JointState, "/littledog/joint_states": JointState,
              "/littledog/odom": Odometry}

    def __init__(self, node: Node) -> None:
        self.lock = threading.Lock()
        self.msgs: list[tuple[int, str, bytes]] = []
        self.subs = [node.create_subscription(t, topic, self._cb(topic), QOS, raw=True)
                     for topic, t in self.TOPICS.items()]

    def _cb(self, topic: str):
        def cb(raw: bytes, info) -> None:
            recv = int(info["received_timestamp"]) or time.time_ns()
            with self.lock:
                self.msgs.append((recv, topic, bytes(raw)))
        return cb

    def count(self, topic: str) -> int:
        with self.lock:
            return sum(1 for _, t, _ in self.msgs if t == topic)

    def write(self, path: Path) -> None:
        from rosbags.rosbag2 import StoragePlugin, Writer
        from rosbags.typesys import Stores, get_typestore

        ts = get_typestore(Stores.ROS2_JAZZY)
        with self.lock:
            msgs = sorted(self.msgs, key=lambda m: m[0])
        with Writer(path, version=9, storage_plugin=StoragePlugin.MCAP) as w:
            conns = {topic: w.add_connection(topic, t.__module__.split(".")[0] + "/msg/"
                                             + t.__name__, typestore=ts)
                     for topic, t in self.TOPICS.items()}
            for recv, topic, raw in msgs:
                w.write(conns[topic], recv, raw)


class Controller:
    """Its own 100 Hz wall timer: one command per tick, its own stamps and joint order."""

    def __init__(self, node: Node) -> None:
        self.node = node
        self.pub = node.create_publisher(JointState, "/littledog/cmd", QOS)
        self.commands: np.ndarray | None = None
        self.k = 0
        self.done = threading.Event()
        self.sent: list[np.ndarray] = []
        node.create_timer(0.01, self._tick)

    def start(self, commands: np.ndarray) -> None:
        self.k, self.done = 0, threading.Event()
        self.commands = commands

    def _tick(self) -> None:
        if self.commands is None:
            return
        u = self.commands[self.k]
        msg = JointState()
        msg.header.stamp = self.node.get_clock().now().to_msg()
        msg.name = CTRL_ORDER
        perm = [JOINT_NAMES.index(j) for j in CTRL_ORDER]
        msg.position = [float(x) for x in u[perm]]
        self.pub.publish(msg)
        self.sent.append(u)
        self.k += 1
        if self.k == len(self.commands):
            self.commands = None
            self.done.set()


@pytest.fixture(scope="module")
def recording(tmp_path_factory):
    tmp = tmp_path_factory.mktemp("dds")
    ros = Ros()
    node = ros.node("import_test")
    sim = Proc("pybullet_node", {"step_mode": "timer", "publish_clock": "false"}, tmp)
    try:
        rec = Recorder(node)
        ctrl = Controller(node)
        reset = node.create_client(Trigger, "/pybullet_node/reset")
        wait_until(lambda: sim.p.poll() is None and reset.service_is_ready()
                   and ctrl.pub.get_subscription_count() >= 1
                   and all(s.get_publisher_count() >= 1 for s in rec.subs[1:]),
                   what="discovery of pybullet_node")
        wait_until(lambda: rec.count("/littledog/joint_states") >= 20, what="joint states")
        rng = np.random.default_rng(0)
        for t in ("F", "L"):
            ctrl.start(trot_commands(sample_trot_params(t, rng))[:N_STEPS])
            assert ctrl.done.wait(60), "controller did not finish"
            time.sleep(0.2)   # the robot holds the last command (measurement window, not a wait)
            call_service(reset, Trigger.Request())
            time.sleep(0.2)
        bag = tmp / "recording"
        rec.write(bag)
        assert sim.stop() == 0, sim.err.read_text()     # sim_node takes the topics next
        with rec.lock:
            msgs = list(rec.msgs)
        yield tmp, bag, np.array(ctrl.sent), node, msgs
    finally:
        try:
            sim.stop()
        finally:
            ros.close()


def test_dds_recording_imports(recording):
    tmp, bag, sent, _, msgs = recording
    out = tmp / "data"
    r = import_bags([bag], out, ImportOptions(test_fraction=0.0))
    b = r.report["bags"][0]
    topics = b["topics"]
    assert topics["joint_states"]["time_source"] == "aligned"   # sim time, another clock
    assert topics["pose"]["time_source"] == "aligned"
    assert topics["cmd"]["time_source"] == "header"            # the controller's wall clock
    moves = load_moves(out, "all")
    # the oracle, from the raw messages on the sim's own clock (header stamps): a reset shows
    # where the pose (position or heading) or a joint jumps back to the start faster than the
    # robot can move, and a pause of the sim's clock (a step skipped under load) is a break too.
    # On a busy machine the robot may barely move in 2.5 s, so the reset may not be visible.
    from rclpy.serialization import deserialize_message

    def stamped(topic, t):
        out = [(deserialize_message(raw, t), recv) for recv, tp, raw in msgs if tp == topic]
        ns = np.array([o.header.stamp.sec * 1_000_000_000 + o.header.stamp.nanosec
                       for o, _ in out])
        return [o for o, _ in out], ns, np.array([r for _, r in out])

    odom, t_odom, r_odom = stamped("/littledog/odom", Odometry)
    js, t_js, r_js = stamped("/littledog/joint_states", JointState)
    p = np.array([[o.pose.pose.position.x, o.pose.pose.position.y] for o in odom])
    quat = np.array([[o.pose.pose.orientation.x, o.pose.pose.orientation.y,
                      o.pose.pose.orientation.z, o.pose.pose.orientation.w] for o in odom])
    dto = np.diff(t_odom) * 1e-9
    dang = 2 * np.arccos(np.clip(np.abs(np.sum(quat[1:] * quat[:-1], axis=1)), 0, 1))
    # how far past the importer's thresholds each sample is (1 = on the threshold)
    odom_r = np.maximum.reduce([np.linalg.norm(np.diff(p, axis=0), axis=1) / (0.05 + 2.0 * dto),
                                dang / (0.3 + 10.0 * dto), dto / 0.05])
    q = np.array([o.position for o in js])
    dtj = np.diff(t_js) * 1e-9
    js_r = np.maximum(np.abs(np.diff(q, axis=0)).max(axis=1) / (0.5 + 30.0 * dtj), dtj / 0.05)
    last_cmd = max(t for t, topic, _ in msgs if topic == "/littledog/cmd")

    def breaks(level: float) -> int:
        """Breaks (a reset or a pause) past ``level`` x the thresholds with commands after."""
        times = np.sort(np.concatenate([r_odom[1:][odom_r > level], r_js[1:][js_r > level]]))
        events = [t for k, t in enumerate(times) if k == 0 or t - times[k - 1] > 100_000_000]
        return sum(t < last_cmd for t in events)

    # a clear break must split the moves, nothing far below the thresholds may; one near them
    # (the robot barely moved before its reset) may go either way
    ended = [s["ended_by"] for s in b["segments"]]
    assert 1 + breaks(1.25) <= len(moves) <= 1 + breaks(0.8), (breaks(1.25), breaks(0.8), ended)
    assert all(any(w in e for w in ("reset", "gap", "time jump")) for e in ended[:-1]), ended
    # the first move starts with the controller's first command
    first_cmd = min(t for t, topic, _ in msgs if topic == "/littledog/cmd")
    assert -10_000_000 < moves[0].stamps_ns[0] - first_cmd < 30_000_000   # sent before it came
    # joint states on the sim's 10 ms clock: every imported sample is a published one
    js = {tuple(deserialize_message(raw, JointState).position)
          for _, topic, raw in msgs if topic == "/littledog/joint_states"}
    pub_q = np.array(sorted(js))
    names = deserialize_message(next(raw for _, t, raw in msgs
                                     if t == "/littledog/joint_states"), JointState).name
    perm = [list(names).index(j) for j in JOINT_NAMES]
    for m in moves:
        d = np.abs(m.q[:, None, :] - pub_q[None][:, :, perm]).max(axis=2).min(axis=1)
        assert d.max() == 0.0
    for m in moves:
        assert m.n_steps >= N_STEPS - 5    # (more: the held stretch, a reset not seen)
        # every command is one the controller sent (exact floats, back in contract order)
        d = np.abs(m.cmd[:, None, :] - sent[None]).max(axis=2).min(axis=1)
        assert d.max() == 0.0
        # joint states on the sim's own 10 ms clock: exactly the published samples
        assert np.all(np.diff(m.stamps_ns) == 10_000_000)


def test_trainer_node_trains_on_the_bag_and_sim_node_serves_it(recording):
    tmp, bag, _, node, _ = recording
    model = tmp / "model"
    p = subprocess.run([str(BIN / "trainer_node"), "--ros-args", "-p", f"bags:=[{bag}]",
                        "-p", f"out:={model}", "-p", "method:=lr", "-p",
                        "import_options:=\"{test_fraction: 0.0}\""],
                       capture_output=True, text=True, env=ENV, timeout=120)
    assert p.returncode == 0, p.stderr
    m = OneStepModel.load(model)
    assert m.method == "lr" and f"imported {m.info['n_moves']} moves" in p.stderr
    # a bag that is no bag: one FATAL line, nothing written
    bad = tmp / "bad.mcap"
    bad.write_bytes(b"not an mcap file")
    p = subprocess.run([str(BIN / "trainer_node"), "--ros-args", "-p", f"bags:=[{bad}]",
                        "-p", f"out:={tmp / 'model2'}"],
                       capture_output=True, text=True, env=ENV, timeout=120)
    assert p.returncode == 1 and str(bad) in p.stderr and not (tmp / "model2").exists()
    # sim_node loads the model and steps
    proc = Proc("sim_node", {"model_path": model, "step_mode": "lockstep"}, tmp)
    got: list[JointState] = []
    try:
        sub = node.create_subscription(JointState, "/littledog/joint_states", got.append, QOS)
        pub = node.create_publisher(JointState, "/littledog/cmd", QOS)
        wait_until(lambda: proc.p.poll() is None and pub.get_subscription_count() >= 1
                   and sub.get_publisher_count() >= 1, what="sim_node")
        msg = JointState()
        msg.name = list(JOINT_NAMES)
        msg.position = [float(x) for x in m.train_states[0, 9:21]]
        # matched on our side may not yet be on theirs: resend until a step comes back. The
        # step a first command made may have gone out before sim_node's publisher matched our
        # subscription, so any step counts, not only the first (stamp 10 ms)
        def stepped(g: JointState) -> bool:
            return g.header.stamp.sec > 0 or g.header.stamp.nanosec > 0

        end = time.monotonic() + TIMEOUT
        while not any(stepped(g) for g in got):
            assert time.monotonic() < end, "timed out waiting for a step of sim_node"
            pub.publish(msg)
            t = time.monotonic()
            while time.monotonic() - t < 0.5 and not any(stepped(g) for g in got):
                time.sleep(0.005)
        step = next(g for g in got if stepped(g))
        ns = step.header.stamp.sec * 1_000_000_000 + step.header.stamp.nanosec
        assert ns % 10_000_000 == 0, ns           # a whole number of 10 ms steps
        assert np.all(np.isfinite(step.position)) and len(step.position) == 12
    finally:
        assert proc.stop() == 0, proc.err.read_text()
