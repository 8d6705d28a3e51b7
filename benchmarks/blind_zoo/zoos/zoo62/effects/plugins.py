"""zoo62's own effect plug-ins (docs/interface.md section 5), where no built-in plug-in gives
the physics. Each is realistic for a 2.5-3 kg LittleDog in a motion-capture lab.

- :class:`ElasticTether`: a slack elastic cord (a power or safety tether) from a fixed anchor
  on the floor, where the move starts, to a point on the body: once the cord's horizontal
  length exceeds its slack, it pulls back towards the anchor with ``stiffness_N_m`` times the
  stretch (horizontal, capped at ``max_force_N``).
- :class:`MocapFrameOffset`: the motion-capture rigid body was defined with its frame turned
  (a small rotation ``rotvec_rad``, body frame) and its origin away from base_link
  (``origin_m``): the reported pose is that frame's, the reported twist its finite difference
  (to first order in the step).
- :class:`JointSoftStop`: a compliant end stop (a rubber bumper or a cable guard) on some
  joints: outside a band of +-``half_width_rad`` about the home pose, a spring of
  ``stiffness_Nm_rad`` pushes the joint back (a torque on top of the servo's).
"""
from __future__ import annotations

from typing import Any

import numpy as np
import pybullet as p

from littledog_mlsim.layout import HOME_POSE
from littledog_mlsim.robot.effects import resolve_joints


def _quat_mul(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Hamilton product of xyzw quaternions."""
    ax, ay, az, aw = a
    bx, by, bz, bw = b
    return np.array([aw * bx + ax * bw + ay * bz - az * by,
                     aw * by - ax * bz + ay * bw + az * bx,
                     aw * bz + ax * by - ay * bx + az * bw,
                     aw * bw - ax * bx - ay * by - az * bz])


def _quat_from_rotvec(v: np.ndarray) -> np.ndarray:
    th = float(np.linalg.norm(v))
    if th < 1e-12:
        return np.array([0.0, 0.0, 0.0, 1.0])
    s = np.sin(0.5 * th) / th
    return np.array([v[0] * s, v[1] * s, v[2] * s, np.cos(0.5 * th)])


def _matrix(q: np.ndarray) -> np.ndarray:
    return np.array(p.getMatrixFromQuaternion(list(map(float, q)))).reshape(3, 3)


class ElasticTether:
    """A slack elastic cord from a floor anchor (the body's start point, on the floor) to
    ``attach_m`` (base_link); horizontal pull -k (d - slack) towards the anchor beyond the
    slack, at most ``max_force_N``."""

    changes_world = False     # a force each physics step only

    def __init__(self, stiffness_N_m: float, slack_m: float = 0.05,
                 attach_m: list[float] | tuple[float, float, float] = (-0.1, 0.0, 0.02),
                 max_force_N: float = 5.0) -> None:
        if not (np.isfinite(stiffness_N_m) and stiffness_N_m >= 0):
            raise ValueError(f"ElasticTether: stiffness_N_m must be >= 0, got {stiffness_N_m!r}")
        self.k = float(stiffness_N_m)
        self.slack = float(slack_m)
        self.attach = np.asarray(attach_m, dtype=float).reshape(3)
        self.max_force = float(max_force_N)
        self._anchor = np.zeros(2)

    def _attach_world(self, sim: Any) -> np.ndarray:
        pos, orn = p.getBasePositionAndOrientation(sim.robot, physicsClientId=sim.client)
        return np.asarray(pos) + _matrix(np.asarray(orn)) @ self.attach

    def reset(self, sim: Any) -> None:
        self._anchor = self._attach_world(sim)[:2].copy()

    def substep(self, sim: Any, t: float) -> None:
        a = self._attach_world(sim)
        d = a[:2] - self._anchor
        r = float(np.hypot(*d))
        if r <= self.slack or self.k == 0.0:
            return
        f = min(self.k * (r - self.slack), self.max_force) * (-d / r)
        p.applyExternalForce(sim.robot, -1, [float(f[0]), float(f[1]), 0.0], a.tolist(),
                             p.WORLD_FRAME, physicsClientId=sim.client)


class MocapFrameOffset:
    """The motion-capture body frame turned by ``rotvec_rad`` (base_link) and its origin at
    ``origin_m`` (base_link): reported position p + R origin, orientation q * q_off, twist
    R_off^T (v + w x origin) and R_off^T w."""

    changes_world = False     # readings only

    def __init__(self, rotvec_rad: list[float] | tuple[float, float, float] = (0.0, 0.0, 0.0),
                 origin_m: list[float] | tuple[float, float, float] = (0.0, 0.0, 0.0)) -> None:
        self.rotvec = np.asarray(rotvec_rad, dtype=float).reshape(3)
        self.origin = np.asarray(origin_m, dtype=float).reshape(3)
        self.q_off = _quat_from_rotvec(self.rotvec)
        self.R_off = _matrix(self.q_off)

    def measure(self, obs: dict, t: float) -> dict:
        q = np.asarray(obs["orientation"], dtype=float)
        R = _matrix(q)
        w = np.asarray(obs["angular_velocity"], dtype=float)
        v = np.asarray(obs["linear_velocity"], dtype=float)
        obs["position"] = np.asarray(obs["position"], dtype=float) + R @ self.origin
        qn = _quat_mul(q, self.q_off)
        obs["orientation"] = qn / np.linalg.norm(qn)
        obs["linear_velocity"] = self.R_off.T @ (v + np.cross(w, self.origin))
        obs["angular_velocity"] = self.R_off.T @ w
        return obs


class JointSoftStop:
    """Compliant end stops on some joints: torque -k (q - clip(q, home - h, home + h)) added
    to the servo's, with a little damping while engaged."""

    changes_world = False     # joint torques each physics step only

    def __init__(self, stiffness_Nm_rad: float, half_width_rad: float,
                 joints: str | list[str] | None = None, damping_Nms_rad: float = 0.01) -> None:
        if not (np.isfinite(stiffness_Nm_rad) and stiffness_Nm_rad >= 0):
            raise ValueError("JointSoftStop: stiffness_Nm_rad must be >= 0")
        if not (np.isfinite(half_width_rad) and half_width_rad >= 0):
            raise ValueError("JointSoftStop: half_width_rad must be >= 0")
        self.k = float(stiffness_Nm_rad)
        self.h = float(half_width_rad)
        self.c = float(damping_Nms_rad)
        self.joints = resolve_joints(joints)
        self.centre = HOME_POSE[self.joints]

    def reset(self, sim: Any) -> None:
        self._ids = [sim.joint_indices[j] for j in self.joints]

    def substep(self, sim: Any, t: float) -> None:
        q, dq = sim.joint_state()
        qj, dqj = q[self.joints], dq[self.joints]
        over = qj - np.clip(qj, self.centre - self.h, self.centre + self.h)
        tau = -self.k * over - self.c * dqj * (over != 0.0)
        p.setJointMotorControlArray(sim.robot, self._ids, p.TORQUE_CONTROL,
                                    forces=tau.tolist(), physicsClientId=sim.client)
