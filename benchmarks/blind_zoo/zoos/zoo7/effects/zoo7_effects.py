"""Effect plug-ins of the seventh blind zoo (sealed: the truth is here, in zNN.yaml and truth.yaml).

Written against the documented hooks only (docs/interface.md section 5: ``reset(sim)``,
``command(u, t)``, ``substep(sim, t)``, ``measure(obs, t)``) and plain pybullet calls. Extra joint
torques are sent with TORQUE_CONTROL, which pybullet adds to the servo's own torque within a
physics step (checked before writing this file).
"""
from __future__ import annotations

import math

import numpy as np
import pybullet as p

from littledog_mlsim.layout import JOINT_LOWER, JOINT_NAMES, JOINT_UPPER, LEGS
from littledog_mlsim.robot.config import per_joint

_GROUPS = {
    "all": lambda n: True,
    "left": lambda n: "_left_" in n,
    "right": lambda n: "_right_" in n,
    "front": lambda n: n.startswith("front_"),
    "back": lambda n: n.startswith("back_"),
    "hip_rolls": lambda n: n.endswith("hip_roll"),
    "hip_pitches": lambda n: n.endswith("hip_pitch"),
    "knees": lambda n: n.endswith("knee"),
}
G = 9.81


def joint_mask(spec: str | list[str]) -> np.ndarray:
    """Boolean (12,) mask of the joints named by a group, a leg, a joint name or a list of them."""
    items = [spec] if isinstance(spec, str) else list(spec)
    mask = np.zeros(len(JOINT_NAMES), dtype=bool)
    for it in items:
        if it in _GROUPS:
            mask |= np.array([_GROUPS[it](n) for n in JOINT_NAMES])
        elif it in LEGS:
            mask |= np.array([n.startswith(it + "_") for n in JOINT_NAMES])
        elif it in JOINT_NAMES:
            mask[JOINT_NAMES.index(it)] = True
        else:
            raise ValueError(f"unknown joint selection {it!r}")
    return mask


def _joint_state(sim) -> tuple[np.ndarray, np.ndarray]:
    st = p.getJointStates(sim.robot, sim.joint_indices, physicsClientId=sim.client)
    return np.array([s[0] for s in st]), np.array([s[1] for s in st])


def _add_joint_torque(sim, tau: np.ndarray) -> None:
    p.setJointMotorControlArray(sim.robot, sim.joint_indices, p.TORQUE_CONTROL,
                                forces=[float(x) for x in tau], physicsClientId=sim.client)


class _ServoModel:
    """The robot's PD servo as the configuration describes it, to reshape its torque from outside:
    an effect computes the torque the servo is sending and adds (wanted - sent)."""

    def _servo_setup(self, sim) -> None:
        cfg = sim.config
        self.kp = per_joint(cfg.kp)
        self.kd = per_joint(cfg.kd)
        self.tau_max = per_joint(cfg.torque_limit)
        self.u = None

    def command(self, u, t):
        self.u = np.clip(np.asarray(u, dtype=float), JOINT_LOWER, JOINT_UPPER)
        return u

    def _servo_torque(self, q, dq, kp=None) -> np.ndarray:
        kp = self.kp if kp is None else kp
        tau = kp * (self.u - q) - self.kd * dq
        return np.clip(tau, -self.tau_max, self.tau_max)


class SetpointLag:
    """Set-points of the selected joints reach the servo ``steps`` control periods late."""

    def __init__(self, steps: int, joints="all") -> None:
        self.steps = int(steps)
        self.mask = joint_mask(joints)
        self.buf: list[np.ndarray] = []

    def reset(self, sim) -> None:
        self.buf = []

    def command(self, u, t):
        u = np.asarray(u, dtype=float)
        self.buf.append(u.copy())
        if len(self.buf) > self.steps + 1:
            self.buf.pop(0)
        out = u.copy()
        out[self.mask] = self.buf[0][self.mask]
        return out


class SetpointSmoothing:
    """Set-points of the selected joints pass a first-order low-pass (time constant ``tau_s``),
    updated at the control rate (e.g. an input filter in the servo board)."""

    def __init__(self, tau_s: float, joints="all") -> None:
        self.tau = float(tau_s)
        self.mask = joint_mask(joints)
        self.y = None
        self.dt = 0.01

    def reset(self, sim) -> None:
        self.y = None
        self.dt = float(sim.control_dt)

    def command(self, u, t):
        u = np.asarray(u, dtype=float)
        if self.y is None:
            self.y = u.copy()
        else:
            a = 1.0 - math.exp(-self.dt / self.tau)
            self.y = self.y + a * (u - self.y)
        out = u.copy()
        out[self.mask] = self.y[self.mask]
        return out


