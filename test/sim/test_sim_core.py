"""The simulator's rules without ROS: ``sim.core.SimulatorCore`` driven by a fake clock.

A fake backend counts its steps and records the commands it gets (its ``state`` is the step
count), so each rule is checked against the schedule the test itself advances: zero-order hold,
flood, stand before the first command, timeout hold/stand (once, and resumed), catch-up after a
late tick and skipping beyond ``MAX_CATCH_UP``, lockstep, pause in both modes, reset (time moves
on by one step), divergence (discarded, reset, counted), the command rule's counters and
throttled warnings, and the statistics (rates, real-time factor, CPU and latency percentiles).
"""
from __future__ import annotations

import numpy as np
import pytest

from littledog_mlsim.layout import CONTROL_DT_NS, HOME_POSE, JOINT_NAMES, JOINT_UPPER
from littledog_mlsim.sim import MAX_CATCH_UP, Backend, CoreConfig, PybulletBackend, SimulatorCore
from littledog_mlsim.sim.core import STEPS_PER_TICK, Logs

MS = 1_000_000


class FakeClock:
    """Monotonic and wall time advanced by the test; each step costs ``cpu_per_read`` ns of
    CPU per reading pair."""

    def __init__(self) -> None:
        self.mono = 1_000 * MS
        self.wall = 5_000_000 * MS
        self.cpu = 0

    def monotonic_ns(self) -> int:
        return self.mono

    def wall_ns(self) -> int:
        return self.wall

    def cpu_ns(self) -> int:
        self.cpu += 50_000          # every reading advances the thread's CPU time by 0.05 ms
        return self.cpu

    def advance(self, ms: float) -> None:
        self.mono += int(ms * MS)
        self.wall += int(ms * MS)


class FakeBackend:
    """Counts steps; ``state`` is [steps since reset]; ``diverge_at`` makes that step fail."""

    def __init__(self) -> None:
        self.commands: list[np.ndarray] = []
        self.resets = 0
        self.diverge_at: int | None = None
        self.reset()

    def reset(self) -> None:
        self.n = 0
        self.resets += 1
        self._out()

    def step(self, u: np.ndarray) -> bool:
        self.commands.append(np.array(u))
        if self.diverge_at is not None and len(self.commands) == self.diverge_at:
            return False
        self.n += 1
        self._out()
        return True

    def _out(self) -> None:
        self.state = np.array([float(self.n)])
        self.q = self.dq = np.zeros(12)
        self.position, self.orientation = np.zeros(3), np.array([0.0, 0.0, 0.0, 1.0])
        self.linear_velocity = self.angular_velocity = np.zeros(3)
        self.pose_covariance = self.twist_covariance = None

    def outputs_finite(self) -> bool:
        return True

    def stats(self) -> dict:
        return {"backend_key": "1"}


class Rig:
    def __init__(self, **config) -> None:
        self.clock = FakeClock()
        self.backend = FakeBackend()
        self.published: list[tuple[int, np.ndarray | None, float]] = []
        self.lines: dict[str, list[str]] = {"info": [], "warning": [], "error": []}
        logs = Logs(**{k: v.append for k, v in self.lines.items()})
        self.core = SimulatorCore(self.backend, CoreConfig(**config), self._publish,
                                  clock=self.clock, logs=logs)
        self.core.start()

    def _publish(self, ns: int, u) -> None:
        self.published.append((ns, None if u is None else np.array(u),
                               float(self.backend.state[0])))

    def cmd(self, u=HOME_POSE, names=JOINT_NAMES) -> None:
        self.core.on_command(list(names), list(u), self.clock.wall_ns())

    def tick(self, ms: float = 10.0) -> int:
        self.clock.advance(ms)
        return self.core.on_tick()

    @property
    def stamps(self) -> list[int]:
        return [p[0] for p in self.published]


def u_(k: float) -> np.ndarray:
    return HOME_POSE + 0.001 * k


