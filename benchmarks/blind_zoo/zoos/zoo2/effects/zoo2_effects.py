"""Second blind effect zoo: eight faults a real LittleDog could suffer from, as effect plug-ins.

Written blind (without reading the diagnosis or the first zoo). Each class implements some of
the hooks of docs/interface.md section 5: ``reset(sim)``, ``command(u, t)``, ``substep(sim, t)``,
``measure(obs, t)``. Torques applied in ``substep`` with TORQUE_CONTROL add to the robot's own
PD servo torque for that physics step; the servo-modifying effects therefore add the difference
between the faulty servo's torque and the normal one, computed from the joint states.
"""
from __future__ import annotations


import numpy as np
import pybullet as p

from littledog_mlsim.layout import JOINT_LOWER, JOINT_NAMES, JOINT_UPPER, LEGS
from littledog_mlsim.robot.config import per_joint

_TYPES = {"hip_rolls": "hip_roll", "hip_pitches": "hip_pitch", "knees": "knee"}


def select_joints(spec: str) -> np.ndarray:
    """Contract indices named by a joint name, a leg, a type, a side or ``all``."""
    if spec == "all":
        return np.arange(len(JOINT_NAMES))
    if spec in JOINT_NAMES:
        return np.array([JOINT_NAMES.index(spec)])
    if spec in LEGS:
        return np.array([i for i, n in enumerate(JOINT_NAMES) if n.startswith(spec + "_")])
    if spec in _TYPES:
        return np.array([i for i, n in enumerate(JOINT_NAMES) if n.endswith("_" + _TYPES[spec])])
    if spec in ("left", "right"):
        return np.array([i for i, n in enumerate(JOINT_NAMES) if n.split("_")[1] == spec])
    raise ValueError(f"unknown joint selection {spec!r}")


def _joint_states(sim) -> tuple[np.ndarray, np.ndarray]:
    st = p.getJointStates(sim.robot, list(sim.joint_indices), physicsClientId=sim.client)
    return np.array([s[0] for s in st]), np.array([s[1] for s in st])


def _add_joint_torques(sim, idx: np.ndarray, tau: np.ndarray) -> None:
    joints = [sim.joint_indices[i] for i in idx]
    p.setJointMotorControlArray(sim.robot, joints, p.TORQUE_CONTROL, forces=[float(x) for x in tau],
                                physicsClientId=sim.client)


class _ServoTwin:
    """Keeps the latest set-points and computes the normal PD torque from the joint states."""

    def reset(self, sim) -> None:
        cfg = sim.config
        self.kp = per_joint(cfg.kp)
        self.kd = per_joint(cfg.kd)
        self.lim = per_joint(cfg.torque_limit)
        self.u = None

    def command(self, u, t):
        self.u = np.clip(np.asarray(u, dtype=float), JOINT_LOWER, JOINT_UPPER)
        return u

    def error(self, sim) -> tuple[np.ndarray, np.ndarray] | None:
        if self.u is None:
            return None
        q, dq = _joint_states(sim)
        return self.u - q, dq





class BodyYawTorque:
    """A constant torque about the body's vertical axis (e.g. a stiff, twisted tether cable or a
    spinning unbalanced part on the body), fixed in base_link."""

    def __init__(self, torque_Nm: float = 0.05) -> None:
        self.torque = float(torque_Nm)

    def substep(self, sim, t) -> None:
        _, orn = p.getBasePositionAndOrientation(sim.robot, physicsClientId=sim.client)
        R = np.array(p.getMatrixFromQuaternion(orn)).reshape(3, 3)
        p.applyExternalTorque(sim.robot, -1, (R @ np.array([0.0, 0.0, self.torque])).tolist(),
                              p.WORLD_FRAME, physicsClientId=sim.client)


class OffsetPayload:
    """An extra mass strapped to the body at an offset from its centre of mass (base_link axes).

    The base's mass grows by ``mass_kg`` (gravity and inertia at the COM) and a force couple
    moves the payload's weight to ``offset_m``: the torque its weight makes about the COM."""

    def __init__(self, mass_kg: float = 0.3, offset_m=(-0.08, 0.0, 0.03)) -> None:
        self.mass = float(mass_kg)
        self.offset = np.asarray(offset_m, dtype=float)
        self._orig: dict = {}

    def reset(self, sim) -> None:
        key = (sim.client, sim.robot)
        cur = p.getDynamicsInfo(sim.robot, -1, physicsClientId=sim.client)[0]
        orig = self._orig.get(key)
        if orig is None or abs(cur - (orig + self.mass)) > 1e-9:
            orig = cur
            self._orig[key] = orig
        p.changeDynamics(sim.robot, -1, mass=orig + self.mass, physicsClientId=sim.client)

    def substep(self, sim, t) -> None:
        pos, orn = p.getBasePositionAndOrientation(sim.robot, physicsClientId=sim.client)
        R = np.array(p.getMatrixFromQuaternion(orn)).reshape(3, 3)
        w = self.mass * 9.81
        at = (np.asarray(pos) + R @ self.offset).tolist()
        p.applyExternalForce(sim.robot, -1, [0.0, 0.0, -w], at, p.WORLD_FRAME,
                             physicsClientId=sim.client)
        p.applyExternalForce(sim.robot, -1, [0.0, 0.0, w], list(pos), p.WORLD_FRAME,
                             physicsClientId=sim.client)


