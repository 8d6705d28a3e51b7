"""zoo20's own effect plug-ins (docs/interface.md section 5). Neutral class names."""
from __future__ import annotations

from collections import deque
from typing import Any

import numpy as np
import pybullet as p

from littledog_mlsim.robot.effects import resolve_joints


class PA:
    """Floor whose friction depends on where a foot is in the world: feet farther than
    ``radius_m`` (horizontally) from ``centre_xy`` stand on a surface of ``scale`` times the
    foot's normal friction coefficient; inside, the normal coefficient. Updated every control
    step from each foot's world position."""

    def __init__(self, scale: float, radius_m: float, centre_xy=(0.0, 0.0)) -> None:
        self.scale = float(scale)
        self.radius_m = float(radius_m)
        self.centre = np.asarray(centre_xy, dtype=float)
        self._last = -1.0

    def reset(self, sim: Any) -> None:
        self._last = -1.0
        self._state: dict[int, bool] = {}

    def substep(self, sim: Any, t: float) -> None:
        if t - self._last < sim.control_dt - 1e-9:
            return
        self._last = t
        c = sim.client
        states = p.getLinkStates(sim.robot, sim.foot_links, computeForwardKinematics=1,
                                 physicsClientId=c)
        for link, st in zip(sim.foot_links, states):
            outside = float(np.hypot(*(np.array(st[0][:2]) - self.centre))) > self.radius_m
            if self._state.get(link) is outside:
                continue
            self._state[link] = outside
            f = sim.config.foot_friction * (self.scale if outside else 1.0)
            p.changeDynamics(sim.robot, link, lateralFriction=f, physicsClientId=c)


class PB:
    """The motion-capture stream (pose and the twist derived from it) arrives ``lag_steps``
    control steps late relative to the joint encoders (the first sample is repeated at the
    start)."""

    KEYS = ("position", "orientation", "linear_velocity", "angular_velocity")

    def __init__(self, lag_steps: int) -> None:
        self.lag = int(lag_steps)
        self._buf: deque = deque()

    def reset(self, sim: Any) -> None:
        self._buf = deque()

    def measure(self, obs: dict, t: float) -> dict:
        cur = {k: np.array(obs[k], copy=True) for k in self.KEYS}
        if not self._buf:
            for _ in range(self.lag):
                self._buf.append(cur)
        self._buf.append(cur)
        old = self._buf.popleft()
        out = dict(obs)
        out.update({k: old[k].copy() for k in self.KEYS})
        return out


class PC:
    """A slack line from a world-fixed anchor (where the move starts) to the body: no force
    within ``slack_m`` of the anchor (horizontal distance), beyond it a horizontal pull back
    towards the anchor of ``stiffness_N_per_m`` * (distance - slack)."""

    def __init__(self, stiffness_N_per_m: float, slack_m: float) -> None:
        self.k = float(stiffness_N_per_m)
        self.slack = float(slack_m)
        self.anchor = np.zeros(2)

    def reset(self, sim: Any) -> None:
        pos, _ = p.getBasePositionAndOrientation(sim.robot, physicsClientId=sim.client)
        self.anchor = np.array(pos[:2], dtype=float)

    def substep(self, sim: Any, t: float) -> None:
        c = sim.client
        pos, _ = p.getBasePositionAndOrientation(sim.robot, physicsClientId=c)
        d = np.array(pos[:2]) - self.anchor
        r = float(np.hypot(*d))
        if r <= self.slack:
            return
        f = -self.k * (r - self.slack) * d / r
        p.applyExternalForce(sim.robot, -1, [float(f[0]), float(f[1]), 0.0], pos,
                             p.WORLD_FRAME, physicsClientId=c)


class PD:
    """The set-point of some joints cannot change faster than ``rate_rad_s`` (a slew-rate
    limit in the servo's command path), started at the first command."""

    def __init__(self, rate_rad_s: float, joints="all") -> None:
        self.rate = float(rate_rad_s)
        self.joints = resolve_joints(joints)
        self._y = None

    def reset(self, sim: Any) -> None:
        self._y = None
        self._dt = float(sim.control_dt)

    def command(self, u: np.ndarray, t: float) -> np.ndarray:
        if self._y is None:
            self._y = u.copy()
        else:
            step = self.rate * self._dt
            self._y = self._y + np.clip(u - self._y, -step, step)
        out = u.copy()
        out[self.joints] = self._y[self.joints]
        return out


class PZ:
    """A negligible constant horizontal force in the world frame (the null recording: the
    chaos floor of the check)."""

    def __init__(self, force_N: float = 1e-3) -> None:
        self.f = float(force_N)

    def substep(self, sim: Any, t: float) -> None:
        pos, _ = p.getBasePositionAndOrientation(sim.robot, physicsClientId=sim.client)
        p.applyExternalForce(sim.robot, -1, [self.f, 0.0, 0.0], pos, p.WORLD_FRAME,
                             physicsClientId=sim.client)
