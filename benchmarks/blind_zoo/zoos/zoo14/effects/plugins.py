"""zoo14's own effect plug-ins (docs/interface.md section 5); sealed with the truth."""
from __future__ import annotations

from collections import deque
from typing import Any

import numpy as np

from littledog_mlsim.robot.effects import resolve_joints

_BODY_KEYS = ("position", "orientation", "linear_velocity", "angular_velocity")


class MocapLatency:
    """The motion-capture stream (pose and the twist derived from it) reaches the recorder
    ``latency_ms`` later than the joint encoders (a whole number of 10 ms control steps): every
    recorded body measurement is the one of ``latency_ms`` before. Before that much history
    exists, the first body measurement of the move is repeated."""

    def __init__(self, latency_ms: float) -> None:
        steps = float(latency_ms) / 10.0
        if not (np.isfinite(steps) and steps >= 0 and abs(steps - round(steps)) < 1e-9):
            raise ValueError(f"MocapLatency: latency_ms must be a non-negative multiple of 10, "
                             f"got {latency_ms!r}")
        self.steps = int(round(steps))
        self._buf: deque[dict[str, np.ndarray]] = deque()

    def reset(self, sim: Any) -> None:
        self._buf.clear()

    def measure(self, obs: dict, t: float) -> dict:
        body = {k: np.array(obs[k], dtype=float, copy=True) for k in _BODY_KEYS}
        if not self._buf:
            self._buf.extend({k: v.copy() for k, v in body.items()} for _ in range(self.steps))
        self._buf.append(body)
        old = self._buf.popleft()
        out = dict(obs)
        out.update(old)
        return out


class BurstyCommandLoss:
    """Set-point packets of some joints lost in bursts (a loose connector on one board): a
    two-state (Gilbert) channel per control step; in the good state a burst starts with
    probability ``p_start``, in the bad state it ends with probability ``p_end``; while in the
    bad state the selected joints' servos keep the last set-point they received. The
    long-run fraction of lost packets is p_start / (p_start + p_end). Drawn from the move's
    generator (``sim.rng``)."""

    def __init__(self, p_start: float, p_end: float, joints: str | list[str] | None = None) -> None:
        if not (0.0 <= p_start <= 1.0 and 0.0 < p_end <= 1.0):
            raise ValueError("BurstyCommandLoss: need 0 <= p_start <= 1 and 0 < p_end <= 1")
        self.p_start = float(p_start)
        self.p_end = float(p_end)
        self.joints = resolve_joints(joints)
        self._rng: np.random.Generator | None = None
        self._held: np.ndarray | None = None
        self._bad = False

    @property
    def lost_fraction(self) -> float:
        return self.p_start / (self.p_start + self.p_end)

    def reset(self, sim: Any) -> None:
        self._rng = sim.rng
        self._held = None
        self._bad = False

    def command(self, u: np.ndarray, t: float) -> np.ndarray:
        if self._held is None:               # the first packet of the move arrives
            self._held = u.copy()
            return u
        r = float(self._rng.random()) if self._rng is not None else 1.0
        self._bad = (r >= self.p_end) if self._bad else (r < self.p_start)
        if not self._bad:
            self._held = u.copy()
            return u
        out = u.copy()
        out[self.joints] = self._held[self.joints]
        return out
