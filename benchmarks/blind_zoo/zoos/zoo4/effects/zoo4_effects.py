"""Effect plug-ins of a sealed blind zoo (see truth.yaml; do not open before your run is scored).

Written against the plug-in protocol of ``docs/interface.md`` section 5 with numpy and pybullet
only: ``reset(sim)`` after the robot has settled, ``command(u, t)`` once per 10 ms control step,
``substep(sim, t)`` before every physics step, ``measure(obs, t)`` on every recorded sample.
Extra joint torques are added with TORQUE_CONTROL, which pybullet accumulates with the servo's own
torque until the next ``stepSimulation``; external forces are re-applied on every physics step.
"""
from __future__ import annotations

import numpy as np
import pybullet as p

from littledog_mlsim.layout import JOINT_NAMES, LEGS

GRAVITY = 9.81
_GROUPS = {
    "all": list(JOINT_NAMES),
    "hip_rolls": [n for n in JOINT_NAMES if n.endswith("hip_roll")],
    "hip_pitches": [n for n in JOINT_NAMES if n.endswith("hip_pitch")],
    "knees": [n for n in JOINT_NAMES if n.endswith("knee")],
    "left": [n for n in JOINT_NAMES if "_left_" in n],
    "right": [n for n in JOINT_NAMES if "_right_" in n],
}


def joint_mask(joints: str | list[str]) -> np.ndarray:
    """Boolean (12,) mask of a joint name, a leg, a group, or a list of those."""
    items = [joints] if isinstance(joints, str) else list(joints)
    mask = np.zeros(len(JOINT_NAMES), dtype=bool)
    for item in items:
        if item in _GROUPS:
            names = _GROUPS[item]
        elif item in LEGS:
            names = [f"{item}_{j}" for j in ("hip_roll", "hip_pitch", "knee")]
        elif item in JOINT_NAMES:
            names = [item]
        else:
            raise ValueError(f"zoo4 effect: unknown joint selector {item!r}")
        mask[[JOINT_NAMES.index(n) for n in names]] = True
    return mask


def _per_joint(triple) -> np.ndarray:
    return np.tile(np.broadcast_to(np.asarray(triple, dtype=float), (3,)), 4)


def _joint_state(sim) -> tuple[np.ndarray, np.ndarray]:
    st = p.getJointStates(sim.robot, list(sim.joint_indices), physicsClientId=sim.client)
    return np.array([s[0] for s in st]), np.array([s[1] for s in st])


class _Base:
    def reset(self, sim) -> None:
        pass

    def command(self, u: np.ndarray, t: float) -> np.ndarray:
        return u

    def substep(self, sim, t: float) -> None:
        pass

    def measure(self, obs: dict, t: float) -> dict:
        return obs


class Lag(_Base):
    """Set-points of the selected joints pass a first-order low-pass (time constant in s)."""

    def __init__(self, tau: float, joints="all") -> None:
        self.tau, self.mask, self.y = float(tau), joint_mask(joints), None

    def reset(self, sim) -> None:
        self.a = 1.0 - np.exp(-sim.control_dt / self.tau)
        self.y = None

    def command(self, u, t):
        u = np.asarray(u, dtype=float)
        if self.y is None:
            self.y = u.copy()
        else:
            self.y = self.y + self.a * (u - self.y)
        out = u.copy()
        out[self.mask] = self.y[self.mask]
        return out


class Late(_Base):
    """Set-points of the selected joints arrive a whole number of control steps late."""

    def __init__(self, steps: int, joints="all") -> None:
        self.steps, self.mask, self.buf = int(steps), joint_mask(joints), []

    def reset(self, sim) -> None:
        self.buf = []

    def command(self, u, t):
        u = np.asarray(u, dtype=float)
        self.buf.append(u.copy())
        old = self.buf.pop(0) if len(self.buf) > self.steps else self.buf[0]
        out = u.copy()
        out[self.mask] = old[self.mask]
        return out


class Bias(_Base):
    """A mis-zeroed encoder: the servo closes its loop on (true + offset), so the joint settles at
    (set-point - offset), and the recording reports (true + offset)."""

    def __init__(self, offset: float, joints="all") -> None:
        self.off = float(offset) * joint_mask(joints)

    def command(self, u, t):
        return np.asarray(u, dtype=float) - self.off

    def measure(self, obs, t):
        obs = dict(obs)
        obs["q"] = np.asarray(obs["q"], dtype=float) + self.off
        return obs


