"""Effect plug-ins of zoo19 beyond littledog_mlsim/robot/effects.py (docs/interface.md section 5).

Sealed with the truth: the classes below are named by the effect files.
"""
from __future__ import annotations

from collections import deque
from typing import Any

import numpy as np
import pybullet as p

from littledog_mlsim.layout import CONTROL_DT
from littledog_mlsim.robot.effects import resolve_joints

_BODY_FIELDS = ("position", "orientation", "linear_velocity", "angular_velocity")


class MocapLatency:
    """The motion-capture pose and twist reach the recording ``steps`` control steps late (a
    slow tracking pipeline); before that many samples exist the first one is repeated. Joint
    readings are on time."""

    def __init__(self, steps: int = 3) -> None:
        if int(steps) != steps or steps < 1:
            raise ValueError("MocapLatency: steps must be a positive integer")
        self.steps = int(steps)
        self._hist: deque = deque()

    def reset(self, sim: Any) -> None:
        self._hist = deque()

    def measure(self, obs: dict, t: float) -> dict:
        body = {k: np.array(obs[k], copy=True) for k in _BODY_FIELDS}
        if not self._hist:
            self._hist.extend({k: v.copy() for k, v in body.items()} for _ in range(self.steps))
        self._hist.append(body)
        old = self._hist.popleft()
        for k in _BODY_FIELDS:
            obs[k] = old[k]
        return obs


class Tether:
    """A slack cable from a fixed anchor on the floor (odom ``anchor_xy``) to a point on the body
    (base_link ``attach``): when the horizontal distance exceeds ``slack_m`` it pulls back
    horizontally with ``stiffness`` N/m times the excess (plus viscous ``damping`` on the rate
    of stretch), capped at ``max_force_N``."""

    def __init__(self, stiffness: float, anchor_xy=(0.0, 0.0), slack_m: float = 0.2,
                 attach=(0.0, 0.0, 0.0), damping: float = 0.0, max_force_N: float = 10.0) -> None:
        self.k = float(stiffness)
        self.anchor = np.asarray(anchor_xy, dtype=float).reshape(2)
        self.slack = float(slack_m)
        self.attach = np.asarray(attach, dtype=float).reshape(3)
        self.c = float(damping)
        self.fmax = float(max_force_N)

    def substep(self, sim: Any, t: float) -> None:
        c = sim.client
        pos, orn = p.getBasePositionAndOrientation(sim.robot, physicsClientId=c)
        R = np.array(p.getMatrixFromQuaternion(orn)).reshape(3, 3)
        point = np.asarray(pos) + R @ self.attach
        d = point[:2] - self.anchor
        dist = float(np.hypot(*d))
        if dist <= self.slack or dist < 1e-9:
            return
        u = d / dist
        lin, ang = p.getBaseVelocity(sim.robot, physicsClientId=c)
        v = np.asarray(lin) + np.cross(np.asarray(ang), R @ self.attach)
        rate = float(u @ v[:2])
        f = self.k * (dist - self.slack) + self.c * max(rate, 0.0)
        f = min(max(f, 0.0), self.fmax)
        p.applyExternalForce(sim.robot, -1, [float(-f * u[0]), float(-f * u[1]), 0.0],
                             point.tolist(), p.WORLD_FRAME, physicsClientId=c)


class StaleEncoders:
    """The reported angles and rates of some joints are ``steps`` control steps old (a slow
    bus to one board); the servo itself reads its encoders on time."""

    def __init__(self, steps: int = 2, joints=None) -> None:
        if int(steps) != steps or steps < 1:
            raise ValueError("StaleEncoders: steps must be a positive integer")
        self.steps = int(steps)
        self.joints = resolve_joints(joints)
        self._hist: deque = deque()

    def reset(self, sim: Any) -> None:
        self._hist = deque()

    def measure(self, obs: dict, t: float) -> dict:
        now = (np.array(obs["q"], copy=True), np.array(obs["dq"], copy=True))
        if not self._hist:
            self._hist.extend((now[0].copy(), now[1].copy()) for _ in range(self.steps))
        self._hist.append(now)
        q_old, dq_old = self._hist.popleft()
        q, dq = np.array(obs["q"], copy=True), np.array(obs["dq"], copy=True)
        q[self.joints] = q_old[self.joints]
        dq[self.joints] = dq_old[self.joints]
        obs["q"], obs["dq"] = q, dq
        return obs


class SetpointSlewLimit:
    """The servo firmware limits how fast the set-point of some joints may move: each control
    step it moves towards the command by at most ``max_rate`` rad/s times the step (started at
    the first command)."""

    def __init__(self, max_rate: float, joints=None) -> None:
        if not (np.isfinite(max_rate) and max_rate > 0):
            raise ValueError("SetpointSlewLimit: max_rate must be > 0")
        self.max_step = float(max_rate) * CONTROL_DT
        self.joints = resolve_joints(joints)
        self._y = None

    def reset(self, sim: Any) -> None:
        self._y = None

    def command(self, u: np.ndarray, t: float) -> np.ndarray:
        if self._y is None:
            self._y = u.copy()
        else:
            self._y = self._y + np.clip(u - self._y, -self.max_step, self.max_step)
        out = u.copy()
        out[self.joints] = self._y[self.joints]
        return out


class NullForce:
    """A negligible constant body force (the check's chaos floor), fixed in odom."""

    def __init__(self, force_N: float = 1e-6) -> None:
        self.f = float(force_N)

    def substep(self, sim: Any, t: float) -> None:
        pos, _ = p.getBasePositionAndOrientation(sim.robot, physicsClientId=sim.client)
        p.applyExternalForce(sim.robot, -1, [self.f, 0.0, 0.0], pos, p.WORLD_FRAME,
                             physicsClientId=sim.client)
