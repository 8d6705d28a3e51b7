"""Effect plug-ins of this zoo that the built-in effects (littledog_mlsim/robot/effects.py) lack.

Protocol: docs/interface.md section 5 (reset / command / substep / measure hooks).
"""
from __future__ import annotations

from typing import Any

import numpy as np
import pybullet as p

from littledog_mlsim.robot.effects import _ServoTorque


class FloorMat:
    """The robot starts on a rubber mat; off the mat the floor is smoother. Every physics step
    each foot's friction coefficient is the robot's own while the foot is over the mat
    (|x - x0| <= half_size[0] and |y - y0| <= half_size[1], odom, centred where the body starts)
    and ``off_mat_scale`` times it elsewhere."""

    def __init__(self, off_mat_scale: float, half_size_m: list[float] = (0.3, 0.25)) -> None:
        if not (np.isfinite(off_mat_scale) and off_mat_scale > 0):
            raise ValueError("FloorMat: off_mat_scale must be > 0")
        self.scale = float(off_mat_scale)
        self.half = np.asarray(half_size_m, dtype=float).reshape(2)
        self._centre = np.zeros(2)
        self._state: dict[int, bool] = {}

    def reset(self, sim: Any) -> None:
        pos, _ = p.getBasePositionAndOrientation(sim.robot, physicsClientId=sim.client)
        self._centre = np.array(pos[:2])
        self._state = {}

    def substep(self, sim: Any, t: float) -> None:
        c = sim.client
        states = p.getLinkStates(sim.robot, sim.foot_links, computeForwardKinematics=1,
                                 physicsClientId=c)
        for link, st in zip(sim.foot_links, states):
            d = np.abs(np.array(st[0][:2]) - self._centre)
            on = bool(np.all(d <= self.half))
            if self._state.get(link) is not on:
                mu = sim.config.foot_friction * (1.0 if on else self.scale)
                p.changeDynamics(sim.robot, link, lateralFriction=mu, physicsClientId=c)
                self._state[link] = on


class Tether:
    """An elastic cable (power / data tether) anchored on the floor where the body starts and
    fixed to the body at ``attach_m`` (base_link): once ``slack_m`` of horizontal distance from
    the anchor is used up it pulls the body back towards the anchor, horizontally, with
    ``stiffness_N_per_m`` times the excess distance."""

    def __init__(self, stiffness_N_per_m: float, slack_m: float = 0.1,
                 attach_m: list[float] = (-0.1, 0.0, 0.03)) -> None:
        self.k = float(stiffness_N_per_m)
        self.slack = float(slack_m)
        self.attach = np.asarray(attach_m, dtype=float).reshape(3)
        self._anchor = np.zeros(2)

    def _attach_world(self, sim: Any) -> np.ndarray:
        pos, orn = p.getBasePositionAndOrientation(sim.robot, physicsClientId=sim.client)
        w, _ = p.multiplyTransforms(pos, orn, self.attach.tolist(), [0, 0, 0, 1])
        return np.array(w)

    def reset(self, sim: Any) -> None:
        self._anchor = self._attach_world(sim)[:2]

    def substep(self, sim: Any, t: float) -> None:
        w = self._attach_world(sim)
        d = w[:2] - self._anchor
        r = float(np.hypot(*d))
        if r <= self.slack or r < 1e-9:
            return
        f = -self.k * (r - self.slack) * d / r
        p.applyExternalForce(sim.robot, -1, [float(f[0]), float(f[1]), 0.0], w.tolist(),
                             p.WORLD_FRAME, physicsClientId=sim.client)


class MotorSpeedLimit(_ServoTorque):
    """A DC motor's torque-speed line (back EMF at a fixed supply voltage): while the servo
    drives a joint in the direction it moves, its torque is at most
    limit * max(0, 1 - |dq| / no_load_speed_rad_s); braking torque keeps the normal limit."""

    def __init__(self, no_load_speed_rad_s: float, joints: str | list[str] | None = None) -> None:
        if not (np.isfinite(no_load_speed_rad_s) and no_load_speed_rad_s > 0):
            raise ValueError("MotorSpeedLimit: no_load_speed_rad_s must be > 0")
        super().__init__(joints)
        self.w0 = float(no_load_speed_rad_s)

    def servo(self, e: np.ndarray, dq: np.ndarray, t: float) -> np.ndarray:
        tau = np.clip(self._kp * e - self._kd * dq, -self._lim0, self._lim0)
        drive = tau * dq > 0
        lim = self._lim0 * np.maximum(0.0, 1.0 - np.abs(dq) / self.w0)
        return np.where(drive, np.clip(tau, -lim, lim), tau)


class SoftFootPads:
    """Compliant rubber foot pads: every foot's contact is a spring of ``stiffness_N_per_m``
    with damping ``damping_Ns_per_m`` (pybullet's contactStiffness / contactDamping) instead of
    the rigid contact."""

    def __init__(self, stiffness_N_per_m: float, damping_Ns_per_m: float) -> None:
        self.k = float(stiffness_N_per_m)
        self.d = float(damping_Ns_per_m)

    def reset(self, sim: Any) -> None:
        for link in sim.foot_links:
            p.changeDynamics(sim.robot, link, contactStiffness=self.k, contactDamping=self.d,
                             physicsClientId=sim.client)


class JointSpring:
    """A cable bundle across some joints acting as a torsional spring: torque
    -stiffness_Nm_per_rad * (q - rest_rad) on each selected joint (rest_rad: one value or one
    per selected joint), added to the servo's every physics step."""

    def __init__(self, stiffness_Nm_per_rad: float, rest_rad: float | list[float] = 0.0,
                 joints: str | list[str] | None = None) -> None:
        from littledog_mlsim.robot.effects import resolve_joints
        self.joints = resolve_joints(joints)
        self.k = float(stiffness_Nm_per_rad)
        self.rest = np.broadcast_to(np.asarray(rest_rad, dtype=float), (len(self.joints),)).copy()

    def reset(self, sim: Any) -> None:
        self._ids = [sim.joint_indices[j] for j in self.joints]

    def substep(self, sim: Any, t: float) -> None:
        states = p.getJointStates(sim.robot, self._ids, physicsClientId=sim.client)
        q = np.array([s[0] for s in states])
        p.setJointMotorControlArray(sim.robot, self._ids, p.TORQUE_CONTROL,
                                    forces=(-self.k * (q - self.rest)).tolist(),
                                    physicsClientId=sim.client)