class WeakServo(_ServoModel):
    """P gain of the selected joints times ``ratio``; damping and torque limit unchanged."""

    def __init__(self, ratio: float, joints="all") -> None:
        self.ratio = float(ratio)
        self.mask = joint_mask(joints)

    def reset(self, sim) -> None:
        self._servo_setup(sim)

    def substep(self, sim, t) -> None:
        if self.u is None:
            return
        q, dq = _joint_state(sim)
        kp2 = np.where(self.mask, self.kp * self.ratio, self.kp)
        extra = self._servo_torque(q, dq, kp2) - self._servo_torque(q, dq)
        _add_joint_torque(sim, np.where(self.mask, extra, 0.0))


class FadingServo(_ServoModel):
    """P gain of the selected joints falls linearly with time since the move's start:
    kp(t) = kp (1 + rate t), rate < 0 (windings warming up / supply sagging), floored at 0.3."""

    def __init__(self, rate: float, joints="all") -> None:
        self.rate = float(rate)
        self.mask = joint_mask(joints)

    def reset(self, sim) -> None:
        self._servo_setup(sim)

    def substep(self, sim, t) -> None:
        if self.u is None:
            return
        q, dq = _joint_state(sim)
        g = max(0.3, 1.0 + self.rate * max(float(t), 0.0))
        kp2 = np.where(self.mask, self.kp * g, self.kp)
        extra = self._servo_torque(q, dq, kp2) - self._servo_torque(q, dq)
        _add_joint_torque(sim, np.where(self.mask, extra, 0.0))


class PlayInJoint(_ServoModel):
    """Play of total width ``width`` [rad] between servo and link on the selected joints: the
    servo's spring acts only on the error beyond +-width/2 (damping and limit unchanged)."""

    def __init__(self, width: float, joints="all") -> None:
        self.half = 0.5 * float(width)
        self.mask = joint_mask(joints)

    def reset(self, sim) -> None:
        self._servo_setup(sim)

    def substep(self, sim, t) -> None:
        if self.u is None:
            return
        q, dq = _joint_state(sim)
        e = self.u - q
        e_dead = np.sign(e) * np.maximum(np.abs(e) - self.half, 0.0)
        wanted = np.clip(self.kp * e_dead - self.kd * dq, -self.tau_max, self.tau_max)
        extra = wanted - self._servo_torque(q, dq)
        _add_joint_torque(sim, np.where(self.mask, extra, 0.0))


class DryFriction:
    """Coulomb friction ``coulomb`` [N m] on the selected joints, smoothed below ``v_s`` rad/s."""

    def __init__(self, coulomb: float, joints="all", v_s: float = 0.05) -> None:
        self.c = float(coulomb)
        self.mask = joint_mask(joints)
        self.v_s = float(v_s)

    def substep(self, sim, t) -> None:
        _, dq = _joint_state(sim)
        tau = -self.c * np.tanh(dq / self.v_s)
        _add_joint_torque(sim, np.where(self.mask, tau, 0.0))


class ShiftedEncoder:
    """The encoder of the selected joints reads ``offset`` [rad] more than the true angle. The
    servo closes its loop on that reading, so the true angle settles ``offset`` short of the
    set-point, and the reported angle carries the offset."""

    def __init__(self, offset: float, joints="all") -> None:
        self.off = np.where(joint_mask(joints), float(offset), 0.0)

    def command(self, u, t):
        return np.asarray(u, dtype=float) - self.off

    def measure(self, obs, t):
        obs = dict(obs)
        obs["q"] = np.asarray(obs["q"], dtype=float) + self.off
        return obs


class WorldPush:
    """A steady horizontal force [N] fixed in odom, at the body's centre of mass."""

    def __init__(self, force: float, direction_deg: float) -> None:
        a = math.radians(direction_deg)
        self.f = [force * math.cos(a), force * math.sin(a), 0.0]

    def substep(self, sim, t) -> None:
        pos, _ = p.getBasePositionAndOrientation(sim.robot, physicsClientId=sim.client)
        p.applyExternalForce(sim.robot, -1, self.f, pos, p.WORLD_FRAME, physicsClientId=sim.client)