def test_fakes_satisfy_the_protocol():
    assert isinstance(FakeBackend(), Backend)
    assert all(hasattr(PybulletBackend, a) for a in ("reset", "step", "outputs_finite", "stats"))


def test_timer_zero_order_hold_and_stand_before_first_command():
    r = Rig(cmd_timeout=0.0)
    assert r.stamps == [0]
    assert r.tick() == 1                       # no command yet: stand_command (HOME_POSE)
    np.testing.assert_array_equal(r.published[-1][1], HOME_POSE)
    r.cmd(u_(1))
    for _ in range(3):                         # held for every following step
        r.tick()
    assert [p[1][0] for p in r.published[2:]] == [u_(1)[0]] * 3
    assert r.stamps == [k * CONTROL_DT_NS for k in range(5)]
    assert r.core.counters.steps == 4 and r.core.counters.cmd_superseded == 0


def test_flood_uses_the_newest_and_counts_superseded():
    r = Rig()
    r.tick()
    for k in range(10):                        # 10 commands within one step period
        r.cmd(u_(k))
    r.tick()
    np.testing.assert_array_equal(r.published[-1][1], u_(9))
    assert r.core.counters.cmd_superseded == 9 and r.core.counters.cmd_accepted == 10
    assert len([ln for ln in r.lines["warning"] if "faster than the step rate" in ln]) == 1


@pytest.mark.parametrize("action", ["hold", "stand"])
def test_timeout_once_and_resume(action):
    r = Rig(cmd_timeout=0.3, cmd_timeout_action=action)
    r.cmd(u_(5))
    for _ in range(30):                        # 0.3 s: not yet (strictly more than the timeout)
        r.tick()
    assert r.core.counters.cmd_timeouts == 0
    for _ in range(20):
        r.tick()
    assert r.core.counters.cmd_timeouts == 1   # once per timeout, not once per step
    expect = u_(5) if action == "hold" else HOME_POSE
    np.testing.assert_array_equal(r.published[-1][1], expect)
    what = "holding the last command" if action == "hold" else "commanding stand_command"
    assert r.lines["warning"] == [f"no valid command for 0.3 s: {what}"]
    r.cmd(u_(6))
    assert r.lines["info"] == ["commands resumed"]
    r.tick()
    np.testing.assert_array_equal(r.published[-1][1], u_(6))


def test_catch_up_after_a_late_tick_and_skip_beyond_the_limit():
    r = Rig(real_time_factor=2.0)              # 5 ms period
    r.tick(5.0)
    # a tick 35 ms late: 7 steps due, at most STEPS_PER_TICK run now; the next ticks run the
    # rest, each with the newest command received before it
    assert r.tick(5.0 * 7) == STEPS_PER_TICK == 2
    r.cmd(u_(3))
    assert r.tick(0.0) == 2
    np.testing.assert_array_equal(r.published[-3][1], HOME_POSE)   # the tick before: stand
    np.testing.assert_array_equal(r.published[-2][1], u_(3))       # the next tick's first step
    assert r.tick(0.0) == 2 and r.tick(0.0) == 1 and r.tick(0.0) == 0
    assert r.core.counters.steps == 8 and r.core.counters.steps_skipped == 0
    assert r.tick(1.0) == 0                    # nothing due before the next period
    # a backlog drains by one a tick while ticks come on time
    r.tick(5.0 * 4)                            # 4 due: 2 run
    assert [r.tick(5.0) for _ in range(3)] == [2, 2, 1]
    assert r.tick(5.0 * (MAX_CATCH_UP + 20)) == 2
    assert r.core.counters.steps_skipped == 20
    assert any("skipped 20 step(s)" in ln for ln in r.lines["warning"])
    assert sum(r.tick(0.0) for _ in range(MAX_CATCH_UP)) == MAX_CATCH_UP - 2
    assert r.tick(0.0) == 0
    # simulated time: one 10 ms step per step run, whatever the wall clock did
    assert r.stamps == [k * CONTROL_DT_NS for k in range(len(r.stamps))]
    # a pause drops the backlog: no burst after it
    r.tick(5.0 * 10)
    assert r.core.counters.steps_skipped == 20
    r.core.set_paused(True)
    assert r.tick(0.0) == 0
    r.core.set_paused(False)
    assert r.tick(0.0) == 0 and r.tick(5.0) == 1
    # steps_per_tick = MAX_CATCH_UP: the whole backlog in one tick, on one held command
    r = Rig(real_time_factor=2.0, steps_per_tick=MAX_CATCH_UP)
    r.tick(5.0)
    r.cmd(u_(1))
    assert r.tick(5.0 * 7) == 7
    assert [p[1][0] for p in r.published[-7:]] == [u_(1)[0]] * 7


