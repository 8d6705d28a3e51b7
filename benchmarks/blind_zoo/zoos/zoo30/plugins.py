"""Effect plug-ins of zoo30 (docs/interface.md section 5), written for this zoo only.

Each class implements some of reset(sim), command(u, t), substep(sim, t), measure(obs, t).
Joints are named as in robot/effects.py (names, legs or groups). Torques added in `substep`
with TORQUE_CONTROL add to the servo's own torque for that physics step.
"""
from __future__ import annotations

from collections import deque
from typing import Any

import numpy as np
import pybullet as p

from littledog_mlsim.layout import JOINT_LOWER, JOINT_UPPER, LEGS, N_JOINTS
from littledog_mlsim.robot.config import per_joint
from littledog_mlsim.robot.effects import resolve_joints


def _joint_state(sim: Any, ids: list[int]) -> tuple[np.ndarray, np.ndarray]:
    st = p.getJointStates(sim.robot, ids, physicsClientId=sim.client)
    return np.array([s[0] for s in st]), np.array([s[1] for s in st])


def _add_torque(sim: Any, ids: list[int], tau: np.ndarray) -> None:
    p.setJointMotorControlArray(sim.robot, ids, p.TORQUE_CONTROL, forces=[float(x) for x in tau],
                                physicsClientId=sim.client)


class _ServoChange:
    """Base: a change of the joint servo of some joints, added as the difference between the
    changed servo's torque and the normal one (computed from the true joint state and the
    set-point as the servo receives it)."""

    def __init__(self, joints: Any = None) -> None:
        self.joints = resolve_joints(joints)
        self._q_des = None

    def reset(self, sim: Any) -> None:
        self._ids = [sim.joint_indices[j] for j in self.joints]
        cfg = sim.config
        self._kp = per_joint(cfg.kp)[self.joints]
        self._kd = per_joint(cfg.kd)[self.joints]
        self._lim = per_joint(cfg.torque_limit)[self.joints]
        self._q_des = None

    def command(self, u: np.ndarray, t: float) -> np.ndarray:
        self._q_des = np.clip(u, JOINT_LOWER, JOINT_UPPER)[self.joints]
        return u

    def normal(self, e: np.ndarray, dq: np.ndarray) -> np.ndarray:
        return np.clip(self._kp * e - self._kd * dq, -self._lim, self._lim)

    def changed(self, e: np.ndarray, dq: np.ndarray, t: float) -> np.ndarray:
        raise NotImplementedError

    def substep(self, sim: Any, t: float) -> None:
        if self._q_des is None:
            return
        q, dq = _joint_state(sim, self._ids)
        e = self._q_des - q
        _add_torque(sim, self._ids, self.changed(e, dq, t) - self.normal(e, dq))


class CarriedLoad:
    """A box of `mass_kg` strapped to the body at `offset_m` (base_link), size `size_m`."""

    def __init__(self, mass_kg: float, offset_m: list[float], size_m: list[float] = (0.08, 0.05, 0.03)) -> None:
        self.mass = float(mass_kg)
        self.offset = [float(v) for v in offset_m]
        self.half = [0.5 * float(v) for v in size_m]

    def reset(self, sim: Any) -> None:
        c = sim.client
        pos, orn = p.getBasePositionAndOrientation(sim.robot, physicsClientId=c)
        world, _ = p.multiplyTransforms(pos, orn, self.offset, [0, 0, 0, 1])
        shape = p.createCollisionShape(p.GEOM_BOX, halfExtents=self.half, physicsClientId=c)
        body = p.createMultiBody(self.mass, shape, basePosition=world, baseOrientation=orn,
                                 physicsClientId=c)
        lin, ang = p.getBaseVelocity(sim.robot, physicsClientId=c)
        p.resetBaseVelocity(body, lin, ang, physicsClientId=c)
        p.setCollisionFilterGroupMask(body, -1, 0, 0, physicsClientId=c)
        cid = p.createConstraint(sim.robot, -1, body, -1, p.JOINT_FIXED, [0, 0, 0], self.offset,
                                 [0, 0, 0], physicsClientId=c)
        p.changeConstraint(cid, maxForce=2e4, physicsClientId=c)


