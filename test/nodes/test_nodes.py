"""The ROS nodes over real DDS: each node in its own process, this test process as controller.

The module records a small dataset (F, S, L; 2 moves each) and fits an LR model with the core,
then checks the nodes against the core: a TestPool move replayed through sim_node in lockstep
gives exactly the core's rollout; the timer mode holds 100 Hz; every kind of bad command is
counted and survived; trainer_node writes a model sim_node loads and fails cleanly on a corrupt
bag; a missing/corrupt/incompatible model is one line and a non-zero exit; pybullet_node
replays exactly like ``simulate_move``; bag_player and bag_recorder close the loop.

One ROS domain (``rosharness.DOMAIN_ID``, derived from the pid), localhost discovery;
simulators run one at a time (class-scoped fixtures) since they share the contract topics.
Every wait is on an event with a timeout; the only fixed-length windows are measurement windows.
"""
from __future__ import annotations

import json
import os
import shutil
import subprocess
import threading
import time
from pathlib import Path

import numpy as np
import pytest

from rosharness import (BIN, ENV, Probe, Proc, Ros, call_service,  # noqa: I001  (first:
                        error_lines, run)                         # it sets the test domain)
import rclpy
from rclpy.node import Node  # noqa: E402
from rclpy.qos import (  # noqa: E402
    DurabilityPolicy,
    QoSProfile,
    ReliabilityPolicy,
)
from sensor_msgs.msg import JointState  # noqa: E402
from std_srvs.srv import SetBool, Trigger  # noqa: E402

from littledog_mlsim.data.bags import read_bag  # noqa: E402
from littledog_mlsim.data.dataset import (  # noqa: E402
    features_responses,
    integrate_path,
    load_moves,
    states_from_recording,
)
from littledog_mlsim.layout import (  # noqa: E402
    CONTROL_DT_NS,
    HOME_POSE,
    JOINT_NAMES,
    JOINT_UPPER,
    S,
)
from littledog_mlsim.models.features import CommandLag, FeatureSet, Heading, Play  # noqa: E402
from littledog_mlsim.models.lr import LinearRegression  # noqa: E402
from littledog_mlsim.models.onestep import OneStepModel  # noqa: E402
from littledog_mlsim.nodes import messages as m  # noqa: E402
from littledog_mlsim.nodes.bag_player import PLAY_QOS  # noqa: E402
from littledog_mlsim.nodes.trainer_node import HEARD, parse_heard  # noqa: E402
from littledog_mlsim.robot.sensors import twist_from_poses  # noqa: E402
from littledog_mlsim.rollout.learned_sim import standing_train_state  # noqa: E402
from littledog_mlsim.rollout.simulate import prepare_test_move, rollout  # noqa: E402
from littledog_mlsim.rotations import quat_to_rpy  # noqa: E402
from waiting import TIMEOUT, wait_until  # noqa: E402

# ---------------------------------------------------------------------------------------------
# fixtures


@pytest.fixture(scope="module")
def ros():
    r = Ros()
    yield r
    r.close()


@pytest.fixture(scope="module")
def work(tmp_path_factory) -> Path:
    return tmp_path_factory.mktemp("nodes")


@pytest.fixture(scope="module")
def dataset(work) -> Path:
    out = work / "data"
    subprocess.run([str(BIN / "littledog-mlsim"), "record", "--out", str(out),
                    "--moves-per-type", "2", "--types", "F,S,L", "--quiet"],
                   check=True, env=ENV, capture_output=True, timeout=300)
    return out


@pytest.fixture(scope="module")
def model_path(work, dataset) -> Path:
    X, Y, _ = features_responses(load_moves(dataset, split="train"))
    path = work / "lr_model"
    OneStepModel.fit(LinearRegression(), X, Y).save(path)
    return path


@pytest.fixture(scope="module")
def model(model_path) -> OneStepModel:
    return OneStepModel.load(model_path)


@pytest.fixture(scope="module")
def test_move(dataset):
    return prepare_test_move(load_moves(dataset, split="test", types=["F"])[0])


# ---------------------------------------------------------------------------------------------
# sim_node, lockstep: the core's rollout exactly


# lagged commands, a recursive play operator, the heading: history, carry and pose online (a
# StateLag here makes this tiny LR diverge under alpha-PROJ, which breaks s_t - s_{t-1})
EFFECTS = FeatureSet((CommandLag(lag=2), Play(width=0.02, source="q"), Heading()))


@pytest.fixture(scope="module", params=["paper", "effects"])
def served(request, work, dataset, model_path):
    """(path, model) sim_node serves in lockstep: the paper's 45 features, or a model with added
    effects (``EFFECTS``)."""
    if request.param == "paper":
        return model_path, OneStepModel.load(model_path)
    X, Y, _ = EFFECTS.features_responses(load_moves(dataset, split="train"))
    path = work / "lr_effects_model"
    OneStepModel.fit(LinearRegression(), X, Y, feature_set=EFFECTS).save(path)
    return path, OneStepModel.load(path)


def core_rollout(model, move, actions):
    """The core's rollout of ``move`` from its s0 and pose with ``actions``, alpha-PROJ 0.5."""
    pose0 = np.array([move.pose0.x0, move.pose0.y0, move.pose0.yaw0])
    return rollout(model, move.s0, actions, model.projection("alpha", 0.5), pose0=pose0)


