"""Controllers that close the loop through a simulator's odometry and joint states.

Each controller sees, every 10 ms step, an :class:`Observation` (what ``sim_node`` publishes on
``~/odom`` and ``~/joint_states``, or what the pybullet robot measures) and returns the
:class:`.gait.TrotCommand` for the next step; :class:`.gait.StreamingTrot` turns it into joint
angles. They keep their commands inside the ranges the data's trots were drawn from
(``gait.trot.DEFAULT_RANGES``), so that a learned simulator is asked about the gaits it saw.

- :class:`WaypointFollower` (pose): heading and distance to the next waypoint -> forward speed
  and yaw rate (a proportional heading loop; speed falls with the heading error, never below the
  data's slowest forward trot while moving).
- :class:`VelocityTracker` (joint states + odometry): a PI loop on the body velocity. Linear body
  velocity is estimated by leg odometry from the joint angles: the feet of the stance pair (the
  diagonal pair lower in the gravity-aligned body frame) are taken as fixed on the ground, so
  v_b = -(d/dt p_foot + w x p_foot), averaged over the stance feet and over one gait period
  (which removes the stride's oscillation); the yaw rate is the odometry's, averaged likewise.
- :class:`TrajectoryTracker` (pose): a timed reference trajectory of poses; the reference's
  own body velocity fed forward plus proportional feedback on the pose error, with the
  sideways velocity as well as forward speed and yaw rate (the robot is holonomic).
"""
from __future__ import annotations

from collections import deque
from dataclasses import dataclass, field
from typing import Any, Mapping

import numpy as np

from ..gait.ik import forward_kinematics
from ..gait.trot import DEFAULT_RANGES
from ..layout import CONTROL_DT, N_JOINTS, wrap_angle
from ..rotations import quat_to_rpy, rotate_xy, rpy_to_matrix
from .gait import TrotCommand

__all__ = ["Observation", "WaypointFollower", "VelocityTracker", "TrajectoryTracker",
           "reference_trajectory", "STANCE_PAIRS"]

# Diagonal pairs in LEGS order (front_left, front_right, back_left, back_right).
STANCE_PAIRS = (np.array([0, 3]), np.array([1, 2]))


@dataclass(frozen=True)
class Observation:
    """One step's odometry (odom frame; twist in base_link) and joint states."""

    position: np.ndarray          # (3,) m
    orientation: np.ndarray       # (4,) xyzw
    linear_velocity: np.ndarray   # (3,) m/s, base_link
    angular_velocity: np.ndarray  # (3,) rad/s, base_link
    q: np.ndarray                 # (12,) rad
    dq: np.ndarray                # (12,) rad/s

    @classmethod
    def from_mapping(cls, obs: Mapping[str, Any]) -> "Observation":
        """From the pybullet robot's measurement dict (``robot.sim.OBS_FIELDS``)."""
        return cls(*(np.asarray(obs[k], dtype=np.float64).copy() for k in
                     ("position", "orientation", "linear_velocity", "angular_velocity",
                      "q", "dq")))

    @classmethod
    def from_learned(cls, sim: Any) -> "Observation":
        """From a ``rollout.learned_sim.LearnedSimulator`` (the values ``sim_node`` publishes)."""
        return cls(sim.position.copy(), sim.orientation.copy(), sim.linear_velocity.copy(),
                   sim.angular_velocity.copy(), sim.q.copy(), sim.dq.copy())

    @property
    def rpy(self) -> np.ndarray:
        return quat_to_rpy(self.orientation)

    def is_finite(self) -> bool:
        return all(np.all(np.isfinite(a)) for a in (self.position, self.orientation,
                                                       self.linear_velocity,
                                                       self.angular_velocity, self.q, self.dq))


