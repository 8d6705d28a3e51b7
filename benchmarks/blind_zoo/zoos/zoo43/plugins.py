"""Effect plug-ins written for zoo43 (docs/interface.md section 5). Each is a fault or condition
of a LittleDog-sized lab robot; the effects files (effects/zNN.yaml) switch one on at a time."""
from __future__ import annotations

from typing import Any

import numpy as np
import pybullet as p

from littledog_mlsim.layout import JOINT_LOWER, JOINT_UPPER, JOINT_NAMES, LEGS, N_JOINTS
from littledog_mlsim.robot.config import per_joint

_GROUPS = {"hip_rolls": "_hip_roll", "hip_pitches": "_hip_pitch", "knees": "_knee"}


def _joints(spec: str | list[str] | None) -> np.ndarray:
    """Indices (contract order) of the joints named: 'all', a joint kind group, a leg, a
    side ('left'/'right') or joint names."""
    if spec is None or spec == "all":
        return np.arange(N_JOINTS)
    names = [spec] if isinstance(spec, str) else list(spec)
    mask = np.zeros(N_JOINTS, dtype=bool)
    for n in names:
        if n in _GROUPS:
            mask |= np.array([j.endswith(_GROUPS[n]) for j in JOINT_NAMES])
        elif n in LEGS:
            mask |= np.array([j.startswith(n + "_") for j in JOINT_NAMES])
        elif n in ("left", "right"):
            mask |= np.array([f"_{n}_" in j for j in JOINT_NAMES])
        elif n in JOINT_NAMES:
            mask |= np.array([j == n for j in JOINT_NAMES])
        else:
            raise ValueError(f"unknown joint spec {n!r}")
    return np.flatnonzero(mask)


def _leg(leg: str) -> int:
    if leg not in LEGS:
        raise ValueError(f"unknown leg {leg!r}")
    return LEGS.index(leg)


# ----------------------------------------------------------------------------- servo changes
class _ServoChange:
    """A changed PD servo on some joints: every physics step the difference between the
    changed servo's torque and the normal one (from the robot's own gains and limits, on the
    joint state) is added as joint torque."""

    changes_world = False

    def __init__(self, joints: Any) -> None:
        self.joints = _joints(joints)
        self._q_des = np.zeros(N_JOINTS)

    def reset(self, sim: Any) -> None:
        cfg = sim.config
        self._ids = [sim.joint_indices[j] for j in self.joints]
        self._kp = per_joint(cfg.kp)[self.joints]
        self._kd = per_joint(cfg.kd)[self.joints]
        self._lim = per_joint(cfg.torque_limit)[self.joints]

    def command(self, u: np.ndarray, t: float) -> np.ndarray:
        self._q_des = np.clip(u, JOINT_LOWER, JOINT_UPPER)
        return u

    def changed(self, e: np.ndarray, dq: np.ndarray) -> np.ndarray:
        raise NotImplementedError

    def substep(self, sim: Any, t: float) -> None:
        st = p.getJointStates(sim.robot, self._ids, physicsClientId=sim.client)
        q = np.array([s[0] for s in st])
        dq = np.array([s[1] for s in st])
        e = self._q_des[self.joints] - q
        normal = np.clip(self._kp * e - self._kd * dq, -self._lim, self._lim)
        tau = self.changed(e, dq) - normal
        p.setJointMotorControlArray(sim.robot, self._ids, p.TORQUE_CONTROL, forces=tau.tolist(),
                                    physicsClientId=sim.client)


class GearPlay(_ServoChange):
    """Worn gears: within a play of ``width_rad`` the position error drives no torque."""

    def __init__(self, width_rad: float, joints: Any = "all") -> None:
        super().__init__(joints)
        self.width_rad = float(width_rad)

    def changed(self, e, dq):
        h = 0.5 * self.width_rad
        return np.clip(self._kp * (e - np.clip(e, -h, h)) - self._kd * dq, -self._lim, self._lim)


class SoftServo(_ServoChange):
    """The P gain of some joints times ``gain_ratio`` (a mistuned or worn servo)."""

    def __init__(self, gain_ratio: float, joints: Any = "all") -> None:
        super().__init__(joints)
        self.gain_ratio = float(gain_ratio)

    def changed(self, e, dq):
        return np.clip(self.gain_ratio * self._kp * e - self._kd * dq, -self._lim, self._lim)


class CurrentLimit(_ServoChange):
    """The drivers of some joints limit the torque to ``torque_limit_Nm``."""

    def __init__(self, torque_limit_Nm: float, joints: Any = "all") -> None:
        super().__init__(joints)
        self.torque_limit_Nm = float(torque_limit_Nm)

    def changed(self, e, dq):
        lim = np.minimum(self._lim, self.torque_limit_Nm)
        return np.clip(self._kp * e - self._kd * dq, -lim, lim)


