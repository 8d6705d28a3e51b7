"""Effect plug-ins of the thirty-first blind zoo (docs/interface.md section 5).

Written for this zoo by its author; each effects file `effects/zNN.yaml` switches on one of
them. Servo changes are applied as the difference between the changed servo's torque and the
robot's normal PD torque (computed from the joint state with the robot configuration's gains
and limits), added every physics step.
"""
from __future__ import annotations

from collections import deque
from typing import Any

import numpy as np
import pybullet as p

from littledog_mlsim.layout import JOINT_LOWER, JOINT_UPPER, JOINT_NAMES, LEGS, N_JOINTS
from littledog_mlsim.robot.config import per_joint


def _joints(spec: str | list[str]) -> np.ndarray:
    """Indices (contract order) of joints named by a leg, a side, a kind, a name or 'all'."""
    names = [spec] if isinstance(spec, str) else list(spec)
    sel = np.zeros(N_JOINTS, dtype=bool)
    kinds = {"hip_rolls": "_hip_roll", "hip_pitches": "_hip_pitch", "knees": "_knee"}
    for n in names:
        if n == "all":
            sel[:] = True
        elif n in kinds:
            sel |= np.array([j.endswith(kinds[n]) for j in JOINT_NAMES])
        elif n in ("left", "right"):
            sel |= np.array([f"_{n}_" in j for j in JOINT_NAMES])
        elif n in LEGS:
            sel |= np.array([j.startswith(n + "_") for j in JOINT_NAMES])
        elif n in JOINT_NAMES:
            sel |= np.array([j == n for j in JOINT_NAMES])
        else:
            raise ValueError(f"unknown joint selection {n!r}")
    return np.flatnonzero(sel)


def _leg(name: str) -> int:
    if name not in LEGS:
        raise ValueError(f"unknown leg {name!r}")
    return LEGS.index(name)


class _ServoPatch:
    """Base of a changed PD servo on some joints: subclasses give :meth:`changed`."""

    changes_world = False

    def __init__(self, joints: str | list[str]) -> None:
        self.sel = _joints(joints)
        self._q_des = np.zeros(N_JOINTS)

    def reset(self, sim: Any) -> None:
        cfg = sim.config
        self._ids = [sim.joint_indices[j] for j in self.sel]
        self._kp = per_joint(cfg.kp)[self.sel]
        self._kd = per_joint(cfg.kd)[self.sel]
        self._lim = per_joint(cfg.torque_limit)[self.sel]

    def command(self, u: np.ndarray, t: float) -> np.ndarray:
        self._q_des = np.clip(u, JOINT_LOWER, JOINT_UPPER)
        return u

    def changed(self, e: np.ndarray, dq: np.ndarray, t: float) -> np.ndarray:
        raise NotImplementedError

    def substep(self, sim: Any, t: float) -> None:
        st = p.getJointStates(sim.robot, self._ids, physicsClientId=sim.client)
        q = np.array([s[0] for s in st])
        dq = np.array([s[1] for s in st])
        e = self._q_des[self.sel] - q
        normal = np.clip(self._kp * e - self._kd * dq, -self._lim, self._lim)
        extra = self.changed(e, dq, t) - normal
        p.setJointMotorControlArray(sim.robot, self._ids, p.TORQUE_CONTROL,
                                    forces=extra.tolist(), physicsClientId=sim.client)


class BoardGain(_ServoPatch):
    """The motor board of some joints runs its position loop with a P gain ``gain_ratio`` times
    the normal one (a wrong parameter flashed on a replacement board); damping and the current
    limit are unchanged."""

    def __init__(self, gain_ratio: float, joints: str | list[str]) -> None:
        super().__init__(joints)
        self.gain_ratio = float(gain_ratio)

    def changed(self, e, dq, t):
        return np.clip(self.gain_ratio * self._kp * e - self._kd * dq, -self._lim, self._lim)


class SupplySag(_ServoPatch):
    """The motor supply sags under load from the start of each move (an aged battery pack with
    a high-resistance cell, whose polarisation recovers while the robot rests between moves):
    every servo's output torque, current limit included, scales by 1 + rate_per_s * t
    (t since the move started), floored at ``floor``."""

    def __init__(self, rate_per_s: float, joints: str | list[str] = "all",
                 floor: float = 0.5) -> None:
        super().__init__(joints)
        self.rate_per_s = float(rate_per_s)
        self.floor = float(floor)

    def changed(self, e, dq, t):
        s = max(self.floor, 1.0 + self.rate_per_s * t)
        return s * np.clip(self._kp * e - self._kd * dq, -self._lim, self._lim)