def test_lockstep_one_step_per_command_and_pause_drops():
    r = Rig(step_mode="lockstep")
    for k in range(3):
        r.cmd(u_(k))
    assert r.stamps == [0, CONTROL_DT_NS, 2 * CONTROL_DT_NS, 3 * CONTROL_DT_NS]
    assert [p[2] for p in r.published] == [0.0, 1.0, 2.0, 3.0]
    assert r.tick(100.0) == 0 and r.core.counters.steps == 3  # no timer stepping
    assert r.core.set_paused(True) == "paused"
    assert r.core.set_paused(True) == "already paused"
    r.cmd(u_(9))
    assert r.core.counters.cmd_dropped_paused == 1 and len(r.published) == 4
    r.core.set_paused(False)
    r.cmd(u_(10))
    assert r.core.counters.steps == 4
    np.testing.assert_array_equal(r.backend.commands[-1], u_(10))


def test_timer_pause_stops_time_but_keeps_the_command():
    r = Rig()
    r.tick()
    r.core.set_paused(True)
    r.cmd(u_(3))
    for _ in range(5):
        r.tick()
    assert r.core.counters.steps == 1 and len(r.published) == 2
    r.core.set_paused(False)
    r.tick()
    np.testing.assert_array_equal(r.published[-1][1], u_(3))
    assert r.stamps[-1] == 2 * CONTROL_DT_NS  # time stopped while paused


def test_reset_advances_time_one_step_and_stands():
    r = Rig(cmd_timeout=0.0)
    r.cmd(u_(1))
    r.tick()
    r.tick()
    msg = r.core.reset()
    assert r.published[-1] == (3 * CONTROL_DT_NS, None, 0.0)   # initial state, next stamp
    assert "t = 0.03 s" in msg and r.core.counters.resets == 1
    r.tick()
    np.testing.assert_array_equal(r.published[-1][1], HOME_POSE)   # the command is dropped


def test_divergence_discards_the_step_and_resets():
    r = Rig(step_mode="lockstep")
    r.backend.diverge_at = 3
    for k in range(4):
        r.cmd(u_(k))
    assert [p[2] for p in r.published] == [0.0, 1.0, 2.0, 0.0, 1.0]
    assert r.stamps == [k * CONTROL_DT_NS for k in range(5)]      # time still advanced
    assert r.core.counters.diverged == 1 and r.backend.resets == 2
    assert len(r.lines["error"]) == 1 and "non-finite" in r.lines["error"][0]
    assert r.core.stats()[1] == 1                                 # WARN level


BAD = {
    "names": (list(JOINT_NAMES[:11]) + ["tail"], HOME_POSE),
    "length": (list(JOINT_NAMES), HOME_POSE[:11]),
    "nonfinite": (list(JOINT_NAMES), np.r_[np.nan, HOME_POSE[1:]]),
}


