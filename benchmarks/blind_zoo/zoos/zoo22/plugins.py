"""zoo22's own effect plug-ins (docs/interface.md section 5): reset / command / substep hooks."""
from __future__ import annotations

from typing import Any

import numpy as np
import pybullet as p

from littledog_mlsim.robot.effects import resolve_joints


class RaisedFloorPatch:
    """A rigid, level slab on the floor (a mat, a board): its top ``height_m`` above the ground,
    covering x in [x_min_m, x_min_m + length_m] and y in [-width_m/2, width_m/2] (odom, the move's
    start at the origin facing +x). Same friction as the ground."""

    def __init__(self, height_m: float = 0.012, x_min_m: float = 0.18, length_m: float = 1.5,
                 width_m: float = 3.0, y_center_m: float = 0.0) -> None:
        self.h = float(height_m)
        self.x0 = float(x_min_m)
        self.L = float(length_m)
        self.W = float(width_m)
        self.yc = float(y_center_m)

    def reset(self, sim: Any) -> None:
        c = sim.client
        half = [0.5 * self.L, 0.5 * self.W, 0.5 * self.h]
        shape = p.createCollisionShape(p.GEOM_BOX, halfExtents=half, physicsClientId=c)
        body = p.createMultiBody(0.0, shape, basePosition=[self.x0 + 0.5 * self.L, self.yc,
                                                           0.5 * self.h], physicsClientId=c)
        p.changeDynamics(body, -1, lateralFriction=sim.config.ground_friction,
                         physicsClientId=c)


class LinkDropouts:
    """A lossy command link: every 10 ms command packet is lost with probability ``p_start`` (a
    burst of 1..``max_burst`` packets, uniformly); while packets are lost the servos of the
    selected joints keep the last set-point received. Drawn from the move's rng."""

    def __init__(self, p_start: float = 0.06, max_burst: int = 3,
                 joints: str | list[str] | None = None) -> None:
        self.p_start = float(p_start)
        self.max_burst = int(max_burst)
        self.joints = resolve_joints(joints)
        self._held: np.ndarray | None = None
        self._left = 0
        self._rng: np.random.Generator | None = None

    def reset(self, sim: Any) -> None:
        self._held = None
        self._left = 0
        self._rng = sim.rng

    def command(self, u: np.ndarray, t: float) -> np.ndarray:
        if self._held is None:
            self._held = u.copy()
            return u
        if self._left == 0 and self._rng.random() < self.p_start:
            self._left = int(self._rng.integers(1, self.max_burst + 1))
        out = u.copy()
        if self._left > 0:
            self._left -= 1
            out[self.joints] = self._held[self.joints]
        else:
            self._held = u.copy()
        return out


class TorqueRipple:
    """A torque that varies with the joint angle (output-stage gear eccentricity, a cable
    harness): tau = amplitude_Nm * sin(2 pi q / period_rad + phase_rad) on the selected joints,
    added to the servo's every physics step."""

    def __init__(self, amplitude_Nm: float = 0.1, period_rad: float = 0.35,
                 phase_rad: float = 0.0, joints: str | list[str] | None = None) -> None:
        self.A = float(amplitude_Nm)
        self.P = float(period_rad)
        self.phi = float(phase_rad)
        self.joints = resolve_joints(joints)
        self._ids: list[int] = []

    def reset(self, sim: Any) -> None:
        self._ids = [sim.joint_indices[j] for j in self.joints]

    def substep(self, sim: Any, t: float) -> None:
        states = p.getJointStates(sim.robot, self._ids, physicsClientId=sim.client)
        q = np.array([s[0] for s in states])
        tau = self.A * np.sin(2.0 * np.pi * q / self.P + self.phi)
        p.setJointMotorControlArray(sim.robot, self._ids, p.TORQUE_CONTROL, forces=tau.tolist(),
                                    physicsClientId=sim.client)
