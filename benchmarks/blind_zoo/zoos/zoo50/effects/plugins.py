"""zoo50's own effect plug-ins (docs/interface.md section 5): physics the robot's effects module
does not provide."""
from __future__ import annotations

from typing import Any

import numpy as np
import pybullet as p

from littledog_mlsim.robot.effects import resolve_joints


class OscillatingPull:
    """A horizontal force fixed in odom whose size oscillates: F(t) = amplitude_N x
    sin(2 pi frequency_hz t + phase) along direction_deg (odom), at the body's origin
    (a swinging tether or cable). The phase is drawn per move from the move's rng."""

    changes_world = False

    def __init__(self, amplitude_N: float, frequency_hz: float,
                 direction_deg: float = 0.0) -> None:
        self.amplitude_N = float(amplitude_N)
        self.frequency_hz = float(frequency_hz)
        a = np.radians(float(direction_deg))
        self.unit = np.array([np.cos(a), np.sin(a), 0.0])
        self.phase = 0.0

    def reset(self, sim: Any) -> None:
        self.phase = float(sim.rng.uniform(0.0, 2.0 * np.pi))

    def substep(self, sim: Any, t: float) -> None:
        f = self.amplitude_N * np.sin(2.0 * np.pi * self.frequency_hz * t + self.phase)
        pos, _ = p.getBasePositionAndOrientation(sim.robot, physicsClientId=sim.client)
        p.applyExternalForce(sim.robot, -1, (f * self.unit).tolist(), pos, p.WORLD_FRAME,
                             physicsClientId=sim.client)


class SoftFloor:
    """A compliant floor (a foam mat): the ground's contact stiffness [N/m] and damping
    [N s/m] set to these values (pybullet's soft contact), for every foot."""

    def __init__(self, stiffness_N_m: float, damping_N_s_m: float) -> None:
        self.stiffness = float(stiffness_N_m)
        self.damping = float(damping_N_s_m)

    def reset(self, sim: Any) -> None:
        p.changeDynamics(sim.plane, -1, contactStiffness=self.stiffness,
                         contactDamping=self.damping, physicsClientId=sim.client)
        for link in sim.foot_links:
            p.changeDynamics(sim.robot, link, contactStiffness=self.stiffness,
                             contactDamping=self.damping, physicsClientId=sim.client)


class RateLag:
    """The reported joint rates of some joints pass one more first-order low-pass of
    ``cutoff_hz`` (at the 100 Hz reporting rate): a slower velocity filter in the joint-state
    publisher. Angles and the servo are unchanged."""

    changes_world = False

    def __init__(self, cutoff_hz: float, joints: str | list[str] | None = None) -> None:
        self.cutoff_hz = float(cutoff_hz)
        self.joints = resolve_joints(joints)
        self._y: np.ndarray | None = None

    def reset(self, sim: Any) -> None:
        self._y = None
        self._a = 1.0 - np.exp(-2.0 * np.pi * self.cutoff_hz * sim.control_dt)

    def measure(self, obs: dict, t: float) -> dict:
        dq = obs["dq"].copy()
        x = dq[self.joints]
        self._y = x.copy() if self._y is None else self._y + self._a * (x - self._y)
        dq[self.joints] = self._y
        obs["dq"] = dq
        return obs
