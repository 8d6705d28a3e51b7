"""Effect plug-ins written for zoo45 (SEALED). The plug-in protocol of docs/interface.md §5:
``reset(sim)``, ``command(u, t)``, ``substep(sim, t)``, ``measure(obs, t)``.

Servo changes are added as joint torque every physics step: the torque the changed servo would
give minus the torque the robot's own PD gives (both recomputed from the joint state, with the
robot configuration's gains and limits), so that they act on top of the recording robot.
"""
from __future__ import annotations

from collections import deque
from typing import Any

import numpy as np
import pybullet as p

from littledog_mlsim.layout import JOINT_LOWER, JOINT_UPPER, LEGS, N_JOINTS
from littledog_mlsim.robot.config import per_joint
from littledog_mlsim.robot.effects import resolve_joints


def _leg(name: str) -> int:
    if name not in LEGS:
        raise ValueError(f"unknown leg {name!r}")
    return LEGS.index(name)


def _finite(x: Any, what: str) -> float:
    v = float(x)
    if not np.isfinite(v):
        raise ValueError(f"{what} must be finite, got {x!r}")
    return v


class _PDAdd:
    """Base: captures the set-point as the servo gets it and adds ``new - normal`` PD torque on
    the selected joints each physics step."""

    changes_world = False

    def __init__(self, joints: Any) -> None:
        self.joints = resolve_joints(joints)
        self._u = None

    def reset(self, sim: Any) -> None:
        cfg = sim.config
        self._ids = [sim.joint_indices[j] for j in self.joints]
        self._kp = per_joint(cfg.kp)[self.joints]
        self._kd = per_joint(cfg.kd)[self.joints]
        self._lim = per_joint(cfg.torque_limit)[self.joints]
        self._u = None

    def command(self, u: np.ndarray, t: float) -> np.ndarray:
        self._u = np.clip(u, JOINT_LOWER, JOINT_UPPER)[self.joints]
        return u

    def pd(self, e: np.ndarray, dq: np.ndarray) -> np.ndarray:
        return np.clip(self._kp * e - self._kd * dq, -self._lim, self._lim)

    def new_torque(self, q: np.ndarray, dq: np.ndarray, t: float) -> np.ndarray:
        raise NotImplementedError

    def substep(self, sim: Any, t: float) -> None:
        if self._u is None:
            return
        st = p.getJointStates(sim.robot, self._ids, physicsClientId=sim.client)
        q = np.array([s[0] for s in st])
        dq = np.array([s[1] for s in st])
        tau = self.new_torque(q, dq, t) - self.pd(self._u - q, dq)
        p.setJointMotorControlArray(sim.robot, self._ids, p.TORQUE_CONTROL, forces=tau.tolist(),
                                    physicsClientId=sim.client)


class GearboxStribeck:
    """Friction in the gearboxes: Coulomb level ``coulomb_Nm``, a breakaway (static) level
    ``static_Nm`` that falls to the Coulomb level over ``stribeck_rad_s`` of joint speed, and a
    viscous part; smoothed through zero speed over ``smoothing_rad_s``."""

    changes_world = False

    def __init__(self, coulomb_Nm: float, static_Nm: float, stribeck_rad_s: float = 0.3,
                 viscous_Nms: float = 0.0, joints: Any = "all",
                 smoothing_rad_s: float = 0.02) -> None:
        self.fc = _finite(coulomb_Nm, "coulomb_Nm")
        self.fs = _finite(static_Nm, "static_Nm")
        self.vs = _finite(stribeck_rad_s, "stribeck_rad_s")
        self.b = _finite(viscous_Nms, "viscous_Nms")
        self.eps = _finite(smoothing_rad_s, "smoothing_rad_s")
        if not (0 <= self.fc <= self.fs and self.vs > 0 and self.eps > 0):
            raise ValueError("GearboxStribeck: need 0 <= coulomb <= static, speeds > 0")
        self.joints = resolve_joints(joints)

    def reset(self, sim: Any) -> None:
        self._ids = [sim.joint_indices[j] for j in self.joints]

    def substep(self, sim: Any, t: float) -> None:
        st = p.getJointStates(sim.robot, self._ids, physicsClientId=sim.client)
        dq = np.array([s[1] for s in st])
        level = self.fc + (self.fs - self.fc) * np.exp(-(dq / self.vs) ** 2)
        tau = -(level * np.tanh(dq / self.eps) + self.b * dq)
        p.setJointMotorControlArray(sim.robot, self._ids, p.TORQUE_CONTROL, forces=tau.tolist(),
                                    physicsClientId=sim.client)