@pytest.fixture(scope="class")
def lockstep_sim(ros, work, served, test_move):
    # initial state and pose through a params file, the projection through -p.
    params = work / "lockstep.yaml"
    s0 = [float(x) for x in test_move.s0]
    pose = [float(test_move.pose0.x0), float(test_move.pose0.y0), float(test_move.pose0.yaw0)]
    params.write_text(json.dumps({"sim_node": {"ros__parameters": {
        "model_path": str(served[0]), "step_mode": "lockstep", "initial_state": s0,
        "initial_pose": pose, "stats_period": 0.2}}}))
    proc = Proc("sim_node", {"projection": "alpha", "alpha": 0.5, "radius": 0.0}, work,
                "--params-file", str(params))
    probe = Probe(ros)
    probe.connect(proc)
    yield proc, probe
    probe.close()
    assert proc.stop() == 0


class TestLockstep:
    def test_replay_equals_core_rollout(self, lockstep_sim, served, test_move):
        proc, probe = lockstep_sim
        ref = core_rollout(served[1], test_move, test_move.actions)
        k0 = probe.counter("steps") if probe.stats else 0
        assert k0 == 0
        rng = np.random.default_rng(0)
        for k, u in enumerate(test_move.actions):
            perm = rng.permutation(12)   # names in any order, matched by name
            probe.send(u[perm], names=[JOINT_NAMES[i] for i in perm])
            t = (k + 1) * CONTROL_DT_NS
            probe.wait(lambda t=t: t in probe.state and any(j[1] == t for j in probe.js[-3:])
                       and any(o[0] == t for o in probe.odom[-3:]), what=f"state {k + 1}")
        T = len(test_move.actions)
        stamps = [(k + 1) * CONTROL_DT_NS for k in range(T)]
        states = np.array([probe.state[t] for t in stamps])
        np.testing.assert_allclose(states, ref, rtol=0, atol=1e-12)
        js = {j[1]: j for j in probe.js}
        np.testing.assert_array_equal(np.array([js[t][2] for t in stamps]), states[:, S.q])
        np.testing.assert_array_equal(np.array([js[t][3] for t in stamps]), states[:, S.dq])
        # odometry: the pose integrate_path gives for the rollout; z and roll/pitch are states
        odom = dict(probe.odom)
        pos = np.array([odom[t]["position"] for t in stamps])
        rpy = quat_to_rpy(np.array([odom[t]["orientation"] for t in stamps]))
        path = integrate_path(ref, *test_move.pose0)
        np.testing.assert_allclose(pos[:, :2], path[:, :2], atol=1e-9)
        np.testing.assert_allclose(pos[:, 2], ref[:, S.z_w], atol=1e-12)
        np.testing.assert_allclose(rpy[:, :2], ref[:, S.roll_pitch], atol=1e-9)
        np.testing.assert_allclose(np.unwrap(rpy[:, 2]), np.unwrap(path[:, 2]), atol=1e-9)
        # twist in base_link: the finite difference of the published poses
        quat = np.array([odom[t]["orientation"] for t in stamps])
        lin = np.array([odom[t]["linear_velocity"] for t in stamps])
        ang = np.array([odom[t]["angular_velocity"] for t in stamps])
        v, w = twist_from_poses(pos[:-1], quat[:-1], pos[1:], quat[1:], 0.01)
        np.testing.assert_allclose(lin[1:], v, atol=1e-9)
        np.testing.assert_allclose(ang[1:], w, atol=1e-9)
        # covariances from LR's residual std, summed along the rollout for x, y, yaw
        cov = odom[stamps[-1]]["pose_covariance"].reshape(6, 6)
        assert cov[0, 0] > 0 and cov[1, 1] > 0 and cov[5, 5] > 0
        assert cov[0, 0] > odom[stamps[0]]["pose_covariance"][0]    # summed along the rollout
        # /clock: every step's time, never backwards
        clock = np.array(probe.clock)
        assert np.all(np.diff(clock) > 0) and set(stamps) <= set(clock.tolist())
        # the applied commands are the ones sent, stamped at the start of their step
        np.testing.assert_array_equal(
            np.array([probe.applied[t - CONTROL_DT_NS] for t in stamps]), test_move.actions)
        st = probe.wait_counter("steps", T)
        assert int(st["steps"]) == T and int(st["cmd_accepted"]) == T

    def test_reset_and_pause(self, lockstep_sim, served, test_move):
        proc, probe = lockstep_sim
        k = int(probe.wait_counter("steps", 1)["steps"])
        t_before = max(probe.state)
        assert probe.call(probe.reset_client, Trigger.Request()).success
        t_reset = t_before + CONTROL_DT_NS            # time moves on by one step on reset
        probe.wait(lambda: t_reset in probe.state, what="the reset state")
        np.testing.assert_array_equal(probe.state[t_reset], test_move.s0)
        # after the reset, the same command gives the same first step as the rollout
        probe.send(test_move.actions[0])
        probe.wait(lambda: t_reset + CONTROL_DT_NS in probe.state, what="a step after reset")
        ref = core_rollout(served[1], test_move, test_move.actions[:1])
        np.testing.assert_allclose(probe.state[t_reset + CONTROL_DT_NS], ref[0], atol=1e-12)
        # paused: a lockstep command is dropped and counted, no state is published
        assert probe.call(probe.pause_client, SetBool.Request(data=True)).success
        n_states = len(probe.state)
        probe.send(test_move.actions[1])
        probe.wait_counter("cmd_dropped_paused", 1)
        assert len(probe.state) == n_states
        assert probe.call(probe.pause_client, SetBool.Request(data=False)).success
        probe.send(test_move.actions[1])
        probe.wait(lambda: t_reset + 2 * CONTROL_DT_NS in probe.state, what="a step after pause")
        st = probe.wait_counter("steps", k + 2)
        assert int(st["resets"]) == 1 and proc.alive()


