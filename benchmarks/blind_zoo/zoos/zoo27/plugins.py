"""Effect plug-ins of zoo27 that robot/effects.py does not offer (docs/interface.md section 5).

Each is a physically plausible disturbance of a real robot lab; the zoo's effects files name them
as ``plugins.py:ClassName``.
"""
from __future__ import annotations

import math
from typing import Any

import numpy as np
import pybullet as p


class AnchoredCable:
    """A cable from a point fixed in the room (a power or safety line tied to a post) to the
    body: slack within ``length_m`` of the anchor, then pulling the body horizontally towards
    the anchor with ``stiffness_N_per_m`` times the stretch, the pull leveling off smoothly at
    ``max_force_N`` (the line slips through a friction clamp)."""

    def __init__(self, anchor_xy=(-0.45, -0.35), length_m: float = 0.50,
                 stiffness_N_per_m: float = 12.0, max_force_N: float = 2.5) -> None:
        self.anchor = np.asarray(anchor_xy, dtype=float).reshape(2)
        self.length_m = float(length_m)
        self.k = float(stiffness_N_per_m)
        self.fmax = float(max_force_N)

    def substep(self, sim: Any, t: float) -> None:
        pos, _ = p.getBasePositionAndOrientation(sim.robot, physicsClientId=sim.client)
        d = self.anchor - np.array(pos[:2])
        dist = float(np.hypot(*d))
        stretch = dist - self.length_m
        if stretch <= 0.0 or dist < 1e-9:
            return
        f = self.fmax * math.tanh(self.k * stretch / self.fmax)
        fx, fy = f * d / dist
        p.applyExternalForce(sim.robot, -1, [float(fx), float(fy), 0.0], pos, p.WORLD_FRAME,
                             physicsClientId=sim.client)


class SlipperyPanel:
    """A polished (or freshly cleaned) floor panel: where a foot stands beyond the line
    x > ``edge_x_m`` (odom), its friction is ``scale`` times the normal one; elsewhere normal."""

    def __init__(self, edge_x_m: float = 0.10, scale: float = 0.40) -> None:
        self.edge = float(edge_x_m)
        self.scale = float(scale)
        self._on: list[bool] = []

    def reset(self, sim: Any) -> None:
        self._on = [False] * len(sim.foot_links)

    def substep(self, sim: Any, t: float) -> None:
        c = sim.client
        states = p.getLinkStates(sim.robot, sim.foot_links, computeForwardKinematics=1,
                                 physicsClientId=c)
        for i, (link, st) in enumerate(zip(sim.foot_links, states)):
            on = float(st[0][0]) > self.edge
            if on != self._on[i]:
                mu = sim.config.foot_friction * (self.scale if on else 1.0)
                p.changeDynamics(sim.robot, link, lateralFriction=mu, physicsClientId=c)
                self._on[i] = on


class CableWindup:
    """A tether hanging from the ceiling above the start that twists as the robot turns: a yaw
    torque -``stiffness_Nm_per_rad`` * (yaw - yaw at the start of the move), yaw unwrapped,
    about the world vertical (the twist stored in the cable since the move began)."""

    def __init__(self, stiffness_Nm_per_rad: float = 0.08) -> None:
        self.k = float(stiffness_Nm_per_rad)
        self._yaw0: float | None = None
        self._yaw = 0.0

    @staticmethod
    def _heading(sim: Any) -> float:
        _, orn = p.getBasePositionAndOrientation(sim.robot, physicsClientId=sim.client)
        return float(p.getEulerFromQuaternion(orn)[2])

    def reset(self, sim: Any) -> None:
        self._yaw0 = None

    def substep(self, sim: Any, t: float) -> None:
        y = self._heading(sim)
        if self._yaw0 is None:
            self._yaw0, self._yaw = y, y
        else:
            self._yaw += (y - self._yaw + math.pi) % (2 * math.pi) - math.pi
        tau = -self.k * (self._yaw - self._yaw0)
        p.applyExternalTorque(sim.robot, -1, [0.0, 0.0, tau], p.WORLD_FRAME,
                              physicsClientId=sim.client)
