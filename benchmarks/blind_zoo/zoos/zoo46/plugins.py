"""zoo46's effect plug-ins (SEALED), written for this zoo (docs/interface.md section 5).

None of these is, or subclasses, a built-in effect of ``littledog_mlsim.robot.effects``. They
use only the plug-in protocol (``reset``, ``command``, ``substep``, ``measure``), pybullet, the
robot's configuration and the layout's names.
"""
from __future__ import annotations

from typing import Any, Iterable

import numpy as np
import pybullet as p

from littledog_mlsim.layout import CONTROL_DT, JOINT_LOWER, JOINT_NAMES, JOINT_UPPER, LEGS
from littledog_mlsim.robot.config import per_joint
from littledog_mlsim.robot.sensors import twist_from_poses

_GROUPS = {
    "all": lambda n: True,
    "hip_rolls": lambda n: n.endswith("_hip_roll"),
    "hip_pitches": lambda n: n.endswith("_hip_pitch"),
    "knees": lambda n: n.endswith("_knee"),
    "left": lambda n: "_left_" in n,
    "right": lambda n: "_right_" in n,
    "front": lambda n: n.startswith("front_"),
    "back": lambda n: n.startswith("back_"),
}


def joint_ids(spec: str | Iterable[str]) -> np.ndarray:
    """Contract indices of the joints a name, a leg or a group names (sorted)."""
    names = [spec] if isinstance(spec, str) else list(spec)
    keep = set()
    for s in names:
        if s in _GROUPS:
            keep |= {i for i, n in enumerate(JOINT_NAMES) if _GROUPS[s](n)}
        elif s in LEGS:
            keep |= {i for i, n in enumerate(JOINT_NAMES) if n.startswith(s + "_")}
        elif s in JOINT_NAMES:
            keep.add(JOINT_NAMES.index(s))
        else:
            raise ValueError(f"unknown joint, leg or group {s!r}")
    return np.array(sorted(keep), dtype=int)


def leg_id(leg: str) -> int:
    if leg not in LEGS:
        raise ValueError(f"unknown leg {leg!r}")
    return LEGS.index(leg)


# ------------------------------------------------------------------------------ servo patches
class _ServoPatch:
    """Changes what the joint servo of some joints does, as a torque added every physics step:
    the servo's own torque (recomputed from the joint state with the robot's gains and limits)
    is replaced by :meth:`torque`."""

    changes_world = False

    def __init__(self, joints: str | list[str]) -> None:
        self.idx = joint_ids(joints)
        self._qdes = None

    def reset(self, sim: Any) -> None:
        cfg = sim.config
        self._ids = [sim.joint_indices[j] for j in self.idx]
        self.kp = per_joint(cfg.kp)[self.idx]
        self.kd = per_joint(cfg.kd)[self.idx]
        self.lim = per_joint(cfg.torque_limit)[self.idx]
        self._qdes = None

    def command(self, u: np.ndarray, t: float) -> np.ndarray:
        self._qdes = np.clip(u, JOINT_LOWER, JOINT_UPPER)[self.idx]
        return u

    def _state(self, sim: Any) -> tuple[np.ndarray, np.ndarray]:
        st = p.getJointStates(sim.robot, self._ids, physicsClientId=sim.client)
        return np.array([s[0] for s in st]), np.array([s[1] for s in st])

    def normal(self, q: np.ndarray, dq: np.ndarray) -> np.ndarray:
        return np.clip(self.kp * (self._qdes - q) - self.kd * dq, -self.lim, self.lim)

    def torque(self, q: np.ndarray, dq: np.ndarray, t: float) -> np.ndarray:
        raise NotImplementedError

    def substep(self, sim: Any, t: float) -> None:
        if self._qdes is None:
            return
        q, dq = self._state(sim)
        extra = self.torque(q, dq, t) - self.normal(q, dq)
        p.setJointMotorControlArray(sim.robot, self._ids, p.TORQUE_CONTROL,
                                    forces=extra.tolist(), physicsClientId=sim.client)


class DetunedStiffness(_ServoPatch):
    """The P gain of some joints' servos is ``ratio`` times the configured one (a driver's gain
    register set wrong); damping and torque limit unchanged."""

    def __init__(self, ratio: float, joints: str | list[str]) -> None:
        super().__init__(joints)
        self.ratio = float(ratio)

    def torque(self, q, dq, t):
        return np.clip(self.ratio * self.kp * (self._qdes - q) - self.kd * dq,
                       -self.lim, self.lim)


