"""zoo63's own effect plug-ins (docs/interface.md section 5) for physics no built-in plug-in
provides. Sealed with the zoo: which of them the zoo uses, where and how strongly, is in the
effect files and truth.yaml only."""
from __future__ import annotations

from typing import Any

import numpy as np
import pybullet as p

from littledog_mlsim.layout import HOME_POSE
from littledog_mlsim.robot.effects import _ServoTorque, _clip, _values, resolve_joints


class CableReel:
    """A cable from a spring-loaded reel on the floor to a point on the body: the reel sits on
    the ground at the body's start position shifted by ``anchor_xy`` [m] (odom, at z 0); the
    cable pays out freely up to ``slack_m`` and pulls back beyond it with tension
    ``stiffness_N_m`` x (length - slack) [N], along the cable (from the attachment point,
    ``attach`` in base_link [m], towards the reel)."""

    changes_world = False     # forces only, each step

    def __init__(self, stiffness_N_m: float, slack_m: float,
                 attach: list[float] | tuple[float, float, float] = (-0.1, 0.0, 0.03),
                 anchor_xy: list[float] | tuple[float, float] = (0.0, 0.0)) -> None:
        if not (np.isfinite(stiffness_N_m) and stiffness_N_m >= 0):
            raise ValueError("CableReel: stiffness_N_m must be >= 0")
        if not (np.isfinite(slack_m) and slack_m >= 0):
            raise ValueError("CableReel: slack_m must be >= 0")
        self.k = float(stiffness_N_m)
        self.slack = float(slack_m)
        self.attach = _values(attach, 3, "CableReel.attach").tolist()
        self.anchor_xy = _values(anchor_xy, 2, "CableReel.anchor_xy")
        self.anchor = np.zeros(3)

    def reset(self, sim: Any) -> None:
        pos, _ = p.getBasePositionAndOrientation(sim.robot, physicsClientId=sim.client)
        self.anchor = np.array([pos[0] + self.anchor_xy[0], pos[1] + self.anchor_xy[1], 0.0])

    def substep(self, sim: Any, t: float) -> None:
        c = sim.client
        pos, orn = p.getBasePositionAndOrientation(sim.robot, physicsClientId=c)
        point, _ = p.multiplyTransforms(pos, orn, self.attach, [0, 0, 0, 1])
        d = self.anchor - np.array(point)
        length = float(np.linalg.norm(d))
        if length <= self.slack or length < 1e-9:
            return
        f = self.k * (length - self.slack) * d / length
        p.applyExternalForce(sim.robot, -1, f.tolist(), point, p.WORLD_FRAME, physicsClientId=c)


class HarnessSpring:
    """A stiff cable harness (or a protective boot) across some joints: a torsional spring
    torque -``stiffness_Nm_rad`` x (q - q_rest) on each, with q_rest = the home pose's angle +
    ``rest_offset_rad`` (one value, or one per selected joint) [N m/rad], [rad]."""

    changes_world = False     # torques only, each step

    def __init__(self, stiffness_Nm_rad: float, rest_offset_rad: float | list[float] = 0.0,
                 joints: str | list[str] | None = None) -> None:
        if not (np.isfinite(stiffness_Nm_rad) and stiffness_Nm_rad >= 0):
            raise ValueError("HarnessSpring: stiffness_Nm_rad must be >= 0")
        self.joints = resolve_joints(joints)
        self.k = float(stiffness_Nm_rad)
        self.rest = HOME_POSE[self.joints] + _values(rest_offset_rad, len(self.joints),
                                                     "HarnessSpring.rest_offset_rad")
        self._ids: list[int] = []

    def reset(self, sim: Any) -> None:
        self._ids = [sim.joint_indices[j] for j in self.joints]

    def substep(self, sim: Any, t: float) -> None:
        q = sim.joint_state()[0][self.joints]
        p.setJointMotorControlArray(sim.robot, self._ids, p.TORQUE_CONTROL,
                                    forces=(-self.k * (q - self.rest)).tolist(),
                                    physicsClientId=sim.client)


class GearLoss(_ServoTorque):
    """Load-dependent gear friction on some joints: a spur/planetary gear train loses a share
    (1 - ``efficiency``) of the torque it transmits, opposing the joint's motion, so the loss
    grows with the servo's torque (unlike a constant Coulomb friction) and vanishes when the
    servo is idle: the output torque is tau - (1 - efficiency) |tau| tanh(dq / ``smoothing``),
    tau the servo's own (within its normal limit)."""

    def __init__(self, efficiency: float, joints: str | list[str] | None = None,
                 smoothing: float = 0.05) -> None:
        if not (np.isfinite(efficiency) and 0 < efficiency <= 1):
            raise ValueError("GearLoss: efficiency must be in (0, 1]")
        if not (np.isfinite(smoothing) and smoothing > 0):
            raise ValueError("GearLoss: smoothing must be > 0")
        super().__init__(joints)
        self.efficiency = float(efficiency)
        self.smoothing = float(smoothing)

    def servo(self, e: np.ndarray, dq: np.ndarray, t: float) -> np.ndarray:
        tau = _clip(self._kp * e - self._kd * dq, -self._lim0, self._lim0)
        return tau - (1.0 - self.efficiency) * np.abs(tau) * np.tanh(dq / self.smoothing)
