"""Analytic forward and inverse kinematics of LittleDog's 3-DOF legs (the URDF's geometry).

Chain per leg (LITTLEDOG.md, robot/littledog.urdf): body -> hip roll (axis x) at ``hip_origin``
-> hip pitch (axis y) at (0, +-0.0236, 0) -> knee (axis y) at (0, 0, -0.0751) -> foot centre at
(-+0.0265, 0, -0.0985) in the lower-leg frame (front legs -0.0265, back legs +0.0265).

Method: a rotation R_y(a) acts on w = z + i x as w -> w e^{ia}, R_x(a) on y + i z as multiplication
by e^{ia}. So the pitch/knee chain is planar in the hip-roll frame's plane y = +-0.0236:
W = e^{i q_pitch} (-l1 + e^{i q_knee} (f_z + i f_x)), and the roll turns (d + i Z) by q_roll.
The inverse is a circle intersection (roll) and the law of cosines (knee); the knee branch is the
one of the home pose (front knees negative, back knees positive).

Shapes: joint angles (..., 12) in contract order; foot positions (..., 4, 3) in the body frame,
legs in ``layout.LEGS`` order.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..layout import JOINT_LOWER, JOINT_UPPER, LEGS, N_JOINTS, wrap_angle


@dataclass(frozen=True)
class LegGeometry:
    """Per-leg constants, arrays over the 4 legs in LEGS order."""

    hip_origin: np.ndarray    # (4, 3) hip-roll joint in the body frame [m]
    pitch_offset: np.ndarray  # (4,) y of the hip-pitch joint in the hip-roll frame [m]
    upper_length: float       # hip pitch -> knee [m]
    foot_offset: np.ndarray   # (4, 2) foot centre (x, z) in the lower-leg frame [m]
    knee_branch: np.ndarray   # (4,) +1 front (knee < 0 at home), -1 back


def _littledog() -> LegGeometry:
    front = np.array([leg.startswith("front") for leg in LEGS])
    left = np.array([leg.endswith("left") for leg in LEGS])
    sx = np.where(front, 1.0, -1.0)
    sy = np.where(left, 1.0, -1.0)
    return LegGeometry(
        hip_origin=np.stack([0.101 * sx, 0.03625 * sy, np.zeros(4)], axis=1),
        pitch_offset=0.0236 * sy,
        upper_length=0.0751,
        foot_offset=np.stack([-0.0265 * sx, np.full(4, -0.0985)], axis=1),
        knee_branch=sx,
    )


LITTLEDOG = _littledog()


def _legs(q: np.ndarray) -> np.ndarray:
    q = np.asarray(q, dtype=float)
    if q.shape[-1] != N_JOINTS:
        raise ValueError(f"expected joint angles (..., {N_JOINTS}), got {q.shape}")
    return q.reshape(q.shape[:-1] + (4, 3))


def forward_kinematics(q: np.ndarray, geometry: LegGeometry = LITTLEDOG) -> np.ndarray:
    """Foot centres in the body frame, (..., 4, 3), for joint angles q (..., 12)."""
    ql = _legs(q)
    roll, pitch, knee = ql[..., 0], ql[..., 1], ql[..., 2]
    fx, fz = geometry.foot_offset[:, 0], geometry.foot_offset[:, 1]
    w = np.exp(1j * pitch) * (-geometry.upper_length + np.exp(1j * knee) * (fz + 1j * fx))
    x, z = w.imag, w.real
    yz = (geometry.pitch_offset + 1j * z) * np.exp(1j * roll)
    return geometry.hip_origin + np.stack([x, yz.real, yz.imag], axis=-1)


def inverse_kinematics(feet: np.ndarray, geometry: LegGeometry = LITTLEDOG,
                       clip: bool = True) -> np.ndarray:
    """Joint angles (..., 12) placing the foot centres at ``feet`` (..., 4, 3) (body frame).

    Unreachable targets are projected onto the workspace boundary (the leg stretches towards
    them). With ``clip`` the result is clamped to the joint limits.
    """
    feet = np.asarray(feet, dtype=float)
    if feet.shape[-2:] != (4, 3):
        raise ValueError(f"expected foot positions (..., 4, 3), got {feet.shape}")
    rel = feet - geometry.hip_origin
    x, y, z = rel[..., 0], rel[..., 1], rel[..., 2]
    d = geometry.pitch_offset
    # Roll: (d + iZ) e^{i roll} = y + i z with Z < 0 (foot below the hip).
    zz = -np.sqrt(np.maximum(y**2 + z**2 - d**2, 0.0))
    roll = np.angle(y + 1j * z) - np.angle(d + 1j * zz)
    # Knee: |W|^2 = l1^2 + rho^2 - 2 l1 rho cos(knee + beta), W = zz + i x.
    l1 = geometry.upper_length
    fx, fz = geometry.foot_offset[:, 0], geometry.foot_offset[:, 1]
    rho = np.hypot(fx, fz)
    beta = np.arctan2(fx, fz)
    cos_k = np.clip((l1**2 + rho**2 - (x**2 + zz**2)) / (2 * l1 * rho), -1.0, 1.0)
    knee = geometry.knee_branch * np.arccos(cos_k) - beta
    # Pitch: W = e^{i pitch} (-l1 + e^{i knee} (fz + i fx)).
    inner = -l1 + np.exp(1j * knee) * (fz + 1j * fx)
    pitch = np.angle(zz + 1j * x) - np.angle(inner)
    q = wrap_angle(np.stack([roll, pitch, knee], axis=-1)).reshape(feet.shape[:-2] + (N_JOINTS,))
    return np.clip(q, JOINT_LOWER, JOINT_UPPER) if clip else q
