"""zoo47's effect plug-ins (SEALED): written for this zoo, none of them a package built-in or a
subclass of one. Protocol: docs/interface.md section 5 (``reset``, ``command``, ``substep``,
``measure``; ``changes_world = False`` where an effect leaves the world as built).

Joints are named as in the package (a contract joint name, a leg, ``all``, ``hip_rolls``,
``hip_pitches``, ``knees``, ``left``, ``right``), resolved here by :func:`joint_mask`.

Servo changes (:class:`_ServoReshape` and its subclasses here) replace the robot's torque-mode PD
servo on some joints by another torque law: every physics step they compute the normal servo's
torque from exactly what that servo is about to read (the encoders' angle and unfiltered rate,
the set-point as it receives it, the robot config's gains and limits) and add the difference
between the new law and it as joint torque, so the joint receives the new law's torque.
"""
from __future__ import annotations

from typing import Any, Iterable

import numpy as np
import pybullet as p

from littledog_mlsim.layout import CONTROL_DT, JOINT_LOWER, JOINT_NAMES, JOINT_UPPER, LEGS, N_JOINTS
from littledog_mlsim.robot.config import per_joint
from littledog_mlsim.robot.sensors import twist_from_poses
from littledog_mlsim.rotations import quat_from_rotvec, quat_multiply, quat_to_matrix

_KINDS = {"hip_rolls": "_hip_roll", "hip_pitches": "_hip_pitch", "knees": "_knee"}


def joint_mask(spec: str | Iterable[str] | None) -> np.ndarray:
    """Indices (contract order) of the joints a name, a group or a list of them selects."""
    names = ["all"] if spec is None else ([spec] if isinstance(spec, str) else list(spec))
    sel = np.zeros(N_JOINTS, dtype=bool)
    for n in names:
        n = str(n)
        if n == "all":
            m = [True] * N_JOINTS
        elif n in _KINDS:
            m = [j.endswith(_KINDS[n]) for j in JOINT_NAMES]
        elif n in ("left", "right"):
            m = [f"_{n}_" in j for j in JOINT_NAMES]
        elif n in ("front", "back") or n in LEGS:
            m = [j.startswith(n + "_") for j in JOINT_NAMES]
        elif n in JOINT_NAMES:
            m = [j == n for j in JOINT_NAMES]
        else:
            raise ValueError(f"unknown joint or group {n!r}")
        sel |= np.array(m)
    return np.flatnonzero(sel)


def _leg_index(leg: str) -> int:
    if leg not in LEGS:
        raise ValueError(f"unknown leg {leg!r}")
    return LEGS.index(leg)


def _finite(x: Any, what: str, lo: float | None = None) -> float:
    v = float(x)
    if not np.isfinite(v) or (lo is not None and v < lo):
        raise ValueError(f"{what} must be finite{'' if lo is None else f' and >= {lo}'}, got {x!r}")
    return v


# --------------------------------------------------------------------------- servo replacement
class _ServoReshape:
    """Base: the servo of ``joints`` follows :meth:`law` instead of the normal clipped PD."""

    changes_world = False          # joint torques for one physics step and own state only

    def __init__(self, joints: str | list[str] | None) -> None:
        self.sel = joint_mask(joints)
        self._target = None

    def reset(self, sim: Any) -> None:
        cfg = sim.config
        self._ids = [sim.joint_indices[j] for j in self.sel]
        self.kp = per_joint(cfg.kp)[self.sel]
        self.kd = per_joint(cfg.kd)[self.sel]
        self.limit = per_joint(cfg.torque_limit)[self.sel]
        self.dt = float(sim.physics_dt)
        self._target = None
        self.start(sim)

    def start(self, sim: Any) -> None:
        """Per-move state of a subclass."""

    def command(self, u: np.ndarray, t: float) -> np.ndarray:
        self._target = np.clip(np.asarray(u, dtype=float), JOINT_LOWER, JOINT_UPPER)[self.sel]
        return u

    def _sensed(self, sim: Any) -> tuple[np.ndarray, np.ndarray]:
        """(angle, rate) of the selected joints as the servo reads them this physics step."""
        enc = getattr(sim, "_encoders", None)
        if enc is not None and hasattr(enc, "raw_rate"):
            return np.asarray(enc.position)[self.sel], np.asarray(enc.raw_rate)[self.sel]
        states = p.getJointStates(sim.robot, self._ids, physicsClientId=sim.client)
        return np.array([s[0] for s in states]), np.array([s[1] for s in states])

    def _true_rate(self, sim: Any) -> np.ndarray:
        states = p.getJointStates(sim.robot, self._ids, physicsClientId=sim.client)
        return np.array([s[1] for s in states])

    def law(self, sim: Any, target: np.ndarray, q: np.ndarray, dq: np.ndarray,
            t: float) -> np.ndarray:
        raise NotImplementedError

    def substep(self, sim: Any, t: float) -> None:
        if self._target is None:
            return
        q, dq = self._sensed(sim)
        normal = np.clip(self.kp * (self._target - q) - self.kd * dq, -self.limit, self.limit)
        extra = self.law(sim, self._target, q, dq, t) - normal
        p.setJointMotorControlArray(sim.robot, self._ids, p.TORQUE_CONTROL,
                                    forces=extra.tolist(), physicsClientId=sim.client)


