"""zoo65's own effect plug-ins (docs/interface.md section 5), for effects no built-in provides.

- :class:`GearToothRipple`: a damaged gear stage in one joint; a torque that repeats with the
  output angle, tau = -amplitude_Nm sin(2 pi q / period_rad + phase), added to the servo's.
- :class:`CableTether`: an elastic cable (power or safety line) from a fixed anchor point in
  the world to the body; slack until the body is farther than its rest length from the anchor,
  then a pull k (d - rest) towards the anchor, at most max_force_N.
- :class:`SharedSupplyLimit`: the servos of a group of joints (one side) share one supply whose
  current limit caps the sum of their torques' magnitudes: when the sum of |tau| the PD servos
  ask for exceeds total_Nm, every servo of the group gets its torque times total_Nm / sum.
"""
from __future__ import annotations

from typing import Any

import numpy as np
import pybullet as p

from littledog_mlsim.robot.effects import _clip, _ServoTorque, resolve_joints


class GearToothRipple:
    """A torque periodic in the joint's angle on some joints (a chipped or worn gear stage)."""

    changes_world = False

    def __init__(self, amplitude_Nm: float, period_rad: float, phase_rad: float = 0.0,
                 joints: str | list[str] = "front_left_knee") -> None:
        if not (np.isfinite(amplitude_Nm) and amplitude_Nm >= 0):
            raise ValueError("GearToothRipple: amplitude_Nm must be >= 0")
        if not (np.isfinite(period_rad) and period_rad > 0):
            raise ValueError("GearToothRipple: period_rad must be > 0")
        self.amplitude = float(amplitude_Nm)
        self.k = 2.0 * np.pi / float(period_rad)
        self.phase = float(phase_rad)
        self.joints = resolve_joints(joints)
        self._ids: list[int] = []

    def reset(self, sim: Any) -> None:
        self._ids = [sim.joint_indices[j] for j in self.joints]

    def substep(self, sim: Any, t: float) -> None:
        q = sim.joint_state()[0][self.joints]
        tau = -self.amplitude * np.sin(self.k * q + self.phase)
        p.setJointMotorControlArray(sim.robot, self._ids, p.TORQUE_CONTROL, forces=tau.tolist(),
                                    physicsClientId=sim.client)


class CableTether:
    """An elastic cable from ``anchor_m`` (odom) to the body's origin: slack within
    ``rest_length_m``, beyond it a pull of ``stiffness_N_m`` per metre, at most
    ``max_force_N``, along the cable towards the anchor."""

    changes_world = False

    def __init__(self, anchor_m: list[float], rest_length_m: float, stiffness_N_m: float,
                 max_force_N: float = 5.0) -> None:
        self.anchor = np.asarray(anchor_m, dtype=float).reshape(3)
        self.rest = float(rest_length_m)
        self.k = float(stiffness_N_m)
        self.fmax = float(max_force_N)
        if not (self.rest > 0 and self.k >= 0 and self.fmax >= 0):
            raise ValueError("CableTether: rest_length_m > 0, stiffness_N_m and max_force_N >= 0")

    def substep(self, sim: Any, t: float) -> None:
        pos, _ = p.getBasePositionAndOrientation(sim.robot, physicsClientId=sim.client)
        d = self.anchor - np.asarray(pos)
        n = float(np.linalg.norm(d))
        if n <= self.rest:
            return
        f = min(self.k * (n - self.rest), self.fmax) * d / n
        p.applyExternalForce(sim.robot, -1, f.tolist(), pos, p.WORLD_FRAME,
                             physicsClientId=sim.client)


class SharedSupplyLimit(_ServoTorque):
    """The PD servos of ``joints`` share a supply: the sum of their torques' magnitudes is
    capped at ``total_Nm`` (each scaled by the same factor where the sum is larger)."""

    def __init__(self, total_Nm: float, joints: str | list[str] = "left") -> None:
        if not (np.isfinite(total_Nm) and total_Nm > 0):
            raise ValueError("SharedSupplyLimit: total_Nm must be > 0")
        super().__init__(joints)
        self.total = float(total_Nm)

    def servo(self, e: np.ndarray, dq: np.ndarray, t: float) -> np.ndarray:
        tau = _clip(self._kp * e - self._kd * dq, -self._lim0, self._lim0)
        s = float(np.abs(tau).sum())
        return tau * (self.total / s) if s > self.total else tau
