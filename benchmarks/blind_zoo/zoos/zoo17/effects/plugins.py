"""zoo17's own effect plug-ins (docs/interface.md section 5). SEALED."""
from __future__ import annotations

from typing import Any

import numpy as np
import pybullet as p

from littledog_mlsim.layout import LEGS
from littledog_mlsim.robot.effects import resolve_joints


class TiledFloor:
    """A floor of square tiles (``tile_m``, a grid turned by ``grid_deg`` about ``origin_xy`` in
    odom) of two finishes in a checkerboard: on the tiles of odd parity a foot's friction
    coefficient is ``scale`` times the robot's (polished tiles between rough ones). Which
    friction a foot has depends on where it stands on the floor."""

    def __init__(self, scale: float, tile_m: float = 0.2, grid_deg: float = 0.0,
                 origin_xy: list[float] | tuple[float, float] = (0.0, 0.0)) -> None:
        if not (np.isfinite(scale) and scale > 0 and tile_m > 0):
            raise ValueError("TiledFloor: scale and tile_m must be > 0")
        self.scale = float(scale)
        self.tile_m = float(tile_m)
        a = np.radians(grid_deg)
        self._rot = np.array([[np.cos(a), np.sin(a)], [-np.sin(a), np.cos(a)]])  # odom -> grid
        self.origin = np.asarray(origin_xy, dtype=float).reshape(2)
        self._state: dict[int, bool] = {}

    def _odd(self, xy: np.ndarray) -> bool:
        g = self._rot @ (np.asarray(xy, dtype=float) - self.origin)
        i, j = np.floor(g / self.tile_m).astype(int)
        return bool((i + j) % 2)

    def reset(self, sim: Any) -> None:
        self._state = {}
        self._base = float(sim.config.foot_friction)
        self.substep(sim, 0.0)

    def substep(self, sim: Any, t: float) -> None:
        c = sim.client
        states = p.getLinkStates(sim.robot, list(sim.foot_links), physicsClientId=c)
        for link, st in zip(sim.foot_links, states):
            odd = self._odd(st[0][:2])
            if self._state.get(link) is odd:
                continue
            self._state[link] = odd
            p.changeDynamics(sim.robot, link,
                             lateralFriction=self._base * (self.scale if odd else 1.0),
                             physicsClientId=c)


class SetpointDropouts:
    """Set-point packets to one leg's joints are lost in bursts (a loose connector): at each
    control step a burst starts with probability ``p_start`` and lasts ``min_steps`` to
    ``max_steps`` control steps, during which the leg's servos keep the last set-point that
    arrived. Drawn from the move's generator (``sim.rng``)."""

    def __init__(self, legs: str | list[str], p_start: float = 0.03, min_steps: int = 3,
                 max_steps: int = 8) -> None:
        names = [legs] if isinstance(legs, str) else list(legs)
        for n in names:
            if n not in LEGS:
                raise ValueError(f"SetpointDropouts: unknown leg {n!r}")
        if not (0 <= p_start <= 1 and 1 <= min_steps <= max_steps):
            raise ValueError("SetpointDropouts: need 0 <= p_start <= 1, 1 <= min <= max steps")
        self.joints = resolve_joints(names)
        self.p_start = float(p_start)
        self.min_steps, self.max_steps = int(min_steps), int(max_steps)
        self._held: np.ndarray | None = None
        self._left = 0
        self._rng = np.random.default_rng(0)

    def reset(self, sim: Any) -> None:
        self._held = None
        self._left = 0
        self._rng = sim.rng

    def command(self, u: np.ndarray, t: float) -> np.ndarray:
        if self._held is None:
            self._held = u.copy()
            return u
        if self._left == 0 and self._rng.random() < self.p_start:
            self._left = int(self._rng.integers(self.min_steps, self.max_steps + 1))
        out = u.copy()
        if self._left > 0:
            self._left -= 1
            out[self.joints] = self._held[self.joints]
        else:
            self._held = u.copy()
        return out


class ParallelSpring:
    """A passive torsion spring across some joints (a stiff cable bundle or a rubber boot):
    torque -``stiffness_Nm_per_rad`` (q - ``rest_rad``) added to the servo's every physics
    step."""

    def __init__(self, stiffness_Nm_per_rad: float, rest_rad: float,
                 joints: str | list[str] | None = None) -> None:
        if not (np.isfinite(stiffness_Nm_per_rad) and stiffness_Nm_per_rad >= 0):
            raise ValueError("ParallelSpring: stiffness must be >= 0")
        self.k = float(stiffness_Nm_per_rad)
        self.rest = float(rest_rad)
        self.joints = resolve_joints(joints)

    def reset(self, sim: Any) -> None:
        self._ids = [sim.joint_indices[j] for j in self.joints]

    def substep(self, sim: Any, t: float) -> None:
        states = p.getJointStates(sim.robot, self._ids, physicsClientId=sim.client)
        q = np.array([s[0] for s in states])
        p.setJointMotorControlArray(sim.robot, self._ids, p.TORQUE_CONTROL,
                                    forces=(-self.k * (q - self.rest)).tolist(),
                                    physicsClientId=sim.client)
