"""Blind effect zoo: physical faults a real LittleDog could suffer from, as effect plug-ins.

Each class implements some of the effect hooks of ``littledog_mlsim.robot.effects`` (reset,
command, substep, measure). Only the public robot API (the ``sim`` attributes, the robot
configuration's servo gains and limits, the joint layout), pybullet and numpy are used.

Servo-path faults (gain, torque limit, backlash, encoder offset) are written as a correction
torque added to the robot's own PD servo: the servo's torque is recomputed from the true joint
state and the set-point of this control step, the faulty servo's torque likewise, and the
difference is applied with TORQUE_CONTROL (pybullet adds it to the servo's torque).
"""
from __future__ import annotations

import math
from typing import Any

import numpy as np
import pybullet as p

from littledog_mlsim.layout import JOINT_LOWER, JOINT_UPPER, LEGS, N_JOINTS
from littledog_mlsim.robot.config import per_joint
from littledog_mlsim.robot.effects import resolve_joints


# ----------------------------------------------------------------------------- body-level forces
class OdomForce:
    """Constant horizontal force fixed in odom (a tether or a steady side wind) on the body [N]."""

    def __init__(self, force_N: float, direction_deg: float) -> None:
        a = math.radians(direction_deg)
        self.force = [force_N * math.cos(a), force_N * math.sin(a), 0.0]

    def substep(self, sim: Any, t: float) -> None:
        pos, _ = p.getBasePositionAndOrientation(sim.robot, physicsClientId=sim.client)
        p.applyExternalForce(sim.robot, -1, self.force, pos, p.WORLD_FRAME, physicsClientId=sim.client)


class BodyFrameForce:
    """Constant force fixed in base_link (a cable dragging on the body), applied at a body point."""

    def __init__(self, force_N: float, direction_deg: float, elevation_deg: float = 0.0,
                 point_m: tuple[float, float, float] = (0.0, 0.0, 0.0)) -> None:
        a, e = math.radians(direction_deg), math.radians(elevation_deg)
        self.force = [force_N * math.cos(e) * math.cos(a), force_N * math.cos(e) * math.sin(a),
                      force_N * math.sin(e)]
        self.point = list(point_m)

    def substep(self, sim: Any, t: float) -> None:
        p.applyExternalForce(sim.robot, -1, self.force, self.point, p.LINK_FRAME,
                             physicsClientId=sim.client)


class GroundSlope:
    """Inclined ground: gravity rotated so that the (odom-level) ground rises towards uphill_deg."""

    def __init__(self, slope_deg: float, uphill_direction_deg: float, g: float = 9.81) -> None:
        s, a = math.radians(slope_deg), math.radians(uphill_direction_deg)
        self.gravity = [-g * math.sin(s) * math.cos(a), -g * math.sin(s) * math.sin(a), -g * math.cos(s)]

    def reset(self, sim: Any) -> None:
        p.setGravity(*self.gravity, physicsClientId=sim.client)


class CarriedPayload:
    """A rigid payload (a sensor box) of ``mass_kg`` bolted to the body at ``offset_m`` (base_link)."""

    def __init__(self, mass_kg: float, offset_m: tuple[float, float, float]) -> None:
        self.mass = float(mass_kg)
        self.offset = [float(v) for v in offset_m]

    def reset(self, sim: Any) -> None:
        c = sim.client
        pos, orn = p.getBasePositionAndOrientation(sim.robot, physicsClientId=c)
        world, _ = p.multiplyTransforms(pos, orn, self.offset, [0, 0, 0, 1])
        shape = p.createCollisionShape(p.GEOM_BOX, halfExtents=[0.03, 0.03, 0.02], physicsClientId=c)
        body = p.createMultiBody(self.mass, shape, basePosition=world, baseOrientation=orn,
                                 physicsClientId=c)
        lin, ang = p.getBaseVelocity(sim.robot, physicsClientId=c)
        p.resetBaseVelocity(body, lin, ang, physicsClientId=c)
        p.setCollisionFilterGroupMask(body, -1, 0, 0, physicsClientId=c)
        cid = p.createConstraint(sim.robot, -1, body, -1, p.JOINT_FIXED, [0, 0, 0], self.offset,
                                 [0, 0, 0], physicsClientId=c)
        p.changeConstraint(cid, maxForce=1e4, physicsClientId=c)


class SoftGround:
    """Compliant ground (a foam mat / turf): contact stiffness [N/m] and damping [N s/m]."""

    def __init__(self, stiffness_N_per_m: float, damping_Ns_per_m: float) -> None:
        self.k, self.b = float(stiffness_N_per_m), float(damping_Ns_per_m)

    def reset(self, sim: Any) -> None:
        p.changeDynamics(sim.plane, -1, contactStiffness=self.k, contactDamping=self.b,
                         physicsClientId=sim.client)