class WeakStiffness(_ServoChange):
    """Servo stiffness of some joints times `ratio` (damping and current limit unchanged)."""

    def __init__(self, ratio: float, joints: Any = None) -> None:
        super().__init__(joints)
        self.ratio = float(ratio)

    def changed(self, e, dq, t):
        return np.clip(self.ratio * self._kp * e - self._kd * dq, -self._lim, self._lim)


class CurrentLimit(_ServoChange):
    """Servo torque of some joints limited to `limit_Nm` (a weak motor or driver)."""

    def __init__(self, limit_Nm: float, joints: Any = None) -> None:
        super().__init__(joints)
        self.limit = float(limit_Nm)

    def changed(self, e, dq, t):
        lim = np.minimum(self._lim, self.limit)
        return np.clip(self._kp * e - self._kd * dq, -lim, lim)


class SupplySag(_ServoChange):
    """Servo torque of some joints scaled by max(0.2, 1 + rate_per_s * t): the supply voltage
    sags as the move draws current (t since the move started)."""

    def __init__(self, rate_per_s: float, joints: Any = None) -> None:
        super().__init__(joints)
        self.rate = float(rate_per_s)

    def changed(self, e, dq, t):
        return max(0.2, 1.0 + self.rate * t) * self.normal(e, dq)


class GearPlay(_ServoChange):
    """Play in the gear train of some joints (massless motor side): within +-width/2 of the
    set-point the servo's spring transmits nothing, beyond it k (|e| - width/2); damping kept."""

    def __init__(self, width_rad: float, joints: Any = None) -> None:
        super().__init__(joints)
        self.h = 0.5 * float(width_rad)

    def changed(self, e, dq, t):
        e_eff = e - np.clip(e, -self.h, self.h)
        return np.clip(self._kp * e_eff - self._kd * dq, -self._lim, self._lim)


class GearboxFriction:
    """Coulomb friction `coulomb_Nm` with a static bump (`static_Nm` at rest, Stribeck speed
    `stribeck_rad_s`) and viscous `viscous_Nms` on some joints."""

    def __init__(self, coulomb_Nm: float, static_Nm: float, stribeck_rad_s: float = 0.3,
                 viscous_Nms: float = 0.0, joints: Any = None, smoothing_rad_s: float = 0.02) -> None:
        self.joints = resolve_joints(joints)
        self.fc, self.fs = float(coulomb_Nm), float(static_Nm)
        self.vs, self.b, self.eps = float(stribeck_rad_s), float(viscous_Nms), float(smoothing_rad_s)

    def reset(self, sim: Any) -> None:
        self._ids = [sim.joint_indices[j] for j in self.joints]

    def substep(self, sim: Any, t: float) -> None:
        _, dq = _joint_state(sim, self._ids)
        mag = self.fc + (self.fs - self.fc) * np.exp(-(dq / self.vs) ** 2)
        _add_torque(sim, self._ids, -(mag * np.tanh(dq / self.eps) + self.b * dq))


class BusLatency:
    """Set-points of some joints arrive `steps` control steps (10 ms each) late."""

    def __init__(self, steps: int, joints: Any = None) -> None:
        self.steps = int(steps)
        self.joints = resolve_joints(joints)
        self._h: deque = deque()

    def reset(self, sim: Any) -> None:
        self._h = deque()

    def command(self, u: np.ndarray, t: float) -> np.ndarray:
        if not self._h:
            self._h.extend(u.copy() for _ in range(self.steps))
        self._h.append(u.copy())
        old = self._h.popleft()
        out = u.copy()
        out[self.joints] = old[self.joints]
        return out


class PacketLoss:
    """Lost command packets (a radio link): a two-state (good/bad) channel; in the bad state a
    packet is lost and the servos keep the last set-point they received. `loss_fraction` is the
    long-run fraction of lost packets, `mean_burst` the mean length of a loss burst [steps]."""

    def __init__(self, loss_fraction: float, mean_burst: float = 2.5, joints: Any = None) -> None:
        self.joints = resolve_joints(joints)
        self.p_exit = 1.0 / float(mean_burst)                       # bad -> good
        f = float(loss_fraction)
        self.p_enter = f * self.p_exit / (1.0 - f)                  # good -> bad
        self._last = None
        self._bad = False

    def reset(self, sim: Any) -> None:
        self.rng = np.random.default_rng(sim.rng.integers(2**32))
        self._last, self._bad = None, False

    def command(self, u: np.ndarray, t: float) -> np.ndarray:
        if self._last is None:
            self._last = u.copy()
            return u
        r = self.rng.random()
        self._bad = (r >= self.p_exit) if self._bad else (r < self.p_enter)
        out = u.copy()
        if self._bad:
            out[self.joints] = self._last[self.joints]
        else:
            self._last = u.copy()
        return out


