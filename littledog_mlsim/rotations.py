"""Vectorised rotation helpers shared by the robot and the data code.

Quaternions are (x, y, z, w) like pybullet and ROS; roll-pitch-yaw are ZYX Euler angles
(R = Rz(yaw) Ry(pitch) Rx(roll), body -> world). Functions broadcast over leading dimensions:
quaternions (..., 4), vectors (..., 3), matrices (..., 3, 3). The ``...1`` variants take one pose
as plain Python floats for the 100 Hz measurement loop (about 20x faster on one pose).
"""
from __future__ import annotations

import math

import numpy as np

from .layout import wrap_angle


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


def quat_to_matrix(quat: np.ndarray) -> np.ndarray:
    """(..., 4) quaternions (x, y, z, w), normalised here -> (..., 3, 3) rotation matrices."""
    q = np.asarray(quat, dtype=np.float64)
    q = q / np.linalg.norm(q, axis=-1, keepdims=True)
    x, y, z, w = np.moveaxis(q, -1, 0)
    return np.stack([
        np.stack([1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)], -1),
        np.stack([2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)], -1),
        np.stack([2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)], -1),
    ], -2)


def quat_to_rpy(quat: np.ndarray) -> np.ndarray:
    """(..., 4) quaternions (x, y, z, w) -> (..., 3) roll, pitch, yaw (ZYX), yaw in (-pi, pi]."""
    R = quat_to_matrix(quat)
    roll = np.arctan2(R[..., 2, 1], R[..., 2, 2])
    pitch = np.arctan2(-R[..., 2, 0], np.hypot(R[..., 2, 1], R[..., 2, 2]))
    yaw = np.arctan2(R[..., 1, 0], R[..., 0, 0])
    return np.stack([roll, pitch, wrap_angle(yaw)], -1)


def rpy_to_quat(rpy: np.ndarray) -> np.ndarray:
    """(..., 3) roll, pitch, yaw (ZYX) -> (..., 4) unit quaternions (x, y, z, w) with w >= 0."""
    r, p, y = np.moveaxis(np.asarray(rpy, dtype=np.float64) / 2.0, -1, 0)
    cr, sr, cp, sp, cy, sy = np.cos(r), np.sin(r), np.cos(p), np.sin(p), np.cos(y), np.sin(y)
    q = np.stack([
        sr * cp * cy - cr * sp * sy,
        cr * sp * cy + sr * cp * sy,
        cr * cp * sy - sr * sp * cy,
        cr * cp * cy + sr * sp * sy,
    ], -1)
    return np.where(q[..., 3:4] < 0, -q, q)


def rpy_to_matrix(rpy: np.ndarray) -> np.ndarray:
    """(..., 3) roll, pitch, yaw -> (..., 3, 3) R = Rz(yaw) Ry(pitch) Rx(roll) (body -> world)."""
    r, p, y = np.moveaxis(np.asarray(rpy, dtype=np.float64), -1, 0)
    cr, sr, cp, sp, cy, sy = np.cos(r), np.sin(r), np.cos(p), np.sin(p), np.cos(y), np.sin(y)
    return np.stack([
        np.stack([cy * cp, cy * sp * sr - sy * cr, cy * sp * cr + sy * sr], -1),
        np.stack([sy * cp, sy * sp * sr + cy * cr, sy * sp * cr - cy * sr], -1),
        np.stack([-sp, cp * sr, cp * cr], -1),
    ], -2)


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


def rpy_to_matrix1(roll: float, pitch: float, yaw: float) -> np.ndarray:
    """``rpy_to_matrix`` of one pose from plain floats (the learned simulator's step)."""
    cr, sr, cp, sp = math.cos(roll), math.sin(roll), math.cos(pitch), math.sin(pitch)
    cy, sy = math.cos(yaw), math.sin(yaw)
    return np.array([[cy * cp, cy * sp * sr - sy * cr, cy * sp * cr + sy * sr],
                     [sy * cp, sy * sp * sr + cy * cr, sy * sp * cr - cy * sr],
                     [-sp, cp * sr, cp * cr]])


def rpy_to_quat1(roll: float, pitch: float, yaw: float) -> np.ndarray:
    """``rpy_to_quat`` of one pose from plain floats (w >= 0)."""
    cr, sr = math.cos(roll / 2.0), math.sin(roll / 2.0)
    cp, sp = math.cos(pitch / 2.0), math.sin(pitch / 2.0)
    cy, sy = math.cos(yaw / 2.0), math.sin(yaw / 2.0)
    q = np.array([sr * cp * cy - cr * sp * sy, cr * sp * cy + sr * cp * sy,
                  cr * cp * sy - sr * sp * cy, cr * cp * cy + sr * sp * sy])
    return -q if q[3] < 0 else q


def rotate_xy(v: np.ndarray, angle: float) -> np.ndarray:
    """Planar vectors ``v`` (..., 2) turned by ``angle`` [rad] about z (counter-clockwise):
    a body-frame (x, y) into odom with the body's yaw, or back with minus it."""
    c, s = math.cos(angle), math.sin(angle)
    v = np.asarray(v, dtype=np.float64)
    return np.stack([c * v[..., 0] - s * v[..., 1], s * v[..., 0] + c * v[..., 1]], axis=-1)
