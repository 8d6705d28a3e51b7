"""zoo68's own effect plug-ins (sealed): physical faults and conditions no built-in plug-in
provides (docs/interface.md section 5)."""
from __future__ import annotations

import numpy as np
import pybullet as p

from littledog_mlsim.layout import JOINT_NAMES, LEGS


class Tether:
    """A cable from a fixed anchor in the world (a boom above and beside the floor) to a point
    on the body (``attach_b``, base_link): elastic when taut, slack when shorter than its rest
    length. Its rest length is the anchor's distance at the move's start less ``pretension_m``
    (the cable slightly taut as the robot stands at its start). Force on the body
    k * max(0, d - L0) towards the anchor, applied at the attachment point."""

    changes_world = False     # forces only, each step

    def __init__(self, anchor: list[float], stiffness_N_m: float = 20.0,
                 pretension_m: float = 0.03,
                 attach_b: list[float] | tuple[float, float, float] = (-0.08, 0.0, 0.03)) -> None:
        self.anchor = np.asarray(anchor, dtype=float).reshape(3)
        self.k = float(stiffness_N_m)
        self.pre = float(pretension_m)
        self.attach = np.asarray(attach_b, dtype=float).reshape(3)
        self.rest = None

    def _point(self, sim) -> np.ndarray:
        pos, orn = p.getBasePositionAndOrientation(sim.robot, physicsClientId=sim.client)
        R = np.array(p.getMatrixFromQuaternion(orn)).reshape(3, 3)
        return np.asarray(pos) + R @ self.attach

    def reset(self, sim) -> None:
        self.rest = float(np.linalg.norm(self.anchor - self._point(sim))) - self.pre

    def substep(self, sim, t: float) -> None:
        x = self._point(sim)
        v = self.anchor - x
        d = float(np.linalg.norm(v))
        stretch = d - self.rest
        if stretch <= 0.0 or d < 1e-9:
            return
        f = self.k * stretch * v / d
        p.applyExternalForce(sim.robot, -1, f.tolist(), x.tolist(), p.WORLD_FRAME,
                             physicsClientId=sim.client)


class HardStop:
    """A mechanical stop inside one joint's normal range (a bent bracket, a cable tie or a
    wire bundle the link runs into): beyond ``stop_rad`` on the side ``side`` (+1: angles above
    it, -1: below it) a stiff contact torque -(k (q - stop) + b dq) pushes back (b only while
    pressing in)."""

    changes_world = False     # torques only, each step

    def __init__(self, joint: str, stop_rad: float, side: int = 1,
                 stiffness_Nm_rad: float = 25.0, damping_Nms_rad: float = 0.05) -> None:
        self.j = JOINT_NAMES.index(joint)
        self.stop = float(stop_rad)
        self.side = 1.0 if side > 0 else -1.0
        self.k = float(stiffness_Nm_rad)
        self.b = float(damping_Nms_rad)

    def substep(self, sim, t: float) -> None:
        q, dq = sim.joint_state()
        pen = self.side * (q[self.j] - self.stop)
        if pen <= 0.0:
            tau = 0.0
        else:
            rate_in = self.side * dq[self.j]
            tau = -self.side * (self.k * pen + (self.b * rate_in if rate_in > 0 else 0.0))
        p.setJointMotorControl2(sim.robot, sim.joint_indices[self.j], p.TORQUE_CONTROL,
                                force=float(tau), physicsClientId=sim.client)


class SlipperyRegion:
    """The floor on one side of a straight edge is slippery (a polished or wet strip beside the
    mat the robot starts on): a foot whose position lies beyond the edge, (x, y) . n > offset_m
    with n = (cos a, sin a), a = ``direction_deg`` in odom, grips with ``scale`` times its
    normal friction coefficient."""

    def __init__(self, scale: float, direction_deg: float, offset_m: float = 0.0) -> None:
        self.scale = float(scale)
        a = np.radians(float(direction_deg))
        self.n = np.array([np.cos(a), np.sin(a)])
        self.offset = float(offset_m)
        self._state: list[bool] = []

    def reset(self, sim) -> None:
        self._state = [False] * len(LEGS)
        self._set(sim, force=True)

    def _set(self, sim, force: bool = False) -> None:
        c = sim.client
        st = p.getLinkStates(sim.robot, sim.foot_links, computeForwardKinematics=1,
                             physicsClientId=c)
        for i, (link, s) in enumerate(zip(sim.foot_links, st)):
            slip = float(np.dot(self.n, s[0][:2])) > self.offset
            if force or slip != self._state[i]:
                mu = sim.config.foot_friction * (self.scale if slip else 1.0)
                p.changeDynamics(sim.robot, link, lateralFriction=mu, physicsClientId=c)
                self._state[i] = slip

    def substep(self, sim, t: float) -> None:
        self._set(sim)