class StickyGearbox:
    """Extra Coulomb friction ``coulomb_Nm`` in some joints (dry gearbox), smoothed through zero
    over ``smoothing`` rad/s."""

    changes_world = False

    def __init__(self, coulomb_Nm: float, joints: Any = "all", smoothing: float = 0.03) -> None:
        self.joints = _joints(joints)
        self.coulomb_Nm = float(coulomb_Nm)
        self.smoothing = float(smoothing)

    def reset(self, sim: Any) -> None:
        self._ids = [sim.joint_indices[j] for j in self.joints]

    def substep(self, sim: Any, t: float) -> None:
        st = p.getJointStates(sim.robot, self._ids, physicsClientId=sim.client)
        dq = np.array([s[1] for s in st])
        tau = -self.coulomb_Nm * np.tanh(dq / self.smoothing)
        p.setJointMotorControlArray(sim.robot, self._ids, p.TORQUE_CONTROL, forces=tau.tolist(),
                                    physicsClientId=sim.client)


class ShiftedEncoder:
    """A joint's encoder zeroed wrong: it reads true + ``offset_rad``, and the servo closes its
    loop on it (the joint sits ``offset_rad`` short of the set-point; the reading matches it)."""

    changes_world = False

    def __init__(self, offset_rad: float, joints: Any) -> None:
        self.joints = _joints(joints)
        self.offset_rad = float(offset_rad)

    def command(self, u: np.ndarray, t: float) -> np.ndarray:
        out = u.copy()
        out[self.joints] -= self.offset_rad
        return out

    def measure(self, obs: dict, t: float) -> dict:
        q = obs["q"].copy()
        q[self.joints] += self.offset_rad
        obs["q"] = q
        return obs


class LostPackets:
    """The command link drops packets: a lost packet leaves the servo on the previous set-point.
    Losses come in bursts (a two-state chain: a packet is lost with ``p_loss`` after a received
    one and with ``p_stay`` after a lost one)."""

    changes_world = False

    def __init__(self, p_loss: float, p_stay: float = 0.5, joints: Any = "all") -> None:
        self.p_loss = float(p_loss)
        self.p_stay = float(p_stay)
        self.joints = _joints(joints)
        self._held: np.ndarray | None = None
        self._lost = False
        self._rng = np.random.default_rng(0)

    def reset(self, sim: Any) -> None:
        self._held = None
        self._lost = False
        self._rng = np.random.default_rng(sim.rng.integers(2**63))

    def command(self, u: np.ndarray, t: float) -> np.ndarray:
        if self._held is None:
            self._held = u.copy()
            return u
        self._lost = self._rng.random() < (self.p_stay if self._lost else self.p_loss)
        if not self._lost:
            self._held = u.copy()
        out = u.copy()
        out[self.joints] = self._held[self.joints]
        return out


# ----------------------------------------------------------------------------- body, ground, feet
class InclinedFloor:
    """The floor inclined by ``slope_deg`` rising towards ``uphill_direction_deg`` (odom), gravity
    still along -z; the robot is set down on it where it stands."""

    def __init__(self, slope_deg: float, uphill_direction_deg: float = 0.0) -> None:
        self.slope_deg = float(slope_deg)
        self.uphill_direction_deg = float(uphill_direction_deg)

    def reset(self, sim: Any) -> None:
        c = sim.client
        s, phi = np.radians(self.slope_deg), np.radians(self.uphill_direction_deg)
        quat = p.getQuaternionFromAxisAngle([-np.sin(phi), np.cos(phi), 0.0], -s)
        p.resetBasePositionAndOrientation(sim.plane, [0.0, 0.0, 0.0], quat, physicsClientId=c)
        n = np.array(p.getMatrixFromQuaternion(quat)).reshape(3, 3)[:, 2]
        feet = p.getLinkStates(sim.robot, sim.foot_links, computeForwardKinematics=1,
                               physicsClientId=c)
        lift = max(-(n[0] * f[0][0] + n[1] * f[0][1]) / n[2] for f in feet)
        if lift > 0:
            pos, orn = p.getBasePositionAndOrientation(sim.robot, physicsClientId=c)
            p.resetBasePositionAndOrientation(sim.robot, [pos[0], pos[1], pos[2] + lift], orn,
                                              physicsClientId=c)


