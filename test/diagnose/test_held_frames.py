"""Decision 044 (``littledog_mlsim.diagnose.held_frames``): a sensor stream that repeats its last
frame while the robot moves is found, named and filled in."""
from __future__ import annotations

import numpy as np
import pytest

from littledog_mlsim.data.recording import MoveRecording
from littledog_mlsim.diagnose.held_frames import (MIN_HELD_FRACTION, held_frames, held_rows,
                                                  reference_streams, repair, repair_move,
                                                  repair_plan)

N = 300


def _walk(seed: int) -> MoveRecording:
    """A move of N rows: the body walks along x and turns, with 0.1 mm of pose noise; the
    joints swing; the twist is the body's true velocity."""
    rng = np.random.default_rng(seed)
    t = np.arange(N) * 0.01
    yaw = 0.3 * t
    position = np.column_stack([0.1 * t, 0.02 * np.sin(t), np.full(N, 0.2)])
    position += 1e-4 * rng.standard_normal((N, 3))
    orientation = np.column_stack([np.zeros(N), np.zeros(N), np.sin(yaw / 2), np.cos(yaw / 2)])
    q = 0.2 * np.sin(2 * np.pi * 2.0 * t[:, None] + np.arange(12)[None, :])
    dq = np.gradient(q, 0.01, axis=0)
    lin = np.column_stack([np.full(N, 0.1), 0.02 * np.cos(t), np.zeros(N)])
    ang = np.column_stack([np.zeros(N), np.zeros(N), np.full(N, 0.3)])
    return MoveRecording(f"F_{seed:02d}", "F", np.arange(N, dtype=np.int64) * 10_000_000,
                         q[:-1].copy(), q, dq, position, orientation, lin, ang)


def _hold(m: MoveRecording, rows: np.ndarray, stream: str = "pose",
          velocity: str = "zeroed") -> MoveRecording:
    """``m`` with ``stream``'s frame at each of ``rows`` the previous row's (as published: a
    held row after a held row repeats the same last good frame); its velocity there zero and
    the whole jump at the next good row ("zeroed", a difference of the published frames),
    the previous row's ("held"), or as measured."""
    rows = np.sort(rows)
    if stream == "pose":
        frames = [m.position.copy(), m.orientation.copy()]
        vels = [m.linear_velocity.copy(), m.angular_velocity.copy()]
    else:
        frames, vels = [m.q.copy()], [m.dq.copy()]
    for r in rows:
        for x in frames:
            x[r] = x[r - 1]
        for v in vels:
            if velocity == "held":
                v[r] = v[r - 1]
            elif velocity == "zeroed":
                v[r] = 0.0
    if velocity == "zeroed":
        held = np.zeros(N, bool)
        held[rows] = True
        for r in np.flatnonzero(~held[1:] & held[:-1]) + 1:     # the next good row: the jump
            k = 1
            while held[r - k]:
                k += 1
            for v in vels:
                v[r] = v[r] * k
    if stream == "pose":
        out = MoveRecording(m.name, m.move_type, m.stamps_ns, m.cmd, m.q, m.dq, frames[0],
                            frames[1], vels[0], vels[1])
    else:
        out = MoveRecording(m.name, m.move_type, m.stamps_ns, m.cmd, frames[0], vels[0],
                            m.position, m.orientation, m.linear_velocity, m.angular_velocity)
    out.validate()
    return out


def _drops(seed: int, p: float = 0.15) -> np.ndarray:
    """Rows lost with probability ``p`` (then each next with 0.5), never the first or last."""
    rng = np.random.default_rng(100 + seed)
    lost, prev = [], False
    for r in range(1, N - 1):
        prev = rng.random() < (0.5 if prev else p)
        if prev:
            lost.append(r)
    return np.array(lost, int)


def test_clean_walking_holds_no_frame_and_is_not_repaired():
    moves = [_walk(s) for s in range(12)]
    h = held_frames(moves)
    assert not h["significant"] and "vocabulary" not in h
    assert all(r["held_fraction"] == 0.0 for r in h["streams"])
    assert repair_plan(h) is None


