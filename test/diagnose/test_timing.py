"""The sensor-timing check (``littledog_mlsim.diagnose.timing``) on synthetic walking moves whose
feet stand on the floor: the joint states or the pose made late by whole steps."""
from __future__ import annotations

import numpy as np
import pytest

from littledog_mlsim.data.dataset import load_moves
from littledog_mlsim.data.recording import MoveRecording
from littledog_mlsim.diagnose.timing import MIN_SHIFT_MS, _leg_scope, move_lead, sensor_timing
from littledog_mlsim.gait.ik import forward_kinematics
from littledog_mlsim.layout import HOME_POSE, LEGS

N = 401


def _true_motion(seed: int) -> tuple[np.ndarray, np.ndarray]:
    """(q (N+8, 12), body height (N+8,)) of a trot-like gait whose two lowest feet (a diagonal
    pair, in phase) stay on a level floor, with 0.05 mm of height noise."""
    rng = np.random.default_rng(seed)
    t = np.arange(N + 8) * 0.01
    f = rng.uniform(1.5, 2.5)
    q = np.tile(HOME_POSE, (len(t), 1))
    for leg in range(4):
        phase = np.pi * (leg in (1, 2))
        q[:, 3 * leg + 1] += 0.15 * np.sin(2 * np.pi * f * t + phase)
        q[:, 3 * leg + 2] += 0.25 * np.clip(np.sin(2 * np.pi * f * t + phase), 0, None)
    feet_z = forward_kinematics(q)[..., 2]
    z = -np.sort(feet_z, axis=1)[:, :2].mean(axis=1) + 5e-5 * rng.standard_normal(len(t))
    return q, z


def _move(seed: int, joints_late: int = 0, pose_late: int = 0) -> MoveRecording:
    """A move of N samples whose joint states (or pose) are those of ``joints_late``
    (``pose_late``) steps before their stamp."""
    q, z = _true_motion(seed)
    k = 4
    q_meas = q[k - joints_late:k - joints_late + N]
    z_meas = z[k - pose_late:k - pose_late + N]
    position = np.column_stack([np.zeros(N), np.zeros(N), z_meas])
    orientation = np.tile([0.0, 0.0, 0.0, 1.0], (N, 1))
    return MoveRecording(name=f"F_{seed:02d}", move_type="F",
                         stamps_ns=np.arange(N, dtype=np.int64) * 10_000_000,
                         cmd=q_meas[:-1].copy(), q=q_meas, dq=np.gradient(q_meas, 0.01, axis=0),
                         position=position, orientation=orientation,
                         linear_velocity=np.zeros((N, 3)), angular_velocity=np.zeros((N, 3)))


def test_streams_of_one_instant_read_no_shift():
    moves = [_move(s) for s in range(20)]
    assert abs(move_lead(moves[0])) < 2.0
    t = sensor_timing(moves)
    assert not t["significant"] and abs(t["shift_ms"]) < MIN_SHIFT_MS
    assert "vocabulary" not in t


@pytest.mark.parametrize("joints_late, pose_late, stream, scope, sign", [
    (2, 0, "joint_states", "all", 1.0), (0, 2, "pose", "body", -1.0)])
def test_a_late_stream_is_named_with_its_latency(joints_late, pose_late, stream, scope, sign):
    moves = [_move(s, joints_late, pose_late) for s in range(20)]
    t = sensor_timing(moves)
    assert t["significant"] and t["stream"] == stream
    assert sign * t["shift_ms"] == pytest.approx(20.0, abs=3.0)
    assert t["vocabulary"]["family"] == "other" and t["vocabulary"]["scope"] == scope
    assert t["vocabulary"]["params"]["latency_ms"] == pytest.approx(20.0, abs=3.0)


def _leg_late(m: MoveRecording, leg: int, steps: int) -> MoveRecording:
    """``m`` with leg ``leg``'s joint states those of ``steps`` steps before their stamp (the
    first ``steps`` samples dropped)."""
    q = m.q[steps:].copy()
    q[:, 3 * leg:3 * leg + 3] = m.q[:len(m.q) - steps, 3 * leg:3 * leg + 3]
    return MoveRecording(m.name, m.move_type, m.stamps_ns[steps:], m.cmd[steps:], q,
                         m.dq[steps:], m.position[steps:], m.orientation[steps:],
                         m.linear_velocity[steps:], m.angular_velocity[steps:])