class ServoBoardLowPass(_ServoReshape):
    """The servo boards of ``joints`` smooth their set-point with a first-order low-pass of
    ``tau_ms`` run at the servo rate (every physics step), starting at the move's first
    set-point; the PD then tracks the smoothed set-point."""

    def __init__(self, tau_ms: float, joints: str | list[str] | None = None) -> None:
        super().__init__(joints)
        self.tau_ms = _finite(tau_ms, "tau_ms", 0.0)
        self._y = None

    def start(self, sim: Any) -> None:
        self._y = None
        self._a = 1.0 - np.exp(-self.dt / (self.tau_ms * 1e-3)) if self.tau_ms > 0 else 1.0

    def law(self, sim, target, q, dq, t):
        self._y = target.copy() if self._y is None else self._y + self._a * (target - self._y)
        return np.clip(self.kp * (self._y - q) - self.kd * dq, -self.limit, self.limit)


class SoftStiffness(_ServoReshape):
    """The P gain of ``joints`` is ``ratio`` times the configured one (a servo board flashed
    with the wrong gain table); damping and torque limit unchanged."""

    def __init__(self, ratio: float, joints: str | list[str] | None = None) -> None:
        super().__init__(joints)
        self.ratio = _finite(ratio, "ratio", 0.0)

    def law(self, sim, target, q, dq, t):
        return np.clip(self.ratio * self.kp * (target - q) - self.kd * dq,
                       -self.limit, self.limit)


class WornGearPlay(_ServoReshape):
    """A gear train with ``play_rad`` of total play between motor and link on ``joints`` (the
    encoder on the output, so readings are the link's): within the play the motor is
    unloaded and the link gets no torque; once the position error exceeds half the play the
    teeth engage and the link gets the PD torque on the error beyond it. The damping term acts
    on the link only while engaged (blended in over a tenth of the half play)."""

    def __init__(self, play_rad: float, joints: str | list[str] | None = None) -> None:
        super().__init__(joints)
        self.play_rad = _finite(play_rad, "play_rad", 0.0)

    def law(self, sim, target, q, dq, t):
        h = 0.5 * self.play_rad
        e = target - q
        beyond = e - np.clip(e, -h, h)
        band = max(0.1 * h, 1e-6)
        engaged = np.clip((np.abs(e) - h) / band, 0.0, 1.0)
        engaged = engaged * engaged * (3.0 - 2.0 * engaged)        # smoothstep
        return np.clip(self.kp * beyond - engaged * self.kd * dq, -self.limit, self.limit)


class RegulatorDroop(_ServoReshape):
    """The supply rail of ``joints``' servo amplifiers droops through the move: their whole
    output (P and D torque and the torque they can reach) is scaled by
    s(t) = clip(1 + ``droop_per_s`` * t, 0, 1), t since the move started."""

    def __init__(self, droop_per_s: float, joints: str | list[str] | None = None) -> None:
        super().__init__(joints)
        self.droop_per_s = _finite(droop_per_s, "droop_per_s")

    def law(self, sim, target, q, dq, t):
        s = min(1.0, max(0.0, 1.0 + self.droop_per_s * t))
        return s * np.clip(self.kp * (target - q) - self.kd * dq, -self.limit, self.limit)


class EncoderCountScale(_ServoReshape):
    """The encoders of ``joints`` are set up with the wrong counts per radian: they read
    ``scale`` times the true angle (and rate), and the servo closes its loop on that reading,
    tau = clip(k (q_des - scale q) - b scale dq): the joints settle at q_des / scale while the
    reported angles follow the set-points."""

    def __init__(self, scale: float, joints: str | list[str] | None = None) -> None:
        super().__init__(joints)
        self.scale = _finite(scale, "scale", 1e-3)

    def law(self, sim, target, q, dq, t):
        s = self.scale
        return np.clip(self.kp * (target - s * q) - self.kd * s * dq, -self.limit, self.limit)

    def measure(self, obs: dict, t: float) -> dict:
        for k in ("q", "dq"):
            v = np.array(obs[k], dtype=float)
            v[self.sel] *= self.scale
            obs[k] = v
        return obs


