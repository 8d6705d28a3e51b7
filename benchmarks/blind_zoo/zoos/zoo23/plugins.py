"""zoo23's own effect plug-ins (docs/interface.md section 5). SEALED with the truth.

Each class implements some of ``reset(sim)``, ``command(u, t)``, ``substep(sim, t)``,
``measure(obs, t)``; the effect files in ``effects/`` name them as ``../plugins.py:ClassName``.
"""
from __future__ import annotations

from typing import Any

import numpy as np
import pybullet as p

from littledog_mlsim.layout import JOINT_LOWER, JOINT_UPPER, LEGS, N_JOINTS
from littledog_mlsim.robot.config import per_joint
from littledog_mlsim.robot.effects import resolve_joints


class WetFloorPatch:
    """A wet (slippery) region of the floor: a foot standing beyond the line
    ``x cos(d) + y sin(d) > offset_m`` (odom) grips with ``friction_scale`` times its normal
    friction coefficient. Where a foot is, not what the robot does, decides its grip."""

    def __init__(self, friction_scale: float, direction_deg: float = 0.0,
                 offset_m: float = 0.1) -> None:
        if not (np.isfinite(friction_scale) and friction_scale > 0):
            raise ValueError("WetFloorPatch: friction_scale must be > 0")
        self.friction_scale = float(friction_scale)
        d = np.radians(float(direction_deg))
        self.normal = np.array([np.cos(d), np.sin(d)])
        self.offset_m = float(offset_m)
        self._wet: list[bool] = []

    def reset(self, sim: Any) -> None:
        self._wet = [False] * len(sim.foot_links)

    def substep(self, sim: Any, t: float) -> None:
        c = sim.client
        states = p.getLinkStates(sim.robot, sim.foot_links, computeForwardKinematics=1,
                                 physicsClientId=c)
        for i, (link, st) in enumerate(zip(sim.foot_links, states)):
            wet = float(np.dot(self.normal, st[0][:2])) > self.offset_m
            if wet != self._wet[i]:
                mu = sim.config.foot_friction * (self.friction_scale if wet else 1.0)
                p.changeDynamics(sim.robot, link, lateralFriction=mu, physicsClientId=c)
                self._wet[i] = wet


class ThermalFade:
    """Motor heating of some joints' servos: the winding temperature rise dT follows
    d(dT)/dt = (heating_K_per_Nm2 * tau^2 - dT) / time_constant_s with tau the servo's torque,
    and the winding resistance rising with it (copper, alpha_per_K) scales the whole servo torque
    (PD and limit) by 1 / (1 + alpha dT). The motors start the move at ``start_rise_K``."""

    def __init__(self, heating_K_per_Nm2: float, time_constant_s: float = 2.0,
                 alpha_per_K: float = 0.0039, start_rise_K: float = 0.0,
                 joints: str | list[str] | None = "knees") -> None:
        if heating_K_per_Nm2 < 0 or time_constant_s <= 0 or alpha_per_K < 0:
            raise ValueError("ThermalFade: bad parameters")
        self.heat = float(heating_K_per_Nm2)
        self.tc = float(time_constant_s)
        self.alpha = float(alpha_per_K)
        self.start = float(start_rise_K)
        self.joints = resolve_joints(joints)
        self._q_des = np.zeros(N_JOINTS)

    def reset(self, sim: Any) -> None:
        self._ids = [sim.joint_indices[j] for j in self.joints]
        cfg = sim.config
        self._kp = per_joint(cfg.kp)[self.joints]
        self._kd = per_joint(cfg.kd)[self.joints]
        self._lim = per_joint(cfg.torque_limit)[self.joints]
        self._dT = np.full(len(self.joints), self.start)
        self._dt = sim.physics_dt

    def command(self, u: np.ndarray, t: float) -> np.ndarray:
        self._q_des = np.clip(u, JOINT_LOWER, JOINT_UPPER)
        return u

    def substep(self, sim: Any, t: float) -> None:
        states = p.getJointStates(sim.robot, self._ids, physicsClientId=sim.client)
        q = np.array([s[0] for s in states])
        dq = np.array([s[1] for s in states])
        normal = np.clip(self._kp * (self._q_des[self.joints] - q) - self._kd * dq,
                         -self._lim, self._lim)
        scale = 1.0 / (1.0 + self.alpha * self._dT)
        tau = scale * normal
        self._dT += self._dt * (self.heat * tau ** 2 - self._dT) / self.tc
        p.setJointMotorControlArray(sim.robot, self._ids, p.TORQUE_CONTROL,
                                    forces=(tau - normal).tolist(), physicsClientId=sim.client)


class HarnessSpring:
    """A stiff cable bundle across some joints: a passive torsional spring
    tau = -stiffness_Nm_per_rad * (q - rest_rad) - damping_Nms * dq, on top of the servo."""

    def __init__(self, stiffness_Nm_per_rad: float, rest_rad: float | list[float] = 0.0,
                 damping_Nms: float = 0.0, joints: str | list[str] | None = "all") -> None:
        self.k = float(stiffness_Nm_per_rad)
        self.joints = resolve_joints(joints)
        self.rest = np.broadcast_to(np.asarray(rest_rad, float), (len(self.joints),)).copy()
        self.b = float(damping_Nms)

    def reset(self, sim: Any) -> None:
        self._ids = [sim.joint_indices[j] for j in self.joints]

    def substep(self, sim: Any, t: float) -> None:
        states = p.getJointStates(sim.robot, self._ids, physicsClientId=sim.client)
        q = np.array([s[0] for s in states])
        dq = np.array([s[1] for s in states])
        tau = -self.k * (q - self.rest) - self.b * dq
        p.setJointMotorControlArray(sim.robot, self._ids, p.TORQUE_CONTROL,
                                    forces=tau.tolist(), physicsClientId=sim.client)


__all__ = ["WetFloorPatch", "ThermalFade", "HarnessSpring", "LEGS"]