def test_one_legs_late_joint_states_are_named_at_that_leg(small_dataset):
    """On recorded walking (the feet really stand): one leg's joint states 2 steps late move
    that leg's own lead and not the others', so the finding is at the leg, not all joints and
    not the pose; the unchanged recording against itself finds nothing. (Six moves: the level
    is raised to what six moves can reach.)"""
    moves = load_moves(small_dataset, "all")
    ref = [_leg_late(m, 0, 0) for m in moves]
    for leg in (1, 2):
        t = sensor_timing([_leg_late(m, leg, 2) for m in moves], ref, alpha=0.05)
        legs = t["legs"]
        assert legs["late"] == [LEGS[leg]], legs
        assert t["significant"] and t["stream"] == "joint_states"
        assert t["vocabulary"]["family"] == "other"
        assert t["vocabulary"]["scope"] == f"leg:{LEGS[leg]}"
        assert t["vocabulary"]["params"]["latency_ms"] >= MIN_SHIFT_MS
        others = [r for r in legs["per_leg"] if r["leg"] != LEGS[leg]]
        assert all(abs(r["shift_ms"]) < MIN_SHIFT_MS for r in others)
        assert LEGS[leg].replace("_", "-") in t["statement"]
    same = sensor_timing(ref, ref, alpha=0.05)
    assert not same["significant"] and same["legs"]["late"] == []


def test_a_whole_robot_latency_is_no_one_legs():
    """Every joint state late moves every leg alike: the finding is all joints, no leg's."""
    whole = sensor_timing([_move(s, joints_late=2) for s in range(20)],
                          [_move(s + 50) for s in range(20)])
    assert whole["legs"]["late"] == [] and whole["vocabulary"]["scope"] == "all"


def test_legs_on_one_side_read_as_that_side():
    assert _leg_scope(["front_left", "back_left"]) == "side:left"
    assert _leg_scope(["back_right"]) == "leg:back_right"
    assert _leg_scope(["front_left", "back_right"]) == "all"


def test_against_a_reference_only_the_change_counts():
    """A reference with the same latency cancels it; a reference without it leaves it."""
    late = [_move(s, joints_late=2) for s in range(20)]
    same = sensor_timing(late, [_move(s + 50, joints_late=2) for s in range(20)])
    assert not same["significant"] and abs(same["shift_ms"]) < MIN_SHIFT_MS
    changed = sensor_timing(late, [_move(s + 50) for s in range(20)])
    assert changed["significant"] and changed["shift_ms"] == pytest.approx(20.0, abs=3.0)
    assert "reference" in changed["statement"] and "Mann-Whitney" in changed["test"]


def test_bad_input_is_refused_in_one_line():
    with pytest.raises(ValueError, match="no moves"):
        sensor_timing([])
    m = _move(0)
    short = MoveRecording(m.name, m.move_type, m.stamps_ns[:5], m.cmd[:4], m.q[:5], m.dq[:5],
                          m.position[:5], m.orientation[:5], m.linear_velocity[:5],
                          m.angular_velocity[:5])
    with pytest.raises(ValueError, match="no move of the data can be read .1 shorter"):
        sensor_timing([short])
    # a short move among readable ones is skipped and counted
    t = sensor_timing([short] + [_move(s) for s in range(20)])
    assert t["n_moves"] == 20 and t["n_skipped"] == {"short": 1, "flat": 0}


def test_a_robot_standing_still_has_no_lead_to_read():
    """Constant joint angles and pose: every lead fits equally well, so no move is read and
    nothing is claimed (not an arbitrary lead on every move)."""
    m = _move(0)
    still = MoveRecording(m.name, m.move_type, m.stamps_ns, m.cmd,
                          np.tile(HOME_POSE, (N, 1)), np.zeros((N, 12)),
                          np.tile([0.0, 0.0, 0.14], (N, 1)), m.orientation,
                          m.linear_velocity, m.angular_velocity)
    assert np.isnan(move_lead(still))
    with pytest.raises(ValueError, match="20 with a flat profile"):
        sensor_timing([still] * 20)
    t = sensor_timing([still] * 3 + [_move(s) for s in range(20)])
    assert t["n_skipped"] == {"short": 0, "flat": 3} and not t["significant"]