# ----------------------------------------------------------------------------- legs and contacts
class HeavyLeg:
    """One leg's links are ``scale`` times heavier (mass and inertia), e.g. a heavier motor fitted."""

    def __init__(self, leg: str, scale: float) -> None:
        if leg not in LEGS:
            raise ValueError(f"unknown leg {leg!r}")
        self.joints = resolve_joints(leg)
        self.scale = float(scale)

    def reset(self, sim: Any) -> None:
        for j in self.joints:
            link = sim.joint_indices[j]
            info = p.getDynamicsInfo(sim.robot, link, physicsClientId=sim.client)
            p.changeDynamics(sim.robot, link, mass=info[0] * self.scale,
                             localInertiaDiagonal=[v * self.scale for v in info[2]],
                             physicsClientId=sim.client)


class SlipperyFoot:
    """One foot's pad is worn smooth: its friction coefficient with the ground becomes ``mu``."""

    def __init__(self, leg: str, mu: float) -> None:
        self.leg = LEGS.index(leg)
        self.mu = float(mu)

    def reset(self, sim: Any) -> None:
        ground = p.getDynamicsInfo(sim.plane, -1, physicsClientId=sim.client)[1]
        # pybullet multiplies the two bodies' friction coefficients
        p.changeDynamics(sim.robot, sim.foot_links[self.leg], lateralFriction=self.mu / ground,
                         physicsClientId=sim.client)


class SwingSnag:
    """A foot drags through tall grass / snags a loose cable while in swing (not touching ground).

    A horizontal force of up to ``force_N`` opposing the foot's horizontal velocity acts on the
    foot only while it has no ground contact.
    """

    def __init__(self, leg: str, force_N: float, v_smooth: float = 0.05) -> None:
        self.leg = LEGS.index(leg)
        self.force = float(force_N)
        self.v_smooth = float(v_smooth)

    def substep(self, sim: Any, t: float) -> None:
        c, link = sim.client, sim.foot_links[self.leg]
        if p.getContactPoints(sim.robot, sim.plane, linkIndexA=link, physicsClientId=c):
            return
        st = p.getLinkState(sim.robot, link, computeLinkVelocity=1, physicsClientId=c)
        v = np.array(st[6][:2])
        speed = float(np.linalg.norm(v))
        if speed < 1e-6:
            return
        mag = self.force * math.tanh(speed / self.v_smooth)
        f = [-mag * v[0] / speed, -mag * v[1] / speed, 0.0]
        p.applyExternalForce(sim.robot, link, f, st[0], p.WORLD_FRAME, physicsClientId=c)


# ----------------------------------------------------------------------------- command path
class LegCommandDelay:
    """Set-points of some joints arrive ``delay_ms`` late (a slow bus segment), whole 10 ms steps."""

    def __init__(self, delay_ms: float, joints: str | list[str]) -> None:
        self.steps = int(round(delay_ms / 10.0))
        self.joints = resolve_joints(joints)
        self.hist: list[np.ndarray] = []

    def reset(self, sim: Any) -> None:
        self.hist = []

    def command(self, u: np.ndarray, t: float) -> np.ndarray:
        if not self.hist:
            self.hist = [u.copy() for _ in range(self.steps)]
        self.hist.append(u.copy())
        old = self.hist.pop(0)
        out = u.copy()
        out[self.joints] = old[self.joints]
        return out


class SetpointLowPass:
    """Set-points of some joints pass a first-order low-pass of time constant ``time_constant_ms``.

    Discretised exactly for the 10 ms command period (zero-order hold of the input).
    """

    def __init__(self, time_constant_ms: float, joints: str | list[str]) -> None:
        self.joints = resolve_joints(joints)
        self.tau = time_constant_ms / 1000.0
        self.y: np.ndarray | None = None
        self.a = 0.0

    def reset(self, sim: Any) -> None:
        self.y = None
        self.a = math.exp(-sim.control_dt / self.tau)

    def command(self, u: np.ndarray, t: float) -> np.ndarray:
        if self.y is None:
            self.y = u[self.joints].copy()
        self.y = self.a * self.y + (1.0 - self.a) * u[self.joints]
        out = u.copy()
        out[self.joints] = self.y
        return out


# ----------------------------------------------------------------------------- servo faults
class _ServoCorrection:
    """Base: adds (faulty servo torque - normal servo torque) on the selected joints each substep."""

    def __init__(self, joints: str | list[str]) -> None:
        self.joints = resolve_joints(joints)
        self.q_des = np.zeros(N_JOINTS)
        self._ids: list[int] = []

    def reset(self, sim: Any) -> None:
        cfg = sim.config
        self.kp = per_joint(cfg.kp)[self.joints]
        self.kd = per_joint(cfg.kd)[self.joints]
        self.tmax = per_joint(cfg.torque_limit)[self.joints]
        self._ids = [sim.joint_indices[j] for j in self.joints]
        states = p.getJointStates(sim.robot, sim.joint_indices, physicsClientId=sim.client)
        self.q_des = np.array([s[0] for s in states])

    def command(self, u: np.ndarray, t: float) -> np.ndarray:
        self.q_des = np.clip(u, JOINT_LOWER, JOINT_UPPER)
        return u

    def faulty(self, e: np.ndarray, dq: np.ndarray) -> np.ndarray:
        raise NotImplementedError

    def substep(self, sim: Any, t: float) -> None:
        states = p.getJointStates(sim.robot, self._ids, physicsClientId=sim.client)
        q = np.array([s[0] for s in states])
        dq = np.array([s[1] for s in states])
        e = self.q_des[self.joints] - q
        normal = np.clip(self.kp * e - self.kd * dq, -self.tmax, self.tmax)
        p.setJointMotorControlArray(sim.robot, self._ids, p.TORQUE_CONTROL,
                                    forces=(self.faulty(e, dq) - normal).tolist(),
                                    physicsClientId=sim.client)