class MotorSidePlay(_PDAdd):
    """Play of ``width_rad`` in the gear train between the motor (where the encoder sits) and
    the link. The motor's inertia is small, so within the play the motor runs to the set-point
    and the link gets no stiffness torque; beyond it the servo pushes through the gear with the
    play taken up. The encoder, on the motor, reports the link angle plus the motor's position
    within the play (nearer the set-point than the link is)."""

    def __init__(self, width_rad: float, joints: Any) -> None:
        super().__init__(joints)
        self.h = 0.5 * _finite(width_rad, "width_rad")
        if self.h < 0:
            raise ValueError("width_rad must be >= 0")
        self._shift = np.zeros(len(self.joints))

    def reset(self, sim: Any) -> None:
        super().reset(sim)
        self._shift = np.zeros(len(self.joints))

    def new_torque(self, q: np.ndarray, dq: np.ndarray, t: float) -> np.ndarray:
        e = self._u - q
        self._shift = np.clip(e, -self.h, self.h)
        return self.pd(e - self._shift, dq)

    def measure(self, obs: dict, t: float) -> dict:
        q = obs["q"].copy()
        q[self.joints] += self._shift
        obs["q"] = q
        return obs


class LateBusSegment(_PDAdd):
    """The set-points of some joints (one servo bus segment) reach their servos ``delay_ms``
    late, held as they arrive (zero-order hold on the 2 ms servo clock), not at the 10 ms
    command boundaries: before the first arrives the servo holds the move's first command."""

    def __init__(self, delay_ms: float, joints: Any) -> None:
        super().__init__(joints)
        self.delay_s = _finite(delay_ms, "delay_ms") * 1e-3
        if self.delay_s < 0:
            raise ValueError("delay_ms must be >= 0")
        self._hist: deque = deque()
        self._t = 0.0

    def reset(self, sim: Any) -> None:
        super().reset(sim)
        self._hist = deque()

    def command(self, u: np.ndarray, t: float) -> np.ndarray:
        super().command(u, t)
        self._hist.append((t, self._u.copy()))
        return u

    def new_torque(self, q: np.ndarray, dq: np.ndarray, t: float) -> np.ndarray:
        when = t - self.delay_s + 1e-9
        while len(self._hist) > 1 and self._hist[1][0] <= when:
            self._hist.popleft()
        return self.pd(self._hist[0][1] - q, dq)


class MisZeroedJoint:
    """A joint re-zeroed wrongly: its encoder reads the true angle plus ``offset_rad``, and the
    servo, closing its loop on that encoder, holds the joint ``offset_rad`` short of the
    set-point while the reported angle follows the set-point."""

    changes_world = False

    def __init__(self, offset_rad: float, joints: Any) -> None:
        self.offset = _finite(offset_rad, "offset_rad")
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


