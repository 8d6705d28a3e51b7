"""zoo64's own effect plug-ins (docs/interface.md section 5), for effects no built-in provides.

- :class:`SoftFloor`: the floor is compliant (a foam or rubber mat over the whole area): the
  ground's contact stiffness and damping set to ``stiffness_N_m`` and ``damping_N_s_m``.
- :class:`HipCoupling`: the hip's roll drive follows part of the hip pitch's travel (a hip
  differential whose decoupling coefficient is set wrong): each hip roll's set-point, as its
  servo receives it, is moved by ``coupling`` x (its leg's hip pitch set-point - that set-point
  at home), mirrored between the left and the right legs. The encoders read the true angles.
- :class:`ServoDropout`: a loose connector on some joints' motors: at random moments (gaps
  drawn from an exponential law of mean ``mean_interval_s``, from the move's own random
  generator) the motor gets no current for ``duration_ms`` (uniform in [lo, hi]), so the
  servo gives no torque; the rest of the time it is the normal servo.
"""
from __future__ import annotations

from typing import Any

import numpy as np
import pybullet as p

from littledog_mlsim.layout import HOME_POSE, JOINT_NAMES, N_JOINTS
from littledog_mlsim.robot.effects import _ServoTorque, resolve_joints


class SoftFloor:
    """The ground's contact made compliant: stiffness [N/m] and damping [N s/m] per contact."""

    def __init__(self, stiffness_N_m: float, damping_N_s_m: float) -> None:
        if not (np.isfinite(stiffness_N_m) and stiffness_N_m > 0):
            raise ValueError(f"SoftFloor: stiffness_N_m must be > 0, got {stiffness_N_m!r}")
        if not (np.isfinite(damping_N_s_m) and damping_N_s_m >= 0):
            raise ValueError(f"SoftFloor: damping_N_s_m must be >= 0, got {damping_N_s_m!r}")
        self.stiffness = float(stiffness_N_m)
        self.damping = float(damping_N_s_m)

    def reset(self, sim: Any) -> None:
        p.changeDynamics(sim.plane, -1, contactStiffness=self.stiffness,
                         contactDamping=self.damping, physicsClientId=sim.client)


class HipCoupling:
    """Hip roll set-point += sign x ``coupling`` x (hip pitch set-point - its home value); sign
    +1 on the left legs, -1 on the right ones."""

    changes_world = False     # it alters commands only

    def __init__(self, coupling: float) -> None:
        if not np.isfinite(coupling):
            raise ValueError(f"HipCoupling: coupling must be finite, got {coupling!r}")
        self.coupling = float(coupling)
        self.roll = np.array([i for i, n in enumerate(JOINT_NAMES) if n.endswith("_hip_roll")])
        self.pitch = self.roll + 1
        self.sign = np.array([1.0 if "_left_" in JOINT_NAMES[i] else -1.0 for i in self.roll])

    def command(self, u: np.ndarray, t: float) -> np.ndarray:
        out = u.copy()
        out[self.roll] += self.sign * self.coupling * (u[self.pitch] - HOME_POSE[self.pitch])
        return out


class ServoDropout(_ServoTorque):
    """The servo of some joints gives no torque during random dropouts (see module doc)."""

    def __init__(self, mean_interval_s: float, duration_ms: list[float] | tuple[float, float],
                 joints: str | list[str] | None = None) -> None:
        if not (np.isfinite(mean_interval_s) and mean_interval_s > 0):
            raise ValueError(f"ServoDropout: mean_interval_s must be > 0, got {mean_interval_s!r}")
        lo, hi = (float(x) for x in duration_ms)
        if not (0 < lo <= hi):
            raise ValueError(f"ServoDropout: duration_ms must be [lo, hi], 0 < lo <= hi")
        super().__init__(joints)
        self.mean_interval_s = float(mean_interval_s)
        self.duration_s = (lo / 1000.0, hi / 1000.0)
        self._windows = np.zeros((0, 2))

    def reset(self, sim: Any) -> None:
        super().reset(sim)
        rng = sim.rng
        windows, t = [], 0.0
        while t < 120.0:        # far beyond any move (a warm-up included)
            t += rng.exponential(self.mean_interval_s)
            d = rng.uniform(*self.duration_s)
            windows.append((t, t + d))
            t += d
        self._windows = np.array(windows)

    def _off(self, t: float) -> bool:
        k = int(np.searchsorted(self._windows[:, 0], t, side="right")) - 1
        return k >= 0 and t < self._windows[k, 1]

    def servo(self, e: np.ndarray, dq: np.ndarray, t: float) -> np.ndarray:
        if self._off(t):
            return np.zeros_like(e)
        return np.clip(self._kp * e - self._kd * dq, -self._lim0, self._lim0)

    def substep(self, sim: Any, t: float) -> None:
        if self._off(t):
            super().substep(sim, t)


__all__ = ["SoftFloor", "HipCoupling", "ServoDropout"]
