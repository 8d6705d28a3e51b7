"""Effect plug-ins of zoo28 that the built-in module does not offer (SEALED: part of the truth).

Protocol: docs/interface.md section 5 (``reset``, ``command``, ``substep``, ``measure``).
"""
from __future__ import annotations

from collections import deque
from typing import Any

import numpy as np
import pybullet as p

from littledog_mlsim.layout import HOME_POSE, JOINT_NAMES, LEGS


class PoseLatency:
    """Motion capture reaches the recording ``delay_ms`` later than the joint readings: the body
    fields of each measurement (pose and twist) are those of ``delay_ms`` / 10 control steps
    earlier (the first measurement is repeated before that); joint readings are on time."""

    BODY = ("position", "orientation", "linear_velocity", "angular_velocity")

    def __init__(self, delay_ms: float = 30.0) -> None:
        steps = float(delay_ms) / 10.0
        if steps < 0 or abs(steps - round(steps)) > 1e-9:
            raise ValueError("PoseLatency: delay_ms must be a non-negative multiple of 10")
        self.steps = int(round(steps))
        self._buf: deque[dict[str, np.ndarray]] = deque()

    def reset(self, sim: Any) -> None:
        self._buf.clear()

    def measure(self, obs: dict, t: float) -> dict:
        body = {k: np.array(obs[k], copy=True) for k in self.BODY}
        if not self._buf:
            self._buf.extend(dict(body) for _ in range(self.steps))
        self._buf.append(body)
        old = self._buf.popleft()
        out = dict(obs)
        out.update(old)
        return out


class HipCrossCoupling:
    """A mis-set hip differential: each hip roll's set-point picks up ``ratio`` times its hip
    pitch's set-point deviation from the home pose (mirrored on the right side, so both legs of
    a pair move outward together)."""

    def __init__(self, ratio: float = 0.25) -> None:
        self.ratio = float(ratio)
        names = list(JOINT_NAMES)
        self.pairs = []
        for leg in LEGS:
            sign = 1.0 if "_left" in leg else -1.0
            self.pairs.append((names.index(f"{leg}_hip_roll"), names.index(f"{leg}_hip_pitch"),
                               sign))

    def command(self, u: np.ndarray, t: float) -> np.ndarray:
        out = u.copy()
        for r, pi, sign in self.pairs:
            out[r] = u[r] + sign * self.ratio * (u[pi] - HOME_POSE[pi])
        return out


class FloorPatch:
    """A low-friction patch of floor (a wet or polished strip) fixed in the world: a foot whose
    position has x > ``x_min_m`` (odom) has its friction coefficient times ``friction_scale``;
    elsewhere the normal one."""

    def __init__(self, friction_scale: float = 0.25, x_min_m: float = 0.25) -> None:
        if not (0 < friction_scale):
            raise ValueError("FloorPatch: friction_scale must be > 0")
        self.scale = float(friction_scale)
        self.x_min = float(x_min_m)
        self._on: list[bool] = []

    def reset(self, sim: Any) -> None:
        self._on = [False] * len(sim.foot_links)
        self._mu = float(sim.config.foot_friction)

    def substep(self, sim: Any, t: float) -> None:
        c = sim.client
        states = p.getLinkStates(sim.robot, sim.foot_links, computeForwardKinematics=1,
                                 physicsClientId=c)
        for i, (link, st) in enumerate(zip(sim.foot_links, states)):
            on = float(st[0][0]) > self.x_min
            if on != self._on[i]:
                p.changeDynamics(sim.robot, link,
                                 lateralFriction=self._mu * (self.scale if on else 1.0),
                                 physicsClientId=c)
                self._on[i] = on
