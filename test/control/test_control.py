"""Controllers and the streaming trot (littledog_mlsim.control).

Independent references: the batch trot generator ``gait.trot.trot_commands``, the closed form of a
first-order filter, a kinematic unicycle for the waypoint loop, feet moved by the IK along the
ground-fixed motion the leg odometry inverts, and a plant of known gain for the PI loop.
"""
from __future__ import annotations

import numpy as np
import pytest

from littledog_mlsim.control.controllers import (STANCE_PAIRS, Observation, TrajectoryTracker,
                                                 VelocityTracker, WaypointFollower,
                                                 reference_trajectory)
from littledog_mlsim.control.gait import StreamingTrot, TrotCommand
from littledog_mlsim.control.schedule import gait_switch_schedule, straight_trot_schedule
from littledog_mlsim.gait.ik import forward_kinematics, inverse_kinematics
from littledog_mlsim.gait.trot import TrotParams, trot_commands
from littledog_mlsim.layout import CONTROL_DT, HOME_POSE
from littledog_mlsim.rotations import rpy_to_quat


def test_streaming_trot_equals_batch_trot_at_constant_command():
    p = TrotParams("FL", (0.12, 0.0), 0.4, 0.33, 0.025, ramp_time=0.0, phase=0.5, n_steps=200)
    st = StreamingTrot(phase=0.5)
    out = np.array([st.step(TrotCommand.from_params(p)) for _ in range(200)])
    np.testing.assert_allclose(out, trot_commands(p), atol=1e-12)


def test_streaming_trot_smoothing_is_first_order():
    tau, target = 0.3, TrotCommand(0.1, 0.0, 0.2, 0.02, 0.35)
    st = StreamingTrot(smoothing_time=tau, initial=TrotCommand(period=0.35))
    for _ in range(40):
        st.step(target)
    expect = target.as_array() + (TrotCommand(period=0.35).as_array() - target.as_array()) * \
        np.exp(-40 * CONTROL_DT / tau)
    np.testing.assert_allclose(st.applied, expect, rtol=1e-12, atol=1e-15)
    np.testing.assert_array_equal(StreamingTrot().step(TrotCommand()), HOME_POSE)


def test_bad_commands_are_refused():
    with pytest.raises(ValueError, match="finite"):
        TrotCommand(np.nan)
    with pytest.raises(ValueError, match="period"):
        TrotCommand(period=0.0)
    with pytest.raises(ValueError, match="waypoints"):
        WaypointFollower(np.array([[np.inf, 0.0]]))
    with pytest.raises(ValueError, match="reference"):
        VelocityTracker(np.zeros((5, 2)))


def test_gait_switch_schedule_blends_and_switches():
    s = gait_switch_schedule(20.0, np.random.default_rng(3), segment_time=4.0, blend_time=0.5)
    assert s.n_steps == 2000 and len(s.segments) == 5
    assert all(a.move_type != b.move_type for a, b in zip(s.segments, s.segments[1:]))
    assert [seg.start_step for seg in s.segments] == [0, 400, 800, 1200, 1600]
    # starts from standing, reaches each segment's command, never jumps
    assert abs(s.commands[0, 0]) < 0.01 * 0.16 and s.commands[0, 3] < 0.01 * 0.03
    for seg in s.segments:
        np.testing.assert_allclose(s.commands[seg.start_step + 399], seg.command.as_array())
    step = np.abs(np.diff(s.commands, axis=0)).max(axis=0)
    span = np.ptp(s.commands, axis=0)
    # smoothstep over n steps changes by at most 1.5 / n of the jump per step; the shortest
    # blend is the start's ramp (>= 0.3 s = 30 steps)
    assert np.all(step <= 1.5 * span / 30 + 1e-12)
    one = straight_trot_schedule(5.0, np.random.default_rng(0))
    assert one.n_steps == 500 and one.segments[0].move_type == "F"


def _obs(x, y, yaw, q=HOME_POSE, w=(0.0, 0.0, 0.0)):
    return Observation(np.array([x, y, 0.14]), rpy_to_quat(np.array([0.0, 0.0, yaw])),
                       np.zeros(3), np.asarray(w, float), np.asarray(q, float), np.zeros(12))


