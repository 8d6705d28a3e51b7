"""Effect plug-ins of the ninth blind zoo that the stock ``robot/effects.py`` does not offer
(docs/interface.md section 5: any of reset / command / substep / measure)."""
from __future__ import annotations

from typing import Any

import numpy as np
import pybullet as p

from littledog_mlsim.layout import HOME_POSE, LEGS
from littledog_mlsim.robot.effects import _ServoTorque, resolve_joints


class CableTether:
    """A power/data cable from an anchor fixed on the lab floor (odom ``anchor_xy``) to a point
    on the body (``attach`` in base_link). The cable lies on the floor: it pulls the body
    horizontally towards the anchor with its dragged weight ``drag_N``, plus an elastic pull
    ``stiffness_N_m`` * (distance - ``slack_m``) once the slack is taken up, capped at
    ``max_N`` in all."""

    def __init__(self, anchor_xy=(-0.8, 0.35), attach=(-0.1, 0.0, 0.03), drag_N: float = 0.35,
                 slack_m: float = 0.9, stiffness_N_m: float = 4.0, max_N: float = 2.5) -> None:
        self.anchor = np.asarray(anchor_xy, dtype=float).reshape(2)
        self.attach = [float(x) for x in attach]
        self.drag_N = float(drag_N)
        self.slack_m = float(slack_m)
        self.stiffness = float(stiffness_N_m)
        self.max_N = float(max_N)

    def substep(self, sim: Any, t: float) -> None:
        c = sim.client
        pos, orn = p.getBasePositionAndOrientation(sim.robot, physicsClientId=c)
        point, _ = p.multiplyTransforms(pos, orn, self.attach, [0, 0, 0, 1])
        d = self.anchor - np.array(point[:2])
        dist = float(np.hypot(*d))
        if dist < 1e-6:
            return
        mag = min(self.max_N, self.drag_N + self.stiffness * max(0.0, dist - self.slack_m))
        f = mag * d / dist
        p.applyExternalForce(sim.robot, -1, [float(f[0]), float(f[1]), 0.0], point,
                             p.WORLD_FRAME, physicsClientId=c)


class TiledFloor:
    """A lab floor of square tiles (``tile_m``) of two materials in a checkerboard: on the
    tiles of the second kind a foot's friction coefficient is ``scale`` times its normal one.
    The tiles' grid is offset by ``origin_xy`` (odom)."""

    def __init__(self, scale: float = 0.45, tile_m: float = 0.3,
                 origin_xy=(-0.08, 0.13)) -> None:
        self.scale = float(scale)
        self.tile = float(tile_m)
        self.origin = np.asarray(origin_xy, dtype=float).reshape(2)
        self._state: list[bool | None] = [None] * len(LEGS)

    def reset(self, sim: Any) -> None:
        self._state = [None] * len(LEGS)

    def substep(self, sim: Any, t: float) -> None:
        c = sim.client
        states = p.getLinkStates(sim.robot, sim.foot_links, computeForwardKinematics=1,
                                 physicsClientId=c)
        for i, (link, st) in enumerate(zip(sim.foot_links, states)):
            ij = np.floor((np.array(st[0][:2]) - self.origin) / self.tile).astype(int)
            slippery = bool((ij[0] + ij[1]) % 2)
            if slippery != self._state[i]:
                mu = sim.config.foot_friction * (self.scale if slippery else 1.0)
                p.changeDynamics(sim.robot, link, lateralFriction=mu, physicsClientId=c)
                self._state[i] = slippery


class ThermalFade(_ServoTorque):
    """Motor heating of some joints' servos: a first-order thermal state h rises with the
    squared servo torque (``heat_per_Nm2s`` per (N m)^2 s) and cools with ``cool_time_s``;
    the hot winding and magnets deliver the servo's torque times (1 - h), h <= ``max_fade``.
    Starts cold at every move."""

    def __init__(self, heat_per_Nm2s: float = 0.9, cool_time_s: float = 6.0,
                 max_fade: float = 0.5, joints=None) -> None:
        super().__init__(joints)
        self.heat = float(heat_per_Nm2s)
        self.cool = float(cool_time_s)
        self.max_fade = float(max_fade)
        self._h = None
        self._dt = 0.002

    def reset(self, sim: Any) -> None:
        super().reset(sim)
        self._h = np.zeros(len(self.joints))
        self._dt = sim.physics_dt

    def servo(self, e: np.ndarray, dq: np.ndarray, t: float) -> np.ndarray:
        tau = np.clip(self._kp * e - self._kd * dq, -self._lim0, self._lim0)
        self._h = np.minimum(self.max_fade, self._h + self._dt * (
            self.heat * tau ** 2 - self._h / self.cool))
        return (1.0 - self._h) * tau


class HarnessSpring:
    """A stiff cable harness routed across the joints of some joints: a torsional spring
    -``stiffness_Nm_rad`` * (q - rest) with rest = home pose + ``rest_offset_rad`` (one value
    or one per selected joint), plus a little viscous drag ``damping_Nms`` on the joint rate."""

    def __init__(self, stiffness_Nm_rad=0.5, rest_offset_rad=0.35, damping_Nms: float = 0.0,
                 joints="front_right") -> None:
        self.joints = resolve_joints(joints)
        n = len(self.joints)
        self.k = np.broadcast_to(np.asarray(stiffness_Nm_rad, dtype=float), (n,)).copy()
        self.rest = HOME_POSE[self.joints] + np.broadcast_to(
            np.asarray(rest_offset_rad, dtype=float), (n,))
        self.b = float(damping_Nms)

    def reset(self, sim: Any) -> None:
        self._ids = [sim.joint_indices[j] for j in self.joints]

    def substep(self, sim: Any, t: float) -> None:
        states = p.getJointStates(sim.robot, self._ids, physicsClientId=sim.client)
        q = np.array([s[0] for s in states])
        dq = np.array([s[1] for s in states])
        tau = -self.k * (q - self.rest) - self.b * dq
        p.setJointMotorControlArray(sim.robot, self._ids, p.TORQUE_CONTROL, forces=tau.tolist(),
                                    physicsClientId=sim.client)