def test_held_pose_frames_are_named_on_the_body_and_filled_in():
    clean = [_walk(s) for s in range(12)]
    moves = [_hold(m, _drops(s)) for s, m in enumerate(clean)]
    h = held_frames(moves)
    assert h["significant"] and h["stream"] == "pose"
    pose = next(r for r in h["streams"] if r["stream"] == "pose")
    planted = sum(len(_drops(s)) for s in range(12)) / (12 * (N - 1))
    assert pose["held_fraction"] == pytest.approx(planted, rel=0.02)
    assert pose["velocity"] == "zeroed" and pose["mean_run_frames"] > 1.0
    v = h["vocabulary"]
    assert v["family"] == "other" and v["scope"] == "body"
    assert v["params"]["stream"] == "pose" and "twist is zero" in h["statement"]
    joints = next(r for r in h["streams"] if r["stream"] == "joint_states")
    assert not joints["significant"]
    plan = repair_plan(h)
    assert plan == {"streams": ["pose"], "velocity": {"pose": "zeroed"}}
    fixed, filled = repair(moves, plan["streams"], plan["velocity"])
    assert filled == sum(len(_drops(s)) for s in range(12))
    for m, f in zip(clean, fixed):
        # the body moves nearly linearly: interpolation is within the pose noise and a turn's
        # curvature over a few frames
        np.testing.assert_allclose(f.position, m.position, atol=1e-3)
        np.testing.assert_allclose(np.linalg.norm(f.orientation, axis=1), 1.0, atol=1e-12)
        np.testing.assert_allclose(np.abs(np.sum(f.orientation * m.orientation, axis=1)), 1.0,
                                   atol=1e-6)
        np.testing.assert_allclose(f.linear_velocity, m.linear_velocity, atol=2e-3)
        np.testing.assert_allclose(f.angular_velocity, m.angular_velocity, atol=1e-9)
        np.testing.assert_array_equal(f.q, m.q)          # the other stream is not touched
    assert not held_frames(fixed)["significant"]


def test_a_held_twist_is_filled_on_the_held_rows_only():
    m = _walk(0)
    rows = np.array([50, 51, 120])
    held = _hold(m, rows, velocity="held")
    h, _ = held_rows(np.hstack([held.position, held.orientation]), held.q)
    assert list(np.flatnonzero(h)) == [50, 51, 120]
    f, filled = repair_move(held, ["pose"])
    assert filled == 3
    np.testing.assert_allclose(f.linear_velocity, m.linear_velocity, atol=1e-5)
    np.testing.assert_array_equal(f.linear_velocity[52], held.linear_velocity[52])
    # a twist measured on its own (not held with the frame) is left as measured
    own = _hold(m, rows, velocity="measured")
    f, _ = repair_move(own, ["pose"], {"pose": "measured"})
    np.testing.assert_array_equal(f.linear_velocity, own.linear_velocity)


def test_held_joint_states_are_named_on_every_joint():
    moves = [_hold(_walk(s), _drops(s), stream="joint_states") for s in range(12)]
    h = held_frames(moves)
    assert h["significant"] and h["stream"] == "joint_states"
    assert h["vocabulary"]["scope"] == "all" and "joint" in h["statement"]
    fixed, _ = repair(moves, ["joint_states"])
    for s, (m, f) in enumerate(zip(moves, fixed)):
        true = _walk(s).q
        # a 2 Hz swing over runs of up to 11 frames: interpolation is not exact, but four times
        # closer than the held angles or more
        assert np.sqrt(np.mean((f.q - true) ** 2)) < 0.25 * np.sqrt(np.mean((m.q - true) ** 2))


def test_one_leg_standing_still_is_not_a_held_frame():
    moves = []
    for s in range(12):
        m = _walk(s)
        q = m.q.copy()
        q[100:200, 0:3] = q[100, 0:3]                    # one leg still for a second
        moves.append(MoveRecording(m.name, "F", m.stamps_ns, m.cmd, q, m.dq, m.position,
                                   m.orientation, m.linear_velocity, m.angular_velocity))
    h = held_frames(moves)
    assert not h["significant"]
    assert all(r["held_fraction"] == 0.0 for r in h["streams"])


