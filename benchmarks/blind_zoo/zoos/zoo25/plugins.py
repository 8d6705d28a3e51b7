"""zoo25's effect plug-ins that ``littledog_mlsim.robot.effects`` has no class for
(docs/interface.md section 5: ``reset`` / ``command`` / ``substep`` / ``measure`` hooks).

Sealed with the truth.
"""
from __future__ import annotations

from typing import Any

import numpy as np
import pybullet as p

from littledog_mlsim.robot.effects import resolve_joints


class SlipperyPatch:
    """A wet, slippery part of the floor: every foot standing in the half-plane
    ``cos(a) x + sin(a) y > offset_m`` of odom (a = ``direction_deg``) has its friction
    coefficient times ``scale``; elsewhere the floor is as usual. Position-dependent terrain:
    a foot's grip depends on where in the room it is, not on the robot's state."""

    def __init__(self, scale: float, direction_deg: float, offset_m: float) -> None:
        if not (np.isfinite(scale) and scale > 0):
            raise ValueError(f"SlipperyPatch: scale must be > 0, got {scale!r}")
        self.scale = float(scale)
        a = np.radians(float(direction_deg))
        self.normal = np.array([np.cos(a), np.sin(a)])
        self.offset_m = float(offset_m)
        self._on: list[bool] = []

    def reset(self, sim: Any) -> None:
        self._on = [False] * len(sim.foot_links)
        self._mu = float(sim.config.foot_friction)
        self._update(sim)

    def _update(self, sim: Any) -> None:
        c = sim.client
        states = p.getLinkStates(sim.robot, sim.foot_links, computeForwardKinematics=1,
                                 physicsClientId=c)
        for i, (link, st) in enumerate(zip(sim.foot_links, states)):
            on = float(self.normal @ np.asarray(st[0][:2])) > self.offset_m
            if on != self._on[i]:
                p.changeDynamics(sim.robot, link,
                                 lateralFriction=self._mu * (self.scale if on else 1.0),
                                 physicsClientId=c)
                self._on[i] = on

    def substep(self, sim: Any, t: float) -> None:
        self._update(sim)


class TrailingCable:
    """An elastic cable (a power lead / safety line) from a fixed point of the room to a point
    on the body: slack while the attachment point is within ``rest_length_m`` of the anchor,
    beyond that it pulls towards the anchor with ``stiffness_N_per_m`` times the stretch, applied
    at the attachment point (so it also turns the body). The pull depends on where the robot is
    in the room."""

    def __init__(self, anchor_xyz: list[float], attach_base_link: list[float],
                 rest_length_m: float, stiffness_N_per_m: float,
                 max_force_N: float = 10.0) -> None:
        self.anchor = np.asarray(anchor_xyz, dtype=float).reshape(3)
        self.attach = np.asarray(attach_base_link, dtype=float).reshape(3)
        self.rest = float(rest_length_m)
        self.k = float(stiffness_N_per_m)
        self.fmax = float(max_force_N)

    def substep(self, sim: Any, t: float) -> None:
        c = sim.client
        pos, orn = p.getBasePositionAndOrientation(sim.robot, physicsClientId=c)
        R = np.array(p.getMatrixFromQuaternion(orn)).reshape(3, 3)
        point = np.asarray(pos) + R @ self.attach
        d = self.anchor - point
        L = float(np.linalg.norm(d))
        if L <= self.rest or L < 1e-9:
            return
        f = min(self.k * (L - self.rest), self.fmax) * d / L
        p.applyExternalForce(sim.robot, -1, f.tolist(), point.tolist(), p.WORLD_FRAME,
                             physicsClientId=c)


class ParallelSpring:
    """A spring across some joints (a stiff cable bundle routed over the joint): an extra joint
    torque -``stiffness_Nm_per_rad`` (q - ``rest_angle_rad``), with q the joint's true angle and
    the rest angle absolute (not the set-point)."""

    def __init__(self, stiffness_Nm_per_rad: float, rest_angle_rad: float | list[float],
                 joints: str | list[str]) -> None:
        self.joints = resolve_joints(joints)
        self.k = float(stiffness_Nm_per_rad)
        self.q0 = np.broadcast_to(np.asarray(rest_angle_rad, dtype=float),
                                  (len(self.joints),)).copy()

    def reset(self, sim: Any) -> None:
        self._ids = [sim.joint_indices[j] for j in self.joints]

    def substep(self, sim: Any, t: float) -> None:
        states = p.getJointStates(sim.robot, self._ids, physicsClientId=sim.client)
        q = np.array([s[0] for s in states])
        p.setJointMotorControlArray(sim.robot, self._ids, p.TORQUE_CONTROL,
                                    forces=(-self.k * (q - self.q0)).tolist(),
                                    physicsClientId=sim.client)
