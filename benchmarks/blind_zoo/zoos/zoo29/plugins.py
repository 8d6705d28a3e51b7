"""Effect plug-ins of the twenty-ninth blind zoo (sealed with truth.yaml).

Hooks as in docs/interface.md section 5 / littledog_mlsim/robot/effects.py.
"""
from __future__ import annotations

from typing import Any

import numpy as np
import pybullet as p

from littledog_mlsim.layout import CONTROL_DT
from littledog_mlsim.robot.sensors import twist_from_poses


class ScatteredSlabs:
    """Uneven floor: flat slabs (floor tiles, mats, cable covers) lying at fixed places in the
    world, ``height_m`` thick (60-100 % of it), scattered over an annulus around the start point
    (centres within ``outer_radius_m``). The same layout for every move (``layout_seed``); no
    slab reaches within ``clear_radius_m`` of the start point (the start stance is free)."""

    def __init__(self, height_m: float = 0.01, n: int = 70, clear_radius_m: float = 0.24,
                 outer_radius_m: float = 1.0, size_m: tuple[float, float] = (0.05, 0.12),
                 layout_seed: int = 2929) -> None:
        rng = np.random.default_rng(layout_seed)
        slabs = []
        while len(slabs) < n:
            xy = rng.uniform(-outer_radius_m, outer_radius_m, 2)
            r = float(np.hypot(*xy))
            half = rng.uniform(size_m[0], size_m[1], 2) / 2
            if r - float(np.hypot(*half)) < clear_radius_m or r > outer_radius_m:
                continue
            h = height_m * rng.uniform(0.6, 1.0)
            yaw = rng.uniform(0, np.pi)
            slabs.append((xy, half, h, yaw))
        self.slabs = slabs

    def reset(self, sim: Any) -> None:
        c = sim.client
        for xy, half, h, yaw in self.slabs:
            shape = p.createCollisionShape(p.GEOM_BOX, halfExtents=[half[0], half[1], h / 2],
                                           physicsClientId=c)
            body = p.createMultiBody(0, shape, basePosition=[xy[0], xy[1], h / 2],
                                     baseOrientation=p.getQuaternionFromEuler([0, 0, yaw]),
                                     physicsClientId=c)
            p.changeDynamics(body, -1, lateralFriction=sim.config.ground_friction,
                             physicsClientId=c)


class MocapFrameDrops:
    """The motion-capture stream loses frames (occluded markers, radio packet loss): with
    probability ``drop_prob`` a frame, and with ``p_continue`` each following one, repeats the
    last pose received; the twist is the finite difference of the poses as published (zero
    over a repeated frame, the whole jump at the next good one). Joint encoders are unaffected."""

    def __init__(self, drop_prob: float = 0.15, p_continue: float = 0.5) -> None:
        self.drop_prob = float(drop_prob)
        self.p_continue = float(p_continue)
        self._rng = np.random.default_rng(0)
        self._last: tuple[np.ndarray, np.ndarray] | None = None
        self._dropping = False

    def reset(self, sim: Any) -> None:
        self._rng = np.random.default_rng(sim.rng.integers(2**32))
        self._last = None
        self._dropping = False

    def measure(self, obs: dict, t: float) -> dict:
        pos, orn = np.asarray(obs["position"]), np.asarray(obs["orientation"])
        if self._last is None:                      # t = 0: the first frame is received
            self._last = (pos.copy(), orn.copy())
            return obs
        self._dropping = self._rng.random() < (self.p_continue if self._dropping
                                               else self.drop_prob)
        prev_pos, prev_orn = self._last
        if self._dropping:
            new_pos, new_orn = prev_pos.copy(), prev_orn.copy()
        else:
            new_pos, new_orn = pos.copy(), orn.copy()
        lin, ang = twist_from_poses(prev_pos, prev_orn, new_pos, new_orn, CONTROL_DT)
        self._last = (new_pos, new_orn)
        obs = dict(obs)
        obs["position"], obs["orientation"] = new_pos, new_orn
        obs["linear_velocity"], obs["angular_velocity"] = np.asarray(lin), np.asarray(ang)
        return obs


class Tether:
    """A tether (power/data cable) from a fixed anchor on the floor to a point at the back of
    the body: slack within ``slack_m`` of the anchor (horizontal distance), beyond it a
    horizontal pull towards the anchor of ``stiffness_N_per_m`` per metre of stretch, capped at
    ``max_force_N``."""

    def __init__(self, anchor_xy: tuple[float, float] = (-0.2, 0.0), slack_m: float = 0.25,
                 stiffness_N_per_m: float = 8.0, max_force_N: float = 4.0,
                 attach_b: tuple[float, float, float] = (-0.1, 0.0, 0.03)) -> None:
        self.anchor = np.asarray(anchor_xy, dtype=float)
        self.slack = float(slack_m)
        self.k = float(stiffness_N_per_m)
        self.fmax = float(max_force_N)
        self.attach = np.asarray(attach_b, dtype=float)

    def substep(self, sim: Any, t: float) -> None:
        c = sim.client
        pos, orn = p.getBasePositionAndOrientation(sim.robot, physicsClientId=c)
        R = np.array(p.getMatrixFromQuaternion(orn)).reshape(3, 3)
        at = np.asarray(pos) + R @ self.attach
        d = self.anchor - at[:2]
        dist = float(np.hypot(*d))
        stretch = dist - self.slack
        if stretch <= 0 or dist < 1e-9:
            return
        f = min(self.fmax, self.k * stretch) * d / dist
        p.applyExternalForce(sim.robot, -1, [float(f[0]), float(f[1]), 0.0], at.tolist(),
                             p.WORLD_FRAME, physicsClientId=c)
