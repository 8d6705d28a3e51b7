"""Effect plug-ins of the sixth blind zoo (sealed: this file is part of the truth).

Written from the plug-in protocol alone (``docs/interface.md`` §5: hooks ``reset``, ``command``,
``substep``, ``measure``) and pybullet calls. Each class is one undeclared physical effect.

Joint-level torques are applied as an internal torque pair about the joint axis (on the child
link and, reversed, on its parent) with ``applyExternalTorque`` in the world frame, because the
robot's servo owns the joint motor (torque mode). pybullet clears external forces after every
physics step, so ``substep`` re-applies them each step.

Servo-level effects (gain, torque limit, play, gain drift) add the difference between the
torque the changed servo would give and the torque the normal servo gives,
``tau = clip(kp (u - q) - kd dq, -tau_max, tau_max)`` (robot configuration), both evaluated on
the same joint state, so the normal servo plus the correction equals the changed servo.
"""
from __future__ import annotations

from typing import Any, Iterable

import numpy as np
import pybullet as p

LEGS = ("front_left", "front_right", "back_left", "back_right")
KINDS = ("hip_roll", "hip_pitch", "knee")
NAMES = tuple(f"{leg}_{k}" for leg in LEGS for k in KINDS)
GROUPS = {
    "all": list(range(12)),
    "hip_rolls": [i for i, n in enumerate(NAMES) if n.endswith("hip_roll")],
    "hip_pitches": [i for i, n in enumerate(NAMES) if n.endswith("hip_pitch")],
    "knees": [i for i, n in enumerate(NAMES) if n.endswith("knee")],
    "left": [i for i, n in enumerate(NAMES) if "_left_" in n],
    "right": [i for i, n in enumerate(NAMES) if "_right_" in n],
}
for _leg in LEGS:
    GROUPS[_leg] = [i for i, n in enumerate(NAMES) if n.startswith(_leg + "_")]
GRAVITY = 9.81


def select(joints: str | Iterable[str]) -> np.ndarray:
    """Indices (contract order) of a group, leg or joint name, or of a list of them."""
    names = [joints] if isinstance(joints, str) else list(joints)
    out: list[int] = []
    for n in names:
        if n in GROUPS:
            out += GROUPS[n]
        elif n in NAMES:
            out.append(NAMES.index(n))
        else:
            raise ValueError(f"zoo6 effect: unknown joint or group {n!r}")
    return np.array(sorted(set(out)), dtype=int)


def _per_joint(triple: Any) -> np.ndarray:
    return np.tile(np.broadcast_to(np.asarray(triple, dtype=float), (3,)), 4)


def _quat_axis_angle(axis: np.ndarray, angle: float) -> list[float]:
    a = np.asarray(axis, float) / np.linalg.norm(axis)
    s = np.sin(angle / 2.0)
    return [a[0] * s, a[1] * s, a[2] * s, np.cos(angle / 2.0)]


class _JointTorques:
    """Shared machinery: joint state and internal torque pairs about joint axes."""

    def _attach(self, sim: Any) -> None:
        self.sim = sim
        self.c = sim.client
        self.body = sim.robot
        self.jidx = list(sim.joint_indices)
        info = [p.getJointInfo(self.body, j, physicsClientId=self.c) for j in self.jidx]
        self.axis_local = [np.asarray(i[13], float) for i in info]
        self.parent = [int(i[16]) for i in info]
        cfg = sim.config
        self.kp = _per_joint(cfg.kp)
        self.kd = _per_joint(cfg.kd)
        self.tau_max = _per_joint(cfg.torque_limit)

    def _state(self) -> tuple[np.ndarray, np.ndarray]:
        st = p.getJointStates(self.body, self.jidx, physicsClientId=self.c)
        return np.array([s[0] for s in st]), np.array([s[1] for s in st])

    def _apply(self, idx: np.ndarray, tau: np.ndarray) -> None:
        for i, t in zip(idx, tau):
            if t == 0.0:
                continue
            j = self.jidx[i]
            orn = p.getLinkState(self.body, j, physicsClientId=self.c)[5]
            R = np.array(p.getMatrixFromQuaternion(orn)).reshape(3, 3)
            axis = R @ self.axis_local[i]
            v = (t * axis).tolist()
            p.applyExternalTorque(self.body, j, v, p.WORLD_FRAME, physicsClientId=self.c)
            p.applyExternalTorque(self.body, self.parent[i], [-x for x in v], p.WORLD_FRAME,
                                  physicsClientId=self.c)


class _ServoChange(_JointTorques):
    """Base of effects that change the servo law on some joints."""

    def __init__(self, joints: str | list[str] = "all") -> None:
        self.idx = select(joints)
        self.u = None

    def reset(self, sim: Any) -> None:
        self._attach(sim)
        self.u = None

    def command(self, u: np.ndarray, t: float) -> np.ndarray:
        self.u = np.clip(np.asarray(u, float), -np.pi, np.pi)
        return u

    def changed(self, e: np.ndarray, dq: np.ndarray, t: float) -> np.ndarray:
        raise NotImplementedError

    def substep(self, sim: Any, t: float) -> None:
        if self.u is None:
            return
        q, dq = self._state()
        i = self.idx
        e = self.u[i] - q[i]
        normal = np.clip(self.kp[i] * e - self.kd[i] * dq[i], -self.tau_max[i], self.tau_max[i])
        self._apply(i, self.changed(e, dq[i], t) - normal)