def test_against_a_reference_that_holds_as_many_frames_nothing_changed_but_both_are_repaired():
    data = [_hold(_walk(s), _drops(s)) for s in range(12)]
    ref = [_hold(_walk(s + 50), _drops(s + 50)) for s in range(12)]
    h = held_frames(data, ref)
    pose = next(r for r in h["streams"] if r["stream"] == "pose")
    assert not h["significant"] and pose["reference_held_fraction"] > MIN_HELD_FRACTION
    assert "reference" in pose["test"]
    assert repair_plan(h)["streams"] == ["pose"]         # a measurement's fault either way
    assert reference_streams(ref) == ["pose"]
    assert reference_streams([_walk(s) for s in range(3)]) == []
    # against a clean reference the same data are a change
    assert held_frames(data, [_walk(s + 50) for s in range(12)])["significant"]


def test_rows_held_to_the_end_show_no_catch_up_and_are_left_as_recorded():
    m = _hold(_walk(0), np.arange(N - 4, N))
    f, filled = repair_move(m, ["pose"], {"pose": "zeroed"})
    assert filled == 0 and f.n_steps == m.n_steps
    np.testing.assert_array_equal(f.position, m.position)
    still = _hold(_walk(1), np.arange(1, N))
    assert repair_move(still, ["pose"])[1] == 0
    with pytest.raises(ValueError, match="held frames: no moves"):
        held_frames([])


def test_a_robot_standing_still_with_stepped_encoders_holds_no_frame():
    """The joints stand still for the last second of each move: encoders that count in steps
    repeat their reading while the motion capture's noise moves the pose. No catch-up follows,
    so nothing is held, named or filled in; a lost frame in the walk before is."""
    quantum = 2 * np.pi / 4096
    moves = []
    for s in range(12):
        m = _walk(s)
        q = m.q.copy()
        q[200:] = q[200]                                  # standing from row 200
        q = np.round(q / quantum) * quantum
        dq = np.r_[np.zeros((1, 12)), np.diff(q, axis=0) / 0.01]
        moves.append(MoveRecording(m.name, "F", m.stamps_ns, m.cmd, q, dq, m.position,
                                   m.orientation, m.linear_velocity, m.angular_velocity))
    h = held_frames(moves)
    assert not h["significant"] and repair_plan(h) is None
    joints = next(r for r in h["streams"] if r["stream"] == "joint_states")
    assert joints["held_fraction"] < MIN_HELD_FRACTION
    lost = [_hold(m, np.array([50, 51, 120]), stream="joint_states") for m in moves]
    held, _ = held_rows(lost[0].q, np.hstack([lost[0].position, lost[0].orientation]))
    assert {50, 51, 120} <= set(np.flatnonzero(held)) and not held[200:].any()


def test_a_filled_quaternion_is_a_rotation_between_its_neighbours_and_nothing_else_moves():
    m = _walk(3)
    quat = m.orientation.copy()
    quat[1::2] *= -1.0                        # the same rotations, the sign flipping every row
    flipped = MoveRecording(m.name, "F", m.stamps_ns, m.cmd, m.q, m.dq, m.position, quat,
                            m.linear_velocity, m.angular_velocity)
    rows = np.array([40, 41, 90])
    held = _hold(flipped, rows)
    f, filled = repair_move(held, ["pose"])
    assert filled == 3
    others = np.setdiff1d(np.arange(N), rows)
    np.testing.assert_array_equal(f.orientation[others], held.orientation[others])
    np.testing.assert_allclose(np.abs(np.sum(f.orientation[rows] * quat[rows], axis=1)), 1.0,
                               atol=1e-6)
    assert np.all(np.sum(f.orientation[rows] * held.orientation[rows - 1], axis=1) > 0)


def test_a_stage_says_which_corrections_its_data_carry():
    from types import SimpleNamespace

    from littledog_mlsim.diagnose.run import _corrected_label
    assert _corrected_label(SimpleNamespace(repair={"streams": ["pose"]}, correction=None)) \
        == "held frames filled in"
    assert _corrected_label(SimpleNamespace(repair=None, correction={"stream": "pose"})) \
        == "re-stamped"
    assert _corrected_label(SimpleNamespace(repair={"streams": ["pose"]},
                                            correction={"stream": "pose"})) \
        == "held frames filled in and re-stamped"
