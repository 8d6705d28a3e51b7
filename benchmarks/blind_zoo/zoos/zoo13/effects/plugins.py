"""zoo13's own effect plug-ins (docs/interface.md section 5), for effects outside the built-ins."""
from __future__ import annotations

from collections import deque
from typing import Any

import numpy as np
import pybullet as p

from littledog_mlsim.robot.effects import resolve_joints


class JointSensorLag:
    """The joint readings (q and dq, all joints) are published ``lag_ms`` late relative to the
    motion-capture pose (a buffered encoder bus): whole 10 ms steps, the first reading repeated
    until the buffer is full."""

    def __init__(self, lag_ms: float = 20.0, joints: Any = None) -> None:
        self.steps = int(round(float(lag_ms) / 10.0))
        self.joints = resolve_joints(joints)
        self._buf: deque = deque()

    def reset(self, sim: Any) -> None:
        self._buf.clear()

    def measure(self, obs: dict, t: float) -> dict:
        cur = (obs["q"].copy(), obs["dq"].copy())
        if not self._buf:
            self._buf.extend(cur for _ in range(self.steps))
        self._buf.append(cur)
        q_old, dq_old = self._buf.popleft()
        q, dq = obs["q"].copy(), obs["dq"].copy()
        q[self.joints] = q_old[self.joints]
        dq[self.joints] = dq_old[self.joints]
        obs["q"], obs["dq"] = q, dq
        return obs


class Tether:
    """A slack cable from a floor anchor where the move started to the body: no force within
    ``slack_m`` of the anchor (horizontal distance), beyond it a horizontal pull back towards
    the anchor of ``stiffness_N_per_m`` * (distance - slack), at most ``max_force_N``."""

    def __init__(self, stiffness_N_per_m: float = 25.0, slack_m: float = 0.1,
                 max_force_N: float = 4.0) -> None:
        self.k = float(stiffness_N_per_m)
        self.slack = float(slack_m)
        self.fmax = float(max_force_N)
        self.anchor = np.zeros(2)

    def reset(self, sim: Any) -> None:
        pos, _ = p.getBasePositionAndOrientation(sim.robot, physicsClientId=sim.client)
        self.anchor = np.array(pos[:2], dtype=float)

    def substep(self, sim: Any, t: float) -> None:
        pos, _ = p.getBasePositionAndOrientation(sim.robot, physicsClientId=sim.client)
        d = np.array(pos[:2]) - self.anchor
        r = float(np.hypot(*d))
        if r <= self.slack:
            return
        f = -min(self.k * (r - self.slack), self.fmax) * d / r
        p.applyExternalForce(sim.robot, -1, [float(f[0]), float(f[1]), 0.0], pos, p.WORLD_FRAME,
                             physicsClientId=sim.client)


class SetpointSlewLimit:
    """The servo's set-point of some joints moves at most ``rate_rad_s`` towards the command
    (a trajectory generator in the servo firmware), starting at the first command."""

    def __init__(self, rate_rad_s: float = 1.5, joints: Any = None) -> None:
        self.rate = float(rate_rad_s)
        self.joints = resolve_joints(joints)
        self._y: np.ndarray | None = None

    def reset(self, sim: Any) -> None:
        self._y = None

    def command(self, u: np.ndarray, t: float) -> np.ndarray:
        if self._y is None:
            self._y = u.copy()
        else:
            step = self.rate * 0.01
            self._y = self._y + np.clip(u - self._y, -step, step)
        out = u.copy()
        out[self.joints] = self._y[self.joints]
        return out


class SlipperyPatch:
    """The robot starts on a grippy mat of radius ``radius_m``; the floor around it is polished:
    a foot whose position lies farther than ``radius_m`` (horizontally) from where the move
    started has its friction coefficient times ``scale``."""

    def __init__(self, scale: float = 0.3, radius_m: float = 0.08) -> None:
        self.scale = float(scale)
        self.radius = float(radius_m)
        self.origin = np.zeros(2)
        self._state: list[bool] = []

    def reset(self, sim: Any) -> None:
        pos, _ = p.getBasePositionAndOrientation(sim.robot, physicsClientId=sim.client)
        self.origin = np.array(pos[:2], dtype=float)
        self._state = [False] * len(sim.foot_links)

    def substep(self, sim: Any, t: float) -> None:
        c = sim.client
        states = p.getLinkStates(sim.robot, sim.foot_links, physicsClientId=c)
        for i, (link, st) in enumerate(zip(sim.foot_links, states)):
            on = float(np.hypot(*(np.array(st[0][:2]) - self.origin))) > self.radius
            if on != self._state[i]:
                mu = sim.config.foot_friction * (self.scale if on else 1.0)
                p.changeDynamics(sim.robot, link, lateralFriction=mu, physicsClientId=c)
                self._state[i] = on
