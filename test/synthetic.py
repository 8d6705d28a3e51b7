"""Synthetic data for tests that must not depend on pybullet: moves (smooth, known geometry),
states inside the limits, real-data-like point clouds, and the naive nearest-neighbour loop the
searches are checked against."""
from __future__ import annotations

import numpy as np
from scipy.spatial.transform import Rotation

from littledog_mlsim.data.recording import MoveRecording
from littledog_mlsim.layout import CONTROL_DT_NS, HOME_POSE, JOINT_LOWER, JOINT_UPPER, N_STATE, S


def make_recording(name: str = "FL_03", n: int = 400, yaw0: float = 2.9, yaw_rate: float = 0.6,
                   tilt: float = 1.0, seed: int = 0, t0_ns: int = 7_000_000_000) -> MoveRecording:
    """A smooth move (orientation built with scipy) whose yaw crosses +-pi when asked."""
    rng = np.random.default_rng(seed)
    t = np.arange(n + 1) * 0.01
    yaw = yaw0 + yaw_rate * t + 0.05 * np.sin(3 * t)
    roll = tilt * (0.08 * np.sin(2 * np.pi * 1.3 * t + 0.3) + 0.03)
    pitch = tilt * (0.06 * np.cos(2 * np.pi * 0.9 * t) - 0.02)
    quat = Rotation.from_euler("ZYX", np.column_stack([yaw, pitch, roll])).as_quat()
    phase = rng.uniform(0, 2 * np.pi, 12)
    q = HOME_POSE + 0.2 * np.sin(2 * np.pi * 2.5 * t[:, None] + phase)
    dq = 0.2 * 2 * np.pi * 2.5 * np.cos(2 * np.pi * 2.5 * t[:, None] + phase)
    pos = np.column_stack([0.3 + 0.2 * t + 0.01 * np.sin(5 * t), -0.1 + 0.05 * t ** 2,
                           0.146 + 0.005 * np.sin(7 * t)])
    return MoveRecording(
        name=name, move_type=name.split("_")[0],
        stamps_ns=t0_ns + np.arange(n + 1, dtype=np.int64) * CONTROL_DT_NS,
        cmd=q[1:] + 0.01 * rng.standard_normal((n, 12)), q=q, dq=dq, position=pos,
        orientation=quat, linear_velocity=0.1 * rng.standard_normal((n + 1, 3)),
        angular_velocity=0.2 * rng.standard_normal((n + 1, 3)),
    )


def naive_nearest(P: np.ndarray, Q: np.ndarray) -> np.ndarray:
    """Index of the nearest row of P to each row of Q, by a plain loop (the reference)."""
    return np.array([np.argmin(((P - a) ** 2).sum(axis=1)) for a in Q])


def random_states(n: int, seed: int, spread: float = 0.3) -> np.ndarray:
    """States strictly inside the joint limits and the angle range."""
    rng = np.random.default_rng(seed)
    s = spread * rng.standard_normal((n, N_STATE))
    s[:, S.q] = np.clip(s[:, S.q], JOINT_LOWER + 0.05, JOINT_UPPER - 0.05)
    return s


def clustered_points(n: int, seed: int, d: int = N_STATE) -> np.ndarray:
    """Real-data-like points: clusters along curves of a 5-D latent space, mapped into d-D with
    decaying scales (a steep PCA spectrum like the TrainPool's) plus a little noise."""
    rng = np.random.default_rng(seed)
    t = rng.uniform(0, 2 * np.pi, n)
    centres = 3.0 * rng.standard_normal((8, 5))
    lat = centres[rng.integers(0, 8, n)] + np.c_[np.cos(t), np.sin(t), np.cos(2 * t),
                                                 np.sin(3 * t), t / np.pi]
    M = rng.standard_normal((5, d)) * (0.7 ** np.arange(d))
    return lat @ M + 0.05 * rng.standard_normal((n, d)) * (0.85 ** np.arange(d))