class BatteryDroop(_ServoPatch):
    """A tired battery whose voltage droops under the trot's load: the servos' whole output
    (P and D torque and the torque they can reach, a voltage-mode PWM drive) scales with
    1 + ``rate_per_s`` * t (t since the move started; floored at 0.3), recovering while the
    robot stands between moves."""

    def __init__(self, rate_per_s: float, joints: str | list[str] = "all") -> None:
        super().__init__(joints)
        self.rate = float(rate_per_s)

    def torque(self, q, dq, t):
        s = min(1.0, max(0.3, 1.0 + self.rate * t))
        return s * self.normal(q, dq)


class HalfBridgeFault(_ServoPatch):
    """A degraded half of one joint's H-bridge (a switch with a high on-resistance): torque of
    sign ``sign`` comes out ``ratio`` times as large as the servo asks; the other direction is
    unaffected."""

    def __init__(self, ratio: float, joints: str | list[str], sign: int = 1) -> None:
        super().__init__(joints)
        self.ratio = float(ratio)
        self.sign = 1.0 if sign >= 0 else -1.0

    def torque(self, q, dq, t):
        tau = self.normal(q, dq)
        return np.where(self.sign * tau > 0, self.ratio * tau, tau)


class GearPlayMotorEncoder:
    """Play of ``width_rad`` (at the joint) in the gearbox between a joint's motor and its link.
    The encoder sits on the motor (as on the robot) and the servo closes its loop on it: the
    motor (its reflected inertia the configured rotor inertia) runs freely within the play
    under the servo's torque, and drives the link only while it bears on one side of it
    (inelastic contact). The reported angle and rate are the motor's."""

    changes_world = False

    def __init__(self, width_rad: float, joints: str | list[str]) -> None:
        self.half = 0.5 * float(width_rad)
        self.idx = joint_ids(joints)

    def reset(self, sim: Any) -> None:
        cfg = sim.config
        n = len(self.idx)
        self._ids = [sim.joint_indices[j] for j in self.idx]
        self.kp = per_joint(cfg.kp)[self.idx]
        self.kd = per_joint(cfg.kd)[self.idx]
        self.lim = per_joint(cfg.torque_limit)[self.idx]
        self.jm = np.maximum(per_joint(cfg.armature)[self.idx], 2e-4)
        self.dt = sim.physics_dt
        f = cfg.rate_filter_hz
        self.alpha = 1.0 if f is None else 1.0 - np.exp(-2.0 * np.pi * f * self.dt)
        self.d = np.zeros(n)        # motor minus link, in joint units
        self.dd = np.zeros(n)       # its rate
        self.dd_f = np.zeros(n)     # its rate as the encoder filter reports it
        self._qdes = None

    def command(self, u: np.ndarray, t: float) -> np.ndarray:
        self._qdes = np.clip(u, JOINT_LOWER, JOINT_UPPER)[self.idx]
        return u

    def substep(self, sim: Any, t: float) -> None:
        if self._qdes is None:
            return
        st = p.getJointStates(sim.robot, self._ids, physicsClientId=sim.client)
        q, dq = np.array([s[0] for s in st]), np.array([s[1] for s in st])
        m, mv = q + self.d, dq + self.dd
        tau = np.clip(self.kp * (self._qdes - m) - self.kd * mv, -self.lim, self.lim)
        h = self.half
        engaged = ((self.d >= h - 1e-12) & (tau >= 0)) | ((self.d <= -h + 1e-12) & (tau <= 0))
        link_tau = np.where(engaged, tau, 0.0)
        # the free motor: semi-implicit Euler over the step, against the link's motion
        mv_new = mv + self.dt * tau / self.jm
        d_new = self.d + self.dt * (mv_new - dq)
        dd_new = mv_new - dq
        d_new = np.where(engaged, self.d, d_new)
        dd_new = np.where(engaged, 0.0, dd_new)
        hit = np.abs(d_new) > h
        d_new = np.clip(d_new, -h, h)
        dd_new = np.where(hit, 0.0, dd_new)
        rate = (d_new - self.d) / self.dt
        self.d, self.dd = d_new, dd_new
        self.dd_f = self.dd_f + self.alpha * (rate - self.dd_f)
        normal = np.clip(self.kp * (self._qdes - q) - self.kd * dq, -self.lim, self.lim)
        p.setJointMotorControlArray(sim.robot, self._ids, p.TORQUE_CONTROL,
                                    forces=(link_tau - normal).tolist(),
                                    physicsClientId=sim.client)

    def measure(self, obs: dict, t: float) -> dict:
        q, dq = obs["q"].copy(), obs["dq"].copy()
        q[self.idx] += self.d
        dq[self.idx] += self.dd_f
        obs["q"], obs["dq"] = q, dq
        return obs