# every case the DDS test used to send (test_nodes keeps one per reason over DDS)
RULE_CASES = {
    "unknown_name": (list(JOINT_NAMES[:11]) + ["tail"], HOME_POSE, "names"),
    "missing_name": (list(JOINT_NAMES[:11]), HOME_POSE[:11], "names"),
    "duplicated_name": (list(JOINT_NAMES[:11]) + [JOINT_NAMES[0]], HOME_POSE, "names"),
    "short_position": (list(JOINT_NAMES), HOME_POSE[:11], "length"),
    "long_position": (list(JOINT_NAMES), np.r_[HOME_POSE, 0.0], "length"),
    "nan": (list(JOINT_NAMES), np.r_[np.nan, HOME_POSE[1:]], "nonfinite"),
    "inf": (list(JOINT_NAMES), np.r_[HOME_POSE[:5], -np.inf, HOME_POSE[6:]], "nonfinite"),
}


@pytest.mark.parametrize("case", list(RULE_CASES))
def test_command_rule_cases(case):
    """Each malformed command is rejected for its reason, counted, and the held command
    stays; a permuted good command is matched by name."""
    names, pos, reason = RULE_CASES[case]
    r = Rig(step_mode="lockstep")
    perm = np.random.default_rng(1).permutation(12)
    r.cmd(u_(1)[perm], [JOINT_NAMES[i] for i in perm])
    np.testing.assert_array_equal(r.backend.commands[-1], u_(1))
    r.cmd(pos, names)
    assert getattr(r.core.counters, f"cmd_rejected_{reason}") == 1
    assert r.core.counters.steps == 1 and r.core.counters.cmd_received == 2
    assert f"({reason})" in r.lines["warning"][-1]


@pytest.mark.parametrize("reason", list(BAD))
def test_rejected_commands_counted_and_warned_throttled(reason):
    r = Rig(log_throttle=0.5)
    r.cmd(u_(1))
    names, pos = BAD[reason]
    for _ in range(20):
        r.cmd(pos, names)
    r.tick()
    np.testing.assert_array_equal(r.published[-1][1], u_(1))     # the good command holds
    c = r.core.counters
    assert getattr(c, f"cmd_rejected_{reason}") == 20 and c.cmd_accepted == 1
    assert len(r.lines["warning"]) == 1                           # throttled
    r.clock.advance(600)
    r.cmd(pos, names)
    assert len(r.lines["warning"]) == 2 and "(19 more since" in r.lines["warning"][1]


def test_clipped_command_is_used():
    r = Rig(step_mode="lockstep")
    r.cmd(np.r_[HOME_POSE[:2], 7.0, HOME_POSE[3:]])
    assert r.core.counters.cmd_clipped == 1
    assert r.backend.commands[-1][2] == JOINT_UPPER[2]


def test_stats_window_rates_and_percentiles():
    r = Rig(real_time_factor=10.0)             # 1 ms period
    r.core.stats()                             # opens the window
    r.cmd(u_(1))
    for _ in range(1000):
        r.tick(1.0)
    values, level = r.core.stats()
    assert level == 0
    assert float(values["rate_hz"]) == pytest.approx(1000.0, rel=1e-3)
    assert float(values["real_time_factor"]) == pytest.approx(10.0, rel=1e-3)
    assert float(values["step_cpu_ms_p50"]) == pytest.approx(0.05)  # the fake clock's cost
    assert float(values["step_cpu_ms_p99"]) == pytest.approx(0.05)
    assert float(values["step_ms_p99"]) == 0.0                       # no wall time passes
    assert "latency_ms_p50" in values and values["backend_key"] == "1"
    assert values["steps"] == 1000 and values["sim_time"] == "10.00"


def test_latency_log(tmp_path):
    r = Rig(step_mode="lockstep")
    r.cmd(u_(1))
    r.cmd(u_(2))
    path = tmp_path / "lat.csv"
    r.core.write_latency_log(str(path))
    rows = path.read_text().splitlines()
    assert rows[0] == "cmd_received_ns,step_start_ns,published_ns,step_cpu_ns"
    assert len(rows) == 3 and rows[1].split(",")[3] == "50000"