# ---------------------------------------------------------------------------------------------
# sim_node, timer mode: rate, bad commands, timeout


def rate_over(probe: Probe, seconds: float) -> tuple[float, list]:
    """Steps per second the simulator published over the next ``seconds`` of wall time.

    Measured with the simulator's own numbers, so that a test process which lags behind or
    loses a sample (keep-last 10 on a CPU-starved machine) does not bias it: the DDS source
    timestamps (the node's publish times) of the received joint states in the window, and
    their stamps (one 10 ms step each): rate = 1 / the least-squares slope of publish time
    against step, the schedule the node keeps (one step published late after a CPU stall and
    caught up moves the first-to-last ratio by the stall over the window; it moves the slope
    far less). Also returns the messages received in the window.
    """
    t0 = time.time_ns()
    t1 = t0 + int(seconds * 1e9)
    probe.wait(lambda: bool(probe.js) and probe.js[-1][0] >= t1, timeout=seconds + TIMEOUT,
               what=f"{seconds} s of joint states")
    with probe.cond:
        window = [j for j in probe.js if t0 <= j[0] < t1]
    steps = (np.array([j[1] for j in window]) - window[0][1]) / CONTROL_DT_NS
    sent_s = (np.array([j[0] for j in window]) - window[0][0]) / 1e9
    return 1.0 / float(np.polyfit(steps, sent_s, 1)[0]), window


def received_fraction(window: list) -> float:
    """Messages received / steps published in ``window`` (1.0: none lost on the way)."""
    return len(window) / ((window[-1][1] - window[0][1]) / CONTROL_DT_NS + 1)


def starvation(probe: Probe) -> str:
    """Context for a missed rate: the node's own view and the machine's load (2 shared cores:
    with a load average far above 2 the node may simply not get the CPU it needs)."""
    with probe.cond:
        st = probe.stats[-1] if probe.stats else {}
    keys = ("rate_hz", "steps_skipped", "step_ms_p50", "step_ms_p99", "step_ms_max")
    return (f"node: {', '.join(f'{k}={st.get(k)}' for k in keys)}; load average "
            f"{os.getloadavg()[0]:.1f} on {os.cpu_count()} CPUs")


class Streamer:
    """A 100 Hz controller in its own thread (a move's commands, looped)."""

    def __init__(self, probe: Probe, commands: np.ndarray) -> None:
        self.probe, self.commands = probe, commands
        self.stop_ev = threading.Event()
        self.thread = threading.Thread(target=self._run, daemon=True)
        self.thread.start()

    def _run(self) -> None:
        k, t = 0, time.monotonic()
        while not self.stop_ev.wait(max(0.0, t - time.monotonic())):
            self.probe.send(self.commands[k % len(self.commands)])
            k += 1
            t += 0.01

    def stop(self) -> None:
        self.stop_ev.set()
        self.thread.join(5)


BAD_COMMANDS = {
    # case: (names, positions, counter)
    "unknown_name": (list(JOINT_NAMES[:11]) + ["tail"], HOME_POSE, "cmd_rejected_names"),
    "missing_name": (list(JOINT_NAMES[:11]), HOME_POSE[:11], "cmd_rejected_names"),
    "duplicated_name": (list(JOINT_NAMES[:11]) + [JOINT_NAMES[0]], HOME_POSE,
                        "cmd_rejected_names"),
    "short_position": (list(JOINT_NAMES), HOME_POSE[:11], "cmd_rejected_length"),
    "long_position": (list(JOINT_NAMES), np.r_[HOME_POSE, 0.0], "cmd_rejected_length"),
    "nan": (list(JOINT_NAMES), np.r_[np.nan, HOME_POSE[1:]], "cmd_rejected_nonfinite"),
    "inf": (list(JOINT_NAMES), np.r_[HOME_POSE[:5], -np.inf, HOME_POSE[6:]],
            "cmd_rejected_nonfinite"),
    "outside_limits": (list(JOINT_NAMES), np.r_[HOME_POSE[:2], 7.0, HOME_POSE[3:]],
                       "cmd_clipped"),
}


@pytest.fixture(scope="class")
def timer_sim(ros, work, model_path, dataset):
    # queues of 10 s of commands at both ends: the bad-command cases count every command of a
    # burst sent beside a 100 Hz stream, which a keep-last queue of 100 loses where the node's
    # executor stalls for about a second on a loaded machine (the queue is not what they test)
    proc = Proc("sim_node", {"model_path": model_path, "step_mode": "timer",
                             "cmd_timeout": 0.3, "cmd_timeout_action": "stand",
                             "stats_period": 0.25, "log_throttle": 0.5,
                             "cmd_queue_depth": 1000}, work)
    probe = Probe(ros, light=True, cmd_depth=1000)
    probe.connect(proc)
    commands = load_moves(dataset, split="train", types=["F"])[0].cmd
    yield proc, probe, commands
    probe.close()
    assert proc.stop() == 0


