"""Decision 043 (``littledog_mlsim.diagnose.restamp``): a late sensor stream the timing check
finds is moved back to the stamps it belongs to."""
from __future__ import annotations

import numpy as np
import pytest

from littledog_mlsim.data.recording import MoveRecording
from littledog_mlsim.diagnose.restamp import correction_from_timing, restamp, restamp_move
from littledog_mlsim.diagnose.timing import sensor_timing
from littledog_mlsim.layout import JOINT_NAMES

from test_timing import N, _leg_late, _move


def test_a_late_pose_found_by_the_timing_check_is_undone():
    late = [_move(s, pose_late=2) for s in range(20)]
    c = correction_from_timing(sensor_timing(late))
    assert c is not None and c["stream"] == "pose" and c["rows_dropped"] == 2
    assert c["shift_ms"] == pytest.approx(20.0, abs=3.0)
    fixed = restamp(late, {**c, "shift_steps": 2.0})     # the whole steps the moves were made late
    for s, m in enumerate(fixed):
        on_time = _move(s)
        assert m.n_steps == on_time.n_steps - 2
        np.testing.assert_allclose(m.position, on_time.position[:N - 2], atol=1e-12)
        np.testing.assert_array_equal(m.q, on_time.q[:N - 2])      # the joints are not moved
        np.testing.assert_array_equal(m.cmd, on_time.cmd[:N - 3])
    # and the check then reads the streams as of one instant
    assert not sensor_timing(fixed)["significant"]


def test_one_late_legs_correction_moves_that_legs_joints_only():
    moves = [_leg_late(_move(s), 2, 3) for s in range(3)]
    timing = {"significant": True, "stream": "joint_states", "shift_ms": 8.0,
              "legs": {"late": ["back_left"], "shift_ms": 30.0}}
    c = correction_from_timing(timing)
    assert c["joints"] == ["back_left_hip_roll", "back_left_hip_pitch", "back_left_knee"]
    assert c["shift_steps"] == pytest.approx(3.0) and "back-left" in c["statement"]
    cols = [JOINT_NAMES.index(j) for j in c["joints"]]
    other = [i for i in range(12) if i not in cols]
    for m, f in zip(moves, restamp(moves, c)):
        np.testing.assert_array_equal(f.q[:, cols], m.q[3:, cols])
        np.testing.assert_array_equal(f.q[:, other], m.q[:len(m.q) - 3, other])
        np.testing.assert_array_equal(f.position, m.position[:len(m.q) - 3])


def _linear_move(n: int = 50) -> MoveRecording:
    t = np.arange(n, dtype=float)
    yaw = 0.02 * t
    quat = np.column_stack([np.zeros(n), np.zeros(n), np.sin(yaw / 2), np.cos(yaw / 2)])
    quat[1::2] *= -1.0                  # the same rotations, the sign flipping every sample
    return MoveRecording("F_00", "F", (t * 1e7).astype(np.int64), np.zeros((n - 1, 12)),
                         np.tile(t[:, None], (1, 12)), np.ones((n, 12)),
                         np.column_stack([t, 2 * t, np.zeros(n)]), quat, np.ones((n, 3)),
                         np.zeros((n, 3)))


def test_a_fraction_of_a_step_is_interpolated_and_the_quaternion_stays_a_rotation():
    m = _linear_move()
    c = {"stream": "pose", "shift_steps": 1.5, "rows_dropped": 2,
         "fields": ["position", "orientation", "linear_velocity", "angular_velocity"],
         "joints": []}
    f = restamp_move(m, c)
    assert f.n_steps == m.n_steps - 2
    np.testing.assert_allclose(f.position[:, 0], np.arange(48) + 1.5)
    np.testing.assert_allclose(np.linalg.norm(f.orientation, axis=1), 1.0)
    yaw = 2 * np.arctan2(f.orientation[:, 2], f.orientation[:, 3])
    yaw = (yaw - 0.02 * (np.arange(48) + 1.5) + np.pi) % (2 * np.pi) - np.pi
    assert np.abs(yaw).max() < 1e-4


def test_no_finding_no_correction_and_a_move_too_short_is_refused_in_one_line():
    assert correction_from_timing({"significant": False}) is None
    assert correction_from_timing({"error": "no moves", "significant": False}) is None
    c = correction_from_timing({"significant": True, "stream": "pose", "shift_ms": -30.0,
                                "legs": {"late": []}})
    assert c["shift_steps"] == pytest.approx(3.0) and c["rows_dropped"] == 3
    with pytest.raises(ValueError, match=r"^F_00: 4 rows, too short to re-stamp by 3 steps$"):
        restamp_move(_linear_move(4), c)
