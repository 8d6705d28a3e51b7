"""zoo12's effect plug-ins (docs/interface.md section 5): reset / command / substep / measure.

Written for zoo12 by its author; each class is a fault a lab meets on a real quadruped. The
hooks follow robot/effects.py's protocol; joints are addressed as there (names, legs, groups).
Which effect file uses which class, with which parameters, is sealed in ../truth.yaml.
"""
from __future__ import annotations

from collections import deque
from typing import Any

import numpy as np
import pybullet as p

from littledog_mlsim.layout import JOINT_LOWER, JOINT_UPPER, LEGS, N_JOINTS
from littledog_mlsim.robot.config import per_joint
from littledog_mlsim.robot.effects import resolve_joints


def _leg_ids(legs: str | list[str]) -> list[int]:
    names = [legs] if isinstance(legs, str) else list(legs)
    for n in names:
        if n not in LEGS:
            raise ValueError(f"unknown leg {n!r}")
    return [LEGS.index(n) for n in names]


class NullEffect:
    """Every hook, no change (the control plug-in)."""

    def reset(self, sim: Any) -> None:
        pass

    def command(self, u: np.ndarray, t: float) -> np.ndarray:
        return u

    def substep(self, sim: Any, t: float) -> None:
        pass

    def measure(self, obs: dict, t: float) -> dict:
        return obs


class LateBoard:
    """The set-points of some joints reach their servos ``steps`` whole control steps late (a
    motor-controller board on a slower bus segment); before that many have arrived the first
    command is held."""

    def __init__(self, steps: int, joints: str | list[str] | None = None) -> None:
        self.steps = int(steps)
        self.joints = resolve_joints(joints)
        self._h: deque = deque()

    def reset(self, sim: Any) -> None:
        self._h.clear()

    def command(self, u: np.ndarray, t: float) -> np.ndarray:
        if not self._h:
            self._h.extend(u.copy() for _ in range(self.steps))
        self._h.append(u.copy())
        late = self._h.popleft()
        out = u.copy()
        out[self.joints] = late[self.joints]
        return out


class _PDChange:
    """A change of the PD servo of some joints, added as joint torque on every physics step:
    (changed servo's torque) - (the robot's normal servo torque), both from the true joint
    state and the set-point as the servo receives it, each within its torque limit."""

    def __init__(self, joints: str | list[str] | None) -> None:
        self.joints = resolve_joints(joints)
        self._q_des = None

    def reset(self, sim: Any) -> None:
        cfg = sim.config
        self._ids = [sim.joint_indices[j] for j in self.joints]
        self._kp = per_joint(cfg.kp)[self.joints]
        self._kd = per_joint(cfg.kd)[self.joints]
        self._lim = per_joint(cfg.torque_limit)[self.joints]
        self._q_des = None

    def command(self, u: np.ndarray, t: float) -> np.ndarray:
        self._q_des = np.clip(u, JOINT_LOWER, JOINT_UPPER)[self.joints]
        return u

    def changed(self, e: np.ndarray, dq: np.ndarray, t: float) -> np.ndarray:
        raise NotImplementedError

    def substep(self, sim: Any, t: float) -> None:
        if self._q_des is None:
            return
        st = p.getJointStates(sim.robot, self._ids, physicsClientId=sim.client)
        q = np.array([s[0] for s in st])
        dq = np.array([s[1] for s in st])
        e = self._q_des - q
        normal = np.clip(self._kp * e - self._kd * dq, -self._lim, self._lim)
        tau = self.changed(e, dq, t) - normal
        p.setJointMotorControlArray(sim.robot, self._ids, p.TORQUE_CONTROL, forces=tau.tolist(),
                                    physicsClientId=sim.client)


class WeakServo(_PDChange):
    """The P gain of some joints' servos is ``ratio`` of normal (a worn motor, a weak amplifier
    channel); damping and torque limit unchanged."""

    def __init__(self, ratio: float, joints: str | list[str] | None = None) -> None:
        super().__init__(joints)
        self.ratio = float(ratio)

    def changed(self, e, dq, t):
        return np.clip(self.ratio * self._kp * e - self._kd * dq, -self._lim, self._lim)


