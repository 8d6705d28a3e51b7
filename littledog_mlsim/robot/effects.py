"""Effect plug-ins: unmodelled physics switched on while recording (docs/interface.md §5).

An effect is any object implementing some of

- ``reset(sim)`` at the start of a move; ``sim`` exposes ``client`` (pybullet client id),
  ``robot`` (body id), ``joint_indices`` (12, contract order), ``physics_dt``, ``control_dt`` and
  ``rng`` (the move's numpy Generator). Each move starts in the world as built, so an effect may
  add bodies/constraints or change dynamics here without undoing it: after it, the next move
  builds the world again. An effect that changes nothing of the world (its own state, forces
  or torques for one physics step, readings) declares ``changes_world = False``, and the next
  move then restores the world from a snapshot instead (``sim.py``'s module doc).
- ``command(u, t) -> u``: the 12 desired angles (contract order) as the servo will receive them;
  t = k * control_dt [s since the move started].
- ``substep(sim, t)``: before every physics step (forces, torques, terrain). Joint torques sent with
  pybullet TORQUE_CONTROL here add to the servo's torque (pybullet accumulates applied torques
  until the step and then clears them); external forces likewise last one physics step.
- ``measure(obs, t) -> obs``: what the sensors report; ``obs`` maps ``q``, ``dq`` (12,),
  ``position`` (3,), ``orientation`` (4, xyzw), ``linear_velocity``, ``angular_velocity``
  (3, base_link) to arrays.

Effects are listed in a YAML file, a list of ``{class: "package.module:ClassName", params: {...}}``
where the class may also be ``path/to/file.py:ClassName`` (relative to the YAML file's directory,
or absolute); :func:`load_effects` builds them. Joints are addressed by contract names
(``front_left_knee``), leg names (``front_left``), or groups: ``all``, ``hip_rolls``,
``hip_pitches``, ``knees``, ``hips`` (roll and pitch), ``front``, ``back``, ``left``, ``right``.
"""
from __future__ import annotations

import hashlib
import importlib
import importlib.util
import sys
from collections import deque
from pathlib import Path
from typing import Any, Iterable

import numpy as np
import pybullet as p
import yaml

from ..layout import JOINT_NAMES, LEGS, N_JOINTS

try:    # numpy's clip ufunc, which np.clip calls for float arrays with both bounds, without
    from numpy._core.umath import clip as _clip   # its Python layers (every physics step)
except ImportError:  # pragma: no cover - another numpy layout
    _clip = np.clip

HOOKS: tuple[str, ...] = ("reset", "command", "substep", "measure")


def _group_mask(name: str) -> np.ndarray | None:
    joints = np.array(JOINT_NAMES)
    kinds = {"hip_rolls": "hip_roll", "hip_pitches": "hip_pitch", "knees": "knee"}
    if name == "all":
        return np.ones(N_JOINTS, dtype=bool)
    if name in kinds:
        return np.char.endswith(joints, "_" + kinds[name])
    if name == "hips":
        return ~np.char.endswith(joints, "_knee")
    if name in ("front", "back"):
        return np.char.startswith(joints, name + "_")
    if name in ("left", "right"):
        return np.array([f"_{name}_" in j for j in joints])
    if name in LEGS:
        return np.char.startswith(joints, name + "_")
    if name in JOINT_NAMES:
        return joints == name
    return None


def resolve_joints(spec: str | Iterable[str] | None) -> np.ndarray:
    """Indices (sorted, into contract order) of the joints named by ``spec`` (None = all)."""
    if spec is None:
        return np.arange(N_JOINTS)
    names = [spec] if isinstance(spec, str) else list(spec)
    mask = np.zeros(N_JOINTS, dtype=bool)
    for n in names:
        m = _group_mask(str(n))
        if m is None:
            raise ValueError(f"unknown joint or joint group {n!r}")
        mask |= m
    return np.flatnonzero(mask)


def _values(value: float | Iterable[float], n: int, what: str) -> np.ndarray:
    v = np.asarray(value, dtype=float).reshape(-1)
    if v.size == 1:
        return np.full(n, float(v[0]))
    if v.size != n:
        raise ValueError(f"{what}: expected 1 or {n} values, got {v.size}")
    return v


class CommandDelay:
    """Delays the desired angles of some joints by a whole number of 10 ms control steps.

    Before ``steps`` commands have arrived, the first command of the move is repeated (the robot
    was standing still holding it).
    """

    changes_world = False     # it keeps its own state only (LittleDogSim.reset)

    def __init__(self, steps: int, joints: str | list[str] | None = None) -> None:
        if int(steps) != steps or steps < 0:
            raise ValueError(f"CommandDelay: steps must be a non-negative integer, got {steps!r}")
        self.steps = int(steps)
        self.joints = resolve_joints(joints)
        self._history: deque[np.ndarray] = deque()

    def reset(self, sim: Any) -> None:
        self._history.clear()

    def command(self, u: np.ndarray, t: float) -> np.ndarray:
        if not self._history:
            self._history.extend(u.copy() for _ in range(self.steps))
        self._history.append(u.copy())
        delayed = self._history.popleft()
        out = u.copy()
        out[self.joints] = delayed[self.joints]
        return out