class TestTimerMode:
    def test_rate_100hz_over_10s(self, timer_sim):
        """The node keeps its 100 Hz schedule while it has the time for it. Where the machine
        does not give it that time (the node skips steps, or its slowest steps take longer than
        the 10 ms period: the suite's other worker and its processes on 2 cores), the rate is
        not this test's to judge: the node's speed under load is measured in
        ``benchmarks/sim_node_*``."""
        proc, probe, commands = timer_sim
        streamer = Streamer(probe, commands)
        try:
            probe.wait_counter("cmd_accepted", 10)
            skipped = probe.counter("steps_skipped")
            rate, window = rate_over(probe, 10.0)
            skipped = probe.counter("steps_skipped") - skipped
            with probe.cond:
                st = dict(probe.stats[-1]) if probe.stats else {}
        finally:
            streamer.stop()
        if abs(rate - 100.0) > 1.0 and (skipped > 0 or float(st.get("step_ms_p99", 0)) > 10.0):
            pytest.skip(f"the node was not given the time for 100 Hz (published {rate:.2f} Hz, "
                        f"{skipped} steps skipped in the window; {starvation(probe)})")
        assert abs(rate - 100.0) <= 1.0, f"published {rate:.2f} Hz; {starvation(probe)}"
        assert received_fraction(window) > 0.95, starvation(probe)
        assert proc.alive()

    # one case per reason over DDS; every case of the rule is unit-tested without DDS
    # (test_sim_core.py: test_command_rule_cases, test_rejected_commands_counted_and_...)
    @pytest.mark.parametrize("case", ["duplicated_name", "long_position", "nan",
                                      "outside_limits"])
    def test_bad_command(self, timer_sim, case):
        proc, probe, commands = timer_sim
        names, positions, counter = BAD_COMMANDS[case]
        before = probe.counter(counter)
        log_start = len(proc.stderr())
        streamer = Streamer(probe, commands)        # a good controller keeps running
        n_bad = 20
        try:
            probe.wait_counter("cmd_accepted", probe.counter("cmd_accepted") + 5)
            t0 = time.time_ns()
            for _ in range(n_bad):
                probe.send(positions, names=names)
            st = probe.wait_counter(counter, before + n_bad)
            # the rate while bad commands arrive: measured in one case (each reason is the
            # same rejection path after its check); 3 s window: steps caught up after a CPU
            # stall can add up to ~3 % (see sim docs)
            rate = rate_over(probe, 3.0)[0] if case == "nan" else None
            t1 = time.time_ns() + 200_000_000     # and steps published after them
            probe.wait(lambda: bool(probe.js) and probe.js[-1][0] >= t1,
                       what="joint states after the bad commands")
        finally:
            streamer.stop()
        assert int(st[counter]) == before + n_bad
        assert proc.alive()
        assert rate is None or abs(rate - 100.0) <= 4.0, \
            f"{rate:.2f} Hz while receiving bad commands; {starvation(probe)}"
        with probe.cond:
            recent = [j for j in probe.js if j[0] >= t0 - 100_000_000]
            odom = list(probe.odom[-len(recent):])
        assert all(np.all(np.isfinite(j[2])) and np.all(np.isfinite(j[3])) for j in recent)
        assert all(np.all(np.isfinite(np.r_[o["position"], o["orientation"], o["linear_velocity"],
                                            o["angular_velocity"], o["pose_covariance"]]))
                   for _, o in odom)
        if case == "outside_limits":   # clipped, not rejected: the applied command is clipped
            probe.send(positions, names=names)      # alone, so no newer command supersedes it
            probe.wait(lambda: any(a[2] == JOINT_UPPER[2] for a in probe.applied.values()),
                       what="the clipped command applied")
        # logged, throttled: the burst of 20 gives one or two warning lines (log_throttle 0.5 s)
        key = "clipped a command" if case == "outside_limits" else f"({counter.split('_')[-1]})"
        lines = [ln for ln in proc.stderr()[log_start:].splitlines() if key in ln]
        assert 1 <= len(lines) <= 2, lines

    def test_flood_1khz(self, timer_sim):
        proc, probe, commands = timer_sim
        before = probe.counter("cmd_superseded")
        stop = threading.Event()

        def flood():
            t, k = time.monotonic(), 0
            while not stop.wait(max(0.0, t - time.monotonic())):
                probe.send(commands[k % len(commands)])
                k += 1
                t += 0.001
        th = threading.Thread(target=flood, daemon=True)
        th.start()
        try:
            probe.wait_counter("cmd_superseded", before + 100)
            rate, window = rate_over(probe, 3.0)
            st = probe.wait_counter("cmd_superseded", before + 1000)
        finally:
            stop.set()
            th.join(5)
        assert proc.alive()
        assert abs(rate - 100.0) <= 4.0, \
            f"{rate:.2f} Hz under a 1 kHz command flood; {starvation(probe)}"
        assert all(np.all(np.isfinite(j[2])) for j in window)
        assert int(st["cmd_superseded"]) >= before + 1000
        assert int(st["cmd_accepted"]) >= int(st["cmd_superseded"])

    def test_timeout_commands_stand_once(self, timer_sim):
        proc, probe, commands = timer_sim
        streamer = Streamer(probe, commands[100:])      # mid-trot commands, far from HOME_POSE
        before = probe.counter("cmd_timeouts")
        try:
            probe.wait_counter("cmd_accepted", probe.counter("cmd_accepted") + 10)
        finally:
            streamer.stop()
        st = probe.wait_counter("cmd_timeouts", before + 1)
        assert int(st["cmd_timeouts"]) == before + 1
        with probe.cond:
            last_t = max(probe.applied)
        probe.wait(lambda: max(probe.applied) >= last_t + 10 * CONTROL_DT_NS, what="more steps")
        with probe.cond:
            np.testing.assert_array_equal(probe.applied[max(probe.applied)], HOME_POSE)
        text = proc.stderr()
        assert text.count("no valid command for 0.3 s: commanding stand_command") == before + 1
        probe.send(commands[0])
        wait_until(lambda: "commands resumed" in proc.stderr(), what="'commands resumed'")
        assert proc.alive()


