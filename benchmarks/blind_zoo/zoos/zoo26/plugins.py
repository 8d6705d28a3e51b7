"""zoo26's effect plug-ins that ``littledog_mlsim/robot/effects.py`` does not offer
(docs/interface.md section 5: ``reset``, ``command``, ``substep``, ``measure``).

Sealed with the truth: the diagnosis side does not read this file before the run.
"""
from __future__ import annotations

from typing import Any

import numpy as np
import pybullet as p

from littledog_mlsim.robot.effects import _ServoTorque, resolve_joints  # noqa: F401


class ThermalFade(_ServoTorque):
    """A servo motor that heats while it works: its winding temperature rise (arbitrary units,
    the low-passed square of the torque it delivers, thermal time constant ``tau_th_s``) lowers
    the torque it makes per amp and the current it may draw, so the servo's whole output
    (stiffness, damping and limit) is scaled by max(floor, 1 - ``fade_per_Nm2`` * T). The
    temperature starts at 0 at the start of each move (a cool motor) and depends on the torque's
    history, not on the present state."""

    def __init__(self, fade_per_Nm2: float, tau_th_s: float = 1.5,
                 joints: str | list[str] | None = None, floor: float = 0.3) -> None:
        super().__init__(joints)
        self.fade = float(fade_per_Nm2)
        self.tau_th = float(tau_th_s)
        self.floor = float(floor)

    def reset(self, sim: Any) -> None:
        super().reset(sim)
        self._T = np.zeros(len(self.joints))
        self._dt = float(sim.physics_dt)

    def extra(self, e: np.ndarray, dq: np.ndarray, t: float) -> np.ndarray:
        normal = np.clip(self._kp * e - self._kd * dq, -self._lim0, self._lim0)
        s = np.maximum(self.floor, 1.0 - self.fade * self._T)
        out = s * normal
        self._T += self._dt / self.tau_th * (out ** 2 - self._T)
        return out - normal


class GearRipple:
    """A worn output gear: a torque ripple periodic in the joint angle (one period per tooth of
    the output stage), tau = -amplitude * sin(2 pi (q - phase) / pitch_rad), on some joints.
    It depends on the joint angle only."""

    def __init__(self, amplitude_Nm: float, pitch_rad: float = 0.1, phase_rad: float = 0.0,
                 joints: str | list[str] | None = None) -> None:
        self.amplitude = float(amplitude_Nm)
        self.pitch = float(pitch_rad)
        self.phase = float(phase_rad)
        self.joints = resolve_joints(joints)

    def reset(self, sim: Any) -> None:
        self._ids = [sim.joint_indices[j] for j in self.joints]

    def substep(self, sim: Any, t: float) -> None:
        states = p.getJointStates(sim.robot, self._ids, physicsClientId=sim.client)
        q = np.array([s[0] for s in states])
        tau = -self.amplitude * np.sin(2.0 * np.pi * (q - self.phase) / self.pitch)
        p.setJointMotorControlArray(sim.robot, self._ids, p.TORQUE_CONTROL, forces=tau.tolist(),
                                    physicsClientId=sim.client)


class SlipperyPatch:
    """A patch of the floor (a freshly mopped or polished strip, fixed in the world) where the
    feet's friction coefficient is ``scale`` times the normal one: a foot whose centre is inside
    the rectangle ``x_range`` x ``y_range`` (odom, m) slips more easily. Where the robot is on the
    floor is not among the recorded state's elements."""

    def __init__(self, scale: float, x_range: list[float] = (0.15, 5.0),
                 y_range: list[float] = (-5.0, 5.0)) -> None:
        self.scale = float(scale)
        self.x_range = tuple(float(v) for v in x_range)
        self.y_range = tuple(float(v) for v in y_range)

    def reset(self, sim: Any) -> None:
        self._mu = float(sim.config.foot_friction)
        self._inside = [False] * len(sim.foot_links)

    def substep(self, sim: Any, t: float) -> None:
        c = sim.client
        states = p.getLinkStates(sim.robot, sim.foot_links, computeForwardKinematics=1,
                                 physicsClientId=c)
        for i, (link, st) in enumerate(zip(sim.foot_links, states)):
            x, y = st[0][0], st[0][1]
            inside = (self.x_range[0] <= x <= self.x_range[1]
                      and self.y_range[0] <= y <= self.y_range[1])
            if inside != self._inside[i]:
                p.changeDynamics(sim.robot, link,
                                 lateralFriction=self._mu * (self.scale if inside else 1.0),
                                 physicsClientId=c)
                self._inside[i] = inside