class ParallelSpring:
    """A torsional spring across some joints (a stiff cable loom / a boot):
    tau = -stiffness (q - rest_rad)."""

    def __init__(self, stiffness_Nm_rad: float, rest_rad: float, joints: Any = None) -> None:
        self.joints = resolve_joints(joints)
        self.k, self.q0 = float(stiffness_Nm_rad), float(rest_rad)

    def reset(self, sim: Any) -> None:
        self._ids = [sim.joint_indices[j] for j in self.joints]

    def substep(self, sim: Any, t: float) -> None:
        q, _ = _joint_state(sim, self._ids)
        _add_torque(sim, self._ids, -self.k * (q - self.q0))


class FootSnag:
    """While a foot of `leg` is in the air, a horizontal drag up to `force_N` opposes its
    velocity (tall grass, a loose cable): F = -force_N tanh(|v|/speed_m_s) v/|v|."""

    def __init__(self, force_N: float, leg: str, speed_m_s: float = 0.15) -> None:
        self.f, self.vs = float(force_N), float(speed_m_s)
        self.i = LEGS.index(leg)

    def substep(self, sim: Any, t: float) -> None:
        c = sim.client
        link = sim.foot_links[self.i]
        if p.getContactPoints(sim.robot, sim.plane, link, -1, physicsClientId=c):
            return
        st = p.getLinkState(sim.robot, link, computeLinkVelocity=1, computeForwardKinematics=1,
                            physicsClientId=c)
        v = np.array(st[6][:2])
        s = float(np.hypot(*v))
        if s < 1e-9:
            return
        f = -self.f * np.tanh(s / self.vs) * v / s
        p.applyExternalForce(sim.robot, link, [float(f[0]), float(f[1]), 0.0], st[0],
                             p.WORLD_FRAME, physicsClientId=c)


class AirStream:
    """A steady horizontal air stream (a fan, an air-conditioning outlet): a force fixed in the
    world, `force_N` towards `direction_deg` (odom), on the body's centre of mass."""

    def __init__(self, force_N: float, direction_deg: float) -> None:
        a = np.radians(float(direction_deg))
        self.force = [float(force_N) * np.cos(a), float(force_N) * np.sin(a), 0.0]

    def substep(self, sim: Any, t: float) -> None:
        pos, _ = p.getBasePositionAndOrientation(sim.robot, physicsClientId=sim.client)
        p.applyExternalForce(sim.robot, -1, self.force, pos, p.WORLD_FRAME,
                             physicsClientId=sim.client)


class SlipperyPatch:
    """A slippery sheet on part of the floor: where a foot is on the far side of the line
    through `edge_xy` with normal `normal_deg` (odom), the floor's friction is `friction`
    instead of the robot's ground friction (pybullet combines foot and floor friction as a
    product, so the foot's coefficient is scaled by friction / ground_friction there)."""

    def __init__(self, friction: float, edge_xy: list[float], normal_deg: float) -> None:
        self.mu = float(friction)
        self.p0 = np.array(edge_xy, dtype=float)
        a = np.radians(float(normal_deg))
        self.n = np.array([np.cos(a), np.sin(a)])

    def reset(self, sim: Any) -> None:
        self._on = [None] * 4
        self._mu_in = sim.config.foot_friction * self.mu / sim.config.ground_friction
        self._mu_out = sim.config.foot_friction

    def substep(self, sim: Any, t: float) -> None:
        c = sim.client
        states = p.getLinkStates(sim.robot, sim.foot_links, computeForwardKinematics=1,
                                 physicsClientId=c)
        for i, st in enumerate(states):
            on = bool(np.dot(np.array(st[0][:2]) - self.p0, self.n) > 0.0)
            if on != self._on[i]:
                p.changeDynamics(sim.robot, sim.foot_links[i],
                                 lateralFriction=self._mu_in if on else self._mu_out,
                                 physicsClientId=c)
                self._on[i] = on