class InclinedFloor:
    """The floor is a plane inclined by ``slope_deg`` in the level world; ``uphill_deg`` is the
    odom direction of steepest ascent. At reset the floor is tilted about the robot's start point
    and the robot, as it stands, is turned with it (feet stay on the floor)."""

    def __init__(self, slope_deg: float, uphill_deg: float) -> None:
        s, u = math.radians(slope_deg), math.radians(uphill_deg)
        # rotation taking world z to the floor normal: about the horizontal axis perpendicular to
        # the uphill direction, so that moving along uphill goes up.
        axis = np.array([-math.sin(u), math.cos(u), 0.0])
        self.quat = p.getQuaternionFromAxisAngle(axis.tolist(), -s)
        self.R = np.array(p.getMatrixFromQuaternion(self.quat)).reshape(3, 3)

    def reset(self, sim) -> None:
        c = sim.client
        base_pos, base_orn = p.getBasePositionAndOrientation(sim.robot, physicsClientId=c)
        lin, ang = p.getBaseVelocity(sim.robot, physicsClientId=c)
        pivot = np.array([base_pos[0], base_pos[1], 0.0])
        p.resetBasePositionAndOrientation(sim.plane, pivot.tolist(), self.quat, physicsClientId=c)
        new_pos = pivot + self.R @ (np.array(base_pos) - pivot)
        _, new_orn = p.multiplyTransforms([0, 0, 0], self.quat, [0, 0, 0], base_orn)
        p.resetBasePositionAndOrientation(sim.robot, new_pos.tolist(), new_orn, physicsClientId=c)
        p.resetBaseVelocity(sim.robot, (self.R @ np.array(lin)).tolist(),
                            (self.R @ np.array(ang)).tolist(), physicsClientId=c)


class CarriedLoad:
    """A load of ``mass`` [kg] fixed to the body at ``offset`` [m] in base_link from the body's
    centre of mass: the body's mass grows by it, its inertia by the point mass's, and its weight
    acts at the offset (the moment about the centre of mass is applied as a torque)."""

    def __init__(self, mass: float, offset: list[float]) -> None:
        self.m = float(mass)
        self.d = np.asarray(offset, dtype=float)
        self._set: tuple | None = None

    def reset(self, sim) -> None:
        c = sim.client
        info = p.getDynamicsInfo(sim.robot, -1, physicsClientId=c)
        mass, inertia = info[0], tuple(info[2])
        if self._set is not None and abs(mass - self._set[0]) < 1e-9:
            return                     # this world already carries the load
        d = self.d
        add = self.m * np.array([d[1] ** 2 + d[2] ** 2, d[0] ** 2 + d[2] ** 2, d[0] ** 2 + d[1] ** 2])
        new_mass = mass + self.m
        new_inertia = (np.array(inertia) + add).tolist()
        p.changeDynamics(sim.robot, -1, mass=new_mass, localInertiaDiagonal=new_inertia,
                         physicsClientId=c)
        self._set = (new_mass,)

    def substep(self, sim, t) -> None:
        _, orn = p.getBasePositionAndOrientation(sim.robot, physicsClientId=sim.client)
        R = np.array(p.getMatrixFromQuaternion(orn)).reshape(3, 3)
        r = R @ self.d
        tau = np.cross(r, np.array([0.0, 0.0, -self.m * G]))
        p.applyExternalTorque(sim.robot, -1, tau.tolist(), p.WORLD_FRAME, physicsClientId=sim.client)


class SlipperyFoot:
    """One foot's friction coefficient is ``scale`` times its normal value (worn pad)."""

    def __init__(self, leg: str, scale: float) -> None:
        self.leg = LEGS.index(leg)
        self.scale = float(scale)
        self._set = None

    def reset(self, sim) -> None:
        c = sim.client
        link = sim.foot_links[self.leg]
        mu = p.getDynamicsInfo(sim.robot, link, physicsClientId=c)[1]
        if self._set is not None and abs(mu - self._set) < 1e-12:
            return
        self._set = mu * self.scale
        p.changeDynamics(sim.robot, link, lateralFriction=self._set, physicsClientId=c)


class SwingDrag:
    """While one foot is off the ground (swing), a horizontal drag of ``force`` [N] opposes its
    horizontal velocity (tall grass / a snagging cable); faded in below 0.05 m/s."""

    def __init__(self, leg: str, force: float, v_s: float = 0.05) -> None:
        self.leg = LEGS.index(leg)
        self.force = float(force)
        self.v_s = float(v_s)

    def substep(self, sim, t) -> None:
        c = sim.client
        link = sim.foot_links[self.leg]
        if p.getContactPoints(sim.robot, sim.plane, link, -1, physicsClientId=c):
            return
        ls = p.getLinkState(sim.robot, link, computeLinkVelocity=1, computeForwardKinematics=1,
                            physicsClientId=c)
        v = np.array(ls[6][:2])
        speed = float(np.hypot(*v))
        if speed < 1e-6:
            return
        f = -self.force * min(1.0, speed / self.v_s) * v / speed
        p.applyExternalForce(sim.robot, link, [f[0], f[1], 0.0], ls[0], p.WORLD_FRAME,
                             physicsClientId=c)
