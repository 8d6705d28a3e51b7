"""zoo10's own effect plug-ins (docs/interface.md section 5): physics the stock classes of
``littledog_mlsim.robot.effects`` do not offer. Each is used by one effects file of this folder.
"""
from __future__ import annotations

from typing import Any

import numpy as np
import pybullet as p

from littledog_mlsim.layout import LEGS
from littledog_mlsim.robot.effects import _ServoTorque, resolve_joints


class WindingHeat(_ServoTorque):
    """Motor windings that heat with the load: each selected joint's winding temperature rise
    T [K] follows dT/dt = heating * tau^2 - T / cooling_s (tau: the torque the servo asks
    for, a proxy of I^2 R; ``heating`` in K/(s N^2 m^2)), starting at ``start_K`` when the move starts; copper's resistance
    rises by ``alpha_per_K`` per kelvin, so at a fixed drive voltage the servo's whole torque
    (stiffness, damping and its limit) is divided by 1 + alpha_per_K * T."""

    def __init__(self, heating: float, cooling_s: float = 3.0, alpha_per_K: float = 0.0039,
                 start_K: float = 0.0, joints: str | list[str] | None = None) -> None:
        super().__init__(joints)
        if not (heating >= 0 and cooling_s > 0 and alpha_per_K >= 0 and start_K >= 0):
            raise ValueError("WindingHeat: parameters must be non-negative (cooling_s > 0)")
        self.heat = float(heating)
        self.cooling_s = float(cooling_s)
        self.alpha = float(alpha_per_K)
        self.start_K = float(start_K)
        self._T = np.zeros(0)
        self._dt = 0.002

    def reset(self, sim: Any) -> None:
        super().reset(sim)
        self._T = np.full(len(self.joints), self.start_K)
        self._dt = float(sim.physics_dt)

    def servo(self, e: np.ndarray, dq: np.ndarray, t: float) -> np.ndarray:
        demand = np.clip(self._kp * e - self._kd * dq, -self._lim0, self._lim0)
        self._T = self._T + self._dt * (self.heat * demand ** 2 - self._T / self.cooling_s)
        return demand / (1.0 + self.alpha * self._T)


class FloorStrip:
    """A strip of the lab floor with another surface (a polished board, a plastic sheet): where
    a foot stands inside the strip (odom x between ``x_min`` and ``x_max`` and y between
    ``y_min`` and ``y_max``), its friction coefficient is ``scale`` times the normal one."""

    def __init__(self, scale: float, x_min: float = -1e9, x_max: float = 1e9,
                 y_min: float = -1e9, y_max: float = 1e9) -> None:
        if not scale > 0:
            raise ValueError("FloorStrip: scale must be > 0")
        self.scale = float(scale)
        self.box = (float(x_min), float(x_max), float(y_min), float(y_max))
        self._inside: list[bool] = []

    def reset(self, sim: Any) -> None:
        self._inside = [False] * len(LEGS)

    def substep(self, sim: Any, t: float) -> None:
        c = sim.client
        states = p.getLinkStates(sim.robot, sim.foot_links, computeForwardKinematics=1,
                                 physicsClientId=c)
        x0, x1, y0, y1 = self.box
        for i, (link, st) in enumerate(zip(sim.foot_links, states)):
            x, y = st[0][0], st[0][1]
            inside = bool(x0 <= x <= x1 and y0 <= y <= y1)
            if inside != self._inside[i]:
                mu = sim.config.foot_friction * (self.scale if inside else 1.0)
                p.changeDynamics(sim.robot, link, lateralFriction=mu, physicsClientId=c)
                self._inside[i] = inside


class CableSpring:
    """A stiff cable bundle routed across some joints: a torsion spring torque
    -stiffness_Nm_per_rad * (q - rest_rad) on each selected joint, whatever the servo does."""

    def __init__(self, stiffness_Nm_per_rad: float, rest_rad: float | list[float] = 0.0,
                 joints: str | list[str] | None = None) -> None:
        self.joints = resolve_joints(joints)
        self.k = float(stiffness_Nm_per_rad)
        self.rest = np.broadcast_to(np.asarray(rest_rad, dtype=float),
                                    (len(self.joints),)).copy()
        self._ids: list[int] = []

    def reset(self, sim: Any) -> None:
        self._ids = [sim.joint_indices[j] for j in self.joints]

    def substep(self, sim: Any, t: float) -> None:
        states = p.getJointStates(sim.robot, self._ids, physicsClientId=sim.client)
        q = np.array([s[0] for s in states])
        p.setJointMotorControlArray(sim.robot, self._ids, p.TORQUE_CONTROL,
                                    forces=(-self.k * (q - self.rest)).tolist(),
                                    physicsClientId=sim.client)
