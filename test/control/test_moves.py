"""Kinds of recorded move (``control.moves``): transitions, varied trots, closed-loop runs."""
from __future__ import annotations

import numpy as np
import pytest

from littledog_mlsim.control.gait import TrotCommand
from littledog_mlsim.control.controllers import Observation
from littledog_mlsim.control.moves import (MOVE_KINDS, _RelativeWaypoints, closed_loop_policy,
                                           open_loop_commands)
from littledog_mlsim.control.schedule import switch_move_schedule, varied_schedule
from littledog_mlsim.gait.trot import DEFAULT_RANGES, sample_trot_params, trot_commands
from littledog_mlsim.layout import JOINT_LOWER, JOINT_UPPER, STEPS_PER_MOVE
from littledog_mlsim.robot.sim import simulate_closed_loop
from littledog_mlsim.rotations import rpy_to_quat


def test_a_constant_trot_is_the_papers_move_bit_for_bit():
    a = open_loop_commands("trot", "FL", np.random.default_rng(3))
    b = trot_commands(sample_trot_params("FL", np.random.default_rng(3)))
    np.testing.assert_array_equal(a, b)


def test_a_switch_move_changes_type_once_and_blends():
    sched = switch_move_schedule("F", np.random.default_rng(0))
    assert sched.n_steps == STEPS_PER_MOVE
    (first, second) = sched.segments
    assert first.move_type == "F" and second.move_type != "F"
    assert 100 <= second.start_step <= 250                       # 1.0-2.5 s
    k = second.start_step
    rows = sched.commands[k - 1:k + 51]                          # the 0.5 s blend
    assert np.all(np.abs(np.diff(rows, axis=0)) <= np.abs(rows[-1] - rows[0]) / 25 + 1e-12)
    np.testing.assert_allclose(sched.commands[-1], second.command.as_array())


def test_a_varied_move_never_holds_its_command_and_stays_in_the_types_ranges():
    sched = varied_schedule("F", np.random.default_rng(1))
    c = sched.commands
    later = c[sched.segments[1].start_step:]
    assert np.all(np.any(np.diff(later, axis=0) != 0, axis=1))   # changes at every step
    r = DEFAULT_RANGES
    assert np.all((c[:, 0] >= 0) & (c[:, 0] <= r.speed_forward[1] + 1e-12))
    assert np.all(np.abs(c[:, 2]) <= r.yaw_rate_jitter + 1e-12)
    assert np.all((c[:, 4] >= r.period[0] - 1e-12) & (c[:, 4] <= r.period[1] + 1e-12))
    assert len(sched.segments) >= 3


@pytest.mark.parametrize("kind", ["switch", "varied"])
def test_open_loop_kinds_give_joint_commands_inside_the_limits(kind):
    u = open_loop_commands(kind, "DL", np.random.default_rng(2))
    assert u.shape == (STEPS_PER_MOVE, 12) and np.all(np.isfinite(u))
    assert np.all(u >= JOINT_LOWER - 1e-12) and np.all(u <= JOINT_UPPER + 1e-12)


def test_relative_waypoints_are_placed_in_the_first_poses_frame():
    wp = _RelativeWaypoints(np.array([[0.2, 0.0], [0.2, 0.1]]))
    obs = Observation(np.array([1.0, 2.0, 0.14]), rpy_to_quat(np.array([0.0, 0.0, np.pi / 2])),
                      np.zeros(3), np.zeros(3), np.zeros(12), np.zeros(12))
    cmd = wp.command(obs)
    np.testing.assert_allclose(wp.follower.waypoints, [[1.0, 2.2], [0.9, 2.2]], atol=1e-12)
    assert isinstance(cmd, TrotCommand) and abs(cmd.yaw_rate) < 1e-9   # straight ahead


@pytest.mark.parametrize("kind", ["velocity", "waypoints"])
def test_closed_loop_runs_drive_the_robot_from_what_it_measures(kind):
    rec = simulate_closed_loop(closed_loop_policy(kind, np.random.default_rng(0)), 200,
                               seed=1, name="U_00")
    assert rec.move_type == "U" and rec.cmd.shape == (200, 12)
    assert np.linalg.norm(rec.position[-1, :2] - rec.position[0, :2]) > 0.02   # it walked
    assert rec.position[:, 2].min() > 0.1                                      # upright


def test_unknown_kinds_and_bad_policies_are_refused():
    with pytest.raises(ValueError, match="open-loop move kind"):
        open_loop_commands("velocity", "F", np.random.default_rng(0))
    with pytest.raises(ValueError, match="closed-loop move kind"):
        closed_loop_policy("switch", np.random.default_rng(0))
    with pytest.raises(ValueError, match="step 0"):
        simulate_closed_loop(lambda obs: np.full(12, np.nan), 5)
    assert set(MOVE_KINDS) == {"trot", "switch", "varied", "velocity", "waypoints"}