@pytest.mark.parametrize("bad", [dict(step_mode="fast"), dict(cmd_timeout_action="sit"),
                                 dict(real_time_factor=0.0), dict(cmd_timeout=-1.0),
                                 dict(stand_command=np.zeros(11)), dict(steps_per_tick=1),
                                 dict(steps_per_tick=MAX_CATCH_UP + 1),
                                 dict(steps_per_tick=1.5)])
def test_config_refuses_bad_values(bad):
    with pytest.raises(ValueError):
        CoreConfig(**bad)


def test_core_imports_no_rclpy():
    import subprocess
    import sys
    code = ("import sys, littledog_mlsim.sim, littledog_mlsim.rollout.learned_sim; "
            "sys.exit('rclpy' in sys.modules)")
    assert subprocess.run([sys.executable, "-c", code]).returncode == 0


def test_extrapolating_steps_are_warned_throttled():
    r = Rig(step_mode="lockstep", log_throttle=1.0)
    b = r.backend
    b.extrapolating, b.nn_distance, b.trust_radius = True, 2.5, 1.7
    for k in range(5):
        r.cmd(u_(k))
    lines = [ln for ln in r.lines["warning"] if ln.startswith("extrapolating")]
    assert lines == ["extrapolating: the prediction is 2.50 from the nearest TrainPool state, "
                     "beyond the trust radius 1.70 (covariance inflated)"]
    b.extrapolating = False
    r.clock.advance(2000)
    r.cmd(u_(9))
    assert len([ln for ln in r.lines["warning"] if ln.startswith("extrapolating")]) == 1


def test_tf_odometry_with_a_stand_in_message_type(monkeypatch):
    """odom -> base_link on /tf where tf2_msgs exists: here a stand-in module supplies the
    TFMessage type (the pip wheels have none), and the transform equals the odometry's pose."""
    import sys
    import types

    from littledog_mlsim.nodes import messages as m

    class TFMessage:              # what tf2_msgs.msg.TFMessage holds: a list of transforms
        def __init__(self) -> None:
            self.transforms = []

    fake = types.ModuleType("tf2_msgs.msg")
    fake.TFMessage = TFMessage
    monkeypatch.setitem(sys.modules, "tf2_msgs", types.ModuleType("tf2_msgs"))
    monkeypatch.setitem(sys.modules, "tf2_msgs.msg", fake)
    assert m.tf_message_type() is TFMessage
    tf = m.TfOdometry(TFMessage)
    pos, quat = np.array([1.0, -2.0, 0.14]), np.array([0.0, 0.0, np.sin(0.3), np.cos(0.3)])
    msg = tf(2_030_000_000, pos, quat)
    (t,) = msg.transforms
    assert (t.header.frame_id, t.child_frame_id) == ("odom", "base_link")
    assert (t.header.stamp.sec, t.header.stamp.nanosec) == (2, 30_000_000)
    tr, rot = t.transform.translation, t.transform.rotation
    assert [tr.x, tr.y, tr.z] == pos.tolist() and [rot.x, rot.y, rot.z, rot.w] == quat.tolist()
    monkeypatch.setitem(sys.modules, "tf2_msgs.msg", None)      # not installed
    assert m.tf_message_type() is None


def test_robot_description_has_a_base_link_root():
    import xml.etree.ElementTree as ET

    from littledog_mlsim.nodes import messages as m

    root = ET.fromstring(m.robot_description())
    links = {ln.get("name") for ln in root.iter("link")}
    joints = {j.get("name"): j for j in root.iter("joint")}
    assert "base_link" in links and "body" in links
    fixed = joints["base_link_to_body"]
    assert fixed.get("type") == "fixed"
    assert fixed.find("parent").get("link") == "base_link"
    assert fixed.find("child").get("link") == "body"
    children = {j.find("child").get("link") for j in joints.values()}
    assert [ln for ln in links if ln not in children] == ["base_link"]   # the one root