@dataclass
class WaypointFollower:
    """Walk through ``waypoints`` (n, 2) in odom, in order; trot in place after the last.

    Per step: bearing b = angle to the waypoint minus yaw (wrapped); yaw rate
    ``clip(yaw_gain * b, +-max_yaw_rate)``; forward speed ``cruise_speed * cos(b)`` held in
    [min_speed, cruise_speed] (the data has no turning on the spot). A waypoint within
    ``reach_radius`` counts as reached (``reached_steps`` records the step of each).
    """

    waypoints: np.ndarray
    reach_radius: float = 0.12
    cruise_speed: float = 0.13
    min_speed: float = DEFAULT_RANGES.speed_forward[0]
    max_yaw_rate: float = DEFAULT_RANGES.yaw_rate_turn[1]
    yaw_gain: float = 1.5
    step_height: float = 0.025
    period: float = 0.35
    index: int = 0
    reached_steps: list = field(default_factory=list)
    _steps: int = 0

    def __post_init__(self) -> None:
        self.waypoints = np.asarray(self.waypoints, dtype=np.float64).reshape(-1, 2)
        if self.waypoints.shape[0] < 1 or not np.all(np.isfinite(self.waypoints)):
            raise ValueError("waypoints must be (n >= 1, 2) finite values")

    def reset(self) -> None:
        self.index, self.reached_steps, self._steps = 0, [], 0

    @property
    def done(self) -> bool:
        return self.index >= self.waypoints.shape[0]

    def command(self, obs: Observation) -> TrotCommand:
        self._steps += 1
        x, y = obs.position[:2]
        yaw = float(obs.rpy[2])
        while not self.done and np.hypot(*(self.waypoints[self.index] - (x, y))) < self.reach_radius:
            self.reached_steps.append(self._steps)
            self.index += 1
        if self.done:
            return TrotCommand(0.0, 0.0, 0.0, self.step_height, self.period)
        dx, dy = self.waypoints[self.index] - (x, y)
        bearing = float(wrap_angle(np.arctan2(dy, dx) - yaw))
        w = float(np.clip(self.yaw_gain * bearing, -self.max_yaw_rate, self.max_yaw_rate))
        v = float(np.clip(self.cruise_speed * np.cos(bearing), self.min_speed, self.cruise_speed))
        return TrotCommand(v, 0.0, w, self.step_height, self.period)


class VelocityTracker:
    """PI tracking of a body-velocity reference (vx, vy, yaw rate) per step.

    Args:
        reference: (n, 3) per step; after its end the last row holds.
        kp, ki: gains on the error of (vx, vy, yaw rate) [1, 1/s].
        step_height, period: of the trot.
        limits: |vx|, |vy|, |yaw rate| bounds of the command (default: the data's ranges).
    Attributes: ``estimate`` (3,) the current estimate of (vx, vy, yaw rate).
    """

    def __init__(self, reference: np.ndarray, kp: float = 0.5, ki: float = 0.8,
                 step_height: float = 0.025, period: float = 0.35,
                 limits: tuple[float, float, float] = (DEFAULT_RANGES.speed_forward[1],
                                                      DEFAULT_RANGES.speed_sideways[1],
                                                      DEFAULT_RANGES.yaw_rate_turn[1]),
                 dt: float = CONTROL_DT) -> None:
        ref = np.asarray(reference, dtype=np.float64)
        if ref.ndim != 2 or ref.shape[1] != 3 or ref.shape[0] < 1 or not np.all(np.isfinite(ref)):
            raise ValueError(f"reference must be (n >= 1, 3) finite values, got {ref.shape}")
        self.reference = ref
        self.kp, self.ki = float(kp), float(ki)
        self.step_height, self.period = float(step_height), float(period)
        self.limits = np.asarray(limits, dtype=np.float64)
        self.dt = float(dt)
        self.window = max(1, int(round(period / dt)))
        self.reset()

    def reset(self) -> None:
        self._k = 0
        self._integral = np.zeros(3)
        self._prev_feet: np.ndarray | None = None
        self._buf: deque = deque(maxlen=self.window)
        self.estimate = np.zeros(3)

    def _instant_velocity(self, obs: Observation) -> np.ndarray:
        """(vx, vy, yaw rate) of this step: leg odometry and the odometry's yaw rate."""
        feet = forward_kinematics(obs.q)                         # (4, 3) body frame
        w = obs.angular_velocity
        if self._prev_feet is None:
            v = np.zeros(3)
        else:
            roll, pitch, _ = obs.rpy
            level = rpy_to_matrix(np.array([roll, pitch, 0.0])) @ feet.T      # (3, 4)
            z = [level[2, pair].mean() for pair in STANCE_PAIRS]
            pair = STANCE_PAIRS[int(np.argmin(z))]
            dp = (feet[pair] - self._prev_feet[pair]) / self.dt
            v = -(dp + np.cross(w, feet[pair])).mean(axis=0)
        self._prev_feet = feet
        return np.array([v[0], v[1], w[2]])

    def command(self, obs: Observation) -> TrotCommand:
        if obs.q.shape != (N_JOINTS,):
            raise ValueError(f"observation q must be ({N_JOINTS},), got {obs.q.shape}")
        ref = self.reference[min(self._k, self.reference.shape[0] - 1)]
        self._k += 1
        self._buf.append(self._instant_velocity(obs))
        self.estimate = np.mean(self._buf, axis=0)
        err = ref - self.estimate
        raw = ref + self.kp * err + self.ki * (self._integral + err * self.dt)
        cmd = np.clip(raw, -self.limits, self.limits)
        if np.array_equal(cmd, raw):          # anti-windup: integrate only when not saturated
            self._integral += err * self.dt
        return TrotCommand(float(cmd[0]), float(cmd[1]), float(cmd[2]), self.step_height,
                           self.period)


