"""Effect plug-ins of zoo24 that the library's effects module does not provide
(docs/interface.md section 5: reset / command / substep / measure hooks)."""
from __future__ import annotations

from typing import Any

import numpy as np
import pybullet as p

from littledog_mlsim.layout import JOINT_LOWER, JOINT_UPPER, LEGS
from littledog_mlsim.robot.config import per_joint
from littledog_mlsim.robot.effects import resolve_joints


class Tether:
    """A slack elastic cable from a fixed point of the floor to the body: once the body's
    horizontal distance from ``anchor_xy`` (odom) exceeds ``slack_m``, a horizontal force
    ``stiffness_N_per_m`` * (distance - slack) pulls the body towards the anchor."""

    def __init__(self, anchor_xy=(0.0, 0.0), slack_m: float = 0.2,
                 stiffness_N_per_m: float = 8.0) -> None:
        self.anchor = np.asarray(anchor_xy, dtype=float).reshape(2)
        self.slack = float(slack_m)
        self.k = float(stiffness_N_per_m)

    def substep(self, sim: Any, t: float) -> None:
        pos, _ = p.getBasePositionAndOrientation(sim.robot, physicsClientId=sim.client)
        d = np.array(pos[:2]) - self.anchor
        r = float(np.hypot(*d))
        if r <= self.slack or r < 1e-9:
            return
        f = -self.k * (r - self.slack) * d / r
        p.applyExternalForce(sim.robot, -1, [float(f[0]), float(f[1]), 0.0], pos,
                             p.WORLD_FRAME, physicsClientId=sim.client)


class FloorPatch:
    """The floor's grip differs by place: every foot whose position in odom lies farther than
    ``radius_m`` from ``center_xy`` has its friction coefficient times ``scale`` (a polished
    floor around a rug); nearer, the normal coefficient."""

    def __init__(self, scale: float = 0.35, radius_m: float = 0.2,
                 center_xy=(0.0, 0.0)) -> None:
        self.scale = float(scale)
        self.radius = float(radius_m)
        self.center = np.asarray(center_xy, dtype=float).reshape(2)
        self._state: dict[int, bool] = {}

    def reset(self, sim: Any) -> None:
        self._state = {}

    def substep(self, sim: Any, t: float) -> None:
        c = sim.client
        states = p.getLinkStates(sim.robot, sim.foot_links, computeForwardKinematics=1,
                                 physicsClientId=c)
        for link, st in zip(sim.foot_links, states):
            out = float(np.hypot(*(np.array(st[0][:2]) - self.center))) > self.radius
            if self._state.get(link) != out:
                mu = sim.config.foot_friction * (self.scale if out else 1.0)
                p.changeDynamics(sim.robot, link, lateralFriction=mu, physicsClientId=c)
                self._state[link] = out


class OneSidedTorqueLimit:
    """A servo that is weaker in one direction (a worn gear tooth flank, an H-bridge half):
    the torque of the selected joints is limited to ``limit_Nm`` when its sign is ``sign``
    (+1 or -1) and to the normal limit otherwise; the excess is taken off every physics step."""

    def __init__(self, limit_Nm: float, sign: int = 1, joints="front_right_knee") -> None:
        self.limit = float(limit_Nm)
        self.sign = 1 if sign >= 0 else -1
        self.joints = resolve_joints(joints)
        self._q_des = np.zeros(len(JOINT_LOWER))

    def reset(self, sim: Any) -> None:
        cfg = sim.config
        self._ids = [sim.joint_indices[j] for j in self.joints]
        self._kp = per_joint(cfg.kp)[self.joints]
        self._kd = per_joint(cfg.kd)[self.joints]
        self._lim0 = per_joint(cfg.torque_limit)[self.joints]

    def command(self, u: np.ndarray, t: float) -> np.ndarray:
        self._q_des = np.clip(u, JOINT_LOWER, JOINT_UPPER)
        return u

    def substep(self, sim: Any, t: float) -> None:
        states = p.getJointStates(sim.robot, self._ids, physicsClientId=sim.client)
        q = np.array([s[0] for s in states])
        dq = np.array([s[1] for s in states])
        normal = np.clip(self._kp * (self._q_des[self.joints] - q) - self._kd * dq,
                         -self._lim0, self._lim0)
        lim = np.minimum(self.limit, self._lim0)
        changed = (np.minimum(normal, lim) if self.sign > 0 else np.maximum(normal, -lim))
        p.setJointMotorControlArray(sim.robot, self._ids, p.TORQUE_CONTROL,
                                    forces=(changed - normal).tolist(),
                                    physicsClientId=sim.client)
