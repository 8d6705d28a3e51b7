"""The zoo's own effect plug-ins (docs/interface.md section 5): reset / command / substep /
measure hooks on the pybullet LittleDog. Each class is a lab cause on a real robot; which one
is used by which effect file, and how, is in the effect files (and the sealed truth) only."""
from __future__ import annotations

from collections import deque
from typing import Any

import numpy as np
import pybullet as p

from littledog_mlsim.layout import HOME_POSE, JOINT_LOWER, JOINT_UPPER, LEGS, N_JOINTS
from littledog_mlsim.robot.config import per_joint
from littledog_mlsim.robot.effects import resolve_joints


def _leg(name: str) -> int:
    if name not in LEGS:
        raise ValueError(f"unknown leg {name!r}")
    return LEGS.index(name)


# ----------------------------------------------------------------------------- servo changes
class _ServoChange:
    """Adds, every physics step, the difference between a changed joint servo and the robot's
    normal one (gains and limits read from the robot's configuration)."""

    def __init__(self, joints: Any = None) -> None:
        self.joints = resolve_joints(joints)
        self._q_des = np.array(HOME_POSE, dtype=float)

    def reset(self, sim: Any) -> None:
        cfg = sim.config
        self._ids = [sim.joint_indices[j] for j in self.joints]
        self._kp = per_joint(cfg.kp)[self.joints]
        self._kd = per_joint(cfg.kd)[self.joints]
        self._lim = per_joint(cfg.torque_limit)[self.joints]

    def command(self, u: np.ndarray, t: float) -> np.ndarray:
        self._q_des = np.clip(u, JOINT_LOWER, JOINT_UPPER)
        return u

    def normal(self, e: np.ndarray, dq: np.ndarray) -> np.ndarray:
        return np.clip(self._kp * e - self._kd * dq, -self._lim, self._lim)

    def changed(self, e: np.ndarray, dq: np.ndarray, t: float) -> np.ndarray:
        raise NotImplementedError

    def substep(self, sim: Any, t: float) -> None:
        st = p.getJointStates(sim.robot, self._ids, physicsClientId=sim.client)
        q = np.array([s[0] for s in st])
        dq = np.array([s[1] for s in st])
        e = self._q_des[self.joints] - q
        tau = self.changed(e, dq, t) - self.normal(e, dq)
        p.setJointMotorControlArray(sim.robot, self._ids, p.TORQUE_CONTROL, forces=tau.tolist(),
                                    physicsClientId=sim.client)


class MotorWear(_ServoChange):
    """Worn motors (weak magnets, brushes): the P gain times ``ratio`` on some joints."""

    def __init__(self, ratio: float, joints: Any = None) -> None:
        super().__init__(joints)
        self.ratio = float(ratio)

    def changed(self, e, dq, t):
        return np.clip(self.ratio * self._kp * e - self._kd * dq, -self._lim, self._lim)


class DriverCurrentLimit(_ServoChange):
    """A motor driver's current limit set lower: servo torque capped at ``limit_Nm``."""

    def __init__(self, limit_Nm: float, joints: Any = None) -> None:
        super().__init__(joints)
        self.limit_Nm = float(limit_Nm)

    def changed(self, e, dq, t):
        lim = np.minimum(self._lim, self.limit_Nm)
        return np.clip(self._kp * e - self._kd * dq, -lim, lim)


class SupplySag(_ServoChange):
    """The supply voltage sags while the robot works (battery under load): the drivers' output,
    PD torque and its limit alike, scales by max(floor, 1 + rate_per_s * t), t the time since
    the move started."""

    def __init__(self, rate_per_s: float, joints: Any = None, floor: float = 0.3) -> None:
        super().__init__(joints)
        self.rate_per_s = float(rate_per_s)
        self.floor = float(floor)

    def changed(self, e, dq, t):
        g = max(self.floor, 1.0 + self.rate_per_s * t)
        return g * self.normal(e, dq)


# ----------------------------------------------------------------------------- joint mechanics
class GearboxFriction:
    """Extra Coulomb (and viscous) friction in a gearbox: -(c tanh(dq / s) + v dq)."""

    def __init__(self, coulomb_Nm: float, joints: Any = None, viscous: float = 0.0,
                 smoothing: float = 0.05) -> None:
        self.joints = resolve_joints(joints)
        self.c, self.v, self.s = float(coulomb_Nm), float(viscous), float(smoothing)

    def reset(self, sim: Any) -> None:
        self._ids = [sim.joint_indices[j] for j in self.joints]

    def substep(self, sim: Any, t: float) -> None:
        st = p.getJointStates(sim.robot, self._ids, physicsClientId=sim.client)
        dq = np.array([s[1] for s in st])
        tau = -(self.c * np.tanh(dq / self.s) + self.v * dq)
        p.setJointMotorControlArray(sim.robot, self._ids, p.TORQUE_CONTROL, forces=tau.tolist(),
                                    physicsClientId=sim.client)