class ServoGainScale(_ServoChange):
    """Servo stiffness k scaled by ``ratio`` on the chosen joints (damping and limit unchanged)."""

    def __init__(self, ratio: float, joints: str | list[str] = "all") -> None:
        super().__init__(joints)
        self.ratio = float(ratio)

    def changed(self, e, dq, t):
        i = self.idx
        return np.clip(self.ratio * self.kp[i] * e - self.kd[i] * dq, -self.tau_max[i],
                       self.tau_max[i])


class GainDrift(_ServoChange):
    """Servo stiffness falling linearly with time since the move's start (supply sagging):
    k(t) = k (1 + rate t), floored at 10 % of k."""

    def __init__(self, rate: float, joints: str | list[str] = "all") -> None:
        super().__init__(joints)
        self.rate = float(rate)

    def changed(self, e, dq, t):
        i = self.idx
        r = max(0.1, 1.0 + self.rate * float(t))
        return np.clip(r * self.kp[i] * e - self.kd[i] * dq, -self.tau_max[i], self.tau_max[i])


class LowerTorqueLimit(_ServoChange):
    """The servo's torque clipped at ``limit`` N m instead of its normal limit."""

    def __init__(self, limit: float, joints: str | list[str] = "all") -> None:
        super().__init__(joints)
        self.limit = float(limit)

    def changed(self, e, dq, t):
        i = self.idx
        lim = np.minimum(self.limit, self.tau_max[i])
        return np.clip(self.kp[i] * e - self.kd[i] * dq, -lim, lim)


class GearPlay(_ServoChange):
    """Play of total ``width`` rad in the gear train: the output is not pushed by the spring
    part of the servo while it is within +-width/2 of the motor's position (motor assumed to
    sit at the set-point); damping stays."""

    def __init__(self, width: float, joints: str | list[str] = "all") -> None:
        super().__init__(joints)
        self.half = 0.5 * float(width)

    def changed(self, e, dq, t):
        i = self.idx
        dz = np.sign(e) * np.maximum(np.abs(e) - self.half, 0.0)
        return np.clip(self.kp[i] * dz - self.kd[i] * dq, -self.tau_max[i], self.tau_max[i])


class CoulombJointFriction(_JointTorques):
    """Dry friction torque ``coulomb`` N m opposing the joint rate (tanh-smoothed over
    ``v_smooth`` rad/s)."""

    def __init__(self, coulomb: float, joints: str | list[str] = "all",
                 v_smooth: float = 0.05) -> None:
        self.idx = select(joints)
        self.coulomb = float(coulomb)
        self.v_smooth = float(v_smooth)

    def reset(self, sim: Any) -> None:
        self._attach(sim)

    def substep(self, sim: Any, t: float) -> None:
        _, dq = self._state()
        self._apply(self.idx, -self.coulomb * np.tanh(dq[self.idx] / self.v_smooth))


class LateCommands:
    """Set-points reach the servos ``delay_steps`` control steps late (a FIFO)."""

    def __init__(self, delay_steps: int) -> None:
        self.n = int(delay_steps)
        self.buf: list[np.ndarray] = []

    def reset(self, sim: Any) -> None:
        self.buf = []

    def command(self, u: np.ndarray, t: float) -> np.ndarray:
        u = np.asarray(u, float).copy()
        if not self.buf:
            self.buf = [u.copy() for _ in range(self.n)]
        self.buf.append(u)
        return self.buf.pop(0)


class MiscalibratedEncoder:
    """One joint's encoder reads ``offset`` rad more than the true angle. The servo closes its
    loop on that encoder, so it holds the true angle ``offset`` short of the set-point, and the
    reported angle is the true angle plus ``offset``."""

    def __init__(self, offset: float, joints: str | list[str]) -> None:
        self.idx = select(joints)
        self.offset = float(offset)

    def command(self, u: np.ndarray, t: float) -> np.ndarray:
        u = np.asarray(u, float).copy()
        u[self.idx] -= self.offset
        return u

    def measure(self, obs: dict, t: float) -> dict:
        q = np.asarray(obs["q"], float).copy()
        q[self.idx] += self.offset
        obs["q"] = q
        return obs


class WorldPush:
    """A constant horizontal force of ``force`` N fixed in the world, towards ``direction_deg``
    (from +x towards +y), through the body's centre of mass."""

    def __init__(self, force: float, direction_deg: float) -> None:
        a = np.radians(direction_deg)
        self.f = [force * np.cos(a), force * np.sin(a), 0.0]

    def substep(self, sim: Any, t: float) -> None:
        pos, _ = p.getBasePositionAndOrientation(sim.robot, physicsClientId=sim.client)
        p.applyExternalForce(sim.robot, -1, self.f, pos, p.WORLD_FRAME, physicsClientId=sim.client)