class JointFriction:
    """Joint friction torque -(coulomb * tanh(dq / smoothing) + viscous * dq) on some joints.

    Args:
        coulomb: Coulomb friction [N m], one value or one per selected joint.
        viscous: viscous friction [N m s/rad], one value or one per selected joint.
        joints: joint names/groups (None = all).
        smoothing: velocity [rad/s] over which the Coulomb term goes smoothly through zero.
    """

    changes_world = False     # it keeps its own state only (LittleDogSim.reset)

    def __init__(self, coulomb: float | list[float] = 0.05, viscous: float | list[float] = 0.0,
                 joints: str | list[str] | None = None, smoothing: float = 0.05) -> None:
        self.joints = resolve_joints(joints)
        self.coulomb = _values(coulomb, len(self.joints), "JointFriction.coulomb")
        self.viscous = _values(viscous, len(self.joints), "JointFriction.viscous")
        if smoothing <= 0:
            raise ValueError("JointFriction: smoothing must be positive")
        self.smoothing = float(smoothing)
        self._ids: list[int] = []

    def reset(self, sim: Any) -> None:
        self._ids = [sim.joint_indices[j] for j in self.joints]

    def torque(self, dq: np.ndarray) -> np.ndarray:
        """Friction torque [N m] for the selected joints' rates dq (n_selected,)."""
        return -(self.coulomb * np.tanh(dq / self.smoothing) + self.viscous * dq)

    def substep(self, sim: Any, t: float) -> None:
        dq = sim.joint_state()[1][self.joints]
        p.setJointMotorControlArray(sim.robot, self._ids, p.TORQUE_CONTROL,
                                    forces=self.torque(dq), physicsClientId=sim.client)


class Payload:
    """A point mass rigidly fixed to the body at ``offset`` (base_link frame) [kg], [m]."""

    def __init__(self, mass: float, offset: list[float] | tuple[float, float, float] = (0.0, 0.0, 0.0),
                 radius: float = 0.02) -> None:
        if mass <= 0:
            raise ValueError(f"Payload: mass must be positive, got {mass}")
        self.mass = float(mass)
        self.offset = _values(offset, 3, "Payload.offset")
        self.radius = float(radius)
        self.body = -1

    def reset(self, sim: Any) -> None:
        c = sim.client
        pos, orn = p.getBasePositionAndOrientation(sim.robot, physicsClientId=c)
        world, _ = p.multiplyTransforms(pos, orn, self.offset.tolist(), [0, 0, 0, 1])
        shape = p.createCollisionShape(p.GEOM_SPHERE, radius=self.radius, physicsClientId=c)
        self.body = p.createMultiBody(self.mass, shape, basePosition=world, baseOrientation=orn,
                                      physicsClientId=c)
        lin, ang = p.getBaseVelocity(sim.robot, physicsClientId=c)
        p.resetBaseVelocity(self.body, lin, ang, physicsClientId=c)
        p.setCollisionFilterGroupMask(self.body, -1, 0, 0, physicsClientId=c)  # no contacts
        cid = p.createConstraint(sim.robot, -1, self.body, -1, p.JOINT_FIXED, [0, 0, 0],
                                 self.offset.tolist(), [0, 0, 0], physicsClientId=c)
        p.changeConstraint(cid, maxForce=1e4, physicsClientId=c)


class ConstantWind:
    """A constant horizontal force in odom on the body's centre of mass [N].

    Being fixed in the world, its effect in the body frame depends on the robot's heading.
    """

    changes_world = False     # forces or readings only, each step (LittleDogSim.reset)

    def __init__(self, force_xy: list[float] | tuple[float, float]) -> None:
        f = _values(force_xy, 2, "ConstantWind.force_xy")
        self.force = np.array([f[0], f[1], 0.0])

    def substep(self, sim: Any, t: float) -> None:
        pos, _ = p.getBasePositionAndOrientation(sim.robot, physicsClientId=sim.client)
        p.applyExternalForce(sim.robot, -1, self.force.tolist(), pos, p.WORLD_FRAME,
                             physicsClientId=sim.client)


# ----------------------------------------------------------------------------- diagnosis families
# One plug-in per family of the diagnosis vocabulary (docs/diagnosis.md), each with its primary
# parameter in physical units; ``diagnose`` re-simulates them to name and size an effect.

