"""Effect plug-ins of zoo15 (docs/interface.md section 5). SEALED: read only by the recording."""
from __future__ import annotations

from collections import deque
from typing import Any

import numpy as np
import pybullet as p

from littledog_mlsim.layout import HOME_POSE, LEGS
from littledog_mlsim.robot.effects import resolve_joints


class MocapLatency:
    """The motion-capture stream (pose and the twist differenced from it) reaches the recorder
    ``latency_ms`` late (a whole number of 10 ms frames); the joint encoders are on time. Before
    enough frames have arrived, the first frame is repeated."""

    def __init__(self, latency_ms: float) -> None:
        k = latency_ms / 10.0
        if latency_ms < 0 or abs(k - round(k)) > 1e-9:
            raise ValueError("MocapLatency: latency_ms must be a non-negative multiple of 10")
        self.frames = int(round(k))
        self._buf: deque[dict[str, np.ndarray]] = deque()

    KEYS = ("position", "orientation", "linear_velocity", "angular_velocity")

    def reset(self, sim: Any) -> None:
        self._buf.clear()

    def measure(self, obs: dict, t: float) -> dict:
        body = {k: np.array(obs[k], dtype=float).copy() for k in self.KEYS}
        if not self._buf:
            self._buf.extend({k: v.copy() for k, v in body.items()} for _ in range(self.frames))
        self._buf.append(body)
        old = self._buf.popleft()
        out = dict(obs)
        out.update({k: v.copy() for k, v in old.items()})
        return out


class SwingBrush:
    """While a foot is off the ground, a force of up to ``magnitude_N`` opposes its 3-D velocity
    in the world: F = -magnitude_N tanh(|v| / speed_m_s) v / |v|. None in contact."""

    def __init__(self, magnitude_N: float, legs: str | list[str] = "front_left",
                 speed_m_s: float = 0.15) -> None:
        if magnitude_N < 0 or speed_m_s <= 0:
            raise ValueError("SwingBrush: magnitude_N >= 0 and speed_m_s > 0")
        self.magnitude_N = float(magnitude_N)
        self.speed_m_s = float(speed_m_s)
        names = [legs] if isinstance(legs, str) else list(legs)
        self.legs = [LEGS.index(n) for n in names]

    def substep(self, sim: Any, t: float) -> None:
        c = sim.client
        links = [sim.foot_links[i] for i in self.legs]
        states = p.getLinkStates(sim.robot, links, computeLinkVelocity=1,
                                 computeForwardKinematics=1, physicsClientId=c)
        for link, st in zip(links, states):
            if p.getContactPoints(sim.robot, sim.plane, link, -1, physicsClientId=c):
                continue
            v = np.array(st[6], dtype=float)
            speed = float(np.linalg.norm(v))
            if speed < 1e-9:
                continue
            f = -self.magnitude_N * np.tanh(speed / self.speed_m_s) * v / speed
            p.applyExternalForce(sim.robot, link, f.tolist(), st[0], p.WORLD_FRAME,
                                 physicsClientId=c)


class JointSpring:
    """A parallel elastic element (a rubber gaiter) on some joints: an extra torque
    -stiffness (q - rest) [N m] with rest the joint's home angle plus ``rest_shift_rad``."""

    def __init__(self, stiffness_Nm_per_rad: float, joints: str | list[str] = "knees",
                 rest_shift_rad: float = 0.0) -> None:
        self.k = float(stiffness_Nm_per_rad)
        self.joints = resolve_joints(joints)
        self.rest = np.asarray(HOME_POSE, dtype=float)[self.joints] + float(rest_shift_rad)

    def reset(self, sim: Any) -> None:
        self._ids = [sim.joint_indices[j] for j in self.joints]

    def substep(self, sim: Any, t: float) -> None:
        states = p.getJointStates(sim.robot, self._ids, physicsClientId=sim.client)
        q = np.array([s[0] for s in states])
        tau = -self.k * (q - self.rest)
        p.setJointMotorControlArray(sim.robot, self._ids, p.TORQUE_CONTROL,
                                    forces=tau.tolist(), physicsClientId=sim.client)
