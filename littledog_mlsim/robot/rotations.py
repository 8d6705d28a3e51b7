"""Small vectorised quaternion helpers, quaternions stored (x, y, z, w) like pybullet and ROS.

All functions broadcast over leading dimensions: quaternions (..., 4), vectors (..., 3),
matrices (..., 3, 3). Quaternions are assumed unit length.
"""
from __future__ import annotations

import math

import numpy as np


def quat_conjugate(q: np.ndarray) -> np.ndarray:
    """Inverse of a unit quaternion, (..., 4)."""
    q = np.asarray(q, dtype=float)
    return np.concatenate([-q[..., :3], q[..., 3:]], axis=-1)


def quat_multiply(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Hamilton product a * b (apply b, then a), (..., 4)."""
    a = np.asarray(a, dtype=float)
    b = np.asarray(b, dtype=float)
    ax, ay, az, aw = a[..., 0], a[..., 1], a[..., 2], a[..., 3]
    bx, by, bz, bw = b[..., 0], b[..., 1], b[..., 2], b[..., 3]
    return np.stack([
        aw * bx + ax * bw + ay * bz - az * by,
        aw * by - ax * bz + ay * bw + az * bx,
        aw * bz + ax * by - ay * bx + az * bw,
        aw * bw - ax * bx - ay * by - az * bz,
    ], axis=-1)


def quat_to_matrix(q: np.ndarray) -> np.ndarray:
    """Rotation matrices (..., 3, 3) from quaternions (..., 4)."""
    q = np.asarray(q, dtype=float)
    x, y, z, w = q[..., 0], q[..., 1], q[..., 2], q[..., 3]
    r = np.empty(q.shape[:-1] + (3, 3))
    r[..., 0, 0] = 1 - 2 * (y * y + z * z)
    r[..., 0, 1] = 2 * (x * y - z * w)
    r[..., 0, 2] = 2 * (x * z + y * w)
    r[..., 1, 0] = 2 * (x * y + z * w)
    r[..., 1, 1] = 1 - 2 * (x * x + z * z)
    r[..., 1, 2] = 2 * (y * z - x * w)
    r[..., 2, 0] = 2 * (x * z - y * w)
    r[..., 2, 1] = 2 * (y * z + x * w)
    r[..., 2, 2] = 1 - 2 * (x * x + y * y)
    return r


def quat_from_rotvec(v: np.ndarray) -> np.ndarray:
    """Quaternions (..., 4) from rotation vectors (axis * angle) (..., 3)."""
    v = np.asarray(v, dtype=float)
    angle = np.linalg.norm(v, axis=-1, keepdims=True)
    half = 0.5 * angle
    # sin(angle/2)/angle with its series near zero
    k = np.where(angle > 1e-8, np.sin(half) / np.where(angle > 1e-8, angle, 1.0), 0.5 - angle**2 / 48)
    return np.concatenate([v * k, np.cos(half)], axis=-1)


def rotvec_from_quat(q: np.ndarray) -> np.ndarray:
    """Rotation vectors (..., 3) with angle in [0, pi] from quaternions (..., 4)."""
    q = np.asarray(q, dtype=float)
    q = np.where(q[..., 3:] < 0, -q, q)  # shortest rotation
    s = np.linalg.norm(q[..., :3], axis=-1, keepdims=True)
    angle = 2.0 * np.arctan2(s, q[..., 3:])
    k = np.where(s > 1e-12, angle / np.where(s > 1e-12, s, 1.0), 2.0)
    return q[..., :3] * k


def rpy_from_quat(q: np.ndarray) -> np.ndarray:
    """Roll, pitch, yaw (ZYX convention) [rad], (..., 3), from quaternions (..., 4)."""
    r = quat_to_matrix(q)
    roll = np.arctan2(r[..., 2, 1], r[..., 2, 2])
    pitch = np.arcsin(np.clip(-r[..., 2, 0], -1.0, 1.0))
    yaw = np.arctan2(r[..., 1, 0], r[..., 0, 0])
    return np.stack([roll, pitch, yaw], axis=-1)


# Single-pose versions in plain Python floats for the 100 Hz measurement loop (about 20x faster
# than the vectorised ones on one pose); tested against them.
def quat_multiply1(a: tuple[float, ...], b: tuple[float, ...]) -> tuple[float, float, float, float]:
    """Hamilton product a * b of two quaternions (x, y, z, w)."""
    ax, ay, az, aw = a
    bx, by, bz, bw = b
    return (aw * bx + ax * bw + ay * bz - az * by,
            aw * by - ax * bz + ay * bw + az * bx,
            aw * bz + ax * by - ay * bx + az * bw,
            aw * bw - ax * bx - ay * by - az * bz)


def quat_from_rotvec1(v: tuple[float, ...]) -> tuple[float, float, float, float]:
    """Quaternion (x, y, z, w) of a rotation vector (3 floats)."""
    vx, vy, vz = v
    angle = math.sqrt(vx * vx + vy * vy + vz * vz)
    k = math.sin(0.5 * angle) / angle if angle > 1e-8 else 0.5 - angle * angle / 48
    return (vx * k, vy * k, vz * k, math.cos(0.5 * angle))


def rotvec_from_quat1(q: tuple[float, ...]) -> tuple[float, float, float]:
    """Rotation vector (angle in [0, pi]) of a unit quaternion (x, y, z, w)."""
    x, y, z, w = q
    if w < 0:
        x, y, z, w = -x, -y, -z, -w
    s = math.sqrt(x * x + y * y + z * z)
    k = 2.0 * math.atan2(s, w) / s if s > 1e-12 else 2.0
    return (x * k, y * k, z * k)


def rotate_inverse1(q: tuple[float, ...], v: tuple[float, ...]) -> tuple[float, float, float]:
    """R(q)^T v = v - 2w (u x v) + 2 u x (u x v), u = (x, y, z): a world vector in q's frame."""
    x, y, z, w = q
    vx, vy, vz = v
    cx, cy, cz = y * vz - z * vy, z * vx - x * vz, x * vy - y * vx          # u x v
    ddx, ddy, ddz = y * cz - z * cy, z * cx - x * cz, x * cy - y * cx      # u x (u x v)
    return (vx - 2 * w * cx + 2 * ddx, vy - 2 * w * cy + 2 * ddy, vz - 2 * w * cz + 2 * ddz)