class FlakyMotorLead(_ServoReshape):
    """A loose motor lead on ``joints``: the motor current cuts out at random, starting with a
    rate of ``cuts_per_s`` per second and lasting a uniform ``cut_ms`` = [lo, hi] each; while
    cut, the servo drives nothing (the encoders still read). Drawn from the move's generator
    (``sim.rng``)."""

    def __init__(self, cuts_per_s: float, cut_ms: list[float] | tuple[float, float] = (20, 60),
                 joints: str | list[str] | None = None) -> None:
        super().__init__(joints)
        self.cuts_per_s = _finite(cuts_per_s, "cuts_per_s", 0.0)
        lo, hi = (float(x) for x in cut_ms)
        if not (0 < lo <= hi):
            raise ValueError(f"cut_ms must be 0 < lo <= hi, got {cut_ms!r}")
        self.cut_s = (lo * 1e-3, hi * 1e-3)

    def start(self, sim: Any) -> None:
        self._rng = sim.rng
        self._until = -1.0

    def law(self, sim, target, q, dq, t):
        if t >= self._until and self._rng.random() < self.cuts_per_s * self.dt:
            self._until = t + self._rng.uniform(*self.cut_s)
        tau = np.clip(self.kp * (target - q) - self.kd * dq, -self.limit, self.limit)
        return np.zeros_like(tau) if t < self._until else tau


# --------------------------------------------------------------------------- other joint effects
class GreasyGearFriction:
    """Gearbox friction on ``joints`` against the true joint rate w: a Coulomb level
    ``coulomb_Nm`` with a static peak ``breakaway_ratio`` times it at rest (Stribeck, fading
    over ``stribeck_rad_s``), passing smoothly through zero within ``smooth_rad_s``:
    tau = -(c + (s - c) exp(-(w / vs)^2)) tanh(w / eps)."""

    changes_world = False

    def __init__(self, coulomb_Nm: float, joints: str | list[str] | None = None,
                 breakaway_ratio: float = 1.2, stribeck_rad_s: float = 0.15,
                 smooth_rad_s: float = 0.03) -> None:
        self.sel = joint_mask(joints)
        self.c = _finite(coulomb_Nm, "coulomb_Nm", 0.0)
        self.s = self.c * _finite(breakaway_ratio, "breakaway_ratio", 1.0)
        self.vs = _finite(stribeck_rad_s, "stribeck_rad_s", 1e-6)
        self.eps = _finite(smooth_rad_s, "smooth_rad_s", 1e-6)

    def reset(self, sim: Any) -> None:
        self._ids = [sim.joint_indices[j] for j in self.sel]

    def substep(self, sim: Any, t: float) -> None:
        states = p.getJointStates(sim.robot, self._ids, physicsClientId=sim.client)
        w = np.array([s[1] for s in states])
        level = self.c + (self.s - self.c) * np.exp(-(w / self.vs) ** 2)
        p.setJointMotorControlArray(sim.robot, self._ids, p.TORQUE_CONTROL,
                                    forces=(-level * np.tanh(w / self.eps)).tolist(),
                                    physicsClientId=sim.client)


class SlippedEncoderZero:
    """The encoder of ``joints`` was zeroed ``shift_rad`` off: it reads true angle + shift, and
    the servo, closing its loop on that reading, holds the joint ``shift_rad`` short of every
    set-point (the set-point is reached in the reading, not in the joint)."""

    changes_world = False

    def __init__(self, shift_rad: float, joints: str | list[str] | None = None) -> None:
        self.sel = joint_mask(joints)
        self.shift = _finite(shift_rad, "shift_rad")

    def command(self, u: np.ndarray, t: float) -> np.ndarray:
        out = np.array(u, dtype=float)
        out[self.sel] -= self.shift
        return out

    def measure(self, obs: dict, t: float) -> dict:
        q = np.array(obs["q"], dtype=float)
        q[self.sel] += self.shift
        obs["q"] = q
        return obs


# --------------------------------------------------------------------------- body and contact
class TetherPull:
    """An umbilical cable pulls on the body with ``force_N`` in the horizontal plane of the
    body frame (base_link), towards ``heading_deg`` (0 = forward, 90 = left), at the body's
    centre of mass."""

    changes_world = False

    def __init__(self, force_N: float, heading_deg: float) -> None:
        f = _finite(force_N, "force_N", 0.0)
        a = np.radians(_finite(heading_deg, "heading_deg"))
        self.f_body = np.array([f * np.cos(a), f * np.sin(a), 0.0])

    def substep(self, sim: Any, t: float) -> None:
        pos, orn = p.getBasePositionAndOrientation(sim.robot, physicsClientId=sim.client)
        f = quat_to_matrix(np.asarray(orn, dtype=float)) @ self.f_body
        p.applyExternalForce(sim.robot, -1, f.tolist(), list(pos), p.WORLD_FRAME,
                             physicsClientId=sim.client)