def _servo_gains(sim: Any, joints: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(kp, kd, torque limit) of the selected joints from the robot's config (PD servo)."""
    from .config import per_joint
    cfg = sim.config
    return (per_joint(cfg.kp)[joints], per_joint(cfg.kd)[joints],
            per_joint(cfg.torque_limit)[joints])


class SetpointDelay:
    """Set-points of some joints arrive ``delay_ms`` late; a delay between two control steps is
    the linear interpolation of the two neighbouring commands (a sub-step delay of a
    zero-order-held command, averaged over the step)."""

    changes_world = False     # it keeps its own state only (LittleDogSim.reset)

    def __init__(self, delay_ms: float, joints: str | list[str] | None = None) -> None:
        if not (np.isfinite(delay_ms) and delay_ms >= 0):
            raise ValueError(f"SetpointDelay: delay_ms must be >= 0, got {delay_ms!r}")
        self.delay_ms = float(delay_ms)
        self.joints = resolve_joints(joints)
        self._history: deque[np.ndarray] = deque()

    def reset(self, sim: Any) -> None:
        self._history.clear()

    def command(self, u: np.ndarray, t: float) -> np.ndarray:
        steps = self.delay_ms / 10.0
        k = int(np.floor(steps))
        frac = steps - k
        n = k + 2
        if not self._history:
            self._history.extend(u.copy() for _ in range(n))
        self._history.append(u.copy())
        while len(self._history) > n:
            self._history.popleft()
        h = self._history          # h[-1] = u_t, h[-1-k] = u_{t-k}
        delayed = (1.0 - frac) * h[-1 - k] + frac * h[-2 - k]
        out = u.copy()
        out[self.joints] = delayed[self.joints]
        return out


class SetpointFilter:
    """Set-points of some joints pass a first-order low-pass of ``time_constant_ms`` (updated
    at the 100 Hz control rate, starting at the first command)."""

    changes_world = False     # it keeps its own state only (LittleDogSim.reset)

    def __init__(self, time_constant_ms: float, joints: str | list[str] | None = None) -> None:
        if not (np.isfinite(time_constant_ms) and time_constant_ms >= 0):
            raise ValueError(f"SetpointFilter: time_constant_ms must be >= 0, "
                             f"got {time_constant_ms!r}")
        self.time_constant_ms = float(time_constant_ms)
        self.joints = resolve_joints(joints)
        self._y: np.ndarray | None = None

    def reset(self, sim: Any) -> None:
        self._y = None

    def command(self, u: np.ndarray, t: float) -> np.ndarray:
        a = 1.0 - np.exp(-10.0 / self.time_constant_ms) if self.time_constant_ms > 0 else 1.0
        if self._y is None:
            self._y = u.copy()
        else:
            self._y = self._y + a * (u - self._y)
        out = u.copy()
        out[self.joints] = self._y[self.joints]
        return out


class _ServoTorque:
    """A change of the PD servo of some joints, added as joint torque every physics step: the
    set-point is captured as the servo receives it, :meth:`extra` gives the torque to add from
    the joint state (the servo's gains, ``_kp``, ``_kd``, and torque limit, ``_lim0``, are the
    robot config's)."""

    changes_world = False     # it keeps its own state only (LittleDogSim.reset)

    def __init__(self, joints: str | list[str] | None) -> None:
        self.joints = resolve_joints(joints)
        self._q_des = np.zeros(N_JOINTS)

    def reset(self, sim: Any) -> None:
        self._ids = [sim.joint_indices[j] for j in self.joints]
        self._kp, self._kd, self._lim0 = _servo_gains(sim, self.joints)

    def command(self, u: np.ndarray, t: float) -> np.ndarray:
        from ..layout import JOINT_LOWER, JOINT_UPPER
        self._q_des = _clip(u, JOINT_LOWER, JOINT_UPPER)
        return u

    def servo(self, e: np.ndarray, dq: np.ndarray, t: float) -> np.ndarray:
        """The changed servo's torque for the position error e = q_des - q and the rate dq
        [N m], within its torque limit."""
        raise NotImplementedError

    def extra(self, e: np.ndarray, dq: np.ndarray, t: float) -> np.ndarray:
        """Torque to add: the changed servo's minus the normal one (both saturate at their
        limits, so a weaker or play-affected servo that saturates anyway changes nothing)."""
        normal = _clip(self._kp * e - self._kd * dq, -self._lim0, self._lim0)
        return self.servo(e, dq, t) - normal

    def substep(self, sim: Any, t: float) -> None:
        q, dq = sim.joint_state()
        e = self._q_des[self.joints] - q[self.joints]
        tau = self.extra(e, dq[self.joints], t)
        p.setJointMotorControlArray(sim.robot, self._ids, p.TORQUE_CONTROL, forces=tau.tolist(),
                                    physicsClientId=sim.client)


class ServoGain(_ServoTorque):
    """The servo's P gain of some joints times ``gain_ratio`` (plus ``drift_per_s`` * t, a gain
    that drifts with the time since the move started, floored at 0): the servo's torque becomes
    clip(gain(t) k (q_des - q) - b dq) within the normal torque limit."""

    def __init__(self, gain_ratio: float = 1.0, joints: str | list[str] | None = None,
                 drift_per_s: float = 0.0, time_offset_s: float = 0.0) -> None:
        if not (np.isfinite(gain_ratio) and gain_ratio >= 0 and np.isfinite(drift_per_s)):
            raise ValueError(f"ServoGain: gain_ratio must be >= 0, got {gain_ratio!r}")
        super().__init__(joints)
        self.gain_ratio = float(gain_ratio)
        self.drift_per_s = float(drift_per_s)
        self.time_offset_s = float(time_offset_s)   # the move's time at this simulation's start

    def servo(self, e: np.ndarray, dq: np.ndarray, t: float) -> np.ndarray:
        g = (self.gain_ratio * max(0.0, 1.0 + self.drift_per_s * (t + self.time_offset_s))
             if self.drift_per_s else self.gain_ratio)
        return _clip(g * self._kp * e - self._kd * dq, -self._lim0, self._lim0)


class SupplySag(_ServoTorque):
    """The whole servo output of some joints scaled by s(t) = min(1, max(0, 1 + ``rate_per_s``
    * t)), t the time since the move started: clip(k e - b dq, -limit, limit) * s(t). The
    supply voltage of a voltage-mode (PWM) servo sags under load, so the controller's P and D
    torque and the torque it can reach shrink together; the sag restarts with each move (a
    battery that recovers between moves), never exceeds the nominal supply, and at s = 0 the
    servo drives nothing (no back-EMF braking is modelled)."""

    def __init__(self, rate_per_s: float, joints: str | list[str] | None = None,
                 time_offset_s: float = 0.0) -> None:
        if not np.isfinite(rate_per_s):
            raise ValueError(f"SupplySag: rate_per_s must be finite, got {rate_per_s!r}")
        if not np.isfinite(time_offset_s):
            raise ValueError(f"SupplySag: time_offset_s must be finite, got {time_offset_s!r}")
        super().__init__(joints)
        self.rate_per_s = float(rate_per_s)
        self.time_offset_s = float(time_offset_s)   # the move's time at this simulation's start

    def servo(self, e: np.ndarray, dq: np.ndarray, t: float) -> np.ndarray:
        s = min(1.0, max(0.0, 1.0 + self.rate_per_s * (t + self.time_offset_s)))
        return s * _clip(self._kp * e - self._kd * dq, -self._lim0, self._lim0)


class TorqueLimit(_ServoTorque):
    """The servo torque of some joints limited to ``torque_limit_Nm`` (below the normal limit):
    the PD torque k (q_des - q) - b dq is recomputed from the joint state and the excess over the
    lower limit is taken off every physics step."""

    def __init__(self, torque_limit_Nm: float, joints: str | list[str] | None = None) -> None:
        if not (np.isfinite(torque_limit_Nm) and torque_limit_Nm >= 0):
            raise ValueError(f"TorqueLimit: torque_limit_Nm must be >= 0, got {torque_limit_Nm!r}")
        super().__init__(joints)
        self.torque_limit_Nm = float(torque_limit_Nm)

    def servo(self, e: np.ndarray, dq: np.ndarray, t: float) -> np.ndarray:
        lim = np.minimum(self.torque_limit_Nm, self._lim0)
        return _clip(self._kp * e - self._kd * dq, -lim, lim)


class TorqueSpeed(_ServoTorque):
    """A DC motor's torque-speed line on some joints: while the servo drives a joint the way it
    moves (motoring, torque x rate > 0), the torque it can give falls with the joint's speed,
    to clip(``stall_ratio`` x limit x (1 - |dq| / ``no_load_speed_rad_s``), 0, limit) (the
    supply voltage less the motor's back-EMF); braking torque keeps the normal limit. With
    ``stall_ratio`` 1 the line starts at the normal limit at rest; above 1 the limit holds up
    to |dq| = (1 - 1 / stall_ratio) x the no-load speed."""

    def __init__(self, no_load_speed_rad_s: float, joints: str | list[str] | None = None,
                 stall_ratio: float = 1.0) -> None:
        if not (np.isfinite(no_load_speed_rad_s) and no_load_speed_rad_s > 0):
            raise ValueError(f"TorqueSpeed: no_load_speed_rad_s must be > 0, "
                             f"got {no_load_speed_rad_s!r}")
        if not (np.isfinite(stall_ratio) and stall_ratio > 0):
            raise ValueError(f"TorqueSpeed: stall_ratio must be > 0, got {stall_ratio!r}")
        super().__init__(joints)
        self.no_load_speed_rad_s = float(no_load_speed_rad_s)
        self.torque_drop_s_per_rad = 1.0 / self.no_load_speed_rad_s   # the line's slope / stall
        self.stall_ratio = float(stall_ratio)

    def servo(self, e: np.ndarray, dq: np.ndarray, t: float) -> np.ndarray:
        tau = _clip(self._kp * e - self._kd * dq, -self._lim0, self._lim0)
        line = self.stall_ratio * self._lim0 * (1.0 - np.abs(dq) * self.torque_drop_s_per_rad)
        cap = _clip(line, 0.0, self._lim0)
        return np.where(tau * dq > 0, _clip(tau, -cap, cap), tau)


class SetpointBacklash:
    """Play of ``width_rad`` between the set-point and the joint: the set-point passes a play
    (backlash) operator y = clip(y, u - width/2, u + width/2), started at the first command."""

    changes_world = False     # it keeps its own state only (LittleDogSim.reset)

    def __init__(self, width_rad: float, joints: str | list[str] | None = None) -> None:
        if not (np.isfinite(width_rad) and width_rad >= 0):
            raise ValueError(f"SetpointBacklash: width_rad must be >= 0, got {width_rad!r}")
        self.width_rad = float(width_rad)
        self.joints = resolve_joints(joints)
        self._y: np.ndarray | None = None

    def reset(self, sim: Any) -> None:
        self._y = None

    def command(self, u: np.ndarray, t: float) -> np.ndarray:
        h = 0.5 * self.width_rad
        self._y = u.copy() if self._y is None else _clip(self._y, u - h, u + h)
        out = u.copy()
        out[self.joints] = self._y[self.joints]
        return out


class EncoderOffset:
    """Measured angle = true angle + ``offset_rad`` on some joints.

    ``servo_loop`` False: the report only (a calibration error in what is published; the servo
    reads its own sensor). True: the servo closes its loop on the same offset encoder, as a
    joint servo does, so it holds the joint ``offset_rad`` short of the set-point while the
    reported angle still matches the set-point: the error shows in the body's motion, not in the
    joint angles.
    """

    changes_world = False     # forces or readings only, each step (LittleDogSim.reset)

    def __init__(self, offset_rad: float, joints: str | list[str] | None = None,
                 servo_loop: bool = False) -> None:
        if not np.isfinite(offset_rad):
            raise ValueError(f"EncoderOffset: offset_rad must be finite, got {offset_rad!r}")
        self.offset_rad = float(offset_rad)
        self.joints = resolve_joints(joints)
        self.servo_loop = bool(servo_loop)

    def command(self, u: np.ndarray, t: float) -> np.ndarray:
        if not self.servo_loop:
            return u
        out = u.copy()
        out[self.joints] -= self.offset_rad
        return out

    def measure(self, obs: dict, t: float) -> dict:
        q = obs["q"].copy()
        q[self.joints] += self.offset_rad
        obs["q"] = q
        return obs


class BodyWrench:
    """A constant force [N] and torque [N m] fixed in the body frame (base_link), at the base's
    centre of mass."""

    changes_world = False     # forces or readings only, each step (LittleDogSim.reset)

    def __init__(self, force: list[float] | tuple[float, float, float] = (0.0, 0.0, 0.0),
                 torque: list[float] | tuple[float, float, float] = (0.0, 0.0, 0.0)) -> None:
        self.force = _values(force, 3, "BodyWrench.force")
        self.torque = _values(torque, 3, "BodyWrench.torque")

    def substep(self, sim: Any, t: float) -> None:
        c = sim.client
        pos, orn = p.getBasePositionAndOrientation(sim.robot, physicsClientId=c)
        R = np.array(p.getMatrixFromQuaternion(orn)).reshape(3, 3)
        if np.any(self.force):
            p.applyExternalForce(sim.robot, -1, (R @ self.force).tolist(), pos, p.WORLD_FRAME,
                                 physicsClientId=c)
        if np.any(self.torque):
            p.applyExternalTorque(sim.robot, -1, (R @ self.torque).tolist(), p.WORLD_FRAME,
                                  physicsClientId=c)


class GroundSlope:
    """The ground inclined by ``slope_deg`` rising towards ``uphill_direction_deg`` (odom): gravity
    tilted by the slope in odom (the odometry frame stays level with the ground)."""

    def __init__(self, slope_deg: float, uphill_direction_deg: float = 0.0) -> None:
        if not (np.isfinite(slope_deg) and abs(slope_deg) < 45):
            raise ValueError(f"GroundSlope: slope_deg must be in (-45, 45), got {slope_deg!r}")
        self.slope_deg = float(slope_deg)
        self.uphill_direction_deg = float(uphill_direction_deg)

    def reset(self, sim: Any) -> None:
        from .sim import GRAVITY
        s, phi = np.radians(self.slope_deg), np.radians(self.uphill_direction_deg)
        g = GRAVITY * np.array([-np.sin(s) * np.cos(phi), -np.sin(s) * np.sin(phi), -np.cos(s)])
        p.setGravity(*g.tolist(), physicsClientId=sim.client)


#: the floor height under a robot's start below which :class:`GroundTilt` leaves it where it is
LIFT_MIN_M = 1e-3


class GroundTilt:
    """The floor inclined by ``slope_deg``, rising towards ``uphill_direction_deg`` (odom), under a
    level odometry frame (motion capture in the level world): the ground plane is turned about a
    horizontal axis through ``origin_xy`` (at height 0), where the move starts; a robot that
    starts elsewhere (``record --start-spread``) is lifted by the floor's height under its base
    (where it exceeds ``LIFT_MIN_M``), still level, as at ``origin_xy``. Unlike
    :class:`GroundSlope` (gravity tilted, odometry level with the ground) the body's attitude and
    height in odom follow the floor."""

    def __init__(self, slope_deg: float, uphill_direction_deg: float = 0.0,
                 origin_xy: list[float] | tuple[float, float] = (0.0, 0.0)) -> None:
        if not (np.isfinite(slope_deg) and abs(slope_deg) < 45):
            raise ValueError(f"GroundTilt: slope_deg must be in (-45, 45), got {slope_deg!r}")
        self.slope_deg = float(slope_deg)
        self.uphill_direction_deg = float(uphill_direction_deg)
        self.origin_xy = _values(origin_xy, 2, "GroundTilt.origin_xy")

    def reset(self, sim: Any) -> None:
        s, phi = np.radians(self.slope_deg), np.radians(self.uphill_direction_deg)
        quat = p.getQuaternionFromAxisAngle([np.sin(phi), -np.cos(phi), 0.0], s)
        p.resetBasePositionAndOrientation(sim.plane, [float(self.origin_xy[0]),
                                                      float(self.origin_xy[1]), 0.0], quat,
                                          physicsClientId=sim.client)
        # a robot that starts away from origin_xy (record --start-spread) stands on the floor
        # where it is: lifted (or lowered) by the floor's height under its base
        pos, orn = p.getBasePositionAndOrientation(sim.robot, physicsClientId=sim.client)
        n = np.array(p.getMatrixFromQuaternion(quat)).reshape(3, 3)[:, 2]
        h = -(n[0] * (pos[0] - self.origin_xy[0]) + n[1] * (pos[1] - self.origin_xy[1])) / n[2]
        if abs(h) > LIFT_MIN_M:
            p.resetBasePositionAndOrientation(sim.robot, [pos[0], pos[1], pos[2] + h], orn,
                                              physicsClientId=sim.client)


class FootFriction:
    """The friction coefficient of one foot (or several legs) times ``scale``."""

    def __init__(self, scale: float, legs: str | list[str] = "front_left") -> None:
        if not (np.isfinite(scale) and scale > 0):
            raise ValueError(f"FootFriction: scale must be > 0, got {scale!r}")
        self.scale = float(scale)
        self.legs = _legs(legs, "FootFriction")

    def reset(self, sim: Any) -> None:
        for i in self.legs:
            p.changeDynamics(sim.robot, sim.foot_links[i],
                             lateralFriction=sim.config.foot_friction * self.scale,
                             physicsClientId=sim.client)


def _legs(legs: str | list[str], who: str) -> list[int]:
    names = [legs] if isinstance(legs, str) else list(legs)
    for n in names:
        if n not in LEGS:
            raise ValueError(f"{who}: unknown leg {n!r}")
    return [LEGS.index(n) for n in names]


def _leg_links(sim: Any, leg: int) -> list[int]:
    """Leg ``leg``'s links in the simulation: hip, upper leg, lower leg (the knee's), foot."""
    return [sim.joint_indices[3 * leg + k] for k in range(3)] + [sim.foot_links[leg]]


class LegMass:
    """One leg (or several) weighs ``scale`` times its normal mass.

    ``where``: ``"leg"`` (default) scales every link of the leg, with its inertia (and the
    reflected rotor inertia on it) alike: heavier motors. ``"lower"`` puts the whole change on
    the lower leg (the knee's link), its inertia scaled in proportion: a guard, a pad or a
    sensor on the shin. The lower leg keeps at least a tenth of its own mass.
    """

    WHERE = ("leg", "lower")

    def __init__(self, scale: float, legs: str | list[str] = "front_left",
                 where: str = "leg") -> None:
        if not (np.isfinite(scale) and scale > 0):
            raise ValueError(f"LegMass: scale must be > 0, got {scale!r}")
        if where not in self.WHERE:
            raise ValueError(f"LegMass: where must be one of {', '.join(self.WHERE)}, "
                             f"got {where!r}")
        self.scale = float(scale)
        self.legs = _legs(legs, "LegMass")
        self.where = where

    def reset(self, sim: Any) -> None:
        c = sim.client
        if self.where == "lower":
            for i in self.legs:
                links = _leg_links(sim, i)
                leg = sum(p.getDynamicsInfo(sim.robot, link, physicsClientId=c)[0]
                          for link in links)
                shin = links[2]
                mass, _, inertia = p.getDynamicsInfo(sim.robot, shin, physicsClientId=c)[:3]
                new = max(mass + (self.scale - 1.0) * leg, 0.1 * mass)
                p.changeDynamics(sim.robot, shin, mass=new,
                                 localInertiaDiagonal=[v * new / mass for v in inertia],
                                 physicsClientId=c)
            return
        for i in self.legs:
            for link in _leg_links(sim, i):
                mass, _, inertia = p.getDynamicsInfo(sim.robot, link, physicsClientId=c)[:3]
                if mass > 0:
                    p.changeDynamics(sim.robot, link, mass=mass * self.scale,
                                     localInertiaDiagonal=[v * self.scale for v in inertia],
                                     physicsClientId=c)


class SwingDrag:
    """While a foot is off the ground, a horizontal force of up to ``force_N`` opposes its
    velocity (grass, a cable, a snag): F = -force_N tanh(|v| / speed_m_s) v / |v| at the foot,
    with v the foot's horizontal velocity in odom. No force while the foot touches the ground."""

    changes_world = False     # forces or readings only, each step (LittleDogSim.reset)

    def __init__(self, force_N: float, legs: str | list[str] = "front_left",
                 speed_m_s: float = 0.1) -> None:
        if not (np.isfinite(force_N) and force_N >= 0):
            raise ValueError(f"SwingDrag: force_N must be >= 0, got {force_N!r}")
        if not (np.isfinite(speed_m_s) and speed_m_s > 0):
            raise ValueError(f"SwingDrag: speed_m_s must be > 0, got {speed_m_s!r}")
        self.force_N = float(force_N)
        self.speed_m_s = float(speed_m_s)
        self.legs = _legs(legs, "SwingDrag")

    def substep(self, sim: Any, t: float) -> None:
        if self.force_N == 0.0:
            return
        c = sim.client
        links = [sim.foot_links[i] for i in self.legs]
        states = p.getLinkStates(sim.robot, links, computeLinkVelocity=1,
                                 computeForwardKinematics=1, physicsClientId=c)
        for link, st in zip(links, states):
            if p.getContactPoints(sim.robot, sim.plane, link, -1, physicsClientId=c):
                continue
            v = np.array(st[6][:2])
            speed = float(np.hypot(*v))
            if speed < 1e-9:
                continue
            f = -self.force_N * np.tanh(speed / self.speed_m_s) * v / speed
            p.applyExternalForce(sim.robot, link, [float(f[0]), float(f[1]), 0.0], st[0],
                                 p.WORLD_FRAME, physicsClientId=c)


class FootAdhesion:
    """A foot that sticks to the ground (mud, tape, a suction cup): from touch-down until the
    foot has risen ``height_m`` above where it touched down, a downward force ``force_N`` pulls
    it (it loads the stance foot and holds it back at lift-off); none higher up in swing."""

    changes_world = False     # it keeps its own state only (LittleDogSim.reset)

    def __init__(self, force_N: float, legs: str | list[str] = "front_left",
                 height_m: float = 0.01) -> None:
        if not (np.isfinite(force_N) and force_N >= 0):
            raise ValueError(f"FootAdhesion: force_N must be >= 0, got {force_N!r}")
        if not (np.isfinite(height_m) and height_m > 0):
            raise ValueError(f"FootAdhesion: height_m must be > 0, got {height_m!r}")
        self.force_N = float(force_N)
        self.height_m = float(height_m)
        self.legs = _legs(legs, "FootAdhesion")
        self._touch: dict[int, float] = {}

    def reset(self, sim: Any) -> None:
        self._touch = {}

    def substep(self, sim: Any, t: float) -> None:
        if self.force_N == 0.0:
            return
        c = sim.client
        links = [sim.foot_links[i] for i in self.legs]
        states = p.getLinkStates(sim.robot, links, computeForwardKinematics=1,
                                 physicsClientId=c)
        for link, st in zip(links, states):
            z = float(st[0][2])
            if p.getContactPoints(sim.robot, sim.plane, link, -1, physicsClientId=c):
                self._touch[link] = min(z, self._touch.get(link, z))
            elif link in self._touch and z > self._touch[link] + self.height_m:
                del self._touch[link]
            if link in self._touch:
                p.applyExternalForce(sim.robot, link, [0.0, 0.0, -self.force_N], st[0],
                                     p.WORLD_FRAME, physicsClientId=c)


class ServoDeadband(_ServoTorque):
    """Backlash in the gears of some joints as the servo sees it: the position error
    e = q_des - q drives no torque within +-``width_rad``/2 and k (|e| - width/2) beyond it (a
    dead zone on the stiffness term; damping unchanged).

    ``encoder``: where the joint's encoder sits. ``"link"`` (default): on the output, so the
    reported angle is the link's. ``"motor"``: on the motor side of the gears, whose small
    inertia runs to the set-point within the play, so the reported angle is the link's plus
    the motor's place in the play, clip(q_des - q, -width/2, width/2): it reads the set-point
    while the link is within the play.
    """

    ENCODERS = ("link", "motor")

    def __init__(self, width_rad: float, joints: str | list[str] | None = None,
                 encoder: str = "link") -> None:
        if not (np.isfinite(width_rad) and width_rad >= 0):
            raise ValueError(f"ServoDeadband: width_rad must be >= 0, got {width_rad!r}")
        if encoder not in self.ENCODERS:
            raise ValueError(f"ServoDeadband: encoder must be one of {', '.join(self.ENCODERS)}, "
                             f"got {encoder!r}")
        super().__init__(joints)
        self.width_rad = float(width_rad)
        self.encoder = encoder
        if encoder == "motor":      # a reading hook only where the reading changes
            self.measure = self._motor_reading

    def _motor_reading(self, obs: dict, t: float) -> dict:
        h = 0.5 * self.width_rad
        q = obs["q"].copy()
        j = self.joints
        q[j] += _clip(self._q_des[j] - q[j], -h, h)
        obs["q"] = q
        return obs

    def servo(self, e: np.ndarray, dq: np.ndarray, t: float) -> np.ndarray:
        h = 0.5 * self.width_rad
        return _clip(self._kp * (e - _clip(e, -h, h)) - self._kd * dq,
                       -self._lim0, self._lim0)


class EncoderScale(_ServoTorque):
    """Measured angle and rate = ``scale`` x the true ones on some joints (an encoder's counts
    per radian, or the gear ratio it is read through, set wrong), about the encoder's zero.

    The servo closes its loop on the same encoder, as a joint servo does: its torque is
    clip(k (q_des - scale q) - b scale dq) within the normal limit, so it holds the joint at
    q_des / scale (and acts as a servo ``scale`` times as stiff and damped about it) while the
    reported angle still matches the set-point: the error shows in the body's pose and motion,
    not in the joint angles.
    """

    def __init__(self, scale: float, joints: str | list[str] | None = None) -> None:
        if not (np.isfinite(scale) and scale > 0):
            raise ValueError(f"EncoderScale: scale must be > 0, got {scale!r}")
        super().__init__(joints)
        self.scale = float(scale)

    def servo(self, e: np.ndarray, dq: np.ndarray, t: float) -> np.ndarray:
        # the servo's error from the scaled reading: q_des - s q = (1 - s) q_des + s e
        s = self.scale
        err = (1.0 - s) * self._q_des[self.joints] + s * e
        return _clip(self._kp * err - self._kd * s * dq, -self._lim0, self._lim0)

    def measure(self, obs: dict, t: float) -> dict:
        return _scaled_readings(obs, self.joints, self.scale)


class ReadingScale:
    """Reported angle and rate = ``scale`` x the true ones on some joints, the servo reading
    the true ones (a joint-state publisher that converts the encoder's counts with a wrong
    counts per radian): the joints move as commanded, and their reports are off by
    (scale - 1) x the angle."""

    changes_world = False     # readings only (LittleDogSim.reset)

    def __init__(self, scale: float, joints: str | list[str] | None = None) -> None:
        if not (np.isfinite(scale) and scale > 0):
            raise ValueError(f"ReadingScale: scale must be > 0, got {scale!r}")
        self.scale = float(scale)
        self.joints = resolve_joints(joints)

    def measure(self, obs: dict, t: float) -> dict:
        return _scaled_readings(obs, self.joints, self.scale)


def _scaled_readings(obs: dict, joints: np.ndarray, scale: float) -> dict:
    """``obs`` with the angles and rates of ``joints`` times ``scale``."""
    for key in ("q", "dq"):
        v = obs[key].copy()
        v[joints] *= scale
        obs[key] = v
    return obs


# ----------------------------------------------------------------------------- loading from YAML
def _import_class(spec: str, base_dir: Path) -> type:
    module_part, sep, class_name = spec.rpartition(":")
    if not sep or not module_part or not class_name:
        raise ValueError("class must look like 'package.module:ClassName' or 'path/file.py:ClassName'")
    if module_part.endswith(".py") or "/" in module_part or "\\" in module_part:
        path = Path(module_part).expanduser()
        path = path if path.is_absolute() else base_dir / path
        if not path.is_file():
            raise ValueError(f"file {str(path)!r} not found")
        mod_name = "littledog_effect_" + hashlib.sha1(str(path.resolve()).encode()).hexdigest()[:12]
        module = sys.modules.get(mod_name)
        if module is None:
            loader_spec = importlib.util.spec_from_file_location(mod_name, path)
            if loader_spec is None or loader_spec.loader is None:
                raise ValueError(f"cannot import {str(path)!r}")
            module = importlib.util.module_from_spec(loader_spec)
            try:
                loader_spec.loader.exec_module(module)
            except Exception as exc:  # the user's file failed to import
                raise ValueError(f"importing {str(path)!r} failed: {type(exc).__name__}: {exc}") from exc
            sys.modules[mod_name] = module
    else:
        try:
            module = importlib.import_module(module_part)
        except Exception as exc:
            raise ValueError(f"cannot import module {module_part!r}: {type(exc).__name__}: {exc}") from exc
    cls = getattr(module, class_name, None)
    if not isinstance(cls, type):
        raise ValueError(f"{module_part!r} has no class {class_name!r}")
    return cls


def build_effect(entry: Any, base_dir: Path | str = ".") -> Any:
    """One effect from a mapping ``{class: ..., params: {...}}`` (see module docs)."""
    if not isinstance(entry, dict) or "class" not in entry:
        raise ValueError("expected a mapping with a 'class' key")
    unknown = set(entry) - {"class", "params"}
    if unknown:
        raise ValueError(f"unknown keys {sorted(unknown)} (allowed: class, params)")
    spec = entry["class"]
    if not isinstance(spec, str):
        raise ValueError("'class' must be a string")
    params = entry.get("params") or {}
    if not isinstance(params, dict):
        raise ValueError("'params' must be a mapping")
    cls = _import_class(spec, Path(base_dir))
    try:
        effect = cls(**params)
    except Exception as exc:
        raise ValueError(f"{cls.__name__}(**params) failed: {type(exc).__name__}: {exc}") from exc
    if not any(callable(getattr(effect, h, None)) for h in HOOKS):
        raise ValueError(f"{cls.__name__} implements none of {', '.join(HOOKS)}")
    return effect


def load_effects(path: str | Path) -> list[Any]:
    """Effects listed in a YAML file (a list of ``{class, params}``; empty file = none).

    Raises:
        ValueError: one line naming the file and the offending entry.
    """
    path = Path(path)
    try:
        data = yaml.safe_load(path.read_text())
    except (OSError, yaml.YAMLError) as exc:
        reason = " ".join(str(exc).split())
        raise ValueError(f"{path}: cannot read effects: {reason}") from exc
    if data is None:
        return []
    if isinstance(data, dict) and set(data) == {"effects"}:
        data = data["effects"] or []
    if not isinstance(data, list):
        raise ValueError(f"{path}: expected a YAML list of {{class, params}} entries")
    effects = []
    for i, entry in enumerate(data):
        label = entry.get("class") if isinstance(entry, dict) else None
        try:
            effects.append(build_effect(entry, path.parent))
        except ValueError as exc:
            name = f" ({label!r})" if label else ""
            reason = " ".join(str(exc).split())
            raise ValueError(f"{path}: effect #{i + 1}{name}: {reason}") from None
    return effects