class BatterySag(_PDChange):
    """The servos' P gain and torque limit of some joints sag with the time since the move
    started, as the pack's voltage drops under the trot's current: factor max(0.2, 1 + rate t)."""

    def __init__(self, rate_per_s: float, joints: str | list[str] | None = None) -> None:
        super().__init__(joints)
        self.rate = float(rate_per_s)

    def changed(self, e, dq, t):
        g = max(0.2, 1.0 + self.rate * t)
        return np.clip(g * self._kp * e - self._kd * dq, -g * self._lim, g * self._lim)


class GearboxFriction:
    """Coulomb friction ``coulomb_Nm`` * tanh(dq / smoothing) opposing the joint rate of some
    joints (a dry or dirty gearbox), plus an optional small viscous part."""

    def __init__(self, coulomb_Nm: float, joints: str | list[str] | None = None,
                 viscous: float = 0.0, smoothing: float = 0.05) -> None:
        self.joints = resolve_joints(joints)
        self.coulomb = float(coulomb_Nm)
        self.viscous = float(viscous)
        self.smoothing = float(smoothing)

    def reset(self, sim: Any) -> None:
        self._ids = [sim.joint_indices[j] for j in self.joints]

    def substep(self, sim: Any, t: float) -> None:
        st = p.getJointStates(sim.robot, self._ids, physicsClientId=sim.client)
        dq = np.array([s[1] for s in st])
        tau = -(self.coulomb * np.tanh(dq / self.smoothing) + self.viscous * dq)
        p.setJointMotorControlArray(sim.robot, self._ids, p.TORQUE_CONTROL, forces=tau.tolist(),
                                    physicsClientId=sim.client)


class MisZeroedEncoder:
    """An encoder zeroed ``offset_rad`` off: the servo closes its loop on it (the joint is held
    off the set-point) and the same reading is published."""

    def __init__(self, offset_rad: float, joints: str | list[str] | None = None) -> None:
        self.offset = float(offset_rad)
        self.joints = resolve_joints(joints)

    def command(self, u: np.ndarray, t: float) -> np.ndarray:
        out = u.copy()
        out[self.joints] -= self.offset
        return out

    def measure(self, obs: dict, t: float) -> dict:
        q = obs["q"].copy()
        q[self.joints] += self.offset
        obs["q"] = q
        return obs


class StrappedPayload:
    """A payload of ``mass_kg`` rigidly strapped to the body at ``offset_m`` (base_link)."""

    def __init__(self, mass_kg: float, offset_m: list[float]) -> None:
        self.mass = float(mass_kg)
        self.offset = [float(x) for x in offset_m]

    def reset(self, sim: Any) -> None:
        c = sim.client
        pos, orn = p.getBasePositionAndOrientation(sim.robot, physicsClientId=c)
        world, _ = p.multiplyTransforms(pos, orn, self.offset, [0, 0, 0, 1])
        shape = p.createCollisionShape(p.GEOM_BOX, halfExtents=[0.03, 0.02, 0.015],
                                       physicsClientId=c)
        body = p.createMultiBody(self.mass, shape, basePosition=world, baseOrientation=orn,
                                 physicsClientId=c)
        lin, ang = p.getBaseVelocity(sim.robot, physicsClientId=c)
        p.resetBaseVelocity(body, lin, ang, physicsClientId=c)
        p.setCollisionFilterGroupMask(body, -1, 0, 0, physicsClientId=c)
        cid = p.createConstraint(sim.robot, -1, body, -1, p.JOINT_FIXED, [0, 0, 0],
                                 self.offset, [0, 0, 0], physicsClientId=c)
        p.changeConstraint(cid, maxForce=1e4, physicsClientId=c)


class TetherPull:
    """A constant horizontal pull ``force_N`` towards ``direction_deg`` (odom) on the body's
    centre of mass (a power / data tether dragged across the lab)."""

    def __init__(self, force_N: float, direction_deg: float) -> None:
        a = np.radians(direction_deg)
        self.f = [float(force_N * np.cos(a)), float(force_N * np.sin(a)), 0.0]

    def substep(self, sim: Any, t: float) -> None:
        pos, _ = p.getBasePositionAndOrientation(sim.robot, physicsClientId=sim.client)
        p.applyExternalForce(sim.robot, -1, self.f, pos, p.WORLD_FRAME, physicsClientId=sim.client)