class InclinedBoard:
    """The robot walks on a board inclined by ``slope_deg`` rising towards
    ``uphill_direction_deg`` (odom), in the level world: the ground plane is turned about the
    horizontal axis through the origin, and the standing robot is turned with it at reset (it
    stands on the board as it stood on the floor)."""

    def __init__(self, slope_deg: float, uphill_direction_deg: float) -> None:
        self.slope = np.radians(_finite(slope_deg, "slope_deg"))
        self.phi = np.radians(_finite(uphill_direction_deg, "uphill_direction_deg"))
        if not abs(self.slope) < np.radians(30):
            raise ValueError("slope_deg must be below 30")

    def rotation(self) -> tuple[list[float], tuple]:
        axis = [float(np.sin(self.phi)), float(-np.cos(self.phi)), 0.0]
        return axis, p.getQuaternionFromAxisAngle(axis, float(self.slope))

    def reset(self, sim: Any) -> None:
        c = sim.client
        _, quat = self.rotation()
        p.resetBasePositionAndOrientation(sim.plane, [0, 0, 0], quat, physicsClientId=c)
        pos, orn = p.getBasePositionAndOrientation(sim.robot, physicsClientId=c)
        lin, ang = p.getBaseVelocity(sim.robot, physicsClientId=c)
        new_pos, new_orn = p.multiplyTransforms([0, 0, 0], quat, pos, orn)
        R = np.array(p.getMatrixFromQuaternion(quat)).reshape(3, 3)
        p.resetBasePositionAndOrientation(sim.robot, new_pos, new_orn, physicsClientId=c)
        p.resetBaseVelocity(sim.robot, (R @ np.array(lin)).tolist(),
                            (R @ np.array(ang)).tolist(), physicsClientId=c)


class ElasticPayload:
    """A payload of ``mass_kg`` on rubber isolators: a point mass held at ``offset_m``
    (base_link) by a spring-damper (``stiffness_N_m``, ``damping_N_s_m``, the same along
    every axis), not rigidly. It makes no contact."""

    def __init__(self, mass_kg: float, offset_m: list[float], stiffness_N_m: float = 4000.0,
                 damping_N_s_m: float = 20.0) -> None:
        self.mass = _finite(mass_kg, "mass_kg")
        self.offset = np.asarray(offset_m, float).reshape(3)
        self.k = _finite(stiffness_N_m, "stiffness_N_m")
        self.c = _finite(damping_N_s_m, "damping_N_s_m")
        if not (self.mass > 0 and self.k > 0 and self.c >= 0):
            raise ValueError("ElasticPayload: mass and stiffness > 0, damping >= 0")
        self.body = -1

    def _anchor(self, sim: Any) -> tuple[np.ndarray, np.ndarray]:
        c = sim.client
        pos, orn = p.getBasePositionAndOrientation(sim.robot, physicsClientId=c)
        R = np.array(p.getMatrixFromQuaternion(orn)).reshape(3, 3)
        r = R @ self.offset
        lin, ang = p.getBaseVelocity(sim.robot, physicsClientId=c)
        return np.array(pos) + r, np.array(lin) + np.cross(np.array(ang), r)

    def reset(self, sim: Any) -> None:
        c = sim.client
        a, v = self._anchor(sim)
        # sag of the mount under the payload's weight, so that it starts at rest
        a = a + np.array([0.0, 0.0, -self.mass * 9.81 / self.k])
        shape = p.createCollisionShape(p.GEOM_SPHERE, radius=0.02, physicsClientId=c)
        self.body = p.createMultiBody(self.mass, shape, basePosition=a.tolist(),
                                      physicsClientId=c)
        p.setCollisionFilterGroupMask(self.body, -1, 0, 0, physicsClientId=c)
        p.changeDynamics(self.body, -1, linearDamping=0.0, angularDamping=0.0,
                         physicsClientId=c)
        p.resetBaseVelocity(self.body, v.tolist(), [0, 0, 0], physicsClientId=c)

    def substep(self, sim: Any, t: float) -> None:
        c = sim.client
        a, va = self._anchor(sim)
        x, _ = p.getBasePositionAndOrientation(self.body, physicsClientId=c)
        vx, _ = p.getBaseVelocity(self.body, physicsClientId=c)
        f = self.k * (a - np.array(x)) + self.c * (va - np.array(vx))   # on the payload
        p.applyExternalForce(self.body, -1, f.tolist(), list(x), p.WORLD_FRAME,
                             physicsClientId=c)
        p.applyExternalForce(sim.robot, -1, (-f).tolist(), a.tolist(), p.WORLD_FRAME,
                             physicsClientId=c)


