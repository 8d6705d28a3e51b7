"""Effect plug-ins of zoo18 beyond littledog_mlsim/robot/effects.py (docs/interface.md §5).

SEALED with the truth: which of these the zoo uses, where and how strongly is in truth.yaml.
"""
from __future__ import annotations

from typing import Any

import numpy as np
import pybullet as p

from littledog_mlsim.robot.effects import _ServoTorque, _legs, _values


class RotorVibration:
    """An unbalanced rotor carried on the body (a pump, a fan): a force of ``amplitude_N``
    rotating at ``frequency_hz`` in the body's x-z plane (base_link), at the base's centre of
    mass. The rotor's phase at the start of a move is random (the move's rng)."""

    def __init__(self, amplitude_N: float, frequency_hz: float) -> None:
        if not (np.isfinite(amplitude_N) and amplitude_N >= 0):
            raise ValueError("RotorVibration: amplitude_N must be >= 0")
        if not (np.isfinite(frequency_hz) and frequency_hz > 0):
            raise ValueError("RotorVibration: frequency_hz must be > 0")
        self.amplitude_N = float(amplitude_N)
        self.frequency_hz = float(frequency_hz)
        self._phase0 = 0.0

    def reset(self, sim: Any) -> None:
        self._phase0 = float(sim.rng.uniform(0.0, 2.0 * np.pi))

    def substep(self, sim: Any, t: float) -> None:
        c = sim.client
        ph = self._phase0 + 2.0 * np.pi * self.frequency_hz * t
        f_body = self.amplitude_N * np.array([np.cos(ph), 0.0, np.sin(ph)])
        pos, orn = p.getBasePositionAndOrientation(sim.robot, physicsClientId=c)
        R = np.array(p.getMatrixFromQuaternion(orn)).reshape(3, 3)
        p.applyExternalForce(sim.robot, -1, (R @ f_body).tolist(), pos, p.WORLD_FRAME,
                             physicsClientId=c)


class Tether:
    """A cable from a fixed post at ``anchor_xy`` (odom) to the body: slack while the body's
    horizontal distance to the post is below ``slack_m``; beyond it the cable pulls the body
    horizontally towards the post with ``stiffness_N_per_m`` * (distance - slack), at most
    ``max_force_N``, at the base's centre of mass."""

    def __init__(self, stiffness_N_per_m: float, anchor_xy: list[float] = (0.0, 0.0),
                 slack_m: float = 0.2, max_force_N: float = 5.0) -> None:
        self.k = float(stiffness_N_per_m)
        self.anchor = _values(anchor_xy, 2, "Tether.anchor_xy")
        self.slack = float(slack_m)
        self.fmax = float(max_force_N)

    def substep(self, sim: Any, t: float) -> None:
        c = sim.client
        pos, _ = p.getBasePositionAndOrientation(sim.robot, physicsClientId=c)
        d = np.array(pos[:2]) - self.anchor
        r = float(np.hypot(*d))
        if r <= self.slack or r < 1e-9:
            return
        f = min(self.fmax, self.k * (r - self.slack))
        fx, fy = (-f * d / r).tolist()
        p.applyExternalForce(sim.robot, -1, [fx, fy, 0.0], pos, p.WORLD_FRAME,
                             physicsClientId=c)


class ServoDropout(_ServoTorque):
    """Intermittent loss of a servo's output (a loose connector, a driver resetting): at random
    times (a Poisson process of ``rate_per_s``, the move's rng) the servo of the selected joints
    gives no torque for ``duration_ms``; the rest of the time it is the normal servo."""

    def __init__(self, rate_per_s: float, duration_ms: float,
                 joints: str | list[str] | None = None, horizon_s: float = 10.0) -> None:
        super().__init__(joints)
        self.rate = float(rate_per_s)
        self.duration = float(duration_ms) / 1000.0
        self.horizon = float(horizon_s)
        self._starts = np.zeros(0)

    def reset(self, sim: Any) -> None:
        super().reset(sim)
        n = sim.rng.poisson(self.rate * self.horizon)
        self._starts = np.sort(sim.rng.uniform(0.0, self.horizon, n))

    def _off(self, t: float) -> bool:
        i = np.searchsorted(self._starts, t, side="right") - 1
        return bool(i >= 0 and t < self._starts[i] + self.duration)

    def servo(self, e: np.ndarray, dq: np.ndarray, t: float) -> np.ndarray:
        if self._off(t):
            return np.zeros_like(e)
        return np.clip(self._kp * e - self._kd * dq, -self._lim0, self._lim0)


class SlipperyFloor:
    """The floor beyond ``radius_m`` (horizontal distance from ``centre_xy`` in odom) is
    polished: a foot standing there has its friction coefficient times ``scale`` (a mat under
    the start, a smooth floor around it)."""

    def __init__(self, scale: float, radius_m: float, centre_xy: list[float] = (0.0, 0.0),
                 legs: str | list[str] = ("front_left", "front_right", "back_left",
                                          "back_right")) -> None:
        if not (np.isfinite(scale) and scale > 0):
            raise ValueError("SlipperyFloor: scale must be > 0")
        self.scale = float(scale)
        self.radius = float(radius_m)
        self.centre = _values(centre_xy, 2, "SlipperyFloor.centre_xy")
        self.legs = _legs(list(legs) if not isinstance(legs, str) else legs, "SlipperyFloor")
        self._state: dict[int, bool] = {}

    def reset(self, sim: Any) -> None:
        self._state = {}

    def substep(self, sim: Any, t: float) -> None:
        c = sim.client
        links = [sim.foot_links[i] for i in self.legs]
        states = p.getLinkStates(sim.robot, links, computeForwardKinematics=1,
                                 physicsClientId=c)
        for link, st in zip(links, states):
            out = float(np.hypot(*(np.array(st[0][:2]) - self.centre))) > self.radius
            if self._state.get(link) is not out:
                mu = sim.config.foot_friction * (self.scale if out else 1.0)
                p.changeDynamics(sim.robot, link, lateralFriction=mu, physicsClientId=c)
                self._state[link] = out