class CarriedBox:
    """A box of ``mass_kg`` bolted to the body at ``offset_m`` (base_link)."""

    def __init__(self, mass_kg: float, offset_m: list[float], half_extent_m: float = 0.03) -> None:
        self.mass_kg = float(mass_kg)
        self.offset_m = [float(x) for x in offset_m]
        self.half = float(half_extent_m)

    def reset(self, sim: Any) -> None:
        c = sim.client
        pos, orn = p.getBasePositionAndOrientation(sim.robot, physicsClientId=c)
        world, _ = p.multiplyTransforms(pos, orn, self.offset_m, [0, 0, 0, 1])
        shape = p.createCollisionShape(p.GEOM_BOX, halfExtents=[self.half] * 3,
                                       physicsClientId=c)
        box = p.createMultiBody(self.mass_kg, shape, basePosition=world, baseOrientation=orn,
                                physicsClientId=c)
        p.setCollisionFilterGroupMask(box, -1, 0, 0, physicsClientId=c)
        cid = p.createConstraint(sim.robot, -1, box, -1, p.JOINT_FIXED, [0, 0, 0], self.offset_m,
                                 [0, 0, 0], physicsClientId=c)
        p.changeConstraint(cid, maxForce=1e4, physicsClientId=c)


class WornFootPad:
    """One foot's rubber pad worn: its friction coefficient times ``scale``."""

    def __init__(self, scale: float, leg: str) -> None:
        self.scale = float(scale)
        self.leg = _leg(leg)

    def reset(self, sim: Any) -> None:
        p.changeDynamics(sim.robot, sim.foot_links[self.leg],
                         lateralFriction=sim.config.foot_friction * self.scale,
                         physicsClientId=sim.client)


class SnaggedFoot:
    """A foot dragging through something while it swings (a loose sock, long grass): a
    horizontal force up to ``force_N`` against its velocity, only while it is off the ground."""

    changes_world = False

    def __init__(self, force_N: float, leg: str, speed_m_s: float = 0.05) -> None:
        self.force_N = float(force_N)
        self.leg = _leg(leg)
        self.speed = float(speed_m_s)

    def substep(self, sim: Any, t: float) -> None:
        c = sim.client
        link = sim.foot_links[self.leg]
        if p.getContactPoints(sim.robot, sim.plane, link, -1, physicsClientId=c):
            return
        st = p.getLinkState(sim.robot, link, computeLinkVelocity=1, computeForwardKinematics=1,
                            physicsClientId=c)
        v = np.array(st[6][:2])
        speed = float(np.hypot(*v))
        if speed < 1e-9:
            return
        f = -self.force_N * np.tanh(speed / self.speed) * v / speed
        p.applyExternalForce(sim.robot, link, [float(f[0]), float(f[1]), 0.0], st[0],
                             p.WORLD_FRAME, physicsClientId=c)


class PowerTether:
    """A power tether clipped to the back of the body, anchored where the move starts: once the
    body has gone ``slack_m`` from the start (horizontally), the cable pulls it back with
    ``stiffness_N_m`` per metre beyond that, at the clip point (``attach_m``, base_link)."""

    changes_world = False

    def __init__(self, stiffness_N_m: float, slack_m: float = 0.05,
                 attach_m: list[float] = (-0.1, 0.0, 0.04)) -> None:
        self.k = float(stiffness_N_m)
        self.slack = float(slack_m)
        self.attach = [float(x) for x in attach_m]
        self._anchor = np.zeros(2)

    def reset(self, sim: Any) -> None:
        pos, orn = p.getBasePositionAndOrientation(sim.robot, physicsClientId=sim.client)
        world, _ = p.multiplyTransforms(pos, orn, self.attach, [0, 0, 0, 1])
        self._anchor = np.array(world[:2])

    def substep(self, sim: Any, t: float) -> None:
        c = sim.client
        pos, orn = p.getBasePositionAndOrientation(sim.robot, physicsClientId=c)
        world, _ = p.multiplyTransforms(pos, orn, self.attach, [0, 0, 0, 1])
        d = np.array(world[:2]) - self._anchor
        r = float(np.hypot(*d))
        if r <= self.slack:
            return
        f = -self.k * (r - self.slack) * d / r
        p.applyExternalForce(sim.robot, -1, [float(f[0]), float(f[1]), 0.0], list(world),
                             p.WORLD_FRAME, physicsClientId=c)


class FoamMat:
    """The robot walks on a foam mat: the floor's contact is soft (``stiffness_N_m``,
    ``damping_N_s_m``)."""

    def __init__(self, stiffness_N_m: float, damping_N_s_m: float) -> None:
        self.stiffness = float(stiffness_N_m)
        self.damping = float(damping_N_s_m)

    def reset(self, sim: Any) -> None:
        p.changeDynamics(sim.plane, -1, contactStiffness=self.stiffness,
                         contactDamping=self.damping, physicsClientId=sim.client)


class Nothing:
    """The control: a negligible constant force on the body (0.001 N, odom x)."""

    changes_world = False

    def __init__(self, force_N: float = 0.001) -> None:
        self.force_N = float(force_N)

    def substep(self, sim: Any, t: float) -> None:
        pos, _ = p.getBasePositionAndOrientation(sim.robot, physicsClientId=sim.client)
        p.applyExternalForce(sim.robot, -1, [self.force_N, 0.0, 0.0], pos, p.WORLD_FRAME,
                             physicsClientId=sim.client)