class ShinGuard:
    """A guard of ``added_kg`` clamped on the lower leg (knee link) of ``leg``: that link's mass
    grows by it, its inertia in proportion."""

    def __init__(self, added_kg: float, leg: str) -> None:
        self.added = _finite(added_kg, "added_kg")
        if self.added <= 0:
            raise ValueError("added_kg must be > 0")
        self.leg = _leg(leg)

    def reset(self, sim: Any) -> None:
        c = sim.client
        link = sim.joint_indices[3 * self.leg + 2]
        mass, _, inertia = p.getDynamicsInfo(sim.robot, link, physicsClientId=c)[:3]
        s = (mass + self.added) / mass
        p.changeDynamics(sim.robot, link, mass=mass + self.added,
                         localInertiaDiagonal=[v * s for v in inertia], physicsClientId=c)


class TapedFoot:
    """A strip of tape stuck under one foot and the floor: it is slack in stance and stretches
    when the foot lifts, pulling it down with ``force_N`` at lift-off, falling linearly to
    nothing once the foot is ``release_m`` above where it stood (the tape peels free); it
    re-sticks at the next touch-down."""

    changes_world = False

    def __init__(self, force_N: float, leg: str, release_m: float = 0.015) -> None:
        self.force = _finite(force_N, "force_N")
        self.release = _finite(release_m, "release_m")
        if not (self.force >= 0 and self.release > 0):
            raise ValueError("force_N >= 0, release_m > 0")
        self.leg = _leg(leg)
        self._z0: float | None = None

    def reset(self, sim: Any) -> None:
        self._z0 = None

    def substep(self, sim: Any, t: float) -> None:
        c = sim.client
        link = sim.foot_links[self.leg]
        st = p.getLinkState(sim.robot, link, computeForwardKinematics=1, physicsClientId=c)
        z = float(st[0][2])
        if p.getContactPoints(sim.robot, sim.plane, link, -1, physicsClientId=c):
            self._z0 = z
            return
        if self._z0 is None:
            return
        rise = z - self._z0
        if rise >= self.release:
            self._z0 = None
            return
        f = self.force * (1.0 - max(rise, 0.0) / self.release)
        p.applyExternalForce(sim.robot, link, [0.0, 0.0, -f], st[0], p.WORLD_FRAME,
                             physicsClientId=c)


class WarmingMotors(_PDAdd):
    """Motors warming as the move goes on: winding resistance rises, so the torque per volt of
    the voltage-mode servo falls, and with it its whole output, stiffness, damping and the
    torque it can reach: s(t) = max(``floor``, 1 + ``rate_per_s`` t) times the normal output
    (each move starts cool)."""

    def __init__(self, rate_per_s: float, joints: Any, floor: float = 0.2) -> None:
        super().__init__(joints)
        self.rate = _finite(rate_per_s, "rate_per_s")
        self.floor = _finite(floor, "floor")

    def new_torque(self, q: np.ndarray, dq: np.ndarray, t: float) -> np.ndarray:
        s = min(1.0, max(self.floor, 1.0 + self.rate * t))
        return s * self.pd(self._u - q, dq)