class ServoGainChange(_ServoTwin):
    """The P gain of some joints' servos is ``gain_ratio`` times the normal one (e.g. a wrong
    firmware gain table); the damping and the torque limit are unchanged."""

    def __init__(self, joints: str = "knees", gain_ratio: float = 0.7) -> None:
        self.idx = select_joints(joints)
        self.ratio = float(gain_ratio)

    def substep(self, sim, t) -> None:
        e = self.error(sim)
        if e is None:
            return
        err, dq = e[0][self.idx], e[1][self.idx]
        kp, kd, lim = self.kp[self.idx], self.kd[self.idx], self.lim[self.idx]
        normal = np.clip(kp * err - kd * dq, -lim, lim)
        faulty = np.clip(self.ratio * kp * err - kd * dq, -lim, lim)
        _add_joint_torques(sim, self.idx, faulty - normal)


class TorqueLimit(_ServoTwin):
    """Some joints' motor drivers limit the current lower than normal: the servo torque saturates
    at ``torque_limit_Nm``."""

    def __init__(self, joints: str = "hip_pitches", torque_limit_Nm: float = 1.0) -> None:
        self.idx = select_joints(joints)
        self.limit = float(torque_limit_Nm)

    def substep(self, sim, t) -> None:
        e = self.error(sim)
        if e is None:
            return
        err, dq = e[0][self.idx], e[1][self.idx]
        kp, kd, lim = self.kp[self.idx], self.kd[self.idx], self.lim[self.idx]
        raw = kp * err - kd * dq
        new_lim = np.minimum(lim, self.limit)
        _add_joint_torques(sim, self.idx, np.clip(raw, -new_lim, new_lim) - np.clip(raw, -lim, lim))


class CommandDelay:
    """Set-points of some joints arrive ``delay_steps`` control steps (10 ms each) late, e.g. a
    second, slower servo board on that part of the robot."""

    def __init__(self, joints: str = "right", delay_steps: int = 3) -> None:
        self.idx = select_joints(joints)
        self.n = int(delay_steps)
        self.buf: list[np.ndarray] = []

    def reset(self, sim) -> None:
        self.buf = []

    def command(self, u, t):
        u = np.array(u, dtype=float)
        self.buf.append(u.copy())
        if len(self.buf) > self.n + 1:
            self.buf.pop(0)
        old = self.buf[0]
        u[self.idx] = old[self.idx]
        return u


class JointCoulombFriction:
    """Extra Coulomb friction in some joints (a damaged or dirty gearbox): a torque of
    ``coulomb_Nm`` opposing the joint's rotation, smoothed below ``v0`` rad/s."""

    def __init__(self, joints: str = "back_right_hip_pitch", coulomb_Nm: float = 0.15,
                 v0: float = 0.05) -> None:
        self.idx = select_joints(joints)
        self.c = float(coulomb_Nm)
        self.v0 = float(v0)

    def substep(self, sim, t) -> None:
        _, dq = _joint_states(sim)
        _add_joint_torques(sim, self.idx, -self.c * np.tanh(dq[self.idx] / self.v0))


class CalibrationOffset:
    """Some joints were zeroed at the wrong angle: each encoder reads true + ``offset_rad``. The
    servo closes its loop on that reading, so the joint really sits ``offset_rad`` short of the
    set-point while the reported angle follows the set-point."""

    def __init__(self, joints: str = "front_right", offset_rad: float = 0.05) -> None:
        self.idx = select_joints(joints)
        self.off = float(offset_rad)

    def command(self, u, t):
        u = np.array(u, dtype=float)
        u[self.idx] -= self.off
        return u

    def measure(self, obs, t):
        q = np.array(obs["q"], dtype=float)
        q[self.idx] += self.off
        obs["q"] = q
        return obs


class StickyFoot:
    """One foot picks up something sticky (mud, tape): from touch-down until the foot has risen
    ``release_height_m`` above where it touched, a downward pull of ``force_N`` holds it."""

    def __init__(self, leg: str = "back_left", force_N: float = 2.0,
                 release_height_m: float = 0.01) -> None:
        if leg not in LEGS:
            raise ValueError(f"unknown leg {leg!r}")
        self.leg = LEGS.index(leg)
        self.force = float(force_N)
        self.h = float(release_height_m)
        self.stuck_z: float | None = None

    def reset(self, sim) -> None:
        self.stuck_z = None

    def substep(self, sim, t) -> None:
        link = sim.foot_links[self.leg]
        z = p.getLinkState(sim.robot, link, physicsClientId=sim.client)[0]
        contact = len(p.getContactPoints(sim.robot, sim.plane, linkIndexA=link,
                                         physicsClientId=sim.client)) > 0
        if contact:
            self.stuck_z = z[2] if self.stuck_z is None else min(self.stuck_z, z[2])
        elif self.stuck_z is not None and z[2] > self.stuck_z + self.h:
            self.stuck_z = None
        if self.stuck_z is not None:
            p.applyExternalForce(sim.robot, link, [0.0, 0.0, -self.force], list(z), p.WORLD_FRAME,
                                 physicsClientId=sim.client)
