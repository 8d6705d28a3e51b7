"""zoo16's own effect plug-ins (docs/interface.md section 5), for effects the built-in plug-ins
of ``littledog_mlsim/robot/effects.py`` do not express. Sealed with the zoo's truth."""
from __future__ import annotations

from typing import Any

import numpy as np
import pybullet as p

from littledog_mlsim.layout import HOME_POSE
from littledog_mlsim.robot.effects import resolve_joints


class Tether:
    """A cable (power / data umbilical) anchored on the floor where the move starts and clipped
    to the body at ``attach`` (base_link): once the horizontal distance from the anchor to the
    clip exceeds ``slack_m``, the cable pulls the clip back towards the anchor, horizontally,
    with ``stiffness_N_m`` * (distance - slack_m), at most ``max_force_N``."""

    def __init__(self, stiffness_N_m: float, slack_m: float = 0.05,
                 attach: list[float] | tuple[float, float, float] = (-0.10, 0.0, 0.04),
                 max_force_N: float = 10.0) -> None:
        self.k = float(stiffness_N_m)
        self.slack = float(slack_m)
        self.attach = [float(x) for x in attach]
        self.max_force = float(max_force_N)
        self.anchor = np.zeros(2)

    def _clip_point(self, sim: Any) -> np.ndarray:
        pos, orn = p.getBasePositionAndOrientation(sim.robot, physicsClientId=sim.client)
        w, _ = p.multiplyTransforms(pos, orn, self.attach, [0, 0, 0, 1])
        return np.array(w)

    def reset(self, sim: Any) -> None:
        self.anchor = self._clip_point(sim)[:2].copy()

    def substep(self, sim: Any, t: float) -> None:
        c = self._clip_point(sim)
        d = c[:2] - self.anchor
        r = float(np.hypot(*d))
        if r <= self.slack:
            return
        f = min(self.k * (r - self.slack), self.max_force)
        fv = -f * d / r
        p.applyExternalForce(sim.robot, -1, [float(fv[0]), float(fv[1]), 0.0], c.tolist(),
                             p.WORLD_FRAME, physicsClientId=sim.client)


class SoftFloor:
    """A compliant floor covering (a foam or rubber mat): the ground's contact becomes a spring
    of ``stiffness_N_m`` and damper of ``damping_N_s_m`` (pybullet's soft contact)."""

    def __init__(self, stiffness_N_m: float, damping_N_s_m: float) -> None:
        self.stiffness = float(stiffness_N_m)
        self.damping = float(damping_N_s_m)

    def reset(self, sim: Any) -> None:
        p.changeDynamics(sim.plane, -1, contactStiffness=self.stiffness,
                         contactDamping=self.damping, physicsClientId=sim.client)


class JointSpring:
    """A passive elastic element across some joints (a rubber boot over the joint, a stiff cable
    loom): torque -``stiffness_Nm_rad`` * (q - q_rest) added to the servo's, with q_rest the
    home pose angle plus ``rest_offset_rad``."""

    def __init__(self, stiffness_Nm_rad: float, joints: str | list[str] | None = None,
                 rest_offset_rad: float = 0.0) -> None:
        self.k = float(stiffness_Nm_rad)
        self.joints = resolve_joints(joints)
        self.rest = HOME_POSE[self.joints] + float(rest_offset_rad)
        self._ids: list[int] = []

    def reset(self, sim: Any) -> None:
        self._ids = [sim.joint_indices[j] for j in self.joints]

    def substep(self, sim: Any, t: float) -> None:
        states = p.getJointStates(sim.robot, self._ids, physicsClientId=sim.client)
        q = np.array([s[0] for s in states])
        tau = -self.k * (q - self.rest)
        p.setJointMotorControlArray(sim.robot, self._ids, p.TORQUE_CONTROL,
                                    forces=tau.tolist(), physicsClientId=sim.client)
