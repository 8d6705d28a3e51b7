"""The raw record of one move: what the sensors reported and what was commanded.

This is the hand-over between the robot simulation (which produces it), the bag writer (which
serialises it per docs/interface.md §3) and the bag reader (which recovers it). Shapes, with
N = number of commands (400 for a 4 s move):

- ``stamps_ns``        (N+1,)  int64, one 100 Hz clock; measurement k is at stamps_ns[k]
- ``cmd``              (N, 12) desired joint angles sent at stamps_ns[k] for step k -> k+1 [rad]
- ``q``, ``dq``        (N+1, 12) measured joint angles [rad] and rates [rad/s], contract order
- ``position``         (N+1, 3) measured body position in odom [m]
- ``orientation``      (N+1, 4) measured body orientation in odom, quaternion (x, y, z, w)
- ``linear_velocity``  (N+1, 3) body linear velocity expressed in base_link [m/s]
- ``angular_velocity`` (N+1, 3) body angular velocity expressed in base_link [rad/s]
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..layout import N_JOINTS


@dataclass
class MoveRecording:
    name: str                     # bag directory name, e.g. "FL_07"
    move_type: str                # one of layout.MOVE_TYPES
    stamps_ns: np.ndarray
    cmd: np.ndarray
    q: np.ndarray
    dq: np.ndarray
    position: np.ndarray
    orientation: np.ndarray
    linear_velocity: np.ndarray
    angular_velocity: np.ndarray

    @property
    def n_steps(self) -> int:
        return int(self.cmd.shape[0])

    def validate(self) -> None:
        """Raise ValueError naming the field if shapes or values are inconsistent."""
        n1 = self.stamps_ns.shape[0]
        expect = {
            "cmd": (n1 - 1, N_JOINTS), "q": (n1, N_JOINTS), "dq": (n1, N_JOINTS),
            "position": (n1, 3), "orientation": (n1, 4),
            "linear_velocity": (n1, 3), "angular_velocity": (n1, 3),
        }
        for field, shape in expect.items():
            arr = getattr(self, field)
            if arr.shape != shape:
                raise ValueError(f"{self.name}: {field} has shape {arr.shape}, expected {shape}")
            if not np.all(np.isfinite(arr)):
                raise ValueError(f"{self.name}: {field} holds NaN or inf")