class GearPlay(_ServoPatch):
    """Play of ``width_rad`` in the gear train between motor and joint: within +-width/2 of
    the set-point the motor is not in mesh with the output, which then gets neither the
    stiffness nor the damping of the servo; out of it the servo acts on the error beyond the
    play (meshing blended in over ``blend`` of the half width)."""

    def __init__(self, width_rad: float, joints: str | list[str], blend: float = 0.3) -> None:
        super().__init__(joints)
        self.width_rad = float(width_rad)
        self.blend = float(blend)

    def changed(self, e, dq, t):
        h = 0.5 * self.width_rad
        beyond = e - np.clip(e, -h, h)
        mesh = np.clip(np.abs(beyond) / (self.blend * h), 0.0, 1.0) if h > 0 else 1.0
        return np.clip(self._kp * beyond - mesh * self._kd * dq, -self._lim, self._lim)


class GearboxFriction:
    """Dry friction in some joints' gearboxes: a torque -coulomb_Nm * tanh(dq / v0)."""

    changes_world = False

    def __init__(self, coulomb_Nm: float, joints: str | list[str], v0: float = 0.02) -> None:
        self.sel = _joints(joints)
        self.coulomb_Nm = float(coulomb_Nm)
        self.v0 = float(v0)

    def reset(self, sim: Any) -> None:
        self._ids = [sim.joint_indices[j] for j in self.sel]

    def substep(self, sim: Any, t: float) -> None:
        st = p.getJointStates(sim.robot, self._ids, physicsClientId=sim.client)
        dq = np.array([s[1] for s in st])
        tau = -self.coulomb_Nm * np.tanh(dq / self.v0)
        p.setJointMotorControlArray(sim.robot, self._ids, p.TORQUE_CONTROL,
                                    forces=tau.tolist(), physicsClientId=sim.client)


class LateBus:
    """Set-points of some joints reach their board ``steps`` control cycles late (a second,
    daisy-chained bus); before that the first set-point of the move is held."""

    changes_world = False

    def __init__(self, steps: int, joints: str | list[str]) -> None:
        self.steps = int(steps)
        self.sel = _joints(joints)
        self._h: deque = deque()

    def reset(self, sim: Any) -> None:
        self._h = deque()

    def command(self, u: np.ndarray, t: float) -> np.ndarray:
        if not self._h:
            for _ in range(self.steps):
                self._h.append(u.copy())
        self._h.append(u.copy())
        old = self._h.popleft()
        out = u.copy()
        out[self.sel] = old[self.sel]
        return out


class ZeroShift:
    """An encoder re-zeroed wrong after reassembly: it reads true angle + ``offset_rad``, and
    the joint's servo closes its loop on the same reading."""

    changes_world = False

    def __init__(self, offset_rad: float, joint: str) -> None:
        self.offset_rad = float(offset_rad)
        self.sel = _joints(joint)

    def command(self, u: np.ndarray, t: float) -> np.ndarray:
        out = u.copy()
        out[self.sel] -= self.offset_rad
        return out

    def measure(self, obs: dict, t: float) -> dict:
        q = obs["q"].copy()
        q[self.sel] += self.offset_rad
        obs["q"] = q
        return obs


class StrappedBox:
    """A box of ``mass_kg`` (size ``size_m``) strapped rigidly to the body with its centre at
    ``offset_m`` (base_link); it touches nothing."""

    def __init__(self, mass_kg: float, offset_m: list[float],
                 size_m: list[float] = (0.12, 0.08, 0.04)) -> None:
        self.mass_kg = float(mass_kg)
        self.offset_m = [float(x) for x in offset_m]
        self.size_m = [float(x) for x in size_m]

    def reset(self, sim: Any) -> None:
        c = sim.client
        pos, orn = p.getBasePositionAndOrientation(sim.robot, physicsClientId=c)
        world, _ = p.multiplyTransforms(pos, orn, self.offset_m, [0, 0, 0, 1])
        shape = p.createCollisionShape(p.GEOM_BOX, halfExtents=[0.5 * s for s in self.size_m],
                                       physicsClientId=c)
        body = p.createMultiBody(self.mass_kg, shape, basePosition=world, baseOrientation=orn,
                                 physicsClientId=c)
        p.setCollisionFilterGroupMask(body, -1, 0, 0, physicsClientId=c)
        lin, ang = p.getBaseVelocity(sim.robot, physicsClientId=c)
        p.resetBaseVelocity(body, lin, ang, physicsClientId=c)
        cid = p.createConstraint(sim.robot, -1, body, -1, p.JOINT_FIXED, [0, 0, 0],
                                 self.offset_m, [0, 0, 0], physicsClientId=c)
        p.changeConstraint(cid, maxForce=5e4, physicsClientId=c)