class _ServoShape(_Base):
    """Re-shapes the robot's PD torque on the selected joints by adding (wanted - normal)."""

    def __init__(self, joints="all") -> None:
        self.mask = joint_mask(joints)
        self.q_des = None

    def reset(self, sim) -> None:
        cfg = sim.config
        self.kp, self.kd = _per_joint(cfg.kp), _per_joint(cfg.kd)
        self.lim = _per_joint(cfg.torque_limit)
        self.q_des = None

    def command(self, u, t):
        self.q_des = np.asarray(u, dtype=float).copy()
        return u

    def wanted(self, e, dq, t):
        raise NotImplementedError

    def substep(self, sim, t):
        if self.q_des is None:
            return
        q, dq = _joint_state(sim)
        e = self.q_des - q
        normal = np.clip(self.kp * e - self.kd * dq, -self.lim, self.lim)
        extra = np.where(self.mask, self.wanted(e, dq, t) - normal, 0.0)
        p.setJointMotorControlArray(sim.robot, list(sim.joint_indices), p.TORQUE_CONTROL,
                                    forces=extra.tolist(), physicsClientId=sim.client)


class Soft(_ServoShape):
    """Servo P gain times ``ratio`` on the selected joints."""

    def __init__(self, ratio: float, joints="all") -> None:
        super().__init__(joints)
        self.ratio = float(ratio)

    def wanted(self, e, dq, t):
        return np.clip(self.ratio * self.kp * e - self.kd * dq, -self.lim, self.lim)


class Cap(_ServoShape):
    """Servo torque limited to ``limit`` N m on the selected joints."""

    def __init__(self, limit: float, joints="all") -> None:
        super().__init__(joints)
        self.limit = float(limit)

    def wanted(self, e, dq, t):
        lim = np.minimum(self.lim, self.limit)
        return np.clip(self.kp * e - self.kd * dq, -lim, lim)


class Sticky(_Base):
    """Coulomb friction ``coulomb`` N m on the selected joints, as pybullet's implicit velocity
    motor with target 0 and force limit ``coulomb`` (re-set every physics step)."""

    def __init__(self, coulomb: float, joints="all") -> None:
        self.c, self.mask = float(coulomb), joint_mask(joints)

    def substep(self, sim, t):
        idx = [j for j, m in zip(sim.joint_indices, self.mask) if m]
        p.setJointMotorControlArray(sim.robot, idx, p.VELOCITY_CONTROL,
                                    targetVelocities=[0.0] * len(idx), forces=[self.c] * len(idx),
                                    physicsClientId=sim.client)


class WorldPush(_Base):
    """A steady horizontal force fixed in the world, at the body's centre of mass."""

    def __init__(self, force: float, direction_deg: float) -> None:
        a = np.radians(direction_deg)
        self.f = [force * np.cos(a), force * np.sin(a), 0.0]

    def substep(self, sim, t):
        pos, _ = p.getBasePositionAndOrientation(sim.robot, physicsClientId=sim.client)
        p.applyExternalForce(sim.robot, -1, self.f, pos, p.WORLD_FRAME, physicsClientId=sim.client)


class BodyPull(_Base):
    """A steady force fixed in base_link (horizontal in that frame), at the centre of mass."""

    def __init__(self, force: float, direction_deg: float) -> None:
        a = np.radians(direction_deg)
        self.f_b = np.array([force * np.cos(a), force * np.sin(a), 0.0])

    def substep(self, sim, t):
        pos, orn = p.getBasePositionAndOrientation(sim.robot, physicsClientId=sim.client)
        r = np.array(p.getMatrixFromQuaternion(orn)).reshape(3, 3)
        p.applyExternalForce(sim.robot, -1, (r @ self.f_b).tolist(), pos, p.WORLD_FRAME,
                             physicsClientId=sim.client)