class WeakServo(_ServoCorrection):
    """P gain of some servos scaled by ``gain_ratio`` (a worn motor / weak amplifier)."""

    def __init__(self, gain_ratio: float, joints: str | list[str]) -> None:
        super().__init__(joints)
        self.ratio = float(gain_ratio)

    def faulty(self, e: np.ndarray, dq: np.ndarray) -> np.ndarray:
        return np.clip(self.ratio * self.kp * e - self.kd * dq, -self.tmax, self.tmax)


class LowTorqueLimit(_ServoCorrection):
    """The servo's current limit is set low: torque saturates at ``torque_limit_Nm``."""

    def __init__(self, torque_limit_Nm: float, joints: str | list[str]) -> None:
        super().__init__(joints)
        self.limit = float(torque_limit_Nm)

    def faulty(self, e: np.ndarray, dq: np.ndarray) -> np.ndarray:
        lim = np.minimum(self.tmax, self.limit)
        return np.clip(self.kp * e - self.kd * dq, -lim, lim)


class GearBacklash(_ServoCorrection):
    """Play of total width ``width_rad`` between motor and link: no stiffness torque inside it.

    The motor holds the set-point; the link (where the angle is measured) moves freely within
    +-width/2 of it and is only pushed once the gear teeth engage.
    """

    def __init__(self, width_rad: float, joints: str | list[str]) -> None:
        super().__init__(joints)
        self.half = 0.5 * float(width_rad)

    def faulty(self, e: np.ndarray, dq: np.ndarray) -> np.ndarray:
        dz = np.sign(e) * np.maximum(np.abs(e) - self.half, 0.0)
        return np.clip(self.kp * dz - self.kd * dq, -self.tmax, self.tmax)


class EncoderOffset(_ServoCorrection):
    """A joint encoder reads ``offset_rad`` too high (bad zero calibration).

    Both the servo (which then holds the joint offset_rad below the set-point) and the reported
    joint angles see the wrong reading.
    """

    def __init__(self, offset_rad: float, joints: str | list[str]) -> None:
        super().__init__(joints)
        self.offset = float(offset_rad)

    def faulty(self, e: np.ndarray, dq: np.ndarray) -> np.ndarray:
        return np.clip(self.kp * (e - self.offset) - self.kd * dq, -self.tmax, self.tmax)

    def measure(self, obs: dict, t: float) -> dict:
        q = obs["q"].copy()
        q[self.joints] += self.offset
        obs["q"] = q
        return obs


class SideFriction:
    """Extra joint friction -(coulomb tanh(dq/smoothing)) on some joints (dirty / tight bearings)."""

    def __init__(self, coulomb_Nm: float, joints: str | list[str], smoothing: float = 0.05) -> None:
        self.joints = resolve_joints(joints)
        self.c = float(coulomb_Nm)
        self.s = float(smoothing)
        self._ids: list[int] = []

    def reset(self, sim: Any) -> None:
        self._ids = [sim.joint_indices[j] for j in self.joints]

    def substep(self, sim: Any, t: float) -> None:
        states = p.getJointStates(sim.robot, self._ids, physicsClientId=sim.client)
        dq = np.array([s[1] for s in states])
        p.setJointMotorControlArray(sim.robot, self._ids, p.TORQUE_CONTROL,
                                    forces=(-self.c * np.tanh(dq / self.s)).tolist(),
                                    physicsClientId=sim.client)


class SaggingServos(_ServoCorrection):
    """Servo P gain sags linearly with time since the move started (a depleted battery).

    gain ratio(t) = 1 + rate_per_s * t (rate_per_s < 0), floored at 0.
    """

    def __init__(self, rate_per_s: float, joints: str | list[str] = "all") -> None:
        super().__init__(joints)
        self.rate = float(rate_per_s)
        self.t = 0.0

    def substep(self, sim: Any, t: float) -> None:
        self.t = t
        super().substep(sim, t)

    def faulty(self, e: np.ndarray, dq: np.ndarray) -> np.ndarray:
        ratio = max(0.0, 1.0 + self.rate * self.t)
        return np.clip(ratio * self.kp * e - self.kd * dq, -self.tmax, self.tmax)