class GearboxStiction:
    """Dry friction in some joints' gearboxes (debris, a bent shaft): a joint motor of pybullet
    held at zero velocity with at most ``coulomb_Nm`` of torque, i.e. stick-slip Coulomb
    friction solved by the constraint solver."""

    def __init__(self, coulomb_Nm: float, joints: str | list[str]) -> None:
        self.c = float(coulomb_Nm)
        self.idx = joint_ids(joints)

    def reset(self, sim: Any) -> None:
        ids = [sim.joint_indices[j] for j in self.idx]
        p.setJointMotorControlArray(sim.robot, ids, p.VELOCITY_CONTROL,
                                    targetVelocities=[0.0] * len(ids),
                                    forces=[self.c] * len(ids), physicsClientId=sim.client)


# ------------------------------------------------------------------------------ set-points
class BusLag:
    """Set-points of some joints take effect ``delay_ms`` late (a driver board polled late on
    its bus); a fraction of a control step interpolates the two neighbouring set-points. Before
    the delay has passed, the first set-point is held."""

    changes_world = False

    def __init__(self, delay_ms: float, joints: str | list[str]) -> None:
        self.delay = float(delay_ms) / (1e3 * CONTROL_DT)   # in control steps
        self.idx = joint_ids(joints)
        self._past: list[np.ndarray] = []

    def reset(self, sim: Any) -> None:
        self._past = []

    def command(self, u: np.ndarray, t: float) -> np.ndarray:
        k = int(np.floor(self.delay))
        frac = self.delay - k
        if not self._past:
            self._past = [u.copy()] * (k + 2)
        self._past.append(u.copy())
        self._past = self._past[-(k + 2):]
        late = (1.0 - frac) * self._past[-1 - k] + frac * self._past[-2 - k]
        out = u.copy()
        out[self.idx] = late[self.idx]
        return out


class FlakyLegLink:
    """A loose connector on one leg's bus: set-point packets to that leg are lost in bursts
    (a two-state Gilbert-Elliott channel: from good to bad with ``p_bad`` per control step,
    back with ``p_good``; all packets lost while bad), and its servos hold the last set-point
    received. Drawn from the move's generator."""

    changes_world = False

    def __init__(self, leg: str, p_bad: float, p_good: float) -> None:
        self.idx = joint_ids(leg)
        self.p_bad, self.p_good = float(p_bad), float(p_good)
        self._held = None
        self._bad = False

    def reset(self, sim: Any) -> None:
        self.rng = sim.rng
        self._held = None
        self._bad = False

    def command(self, u: np.ndarray, t: float) -> np.ndarray:
        if self._held is None:
            self._held = u[self.idx].copy()
            return u
        r = self.rng.random()
        self._bad = (r >= self.p_good) if self._bad else (r < self.p_bad)
        if not self._bad:
            self._held = u[self.idx].copy()
        out = u.copy()
        out[self.idx] = self._held
        return out


# ------------------------------------------------------------------------------ sensing
class MisHomedEncoder:
    """A joint homed wrongly: its encoder reads the true angle plus ``offset_rad``, and the
    servo, which closes its loop on that encoder, holds the joint ``offset_rad`` away from the
    set-point."""

    changes_world = False

    def __init__(self, offset_rad: float, joints: str | list[str]) -> None:
        self.offset = float(offset_rad)
        self.idx = joint_ids(joints)

    def command(self, u: np.ndarray, t: float) -> np.ndarray:
        out = u.copy()
        out[self.idx] -= self.offset
        return out

    def measure(self, obs: dict, t: float) -> dict:
        q = obs["q"].copy()
        q[self.idx] += self.offset
        obs["q"] = q
        return obs


class MarkerBodyOffset:
    """The motion-capture rigid body defined off the robot's body frame: the tracked frame is
    the body frame turned by the rotation vector ``rotation_deg`` (base_link, degrees) with its
    origin at ``origin_m`` (base_link). The published pose is that frame's, and the twist its
    finite difference."""

    changes_world = False

    def __init__(self, rotation_deg: list[float], origin_m: list[float]) -> None:
        rv = np.radians(np.asarray(rotation_deg, dtype=float).reshape(3))
        ang = float(np.linalg.norm(rv))
        axis = rv / ang if ang > 0 else np.array([1.0, 0.0, 0.0])
        self.q_off = p.getQuaternionFromAxisAngle(axis.tolist(), ang)
        self.r = np.asarray(origin_m, dtype=float).reshape(3)
        self.R_off = np.array(p.getMatrixFromQuaternion(self.q_off)).reshape(3, 3)
        self._prev = None

    def reset(self, sim: Any) -> None:
        self._prev = None

    def measure(self, obs: dict, t: float) -> dict:
        pos, orn = p.multiplyTransforms(obs["position"].tolist(), obs["orientation"].tolist(),
                                        self.r.tolist(), self.q_off)
        pos, orn = np.array(pos), np.array(orn)
        orn = orn / np.linalg.norm(orn)
        if self._prev is None:
            w = np.asarray(obs["angular_velocity"], dtype=float)
            v = np.asarray(obs["linear_velocity"], dtype=float) + np.cross(w, self.r)
            lin, ang = self.R_off.T @ v, self.R_off.T @ w
        else:
            lin, ang = twist_from_poses(self._prev[0], self._prev[1], pos, orn, CONTROL_DT)
        self._prev = (pos, orn)
        obs["position"], obs["orientation"] = pos, orn
        obs["linear_velocity"], obs["angular_velocity"] = np.asarray(lin), np.asarray(ang)
        return obs