class Incline(_Base):
    """The floor is a plane inclined by ``slope_deg`` (uphill towards ``uphill_deg`` in the
    world); gravity stays along -z. At the start of a move the settled robot is carried onto the
    inclined floor rigidly (same stance relative to the floor, same world x, y)."""

    def __init__(self, slope_deg: float, uphill_deg: float) -> None:
        s, a = np.radians(slope_deg), np.radians(uphill_deg)
        # Tilt about the horizontal axis (uphill x z) so that the floor's height grows along
        # (cos a, sin a, 0): its normal leans away from the uphill direction.
        axis = [np.sin(a), -np.cos(a), 0.0]
        self.orn = p.getQuaternionFromAxisAngle(axis, s)

    def reset(self, sim):
        c = sim.client
        rp, ro = p.getBasePositionAndOrientation(sim.robot, physicsClientId=c)
        fp, fo = p.getBasePositionAndOrientation(sim.plane, physicsClientId=c)
        ifp, ifo = p.invertTransform(fp, fo)
        loc, _ = p.multiplyTransforms(ifp, ifo, rp, [0, 0, 0, 1])
        g_old = p.multiplyTransforms(fp, fo, [loc[0], loc[1], 0.0], [0, 0, 0, 1])
        g_new = ([rp[0], rp[1], 0.0], self.orn)
        ig = p.invertTransform(*g_old)
        rel = p.multiplyTransforms(g_new[0], g_new[1], ig[0], ig[1])
        np_, no = p.multiplyTransforms(rel[0], rel[1], rp, ro)
        p.resetBasePositionAndOrientation(sim.plane, g_new[0], g_new[1], physicsClientId=c)
        p.resetBasePositionAndOrientation(sim.robot, np_, no, physicsClientId=c)
        p.resetBaseVelocity(sim.robot, [0, 0, 0], [0, 0, 0], physicsClientId=c)


class Load(_Base):
    """A rigid payload of ``mass`` kg carried at ``offset`` (base_link) from the body's centre of
    mass: the base's mass and inertia grow (parallel-axis term included) and the payload's weight
    acts at its own position (a force couple moves the weight's line of action to the offset)."""

    def __init__(self, mass: float, offset) -> None:
        self.m, self.r = float(mass), np.asarray(offset, dtype=float)
        self.done = False

    def reset(self, sim):
        c = sim.client
        if not self.done:
            info = p.getDynamicsInfo(sim.robot, -1, physicsClientId=c)
            m0, inertia = info[0], np.asarray(info[2])
            r = self.r
            add = self.m * np.array([r[1] ** 2 + r[2] ** 2, r[0] ** 2 + r[2] ** 2,
                                     r[0] ** 2 + r[1] ** 2])
            p.changeDynamics(sim.robot, -1, mass=m0 + self.m,
                             localInertiaDiagonal=(inertia + add).tolist(), physicsClientId=c)
            self.done = True

    def substep(self, sim, t):
        c = sim.client
        pos, orn = p.getBasePositionAndOrientation(sim.robot, physicsClientId=c)
        rot = np.array(p.getMatrixFromQuaternion(orn)).reshape(3, 3)
        w = self.m * GRAVITY
        at = (np.asarray(pos) + rot @ self.r).tolist()
        p.applyExternalForce(sim.robot, -1, [0, 0, -w], at, p.WORLD_FRAME, physicsClientId=c)
        p.applyExternalForce(sim.robot, -1, [0, 0, w], pos, p.WORLD_FRAME, physicsClientId=c)


class FootPad(_Base):
    """One foot's friction coefficient times ``scale`` (a worn or dirty pad)."""

    def __init__(self, leg: str, scale: float) -> None:
        self.k, self.scale, self.base = LEGS.index(leg), float(scale), None

    def reset(self, sim):
        link = sim.foot_links[self.k]
        if self.base is None:
            self.base = p.getDynamicsInfo(sim.robot, link, physicsClientId=sim.client)[1]
        p.changeDynamics(sim.robot, link, lateralFriction=self.base * self.scale,
                         physicsClientId=sim.client)


class SwingSnag(_Base):
    """While one foot is off the ground, a horizontal drag of ``force`` N opposes its horizontal
    velocity (full above ``v_ref`` m/s, proportional below), applied at the foot."""

    def __init__(self, leg: str, force: float, v_ref: float = 0.05) -> None:
        self.k, self.f, self.v_ref = LEGS.index(leg), float(force), float(v_ref)

    def substep(self, sim, t):
        c, link = sim.client, sim.foot_links[self.k]
        if p.getContactPoints(sim.robot, sim.plane, link, -1, physicsClientId=c):
            return
        st = p.getLinkState(sim.robot, link, computeLinkVelocity=1, physicsClientId=c)
        v = np.array(st[6][:2])
        n = float(np.hypot(*v))
        if n < 1e-9:
            return
        f = -self.f * v / max(n, self.v_ref)
        p.applyExternalForce(sim.robot, link, [f[0], f[1], 0.0], st[0], p.WORLD_FRAME,
                             physicsClientId=c)