class GearPlay:
    """Play in a worn gear train between the servo and the joint: what the joint is driven to
    follows the set-point through a play operator of total width ``width_rad``."""

    def __init__(self, width_rad: float, joints: Any = None) -> None:
        self.width = float(width_rad)
        self.joints = resolve_joints(joints)
        self._y = None

    def reset(self, sim: Any) -> None:
        self._y = None

    def command(self, u: np.ndarray, t: float) -> np.ndarray:
        h = 0.5 * self.width
        self._y = u.copy() if self._y is None else np.clip(self._y, u - h, u + h)
        out = u.copy()
        out[self.joints] = self._y[self.joints]
        return out


class HomingOffset:
    """An encoder re-mounted / homed wrong by ``offset_rad``: it reads true + offset, and the
    servo closes its loop on that reading."""

    def __init__(self, offset_rad: float, joints: Any = None) -> None:
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


class CableBoot:
    """A stiff cable bundle / rubber boot over a leg's joints: a spring torque
    -k (q - q_rest) per joint, q_rest = home pose + ``rest_offset`` (hip roll, hip pitch, knee)."""

    def __init__(self, stiffness_Nm_per_rad: float, leg: str,
                 rest_offset: list[float] = (0.0, 0.0, 0.0)) -> None:
        i = _leg(leg)
        self.k = float(stiffness_Nm_per_rad)
        self.joints = np.arange(3 * i, 3 * i + 3)
        self.rest = np.asarray(HOME_POSE, float)[self.joints] + np.asarray(rest_offset, float)

    def reset(self, sim: Any) -> None:
        self._ids = [sim.joint_indices[j] for j in self.joints]

    def substep(self, sim: Any, t: float) -> None:
        st = p.getJointStates(sim.robot, self._ids, physicsClientId=sim.client)
        q = np.array([s[0] for s in st])
        tau = -self.k * (q - self.rest)
        p.setJointMotorControlArray(sim.robot, self._ids, p.TORQUE_CONTROL, forces=tau.tolist(),
                                    physicsClientId=sim.client)


# ----------------------------------------------------------------------------- commands, sensing
class BusLatency:
    """Set-points of some joints arrive ``delay_ms`` late (a whole number of 10 ms steps, a
    slow segment of the command bus); the first command is held before."""

    def __init__(self, delay_ms: float, joints: Any = None) -> None:
        self.n = int(round(float(delay_ms) / 10.0))
        self.joints = resolve_joints(joints)
        self._h: deque = deque()

    def reset(self, sim: Any) -> None:
        self._h.clear()

    def command(self, u: np.ndarray, t: float) -> np.ndarray:
        if not self._h:
            self._h.extend(u.copy() for _ in range(self.n))
        self._h.append(u.copy())
        d = self._h.popleft()
        out = u.copy()
        out[self.joints] = d[self.joints]
        return out


class MocapLatency:
    """Motion capture's pose (and the twist from it) reported ``delay_ms`` late relative to the
    joint data (an uncompensated tracking latency; whole 10 ms steps; the first held before)."""

    KEYS = ("position", "orientation", "linear_velocity", "angular_velocity")

    def __init__(self, delay_ms: float) -> None:
        self.n = int(round(float(delay_ms) / 10.0))
        self._h: deque = deque()

    def reset(self, sim: Any) -> None:
        self._h.clear()

    def measure(self, obs: dict, t: float) -> dict:
        now = {k: np.array(obs[k], float).copy() for k in self.KEYS}
        if not self._h:
            self._h.extend({k: v.copy() for k, v in now.items()} for _ in range(self.n))
        self._h.append(now)
        old = self._h.popleft()
        obs.update({k: old[k] for k in self.KEYS})
        return obs


# ----------------------------------------------------------------------------- body and ground
class TetherPull:
    """A tether / cable bundle pulling the body horizontally with ``force_N`` towards
    ``direction_deg`` in the world (odom), applied at the body's centre of mass."""

    def __init__(self, force_N: float, direction_deg: float) -> None:
        a = np.radians(float(direction_deg))
        self.f = [float(force_N) * np.cos(a), float(force_N) * np.sin(a), 0.0]

    def substep(self, sim: Any, t: float) -> None:
        pos, _ = p.getBasePositionAndOrientation(sim.robot, physicsClientId=sim.client)
        p.applyExternalForce(sim.robot, -1, self.f, pos, p.WORLD_FRAME, physicsClientId=sim.client)


