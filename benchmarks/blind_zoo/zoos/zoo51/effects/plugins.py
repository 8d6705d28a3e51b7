"""zoo51's own effect plug-ins (docs/interface.md section 5), for effects the package's
built-in plug-ins do not provide. Each is a class with some of reset / command / substep /
measure; the YAML files next to this one name them as ``plugins.py:ClassName``."""
from __future__ import annotations

from typing import Any

import numpy as np
import pybullet as p

from littledog_mlsim.robot.effects import _clip, _ServoTorque, resolve_joints


class CompliantFloor:
    """A floor that gives under the feet (a foam mat, a soft gym floor, thick carpet): the
    ground's contact is a spring of ``stiffness_N_m`` [N/m] and a damper of
    ``damping_N_s_m`` [N s/m] per contact instead of the solver's rigid contact."""

    def __init__(self, stiffness_N_m: float, damping_N_s_m: float) -> None:
        if not (stiffness_N_m > 0 and damping_N_s_m >= 0):
            raise ValueError("CompliantFloor: stiffness must be > 0 and damping >= 0")
        self.k = float(stiffness_N_m)
        self.d = float(damping_N_s_m)

    def reset(self, sim: Any) -> None:
        p.changeDynamics(sim.plane, -1, contactStiffness=self.k, contactDamping=self.d,
                         physicsClientId=sim.client)


class ServoDropout(_ServoTorque):
    """A loose connector on some joints: now and then (on average ``rate_per_s`` times a
    second, at random control steps) the servo's power drops out for ``duration_ms`` (drawn
    uniformly in [duration_ms[0], duration_ms[1]]), and the joint gives no torque at all."""

    def __init__(self, rate_per_s: float, duration_ms: list[float],
                 joints: str | list[str] | None = None) -> None:
        super().__init__(joints)
        self.rate_per_s = float(rate_per_s)
        self.duration_ms = (float(duration_ms[0]), float(duration_ms[1]))
        self._until = -1.0
        self._next_check = 0.0

    def reset(self, sim: Any) -> None:
        super().reset(sim)
        self._rng = sim.rng
        self._dt = sim.control_dt
        self._until = -1.0
        self._next_check = 0.0

    def substep(self, sim: Any, t: float) -> None:
        if t >= self._next_check - 1e-9:           # once per control step
            self._next_check = t + self._dt
            if t >= self._until and self._rng.random() < self.rate_per_s * self._dt:
                self._until = t + 1e-3 * self._rng.uniform(*self.duration_ms)
        if t < self._until:
            super().substep(sim, t)

    def servo(self, e: np.ndarray, dq: np.ndarray, t: float) -> np.ndarray:
        return np.zeros_like(e)


class SupplyCurrentLimit(_ServoTorque):
    """All servos share one supply (battery and regulator) whose current is limited: when
    the servos together ask for more than ``budget_Nm`` of summed torque magnitude (the
    current budget expressed as torque through the motors' torque constant), every servo's
    torque is scaled down by the same factor so that the sum stays at the budget."""

    def __init__(self, budget_Nm: float, joints: str | list[str] | None = None) -> None:
        super().__init__(joints)
        self.budget = float(budget_Nm)

    def servo(self, e: np.ndarray, dq: np.ndarray, t: float) -> np.ndarray:
        tau = _clip(self._kp * e - self._kd * dq, -self._lim0, self._lim0)
        total = float(np.sum(np.abs(tau)))
        return tau * (self.budget / total) if total > self.budget else tau


class TorqueProbe(_ServoTorque):
    """For the check only: changes nothing, records the servo's summed torque magnitude."""

    def __init__(self, joints: str | list[str] | None = None) -> None:
        super().__init__(joints)
        self.samples: list[float] = []

    def extra(self, e: np.ndarray, dq: np.ndarray, t: float) -> np.ndarray:
        tau = _clip(self._kp * e - self._kd * dq, -self._lim0, self._lim0)
        self.samples.append(float(np.sum(np.abs(tau))))
        return np.zeros_like(e)

    def substep(self, sim: Any, t: float) -> None:
        q, dq = sim.joint_state()
        self.extra(self._q_des[self.joints] - q[self.joints], dq[self.joints], t)