# ------------------------------------------------------------------------------ the world
class StrappedLoad:
    """A load strapped to the body (a camera, a computer, a spare battery): ``mass_kg`` at
    ``offset_m`` from the body's frame (base_link), held by a stiff fixed constraint; it
    touches nothing."""

    def __init__(self, mass_kg: float, offset_m: list[float], size_m: float = 0.03) -> None:
        self.mass = float(mass_kg)
        self.offset = [float(x) for x in offset_m]
        self.size = float(size_m)

    def reset(self, sim: Any) -> None:
        c = sim.client
        pos, orn = p.getBasePositionAndOrientation(sim.robot, physicsClientId=c)
        at, _ = p.multiplyTransforms(pos, orn, self.offset, [0, 0, 0, 1])
        h = 0.5 * self.size
        shape = p.createCollisionShape(p.GEOM_BOX, halfExtents=[h, h, h], physicsClientId=c)
        body = p.createMultiBody(self.mass, shape, basePosition=at, baseOrientation=orn,
                                 physicsClientId=c)
        p.setCollisionFilterGroupMask(body, -1, 0, 0, physicsClientId=c)
        lin, ang = p.getBaseVelocity(sim.robot, physicsClientId=c)
        p.resetBaseVelocity(body, lin, ang, physicsClientId=c)
        cid = p.createConstraint(sim.robot, -1, body, -1, p.JOINT_FIXED, [0, 0, 0],
                                 self.offset, [0, 0, 0], physicsClientId=c)
        p.changeConstraint(cid, maxForce=2e4, physicsClientId=c)


class WornFootPad:
    """One foot's rubber pad worn through: its friction coefficient is ``scale`` times the
    robot's foot friction."""

    def __init__(self, leg: str, scale: float) -> None:
        self.leg = leg_id(leg)
        self.scale = float(scale)

    def reset(self, sim: Any) -> None:
        p.changeDynamics(sim.robot, sim.foot_links[self.leg],
                         lateralFriction=sim.config.foot_friction * self.scale,
                         physicsClientId=sim.client)


class InclinedBoard:
    """The robot walks on a board inclined by ``slope_deg``, rising towards
    ``uphill_direction_deg`` (odom, level world, gravity along -z). The board is turned about a
    horizontal line through the origin; the standing robot is turned with it (it starts
    standing on the board, perpendicular to it, at rest)."""

    def __init__(self, slope_deg: float, uphill_direction_deg: float) -> None:
        self.slope = np.radians(float(slope_deg))
        self.phi = np.radians(float(uphill_direction_deg))

    def reset(self, sim: Any) -> None:
        c = sim.client
        # rising towards phi: the board's normal leans away from phi
        axis = [-np.sin(self.phi), np.cos(self.phi), 0.0]
        turn = p.getQuaternionFromAxisAngle(axis, -self.slope)
        p.resetBasePositionAndOrientation(sim.plane, [0, 0, 0], turn, physicsClientId=c)
        pos, orn = p.getBasePositionAndOrientation(sim.robot, physicsClientId=c)
        pos2, orn2 = p.multiplyTransforms([0, 0, 0], turn, pos, orn)
        p.resetBasePositionAndOrientation(sim.robot, pos2, orn2, physicsClientId=c)
        p.resetBaseVelocity(sim.robot, [0, 0, 0], [0, 0, 0], physicsClientId=c)


class Draft:
    """A horizontal force ``force_N`` along odom +x on the body (a draft of air)."""

    changes_world = False

    def __init__(self, force_N: float) -> None:
        self.f = [float(force_N), 0.0, 0.0]

    def substep(self, sim: Any, t: float) -> None:
        pos, _ = p.getBasePositionAndOrientation(sim.robot, physicsClientId=sim.client)
        p.applyExternalForce(sim.robot, -1, self.f, pos, p.WORLD_FRAME,
                             physicsClientId=sim.client)


__all__ = ["DetunedStiffness", "BatteryDroop", "HalfBridgeFault", "GearPlayMotorEncoder",
           "GearboxStiction", "BusLag", "FlakyLegLink", "MisHomedEncoder", "MarkerBodyOffset",
           "StrappedLoad", "WornFootPad", "InclinedBoard", "Draft"]