class BenchTether:
    """A coiled (elastic) power and data cable from a bench beside the test area: anchored
    ``distance_m`` away from where the body starts, towards ``direction_deg`` (odom), at
    ``anchor_height_m`` above the attachment's starting height, fixed to the body at
    ``attach_m`` (base_link). It is just taut at the start; walking away from the bench
    stretches it and it pulls along the cable with ``stiffness_N_m`` per metre of stretch;
    walking towards the bench it hangs slack."""

    changes_world = False

    def __init__(self, stiffness_N_m: float, distance_m: float, direction_deg: float,
                 anchor_height_m: float = 0.2, attach_m: list[float] = (-0.08, 0.0, 0.04)) -> None:
        self.k = _finite(stiffness_N_m, "stiffness_N_m")
        self.dist = _finite(distance_m, "distance_m")
        self.phi = np.radians(_finite(direction_deg, "direction_deg"))
        self.h = _finite(anchor_height_m, "anchor_height_m")
        self.attach = np.asarray(attach_m, float).reshape(3)
        if not (self.k >= 0 and self.dist > 0):
            raise ValueError("stiffness_N_m >= 0, distance_m > 0")
        self._anchor = None
        self._L0 = None

    def _point(self, sim: Any) -> np.ndarray:
        pos, orn = p.getBasePositionAndOrientation(sim.robot, physicsClientId=sim.client)
        R = np.array(p.getMatrixFromQuaternion(orn)).reshape(3, 3)
        return np.array(pos) + R @ self.attach

    def reset(self, sim: Any) -> None:
        a = self._point(sim)
        self._anchor = a + np.array([self.dist * np.cos(self.phi),
                                     self.dist * np.sin(self.phi), self.h])
        self._L0 = float(np.linalg.norm(self._anchor - a))

    def substep(self, sim: Any, t: float) -> None:
        a = self._point(sim)
        d = self._anchor - a
        L = float(np.linalg.norm(d))
        if L <= self._L0:
            return
        f = self.k * (L - self._L0) * d / L
        p.applyExternalForce(sim.robot, -1, f.tolist(), a.tolist(), p.WORLD_FRAME,
                             physicsClientId=sim.client)


class FlakyMotorLead(_PDAdd):
    """A motor lead with a cracked conductor: now and then (Poisson, ``rate_hz``) the joint's
    servo drives nothing for ``min_ms``..``max_ms`` (uniform), then works again. The episodes
    are drawn from the move's generator."""

    def __init__(self, rate_hz: float, joints: Any, min_ms: float = 10.0,
                 max_ms: float = 40.0) -> None:
        super().__init__(joints)
        self.rate = _finite(rate_hz, "rate_hz")
        self.lo, self.hi = _finite(min_ms, "min_ms") * 1e-3, _finite(max_ms, "max_ms") * 1e-3
        self._off: list[tuple[float, float]] = []

    def reset(self, sim: Any) -> None:
        super().reset(sim)
        t, self._off = 0.0, []
        while t < 120.0:
            t += float(sim.rng.exponential(1.0 / self.rate))
            d = float(sim.rng.uniform(self.lo, self.hi))
            self._off.append((t, t + d))
            t += d

    def new_torque(self, q: np.ndarray, dq: np.ndarray, t: float) -> np.ndarray:
        if any(a <= t < b for a, b in self._off):
            return np.zeros(len(self.joints))
        return self.pd(self._u - q, dq)


class WrongGearRatio:
    """A joint rebuilt with a gearbox of another ratio than the firmware assumes: the encoder
    (on the motor) reports ``scale`` times the true joint angle and rate, and the servo, closing
    its loop on it, takes the joint to set-point / ``scale``."""

    changes_world = False

    def __init__(self, scale: float, joints: Any) -> None:
        self.scale = _finite(scale, "scale")
        if self.scale <= 0:
            raise ValueError("scale must be > 0")
        self.joints = resolve_joints(joints)

    def command(self, u: np.ndarray, t: float) -> np.ndarray:
        out = u.copy()
        out[self.joints] = u[self.joints] / self.scale
        return out

    def measure(self, obs: dict, t: float) -> dict:
        for k in ("q", "dq"):
            v = obs[k].copy()
            v[self.joints] *= self.scale
            obs[k] = v
        return obs