def test_waypoint_follower_reaches_waypoints_of_a_unicycle():
    wp = np.array([[0.5, 0.0], [0.8, 0.4], [0.4, 0.7]])
    ctrl = WaypointFollower(wp, reach_radius=0.05)
    x = y = yaw = 0.0
    c = ctrl.command(_obs(0.0, 0.0, np.pi / 2))        # waypoint to the right: turn right
    assert c.yaw_rate < 0 and c.vx >= ctrl.min_speed
    ctrl.reset()
    for _ in range(3000):
        c = ctrl.command(_obs(x, y, yaw))
        x += c.vx * np.cos(yaw) * CONTROL_DT
        y += c.vx * np.sin(yaw) * CONTROL_DT
        yaw += c.yaw_rate * CONTROL_DT
        assert abs(c.yaw_rate) <= ctrl.max_yaw_rate and c.vx <= ctrl.cruise_speed
    assert ctrl.done and len(ctrl.reached_steps) == 3
    assert c.vx == 0.0 and c.yaw_rate == 0.0 and c.step_height > 0


def _feet_q(v, w, t, pair):
    """Joint angles whose stance pair's feet are fixed on the ground under body velocity v and
    yaw rate w for t s (small-motion), the other pair lifted 2 cm."""
    feet = forward_kinematics(HOME_POSE).copy()
    p0 = feet[pair].copy()
    ang = -w * t
    c, s = np.cos(ang), np.sin(ang)
    rot = np.array([[c, -s, 0], [s, c, 0], [0, 0, 1]])
    feet[pair] = (rot @ (p0 - np.array([v[0], v[1], 0.0]) * t).T).T
    other = STANCE_PAIRS[1] if pair is STANCE_PAIRS[0] else STANCE_PAIRS[0]
    feet[other, 2] += 0.02
    return inverse_kinematics(feet)


@pytest.mark.parametrize("v,w", [((0.05, 0.0), 0.0), ((0.0, -0.03), 0.0), ((0.0, 0.0), 0.3),
                                 ((0.04, 0.01), 0.2)])
def test_leg_odometry_recovers_body_velocity(v, w):
    tr = VelocityTracker(np.zeros((1, 3)), period=0.1)
    for k in range(15):
        tr.command(_obs(0, 0, 0, _feet_q(v, w, k * CONTROL_DT, STANCE_PAIRS[1]), (0, 0, w)))
    np.testing.assert_allclose(tr.estimate, [v[0], v[1], w], atol=2e-3)


class _Plant(VelocityTracker):
    """The tracker on a plant that achieves 40 % of the commanded body velocity (one step
    late): the estimate is that velocity, so the PI's integral must supply the rest."""

    achieved = np.zeros(3)

    def _instant_velocity(self, obs):
        return self.achieved.copy()


def test_pi_tracker_removes_a_steady_gain_error():
    ref = np.tile([0.04, -0.02, 0.15], (3000, 1))
    tr = _Plant(ref)
    for _ in range(3000):
        c = tr.command(_obs(0, 0, 0))
        tr.achieved = 0.4 * np.array([c.vx, c.vy, c.yaw_rate])
    np.testing.assert_allclose(tr.estimate, ref[0], rtol=0.02)
    # an unreachable reference saturates at the limits without winding up
    tr = _Plant(np.tile([1.0, 0.0, 0.0], (500, 1)))
    for _ in range(500):
        c = tr.command(_obs(0, 0, 0))
        tr.achieved = 0.4 * np.array([c.vx, c.vy, c.yaw_rate])
    assert c.vx == tr.limits[0] and np.all(np.abs(tr._integral) < 1.0)


def test_trajectory_tracker_follows_a_curved_holonomic_reference():
    n = 3000
    t = np.arange(n) * CONTROL_DT
    v = np.stack([np.full(n, 0.08), 0.03 * np.sin(0.2 * t), 0.2 * np.sin(0.1 * t)], axis=1)
    poses = reference_trajectory(v)
    ctrl = TrajectoryTracker(poses, v)
    x, y, yaw = 0.05, -0.04, 0.2                          # start off the reference
    for k in range(n):
        c = ctrl.command(_obs(x, y, yaw))
        assert abs(c.vx) <= ctrl.limits[0] and abs(c.vy) <= ctrl.limits[1]
        x += (np.cos(yaw) * c.vx - np.sin(yaw) * c.vy) * CONTROL_DT
        y += (np.sin(yaw) * c.vx + np.cos(yaw) * c.vy) * CONTROL_DT
        yaw += c.yaw_rate * CONTROL_DT
    np.testing.assert_allclose([x, y], poses[-1, :2], atol=0.01)
    assert abs(yaw - poses[-1, 2]) < 0.01
    with pytest.raises(ValueError, match="finite"):
        TrajectoryTracker(poses[:5], np.full((5, 3), np.nan))