class TiltedFloor:
    """The floor inclined by ``slope_deg`` (gravity stays along -z), rising towards
    ``uphill_deg`` in the world. Floor and robot are rotated together about the world origin
    at reset, so the robot starts standing on the inclined floor."""

    def __init__(self, slope_deg: float, uphill_deg: float) -> None:
        d = np.radians(uphill_deg)
        self.axis = np.array([np.sin(d), -np.cos(d), 0.0])
        self.angle = np.radians(slope_deg)
        self.plane0 = None

    def reset(self, sim: Any) -> None:
        c = sim.client
        if self.plane0 is None:
            self.plane0 = p.getBasePositionAndOrientation(sim.plane, physicsClientId=c)
        q = _quat_axis_angle(self.axis, self.angle)
        R = np.array(p.getMatrixFromQuaternion(q)).reshape(3, 3)
        pos0, orn0 = self.plane0
        _, orn = p.multiplyTransforms([0, 0, 0], q, [0, 0, 0], orn0)
        p.resetBasePositionAndOrientation(sim.plane, (R @ np.asarray(pos0)).tolist(), orn,
                                          physicsClientId=c)
        bpos, born = p.getBasePositionAndOrientation(sim.robot, physicsClientId=c)
        v, w = p.getBaseVelocity(sim.robot, physicsClientId=c)
        _, born2 = p.multiplyTransforms([0, 0, 0], q, [0, 0, 0], born)
        p.resetBasePositionAndOrientation(sim.robot, (R @ np.asarray(bpos)).tolist(), born2,
                                          physicsClientId=c)
        p.resetBaseVelocity(sim.robot, (R @ np.asarray(v)).tolist(), (R @ np.asarray(w)).tolist(),
                            physicsClientId=c)


class CarriedLoad:
    """A load of ``mass`` kg rigidly carried at ``offset`` (base_link, from the body's centre
    of mass): the body's mass and inertia grow (parallel axis, diagonal part) and the load's
    weight acts at the offset (its moment about the body's centre of mass)."""

    def __init__(self, mass: float, offset: list[float]) -> None:
        self.m = float(mass)
        self.r = np.asarray(offset, float)
        self.orig = None

    def reset(self, sim: Any) -> None:
        c = sim.client
        if self.orig is None:
            d = p.getDynamicsInfo(sim.robot, -1, physicsClientId=c)
            self.orig = (float(d[0]), np.asarray(d[2], float))
        m0, I0 = self.orig
        r = self.r
        add = self.m * (np.dot(r, r) - r * r)
        p.changeDynamics(sim.robot, -1, mass=m0 + self.m, localInertiaDiagonal=(I0 + add).tolist(),
                         physicsClientId=c)

    def substep(self, sim: Any, t: float) -> None:
        c = sim.client
        pos, orn = p.getBasePositionAndOrientation(sim.robot, physicsClientId=c)
        R = np.array(p.getMatrixFromQuaternion(orn)).reshape(3, 3)
        tau = np.cross(R @ self.r, [0.0, 0.0, -self.m * GRAVITY])
        p.applyExternalTorque(sim.robot, -1, tau.tolist(), p.WORLD_FRAME, physicsClientId=c)


class SlipperyFoot:
    """One leg's foot with ``scale`` times its normal friction coefficient (worn pad)."""

    def __init__(self, scale: float, leg: str) -> None:
        self.scale = float(scale)
        self.k = LEGS.index(leg)
        self.orig = None

    def reset(self, sim: Any) -> None:
        link = sim.foot_links[self.k]
        if self.orig is None:
            self.orig = float(p.getDynamicsInfo(sim.robot, link, physicsClientId=sim.client)[1])
        p.changeDynamics(sim.robot, link, lateralFriction=self.orig * self.scale,
                         physicsClientId=sim.client)


class SwingDrag:
    """While one leg's foot is off the ground, a horizontal force of ``force`` N opposes its
    horizontal velocity (foot dragging through tall grass); it fades in below ``v_smooth`` m/s.
    Nothing acts while the foot touches the floor."""

    def __init__(self, force: float, leg: str, v_smooth: float = 0.05) -> None:
        self.force = float(force)
        self.k = LEGS.index(leg)
        self.v_smooth = float(v_smooth)

    def substep(self, sim: Any, t: float) -> None:
        c = sim.client
        link = sim.foot_links[self.k]
        if p.getContactPoints(sim.robot, sim.plane, linkIndexA=link, physicsClientId=c):
            return
        st = p.getLinkState(sim.robot, link, computeLinkVelocity=1, physicsClientId=c)
        v = np.array([st[6][0], st[6][1], 0.0])
        s = np.linalg.norm(v)
        if s < 1e-6:
            return
        f = -self.force * v / max(s, self.v_smooth)
        p.applyExternalForce(sim.robot, link, f.tolist(), st[0], p.WORLD_FRAME,
                             physicsClientId=c)
