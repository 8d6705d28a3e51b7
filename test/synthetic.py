"""Synthetic moves for tests that must not depend on pybullet (smooth, known geometry)."""
from __future__ import annotations

import numpy as np
from scipy.spatial.transform import Rotation

from littledog_mlsim.data.recording import MoveRecording
from littledog_mlsim.layout import CONTROL_DT_NS, HOME_POSE


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