class StrappedBox:
    """A box of ``mass_kg`` and size ``size_m`` strapped rigidly to the body with its centre at
    ``at_m`` (base_link); it touches nothing."""

    def __init__(self, mass_kg: float, at_m: list[float],
                 size_m: list[float] | tuple[float, float, float] = (0.09, 0.06, 0.035)) -> None:
        self.mass = _finite(mass_kg, "mass_kg", 1e-6)
        self.at = np.asarray(at_m, dtype=float).reshape(3)
        self.half = 0.5 * np.asarray(size_m, dtype=float).reshape(3)

    def reset(self, sim: Any) -> None:
        c = sim.client
        pos, orn = p.getBasePositionAndOrientation(sim.robot, physicsClientId=c)
        where = np.asarray(pos) + quat_to_matrix(np.asarray(orn, dtype=float)) @ self.at
        shape = p.createCollisionShape(p.GEOM_BOX, halfExtents=self.half.tolist(),
                                       physicsClientId=c)
        box = p.createMultiBody(self.mass, shape, basePosition=where.tolist(),
                                baseOrientation=list(orn), physicsClientId=c)
        p.setCollisionFilterGroupMask(box, -1, 0, 0, physicsClientId=c)
        lin, ang = p.getBaseVelocity(sim.robot, physicsClientId=c)
        w = np.asarray(ang)
        p.resetBaseVelocity(box, (np.asarray(lin) + np.cross(w, where - np.asarray(pos))).tolist(),
                            list(ang), physicsClientId=c)
        cid = p.createConstraint(sim.robot, -1, box, -1, p.JOINT_FIXED, [0, 0, 0],
                                 self.at.tolist(), [0, 0, 0], physicsClientId=c)
        p.changeConstraint(cid, maxForce=2e4, physicsClientId=c)


class PolishedFootPad:
    """The foot pad of ``leg`` is worn smooth: its friction coefficient is ``ratio`` times the
    robot's foot friction."""

    def __init__(self, ratio: float, leg: str = "front_left") -> None:
        self.ratio = _finite(ratio, "ratio", 1e-6)
        self.leg = _leg_index(leg)

    def reset(self, sim: Any) -> None:
        p.changeDynamics(sim.robot, sim.foot_links[self.leg],
                         lateralFriction=sim.config.foot_friction * self.ratio,
                         physicsClientId=sim.client)


# --------------------------------------------------------------------------- what is reported
class MocapBodyMisfit:
    """The motion-capture rigid body was defined off the robot's frame: its pivot sits
    ``pivot_m`` (base_link) from the body's origin and its axes are turned by ``tilt_deg``
    about ``axis`` (base_link). The reported pose is that frame's; the reported twist is its
    finite difference as before (the first one from the true twist moved to that frame)."""

    changes_world = False

    def __init__(self, tilt_deg: float, axis: list[float], pivot_m: list[float]) -> None:
        ax = np.asarray(axis, dtype=float).reshape(3)
        if not np.linalg.norm(ax) > 0:
            raise ValueError("axis must not be zero")
        rv = np.radians(_finite(tilt_deg, "tilt_deg")) * ax / np.linalg.norm(ax)
        self.q_off = np.asarray(quat_from_rotvec(rv), dtype=float)
        self.r_off = quat_to_matrix(self.q_off)
        self.pivot = np.asarray(pivot_m, dtype=float).reshape(3)
        self._prev = None

    def reset(self, sim: Any) -> None:
        self._prev = None

    def measure(self, obs: dict, t: float) -> dict:
        pos = np.asarray(obs["position"], dtype=float)
        orn = np.asarray(obs["orientation"], dtype=float)
        pos2 = pos + quat_to_matrix(orn) @ self.pivot
        orn2 = np.asarray(quat_multiply(orn, self.q_off), dtype=float)
        orn2 = orn2 / np.linalg.norm(orn2)
        if self._prev is None:
            v, w = np.asarray(obs["linear_velocity"]), np.asarray(obs["angular_velocity"])
            lin, ang = self.r_off.T @ (v + np.cross(w, self.pivot)), self.r_off.T @ w
        else:
            lin, ang = twist_from_poses(self._prev[0], self._prev[1], pos2, orn2, CONTROL_DT)
        self._prev = (pos2, orn2)
        obs["position"], obs["orientation"] = pos2, orn2
        obs["linear_velocity"], obs["angular_velocity"] = np.asarray(lin), np.asarray(ang)
        return obs