# ---------------------------------------------------------------------------------------------
# bad models, trainer_node


def _one_fatal_line(text: str) -> str:
    lines = error_lines(text)
    assert len(lines) == 1, f"expected one error line, got:\n{text}"
    assert "Traceback" not in text
    return lines[0]


@pytest.mark.parametrize("case", ["missing", "no_param", "truncated", "incompatible"])
def test_sim_node_refuses_bad_model(work, model_path, case):
    bad = work / f"bad_{case}"
    if case == "missing":
        path = bad
    elif case == "no_param":
        path = ""
    else:
        shutil.rmtree(bad, ignore_errors=True)
        shutil.copytree(model_path, bad)
        path = bad
        if case == "truncated":
            data = (bad / "arrays.npz").read_bytes()
            (bad / "arrays.npz").write_bytes(data[: len(data) // 2])
        else:   # a model over other features (e.g. a feature set this build cannot supply)
            doc = json.loads((bad / "model.json").read_text())
            doc["meta"]["feature_names"] = ["x_w"] + doc["meta"]["feature_names"][1:]
            (bad / "model.json").write_text(json.dumps(doc))
    params = {"model_path": path} if path != "" else {}
    rc, err = run("sim_node", params, work, timeout=60)
    assert rc != 0
    line = _one_fatal_line(err)
    assert "FATAL" in line and ("model" in line)


def test_trainer_model_loads_in_sim_node(ros, work, dataset):
    out = work / "trained"
    rc, err = run("trainer_node", {"data": dataset, "out": out, "method": "lr"}, work)
    assert rc == 0, err
    assert "wrote lr model" in err
    model = OneStepModel.load(out)
    assert model.method == "lr" and model.info["n_moves"] == 3
    # sim_node starts from the model's TrainPool state nearest the home stance
    proc = Proc("sim_node", {"model_path": out, "step_mode": "lockstep", "stats_period": 0.2},
                work)
    probe = Probe(ros)
    # /robot_description: transient-local, so this late subscriber still gets the URDF
    from std_msgs.msg import String
    latched = QoSProfile(depth=1, reliability=ReliabilityPolicy.RELIABLE,
                         durability=DurabilityPolicy.TRANSIENT_LOCAL)
    urdf: list[str] = []
    desc = Node(f"description_{time.monotonic_ns()}", context=ros.context)   # subscribed before the executor spins it
    desc.create_subscription(String, "/robot_description",
                             lambda msg: probe._add(lambda: urdf.append(msg.data)), latched)
    ros.add(desc)
    try:
        probe.connect(proc)
        probe.send(HOME_POSE)
        probe.wait(lambda: CONTROL_DT_NS in probe.state, what="the first step")
        probe.wait(lambda: bool(urdf), what="/robot_description")
        assert '<link name="base_link"/>' in urdf[0] and '<link name="body">' in urdf[0]
        # ~/stats: the distance to the data and the trust radius (the model's gate radius)
        st = probe.wait_counter("steps", 1)
        assert float(st["trust_radius"]) == pytest.approx(model.gate["radius"], abs=1e-3)
        assert np.isfinite(float(st["nn_distance"])) and "real_time_factor" in st
        assert st["extrapolating"] in ("true", "false") and int(st["extrapolating_steps"]) >= 0
        # ... and steps with the default projection: gated alpha-PROJ, the model's own radius
        assert model.gate["radius"] > 0 and model.gate["quantile"] == 0.9
        gated = model.projection("alpha", 0.5, radius=model.gate["radius"])
        s0 = standing_train_state(model.train_states, gated)
        ref = rollout(model, s0, HOME_POSE[None], gated)
        np.testing.assert_allclose(probe.state[CONTROL_DT_NS], ref[0], atol=1e-12)
    finally:
        ros.destroy(desc)
        probe.close()
        assert proc.stop() == 0


def test_sim_node_gated_alpha_proj_equals_the_core(ros, work, model_path, test_move):
    """`radius` gates alpha-PROJ in the node exactly as in the core rollout; the node spins
    rclpy's EventsExecutor here (`executor: events`; the other node tests use the default) and
    still ends with status 0 on SIGINT. The std every 4 steps (`covariance_every`) leaves the
    states as they are."""
    model = OneStepModel.load(model_path)
    gated = model.projection("alpha", 0.5, radius=1.0)
    ref = rollout(model, test_move.s0, test_move.actions[:20], gated)
    assert not np.allclose(ref, rollout(model, test_move.s0, test_move.actions[:20],
                                        model.projection("alpha", 0.5)))   # the gate matters
    proc = Proc("sim_node", {"model_path": model_path, "step_mode": "lockstep", "radius": 1.0,
                             "initial_state": [float(x) for x in test_move.s0],
                             "executor": "events", "covariance_every": 4}, work)
    probe = Probe(ros)
    try:
        probe.connect(proc)
        for k, u in enumerate(test_move.actions[:20]):
            probe.send(u)
            t = (k + 1) * CONTROL_DT_NS
            probe.wait(lambda t=t: t in probe.state, what=f"state {k + 1}")
        got = np.array([probe.state[(k + 1) * CONTROL_DT_NS] for k in range(20)])
        np.testing.assert_allclose(got, ref, rtol=0, atol=1e-12)
    finally:
        probe.close()
        assert proc.stop() == 0


@pytest.mark.parametrize("params", [{"radius": -1.0}, {"radius": 1.0, "projection": "bound"}])
def test_sim_node_refuses_bad_radius(work, model_path, params):
    rc, err = run("sim_node", {"model_path": model_path, **params}, work, timeout=60)
    assert rc != 0
    line = _one_fatal_line(err)
    assert "FATAL" in line and "radius" in line


def test_sim_node_refuses_a_bad_covariance_every(work, model_path):
    rc, err = run("sim_node", {"model_path": model_path, "covariance_every": 0}, work, timeout=60)
    assert rc == 2
    line = _one_fatal_line(err)
    assert "FATAL" in line and "covariance_every" in line


@pytest.mark.parametrize("case", ["missing", "corrupt"])
def test_pybullet_node_refuses_a_bad_twin_file(work, case):
    twin = work / f"twin_{case}.json"
    if case == "corrupt":
        twin.write_text('{"format": "littledog_mlsim.twin", "format_versi')
    rc, err = run("pybullet_node", {"robot": str(twin)}, work, timeout=60)
    assert rc != 0
    line = _one_fatal_line(err)
    assert "FATAL" in line and "parameter robot" in line and str(twin) in line


def test_trainer_corrupt_bag_leaves_model_untouched(work, dataset, model_path):
    data = work / "corrupt_data"
    shutil.rmtree(data, ignore_errors=True)
    shutil.copytree(dataset, data)
    mcap = next((data / "F_00").glob("*.mcap"))
    raw = mcap.read_bytes()
    mcap.write_bytes(raw[: len(raw) // 2])
    out = work / "existing_model"
    shutil.rmtree(out, ignore_errors=True)
    shutil.copytree(model_path, out)
    before = {p.name: p.read_bytes() for p in out.iterdir()}
    rc, err = run("trainer_node", {"data": data, "out": out}, work)
    assert rc == 1
    line = _one_fatal_line(err)
    assert "F_00" in line and "no model written" in line
    assert {p.name: p.read_bytes() for p in out.iterdir()} == before
    assert sorted(p.name for p in work.iterdir() if p.name.startswith(".existing_model")) == []


# ---------------------------------------------------------------------------------------------
# pybullet_node, bag_player, bag_recorder


def test_pybullet_node_replays_like_simulate_move(ros, work, dataset):
    from littledog_mlsim.robot.sim import simulate_move

    commands = load_moves(dataset, split="train", types=["L"])[0].cmd[:60]
    proc = Proc("pybullet_node", {"step_mode": "lockstep", "seed": 7, "robot": "measured"}, work)
    probe = Probe(ros, sim="pybullet_node")
    try:
        probe.connect(proc)
        for k, u in enumerate(commands):
            probe.send(u)
            t = (k + 1) * CONTROL_DT_NS
            probe.wait(lambda t=t: t in probe.state and any(o[0] == t for o in probe.odom[-3:]),
                       what=f"pybullet step {k + 1}")
    finally:
        probe.close()
        assert proc.stop() == 0
    rec = simulate_move(commands, robot="measured", seed=7)
    stamps = [(k + 1) * CONTROL_DT_NS for k in range(len(commands))]
    js, odom = {j[1]: j for j in probe.js}, dict(probe.odom)
    np.testing.assert_array_equal(np.array([js[t][2] for t in stamps]), rec.q[1:])
    np.testing.assert_array_equal(np.array([js[t][3] for t in stamps]), rec.dq[1:])
    for key in ("position", "orientation", "linear_velocity", "angular_velocity"):
        np.testing.assert_array_equal(np.array([odom[t][key] for t in stamps]),
                                      getattr(rec, key)[1:])
    np.testing.assert_allclose(np.array([probe.state[t] for t in stamps]),
                               states_from_recording(rec), atol=1e-12)
    assert odom[stamps[0]]["pose_covariance"][0] == -1.0


def test_bag_player_timing_and_content(ros, work, dataset):
    bag = dataset / "F_00"
    node = ros.node("player_listener")
    got, cond = [], threading.Condition()

    def on_cmd(msg, info):   # the player's publish time: its DDS source timestamp
        with cond:
            got.append((info["source_timestamp"] / 1e9, m.stamp_ns(msg.header.stamp),
                        m.joint_state_arrays(msg)[0]))
            cond.notify_all()
    # a listener that keeps everything, as the player does: a depth-10 reader drops commands
    # when its callbacks fall behind on a loaded machine (397 of 400 once)
    node.create_subscription(JointState, "/littledog/cmd", on_cmd, PLAY_QOS)
    try:
        rc, err = run("bag_player", {"bag": bag, "rate": 2.0, "wait_for_subscribers": 1}, work)
        assert rc == 0, err
        with cond:
            assert cond.wait_for(lambda: len(got) >= 400, TIMEOUT), f"{len(got)} commands"
    finally:
        ros.destroy(node)
    rec = read_bag(bag)
    np.testing.assert_array_equal(np.array([g[2] for g in got]), rec.cmd)
    assert [g[1] for g in got] == rec.stamps_ns[:-1].tolist()
    span = got[-1][0] - got[0][0]                   # 399 intervals of 10 ms at rate 2
    assert abs(span - 399 * 0.005) < 0.05, f"played in {span:.3f} s"
    gaps = np.diff([g[0] for g in got])
    assert abs(np.median(gaps) - 0.005) < 0.0005
    rc, err = run("bag_player", {"bag": work / "no_such_bag"}, work)
    assert rc == 1 and "no_such_bag" in _one_fatal_line(err)


def test_player_sim_recorder_loop(ros, work, dataset, model_path, model):
    """bag_player (paced) -> sim_node (lockstep) -> bag_recorder -> a contract bag that holds
    the core's rollout from the node's initial state."""
    src = read_bag(dataset / "S_00")
    out = work / "recorded" / "S_00"
    out.parent.mkdir(exist_ok=True)
    rec_proc = Proc("bag_recorder", {"out": out, "max_steps": 400}, work)
    sim = Proc("sim_node", {"model_path": model_path, "step_mode": "lockstep"}, work)
    try:
        # the recorder has received the simulator's initial state (a graph match seen from
        # this process is not the simulator's match, nor delivery: the recorder's module doc)
        wait_until(lambda: "ready: measurement at 0.000 s" in rec_proc.stderr(),
                   timeout=2 * TIMEOUT, what="the recorder's ready line")
        rc, err = run("bag_player", {"bag": dataset / "S_00", "pace_topic":
                                     "/littledog/joint_states", "wait_for_subscribers": 1}, work)
        assert rc == 0, err
        # the recorder ends after the last step and its bag is written (a loaded machine has
        # been seen to take over 15 s for that)
        assert rec_proc.wait(4 * TIMEOUT) == 0, rec_proc.stderr()
    finally:
        rec_proc.stop()
        assert sim.stop() == 0
    rec = read_bag(out)
    np.testing.assert_array_equal(rec.cmd, src.cmd)
    s0 = standing_train_state(model.train_states, model.projection("alpha", 0.5))
    ref = rollout(model, s0, src.cmd, model.projection("alpha", 0.5))
    np.testing.assert_array_equal(rec.q, np.vstack([s0[S.q], ref[:, S.q]]))
    np.testing.assert_array_equal(rec.dq, np.vstack([s0[S.dq], ref[:, S.dq]]))
    # the odometry is the pose integrate_path gives (initial_pose 0, 0, 0); z, roll, pitch are
    # state elements. (The learned model predicts d_b, droll, ... separately from z_w, roll,
    # ..., so they are not recomputable from the pose.)
    path = integrate_path(ref, 0.0, 0.0, 0.0, s0[S.roll_pitch])
    np.testing.assert_allclose(rec.position[1:, :2], path[:, :2], atol=1e-9)
    np.testing.assert_allclose(rec.position[:, 2], np.r_[s0[S.z_w], ref[:, S.z_w]], atol=1e-12)
    rpy = quat_to_rpy(rec.orientation[1:])
    np.testing.assert_allclose(rpy[:, :2], ref[:, S.roll_pitch], atol=1e-9)
    np.testing.assert_allclose(np.unwrap(rpy[:, 2]), np.unwrap(path[:, 2]), atol=1e-9)


def test_diverging_model_never_publishes_nan(ros, work, dataset):
    """A model whose predictions overflow: each step is discarded, the node resets to the
    initial state, counts it and publishes nothing non-finite."""
    X, Y, _ = features_responses(load_moves(dataset, split="train"))
    model = OneStepModel.fit(LinearRegression(), X, Y)
    model.estimator.coef_ = np.full_like(model.estimator.coef_, np.inf)  # inf/NaN predictions
    path = work / "diverging_model"
    model.save(path)
    s0 = standing_train_state(model.train_states, model.projection("alpha", 0.5))
    proc = Proc("sim_node", {"model_path": path, "step_mode": "lockstep",
                             "stats_period": 0.2}, work)
    probe = Probe(ros)
    try:
        probe.connect(proc)
        for k in range(3):
            probe.send(HOME_POSE)
            probe.wait(lambda k=k: (k + 1) * CONTROL_DT_NS in probe.state, what="a step")
        st = probe.wait_counter("diverged", 3)
        assert int(st["diverged"]) == 3 and proc.alive()
        for k in range(1, 4):
            np.testing.assert_array_equal(probe.state[k * CONTROL_DT_NS], s0)
        with probe.cond:
            assert all(np.all(np.isfinite(np.r_[j[2], j[3]])) for j in probe.js)
            assert all(np.all(np.isfinite(np.r_[o["position"], o["pose_covariance"],
                                                o["twist_covariance"]])) for _, o in probe.odom)
        assert "non-finite state" in proc.stderr()
    finally:
        probe.close()
        assert proc.stop() == 0


def test_parameters_declared_documented_and_in_config():
    """Every parameter of the nodes is declared with a description, and each config YAML lists
    exactly the declared parameters (those without a default only as a comment)."""
    import yaml

    from littledog_mlsim.nodes.pybullet_node import PybulletNode
    from littledog_mlsim.nodes.sim_node import SimNode
    from littledog_mlsim.nodes.simulator import COMMON_PARAMS
    from littledog_mlsim.nodes.trainer_node import PARAMS as TRAINER_PARAMS

    config = Path(__file__).resolve().parents[2] / "config"
    for file, node, params in (("sim.yaml", "sim_node", SimNode.PARAMS + COMMON_PARAMS),
                               ("pybullet.yaml", "pybullet_node",
                                PybulletNode.PARAMS + COMMON_PARAMS),
                               ("trainer.yaml", "trainer_node", TRAINER_PARAMS)):
        text = (config / file).read_text()
        listed = yaml.safe_load(text)[node]["ros__parameters"]
        for p in params:
            assert len(p.description) > 20, p.name
            if isinstance(p.default, rclpy.parameter.Parameter.Type):
                assert p.name not in listed and f"# {p.name}:" in text, (file, p.name)
            else:
                assert p.name in listed, (file, p.name)
        assert set(listed) <= {p.name for p in params}, file


def test_parameter_descriptions_over_ros(ros, work, model_path):
    """The descriptions are what `ros2 param describe` shows (the parameter services)."""
    from rcl_interfaces.srv import DescribeParameters, GetParameters

    proc = Proc("sim_node", {"model_path": model_path, "step_mode": "lockstep",
                             "alpha": 0.25}, work)
    node = ros.node("describer")
    try:
        desc = node.create_client(DescribeParameters, "/sim_node/describe_parameters")
        get = node.create_client(GetParameters, "/sim_node/get_parameters")
        wait_until(lambda: desc.service_is_ready() and get.service_is_ready() or
                   not proc.alive(), what="sim_node's parameter services")
        names = ["model_path", "alpha", "step_mode", "cmd_timeout", "projection"]
        described = call_service(desc, DescribeParameters.Request(names=names))
        for d in described.descriptors:
            assert d.description and d.read_only, d.name
        alpha, timeout = call_service(get, GetParameters.Request(
            names=["alpha", "cmd_timeout"])).values
        assert alpha.double_value == 0.25          # -p override
        assert timeout.double_value == 0.5         # config/sim.yaml default
    finally:
        ros.destroy(node)
        assert proc.stop() == 0


# ---------------------------------------------------------------------------------------------
# hot swap and the live trainer


def test_sim_node_load_model_swaps_keeps_the_robot_and_refuses_a_broken_model(
        ros, work, dataset, model_path, test_move):
    """~/load_model: the model now at model_path from the next step on, from the state the
    robot is in; a broken model there is refused in one line and the served one kept."""
    path = work / "swap_model"
    shutil.copytree(model_path, path)
    proc = Proc("sim_node", {"model_path": path, "step_mode": "lockstep", "stats_period": 0.2,
                             "projection": "bound"}, work)
    probe = Probe(ros)
    load = probe.node.create_client(Trigger, "/sim_node/load_model")
    try:
        probe.connect(proc)
        u = test_move.actions
        for k in range(3):
            probe.send(u[k])
            probe.wait(lambda k=k: (k + 1) * CONTROL_DT_NS in probe.state, what=f"step {k + 1}")
        # a second model (TrainPool of F only) replaces the directory atomically
        X, Y, _ = features_responses(load_moves(dataset, split="train", types=["F"]))
        OneStepModel.fit(LinearRegression(), X, Y).save(path)
        new = OneStepModel.load(path)
        answer = call_service(load, Trigger.Request())
        assert answer.success and answer.message.startswith("swapped at t = 0.03 s"), answer
        t3 = 3 * CONTROL_DT_NS
        probe.send(u[3])
        probe.wait(lambda: t3 + CONTROL_DT_NS in probe.state, what="the step after the swap")
        ref = rollout(new, probe.state[t3], u[3:4], new.projection("bound"))
        np.testing.assert_allclose(probe.state[t3 + CONTROL_DT_NS], ref[0], atol=1e-12)
        assert int(probe.wait_counter("model_swaps", 1)["model_swaps"]) == 1
        # a broken model: refused, one line; the node steps on with the served model
        shutil.rmtree(path)
        path.mkdir()
        (path / "model.json").write_text("{not json")
        answer = call_service(load, Trigger.Request())
        assert not answer.success and "\n" not in answer.message
        assert answer.message.startswith("kept the previous model:"), answer.message
        t4 = t3 + CONTROL_DT_NS
        probe.send(u[4])
        probe.wait(lambda: t4 + CONTROL_DT_NS in probe.state, what="a step after the refusal")
        ref = rollout(new, probe.state[t4], u[4:5], new.projection("bound"))
        np.testing.assert_allclose(probe.state[t4 + CONTROL_DT_NS], ref[0], atol=1e-12)
        assert proc.alive()
    finally:
        probe.close()
        assert proc.stop() == 0


def test_trainer_live_requests_out_of_order_are_one_line_refusals(ros, work):
    """trainer_node live: ~/train with nothing recorded, ~/record false while not recording
    (it says what it heard), a second ~/record true, ~/train while recording: each refused in one line, the node runs
    on; SIGINT ends it with status 0. A record_dir that is not a dataset: exit status 2."""
    out = work / "live_refusals"
    proc = Proc("trainer_node", {"live": True, "record_dir": out / "data",
                                 "out": out / "model", "heartbeat": 0.0}, work)
    node = ros.node(f"live_client_{time.monotonic_ns()}")
    try:
        record = node.create_client(SetBool, "/trainer_node/record")
        train = node.create_client(Trigger, "/trainer_node/train")
        wait_until(lambda: record.service_is_ready() and train.service_is_ready(),
                   what="the trainer's services")
        a = call_service(train, Trigger.Request())
        assert not a.success and a.message.startswith("nothing recorded")
        a = call_service(record, SetBool.Request(data=False))
        assert not a.success and a.message.startswith("not recording")
        assert parse_heard(a.message) == dict.fromkeys(HEARD, 0)    # nothing published here
        assert call_service(record, SetBool.Request(data=True)).success
        a = call_service(record, SetBool.Request(data=True))
        assert not a.success and a.message.startswith("already recording")
        assert parse_heard(a.message) == dict.fromkeys(HEARD, 0)
        a = call_service(train, Trigger.Request())
        assert not a.success and a.message.startswith("recording: stop it first")
        a = call_service(record, SetBool.Request(data=False))    # nothing arrived: no move
        assert a.success and a.message.startswith("recorded nothing usable"), a.message
        assert proc.alive() and not (out / "model").exists()
    finally:
        ros.destroy(node)
        assert proc.stop() == 0
    (work / "not_a_dataset").mkdir()
    (work / "not_a_dataset" / "x.txt").write_text("x")
    rc, err = run("trainer_node", {"live": True, "record_dir": work / "not_a_dataset",
                                   "out": out / "model"}, work)
    assert rc == 2 and "is not a dataset" in err