class InclinedFloor:
    """The floor (a board, a ramp) inclined by ``slope_deg`` rising towards
    ``uphill_direction_deg`` (odom), turned about a horizontal axis through the start; gravity
    stays along -z of the level world."""

    def __init__(self, slope_deg: float, uphill_direction_deg: float) -> None:
        self.slope = float(slope_deg)
        self.uphill = float(uphill_direction_deg)

    def reset(self, sim: Any) -> None:
        s, phi = np.radians(self.slope), np.radians(self.uphill)
        quat = p.getQuaternionFromAxisAngle([np.sin(phi), -np.cos(phi), 0.0], s)
        p.resetBasePositionAndOrientation(sim.plane, [0.0, 0.0, 0.0], quat,
                                          physicsClientId=sim.client)


class FootPad:
    """The friction coefficient of some feet times ``scale`` (a worn or lost rubber pad)."""

    def __init__(self, scale: float, legs: str | list[str]) -> None:
        self.scale = float(scale)
        self.legs = _leg_ids(legs)

    def reset(self, sim: Any) -> None:
        for i in self.legs:
            p.changeDynamics(sim.robot, sim.foot_links[i],
                             lateralFriction=sim.config.foot_friction * self.scale,
                             physicsClientId=sim.client)


class SwingSnag:
    """While a foot is off the ground a force of up to ``force_N`` opposes its velocity (a loose
    cable or a guard catching on the leg): F = -force_N tanh(|v| / speed_m_s) v / |v|, v the
    foot's velocity in odom (all three axes); nothing while the foot touches the ground."""

    def __init__(self, force_N: float, legs: str | list[str], speed_m_s: float = 0.15) -> None:
        self.force = float(force_N)
        self.speed = float(speed_m_s)
        self.legs = _leg_ids(legs)

    def substep(self, sim: Any, t: float) -> None:
        c = sim.client
        links = [sim.foot_links[i] for i in self.legs]
        states = p.getLinkStates(sim.robot, links, computeLinkVelocity=1,
                                 computeForwardKinematics=1, physicsClientId=c)
        for link, st in zip(links, states):
            if p.getContactPoints(sim.robot, sim.plane, link, -1, physicsClientId=c):
                continue
            v = np.array(st[6])
            sp = float(np.linalg.norm(v))
            if sp < 1e-9:
                continue
            f = -self.force * np.tanh(sp / self.speed) * v / sp
            p.applyExternalForce(sim.robot, link, f.tolist(), st[0], p.WORLD_FRAME,
                                 physicsClientId=c)


class StaleJointStates:
    """The joint-state message (angles and rates) is published ``steps`` control steps late
    relative to the pose (a buffered joint driver): each report holds the joint readings of
    ``steps`` steps before; the body pose and twist are current."""

    def __init__(self, steps: int) -> None:
        self.steps = int(steps)
        self._h: deque = deque()

    def reset(self, sim: Any) -> None:
        self._h.clear()

    def measure(self, obs: dict, t: float) -> dict:
        cur = (obs["q"].copy(), obs["dq"].copy())
        if not self._h:
            self._h.extend(cur for _ in range(self.steps))
        self._h.append(cur)
        q, dq = self._h.popleft()
        obs["q"], obs["dq"] = q, dq
        return obs


class SlipperyPatch:
    """A wet / polished patch of floor: a disc of radius ``radius_m`` about ``centre_xy`` (odom)
    where the feet's friction coefficient is ``scale`` times normal; elsewhere normal."""

    def __init__(self, centre_xy: list[float], radius_m: float, scale: float) -> None:
        self.centre = np.array(centre_xy, dtype=float)
        self.r = float(radius_m)
        self.scale = float(scale)

    def reset(self, sim: Any) -> None:
        self._on = [None] * 4
        self._mu = sim.config.foot_friction

    def substep(self, sim: Any, t: float) -> None:
        c = sim.client
        states = p.getLinkStates(sim.robot, sim.foot_links, computeForwardKinematics=1,
                                 physicsClientId=c)
        for i, st in enumerate(states):
            on = bool(np.hypot(st[0][0] - self.centre[0], st[0][1] - self.centre[1]) < self.r)
            if on != self._on[i]:
                p.changeDynamics(sim.robot, sim.foot_links[i],
                                 lateralFriction=self._mu * (self.scale if on else 1.0),
                                 physicsClientId=c)
                self._on[i] = on