class TetherPull:
    """A cable tethered to the back of the body, led away over a pulley far off: a constant
    horizontal pull ``force_N`` towards ``direction_deg`` (odom), at ``attach_m`` (base_link)."""

    changes_world = False

    def __init__(self, force_N: float, direction_deg: float,
                 attach_m: list[float] = (-0.09, 0.0, 0.035)) -> None:
        a = np.radians(float(direction_deg))
        self.force = [float(force_N) * np.cos(a), float(force_N) * np.sin(a), 0.0]
        self.attach = [float(x) for x in attach_m]

    def substep(self, sim: Any, t: float) -> None:
        c = sim.client
        pos, orn = p.getBasePositionAndOrientation(sim.robot, physicsClientId=c)
        point, _ = p.multiplyTransforms(pos, orn, self.attach, [0, 0, 0, 1])
        p.applyExternalForce(sim.robot, -1, self.force, point, p.WORLD_FRAME,
                             physicsClientId=c)


class FootSnag:
    """A loose strap caught on one foot drags on the floor while that foot swings: a
    horizontal force of up to ``force_N`` against the foot's horizontal velocity
    (tanh-smoothed over ``speed_m_s``); none while the foot touches the ground."""

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
        st = p.getLinkState(sim.robot, link, computeLinkVelocity=1,
                            computeForwardKinematics=1, physicsClientId=c)
        v = np.array(st[6][:2])
        speed = float(np.hypot(*v))
        if speed < 1e-9:
            return
        f = -self.force_N * np.tanh(speed / self.speed) * v / speed
        p.applyExternalForce(sim.robot, link, [float(f[0]), float(f[1]), 0.0], st[0],
                             p.WORLD_FRAME, physicsClientId=c)


class PoseLatency:
    """The motion-capture pose (and the twist differentiated from it) reaches the recording
    ``steps`` control steps later than the joint readings of the same stamp (the capture
    system's processing and network latency, not compensated)."""

    changes_world = False
    BODY = ("position", "orientation", "linear_velocity", "angular_velocity")

    def __init__(self, steps: int) -> None:
        self.steps = int(steps)
        self._h: deque = deque()

    def reset(self, sim: Any) -> None:
        self._h = deque()

    def measure(self, obs: dict, t: float) -> dict:
        now = {k: np.array(obs[k], dtype=float).copy() for k in self.BODY}
        if not self._h:
            for _ in range(self.steps):
                self._h.append({k: v.copy() for k, v in now.items()})
        self._h.append(now)
        old = self._h.popleft()
        out = dict(obs)
        out.update(old)
        return out


class SoftMat:
    """The robot walks on a foam mat: the floor's contact stiffness ``stiffness_N_m`` and
    damping ``damping_N_s_m`` instead of a rigid floor."""

    def __init__(self, stiffness_N_m: float, damping_N_s_m: float) -> None:
        self.k = float(stiffness_N_m)
        self.d = float(damping_N_s_m)

    def reset(self, sim: Any) -> None:
        p.changeDynamics(sim.plane, -1, contactStiffness=self.k, contactDamping=self.d,
                         physicsClientId=sim.client)


class GlossySheet:
    """A thin glossy sheet taped to the floor over a rectangle (odom x from ``x_min_m`` to
    ``x_max_m``, y from ``y_min_m`` to ``y_max_m``), ``thickness_m`` thick, with friction
    coefficient ``friction`` (the floor keeps its own elsewhere)."""

    def __init__(self, friction: float, x_min_m: float, x_max_m: float, y_min_m: float,
                 y_max_m: float, thickness_m: float = 0.001) -> None:
        self.friction = float(friction)
        self.box = (float(x_min_m), float(x_max_m), float(y_min_m), float(y_max_m))
        self.t = float(thickness_m)

    def reset(self, sim: Any) -> None:
        c = sim.client
        x0, x1, y0, y1 = self.box
        half = [0.5 * (x1 - x0), 0.5 * (y1 - y0), 0.5 * self.t]
        shape = p.createCollisionShape(p.GEOM_BOX, halfExtents=half, physicsClientId=c)
        body = p.createMultiBody(0, shape, basePosition=[0.5 * (x0 + x1), 0.5 * (y0 + y1),
                                                         0.5 * self.t], physicsClientId=c)
        p.changeDynamics(body, -1, lateralFriction=self.friction, physicsClientId=c)
