"""What the robot's sensors report: joint encoders and motion capture.

- :class:`JointEncoders` samples the joints at the servo rate (every physics step): angles are
  quantised to whole encoder counts, the rate is the difference of successive counts over the
  sample period (what the PD servo uses), and the reported rate is that difference low-passed by a
  first-order filter (50 Hz on the real robot). With no resolution and no filter it reports the
  simulator's exact angles and rates.
- :class:`MotionCapture` adds seeded Gaussian noise to the body pose at 100 Hz: per-axis position
  noise and a small random rotation (per-axis rotation-vector noise in the body frame).
- :func:`twist_from_poses` turns two successive measured poses into the body twist in base_link
  (REP-105), i.e. the average velocity over the last control step.
"""
from __future__ import annotations

import numpy as np

from ..rotations import (quat_conjugate, quat_from_rotvec1, quat_multiply, quat_multiply1, quat_to_matrix,
                        rotate_inverse1, rotvec_from_quat, rotvec_from_quat1)


class JointEncoders:
    """Quantised, differentiated and filtered joint readings, shapes (12,).

    Args:
        resolution: rad/count per joint (12,), or None for exact angles.
        filter_hz: cut-off of the first-order low-pass on the reported rate, or None for none.
        dt: sample period [s] (the servo period).
    """

    def __init__(self, resolution: np.ndarray | None, filter_hz: float | None, dt: float) -> None:
        self.resolution = None if resolution is None else np.asarray(resolution, dtype=float)
        self._counts_per_rad = None if resolution is None else 1.0 / self.resolution
        self.dt = dt
        self._rate_scale = 1.0 / dt
        # Exact discretisation of a first-order low-pass sampled at dt.
        self.alpha = 1.0 if filter_hz is None else 1.0 - np.exp(-2.0 * np.pi * filter_hz * dt)
        self.position = np.zeros(12)   # reported angle [rad]
        self.raw_rate = np.zeros(12)   # unfiltered rate [rad/s] (servo's D term)
        self.rate = np.zeros(12)       # reported rate [rad/s]

    @property
    def exact(self) -> bool:
        """True when readings are the simulator's values (no quantisation, no filter)."""
        return self.resolution is None and self.alpha == 1.0

    def quantise(self, q: np.ndarray) -> np.ndarray:
        """Angles rounded to whole encoder counts, (12,)."""
        if self.resolution is None:
            return np.asarray(q, dtype=float).copy()
        return np.rint(q * self._counts_per_rad) * self.resolution

    def reset(self, q: np.ndarray, dq: np.ndarray, reported: np.ndarray | None = None) -> None:
        """Start from angles q (12,) and rates dq (12,); the rate filter from ``reported``
        (12,), the rates reported at the start, or at rest in the filter (``dq``) if None."""
        self.position = self.quantise(q)
        self.raw_rate = np.asarray(dq, dtype=float).copy()
        self.rate = (self.raw_rate.copy() if reported is None
                     else np.asarray(reported, dtype=float).copy())

    def update(self, q: np.ndarray, dq: np.ndarray) -> None:
        """One sample of the true angles q (12,) and rates dq (12,), dt after the previous one."""
        if self.resolution is None:
            position = np.asarray(q, dtype=float).copy()
            raw = np.asarray(dq, dtype=float).copy()
        else:   # quantise(q), inline: every physics step
            position = np.rint(q * self._counts_per_rad) * self.resolution
            raw = (position - self.position) * self._rate_scale
        self.position = position
        self.raw_rate = raw
        if self.alpha == 1.0:
            self.rate = raw
        else:
            self.rate = self.rate + self.alpha * (raw - self.rate)


class MotionCapture:
    """Body pose as the motion-capture system reports it.

    Args:
        position_std: per-axis position noise [m].
        orientation_std: per-axis rotation-vector noise [rad], applied in the body frame.
        enabled: False reports the true pose.
        rng: random generator for the noise.
    """

    def __init__(self, position_std: float, orientation_std: float, enabled: bool,
                 rng: np.random.Generator) -> None:
        self.position_std = position_std
        self.orientation_std = orientation_std
        self.enabled = enabled
        self.rng = rng

    def measure(self, position: np.ndarray, orientation: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Measured (position (3,), orientation xyzw (4,)) for the true pose."""
        if not self.enabled:
            return np.array(position, dtype=float), np.array(orientation, dtype=float)
        n = self.rng.normal(size=6).tolist()
        sp, so = self.position_std, self.orientation_std
        p = np.array(position, dtype=float) + sp * np.array(n[:3])
        q = np.array(quat_multiply1(tuple(orientation), quat_from_rotvec1((so * n[3], so * n[4], so * n[5]))))
        return p, q / np.linalg.norm(q)


def twist_from_poses(p0: np.ndarray, q0: np.ndarray, p1: np.ndarray, q1: np.ndarray,
                     dt: float) -> tuple[np.ndarray, np.ndarray]:
    """Body twist in base_link at pose 1 from poses dt apart.

    Args:
        p0, p1: positions in odom, (..., 3); q0, q1: orientations xyzw, (..., 4).
    Returns:
        (linear_velocity (..., 3), angular_velocity (..., 3)), both in the frame of pose 1 [m/s],
        [rad/s]: R1^T (p1 - p0) / dt and log(q0^-1 q1) / dt (the relative rotation's rotation
        vector, expressed in the body frame).
    """
    if np.ndim(p1) == 1:  # one pose pair: plain floats, ~20x faster than the array path
        dt_inv = 1.0 / dt
        dp = ((b - a) * dt_inv for a, b in zip(p0, p1))
        x, y, z, w = q0
        rel = quat_multiply1((-x, -y, -z, w), tuple(q1))
        return (np.array(rotate_inverse1(tuple(q1), tuple(dp))),
                np.array(rotvec_from_quat1(rel)) * dt_inv)
    r1 = quat_to_matrix(q1)
    v_world = (np.asarray(p1, dtype=float) - np.asarray(p0, dtype=float)) / dt
    v_body = np.einsum("...ji,...j->...i", r1, v_world)
    w_body = rotvec_from_quat(quat_multiply(quat_conjugate(q0), q1)) / dt
    return v_body, w_body