class MountedCamera:
    """A camera on a mount, a point mass ``mass_kg`` rigidly fixed at ``offset_m`` (base_link)."""

    def __init__(self, mass_kg: float, offset_m: list[float]) -> None:
        self.mass = float(mass_kg)
        self.offset = [float(x) for x in offset_m]

    def reset(self, sim: Any) -> None:
        c = sim.client
        pos, orn = p.getBasePositionAndOrientation(sim.robot, physicsClientId=c)
        world, _ = p.multiplyTransforms(pos, orn, self.offset, [0, 0, 0, 1])
        shape = p.createCollisionShape(p.GEOM_SPHERE, radius=0.015, physicsClientId=c)
        body = p.createMultiBody(self.mass, shape, basePosition=world, baseOrientation=orn,
                                 physicsClientId=c)
        p.setCollisionFilterGroupMask(body, -1, 0, 0, physicsClientId=c)
        lin, ang = p.getBaseVelocity(sim.robot, physicsClientId=c)
        p.resetBaseVelocity(body, lin, ang, physicsClientId=c)
        cid = p.createConstraint(sim.robot, -1, body, -1, p.JOINT_FIXED, [0, 0, 0], self.offset,
                                 [0, 0, 0], physicsClientId=c)
        p.changeConstraint(cid, maxForce=1e4, physicsClientId=c)


class WornFootPad:
    """One foot's rubber pad worn off: its friction coefficient times ``scale``."""

    def __init__(self, scale: float, leg: str) -> None:
        self.scale = float(scale)
        self.i = _leg(leg)

    def reset(self, sim: Any) -> None:
        p.changeDynamics(sim.robot, sim.foot_links[self.i],
                         lateralFriction=sim.config.foot_friction * self.scale,
                         physicsClientId=sim.client)


class SwingSnag:
    """A cable / long grass dragging one foot while it swings: a horizontal force of up to
    ``force_N`` against the foot's horizontal velocity (tanh ramp over ``speed_m_s``), only while
    the foot is off the ground."""

    def __init__(self, force_N: float, leg: str, speed_m_s: float = 0.1) -> None:
        self.f = float(force_N)
        self.v0 = float(speed_m_s)
        self.i = _leg(leg)

    def substep(self, sim: Any, t: float) -> None:
        c, link = sim.client, sim.foot_links[self.i]
        if p.getContactPoints(sim.robot, sim.plane, link, -1, physicsClientId=c):
            return
        st = p.getLinkState(sim.robot, link, computeLinkVelocity=1, computeForwardKinematics=1,
                            physicsClientId=c)
        v = np.array(st[6][:2])
        s = float(np.hypot(*v))
        if s < 1e-9:
            return
        f = -self.f * np.tanh(s / self.v0) * v / s
        p.applyExternalForce(sim.robot, link, [float(f[0]), float(f[1]), 0.0], st[0],
                             p.WORLD_FRAME, physicsClientId=c)


class SlipperyStrip:
    """A freshly polished (or wet) part of the lab floor: beyond ``distance_m`` from the start
    point along the world direction ``normal_deg``, the feet's friction is ``scale`` times the
    normal one."""

    def __init__(self, scale: float, normal_deg: float, distance_m: float) -> None:
        self.scale = float(scale)
        a = np.radians(float(normal_deg))
        self.n = np.array([np.cos(a), np.sin(a)])
        self.d = float(distance_m)

    def reset(self, sim: Any) -> None:
        self._on = [None] * 4

    def substep(self, sim: Any, t: float) -> None:
        c = sim.client
        states = p.getLinkStates(sim.robot, sim.foot_links, computeForwardKinematics=1,
                                 physicsClientId=c)
        for i, st in enumerate(states):
            on = bool(np.dot(self.n, st[0][:2]) > self.d)
            if on != self._on[i]:
                mu = sim.config.foot_friction * (self.scale if on else 1.0)
                p.changeDynamics(sim.robot, sim.foot_links[i], lateralFriction=mu,
                                 physicsClientId=c)
                self._on[i] = on


class Nothing:
    """The null control: a plug-in that changes nothing (all four hooks, identity)."""

    def reset(self, sim: Any) -> None:
        pass

    def command(self, u, t):
        return u

    def substep(self, sim, t):
        pass

    def measure(self, obs, t):
        return obs