def reference_trajectory(body_velocity: np.ndarray,
                         pose0: tuple[float, float, float] = (0.0, 0.0, 0.0),
                         dt: float = CONTROL_DT) -> np.ndarray:
    """Poses (n, 3) x, y, yaw in odom of a body moving from ``pose0`` with ``body_velocity``
    (n, 3): vx, vy [m/s] in its own frame and yaw rate [rad/s] per step (row k: the pose after
    k + 1 steps)."""
    v = np.asarray(body_velocity, dtype=np.float64)
    if v.ndim != 2 or v.shape[1] != 3 or not np.all(np.isfinite(v)):
        raise ValueError(f"body_velocity must be (n, 3) finite values, got {v.shape}")
    out = np.empty_like(v)
    xy, yaw = np.array(pose0[:2], dtype=np.float64), float(pose0[2])
    for k, (vx, vy, w) in enumerate(v):
        xy = xy + rotate_xy((vx, vy), yaw) * dt
        yaw += w * dt
        out[k] = xy[0], xy[1], yaw
    return out


class TrajectoryTracker:
    """Follow a timed reference trajectory: feedforward plus proportional pose feedback.

    Args:
        poses: (n, 3) reference x, y, yaw in odom per step (after its end the last pose holds,
            with zero feedforward).
        body_velocity: (n, 3) the reference's own vx, vy (in its frame) and yaw rate per step,
            the feedforward (``reference_trajectory`` makes poses from it).
        k_position, k_heading: feedback gains [1/s] on the position error (in the body frame)
            and on the heading error.
        step_height, period: of the trot; limits: |vx|, |vy|, |yaw rate| bounds (default: the
            data's ranges).

    Per step: e = R(yaw)^T (p_ref - p) and dyaw = wrap(yaw_ref - yaw); (vx, vy) = R(dyaw) v_ref
    + k_position e (the reference's body velocity seen from the robot's frame, plus the
    position feedback); yaw rate = w_ref + k_heading dyaw; each clipped to its limit.
    ``error`` holds the last position error (2,) [m] in odom.
    """

    def __init__(self, poses: np.ndarray, body_velocity: np.ndarray, k_position: float = 0.5,
                 k_heading: float = 1.0, step_height: float = 0.025, period: float = 0.35,
                 limits: tuple[float, float, float] = (DEFAULT_RANGES.speed_forward[1],
                                                      DEFAULT_RANGES.speed_sideways[1],
                                                      DEFAULT_RANGES.yaw_rate_turn[1])) -> None:
        p = np.asarray(poses, dtype=np.float64)
        v = np.asarray(body_velocity, dtype=np.float64)
        if (p.ndim != 2 or p.shape[1] != 3 or p.shape[0] < 1 or v.shape != p.shape
                or not np.all(np.isfinite(p)) or not np.all(np.isfinite(v))):
            raise ValueError(f"poses and body_velocity must be (n >= 1, 3) finite values, got "
                             f"{p.shape} and {v.shape}")
        self.poses, self.body_velocity = p, v
        self.k_position, self.k_heading = float(k_position), float(k_heading)
        self.step_height, self.period = float(step_height), float(period)
        self.limits = np.asarray(limits, dtype=np.float64)
        self.reset()

    def reset(self) -> None:
        self._k = 0
        self.error = np.zeros(2)

    def command(self, obs: Observation) -> TrotCommand:
        n = self.poses.shape[0]
        k = min(self._k, n - 1)
        ff = self.body_velocity[k] if self._k < n else np.zeros(3)
        self._k += 1
        yaw = float(obs.rpy[2])
        self.error = self.poses[k, :2] - obs.position[:2]
        dyaw = float(wrap_angle(self.poses[k, 2] - yaw))
        v = rotate_xy(ff[:2], dyaw) + self.k_position * rotate_xy(self.error, -yaw)
        raw = np.array([v[0], v[1], ff[2] + self.k_heading * dyaw])
        cmd = np.clip(raw, -self.limits, self.limits)
        return TrotCommand(float(cmd[0]), float(cmd[1]), float(cmd[2]), self.step_height,
                           self.period)
