"""zoo48's effect plug-ins (docs/interface.md section 5), written for this zoo.

None of them is a package built-in or a subclass of one: each re-implements its physics with
pybullet calls and the hooks of the plug-in protocol (reset / command / substep / measure).
Joints are named through ``littledog_mlsim.robot.effects.resolve_joints`` (the protocol's
joint addressing) and per-joint servo numbers through ``littledog_mlsim.robot.config.per_joint``.

Servo-side classes add, every physics step, the difference between the changed servo and the
robot's normal PD servo (``tau = clip(kp e - kd dq, -limit, limit)`` with the robot's own
``kp``, ``kd`` and ``torque_limit``), computed from the joint state and the set-point as the
servo receives it (captured in ``command``; the class must be the last command hook, which it
is: one effect per file). pybullet adds torques sent in TORQUE_CONTROL before the servo's.
"""
from __future__ import annotations

from typing import Any

import numpy as np
import pybullet as p

from littledog_mlsim.layout import JOINT_LOWER, JOINT_UPPER, LEGS, N_JOINTS
from littledog_mlsim.robot.config import per_joint
from littledog_mlsim.robot.effects import resolve_joints


def _leg_index(leg: str) -> int:
    if leg not in LEGS:
        raise ValueError(f"unknown leg {leg!r}")
    return LEGS.index(leg)


class _Servo:
    """Shared bookkeeping of the servo-side plug-ins (not a package class)."""

    changes_world = False

    def __init__(self, joints: Any) -> None:
        self.joints = resolve_joints(joints)
        self._q_des = np.zeros(N_JOINTS)
        self._have_cmd = False

    def reset(self, sim: Any) -> None:
        cfg = sim.config
        self._ids = [sim.joint_indices[j] for j in self.joints]
        self._kp = per_joint(cfg.kp)[self.joints]
        self._kd = per_joint(cfg.kd)[self.joints]
        self._lim = per_joint(cfg.torque_limit)[self.joints]
        self._have_cmd = False

    def command(self, u: np.ndarray, t: float) -> np.ndarray:
        self._q_des = np.clip(np.asarray(u, float), JOINT_LOWER, JOINT_UPPER)
        self._have_cmd = True
        return u

    def _state(self, sim: Any) -> tuple[np.ndarray, np.ndarray]:
        st = p.getJointStates(sim.robot, self._ids, physicsClientId=sim.client)
        return np.array([s[0] for s in st]), np.array([s[1] for s in st])

    def changed(self, e: np.ndarray, dq: np.ndarray, t: float) -> np.ndarray:
        raise NotImplementedError

    def substep(self, sim: Any, t: float) -> None:
        if not self._have_cmd:
            return
        q, dq = self._state(sim)
        e = self._q_des[self.joints] - q
        normal = np.clip(self._kp * e - self._kd * dq, -self._lim, self._lim)
        tau = self.changed(e, dq, t) - normal
        p.setJointMotorControlArray(sim.robot, self._ids, p.TORQUE_CONTROL,
                                    forces=tau.tolist(), physicsClientId=sim.client)


class StiffnessRatio(_Servo):
    """The P gain of some joints' servos is ``ratio`` times the robot's (a gain table written
    with the wrong value for these joints)."""

    def __init__(self, ratio: float, joints: Any = None) -> None:
        super().__init__(joints)
        self.ratio = float(ratio)

    def changed(self, e, dq, t):
        return np.clip(self.ratio * self._kp * e - self._kd * dq, -self._lim, self._lim)


class WarmingMotors(_Servo):
    """The P gain of some joints' servos falls linearly with the time since the move started,
    gain(t) = max(0, 1 + ``per_second`` t) (windings heating up, an amplifier that sags)."""

    def __init__(self, per_second: float, joints: Any = None) -> None:
        super().__init__(joints)
        self.per_second = float(per_second)

    def changed(self, e, dq, t):
        g = max(0.0, 1.0 + self.per_second * t)
        return np.clip(g * self._kp * e - self._kd * dq, -self._lim, self._lim)


class GearPlay(_Servo):
    """Play of ``width_rad`` in a joint's gear train: within +-width/2 of the set-point the
    motor turns without driving the link, so the stiffness acts on the error beyond the play
    only; the damping (on the link's rate) is unchanged."""

    def __init__(self, width_rad: float, joints: Any = None) -> None:
        super().__init__(joints)
        self.half = 0.5 * float(width_rad)

    def changed(self, e, dq, t):
        beyond = np.sign(e) * np.maximum(np.abs(e) - self.half, 0.0)
        return np.clip(self._kp * beyond - self._kd * dq, -self._lim, self._lim)


class BackEMFLimit(_Servo):
    """A DC motor's torque-speed line: while the servo drives the joint in the direction it
    moves (motoring), the torque it can give falls with speed, to
    min(limit, ``stall_ratio`` limit (1 - |w| / ``no_load_speed_rad_s``)) (the supply voltage
    minus the back-EMF); braking torque keeps the normal limit."""

    def __init__(self, no_load_speed_rad_s: float, stall_ratio: float = 1.5,
                 joints: Any = None) -> None:
        super().__init__(joints)
        self.w0 = float(no_load_speed_rad_s)
        self.stall_ratio = float(stall_ratio)

    def changed(self, e, dq, t):
        tau = np.clip(self._kp * e - self._kd * dq, -self._lim, self._lim)
        cap = np.clip(self.stall_ratio * self._lim * (1.0 - np.abs(dq) / self.w0), 0.0, self._lim)
        motoring = tau * dq > 0
        return np.where(motoring, np.clip(tau, -cap, cap), tau)


class DryJointFriction:
    """Dry (Coulomb) friction of ``torque_Nm`` in some joints (stiff grease, a rubbing seal):
    -torque sign(dq), made continuous over |dq| < ``smooth_rad_s``."""

    changes_world = False

    def __init__(self, torque_Nm: float, joints: Any = None, smooth_rad_s: float = 0.04) -> None:
        self.joints = resolve_joints(joints)
        self.torque = float(torque_Nm)
        self.smooth = float(smooth_rad_s)

    def reset(self, sim: Any) -> None:
        self._ids = [sim.joint_indices[j] for j in self.joints]

    def substep(self, sim: Any, t: float) -> None:
        st = p.getJointStates(sim.robot, self._ids, physicsClientId=sim.client)
        dq = np.array([s[1] for s in st])
        tau = -self.torque * np.clip(dq / self.smooth, -1.0, 1.0)
        p.setJointMotorControlArray(sim.robot, self._ids, p.TORQUE_CONTROL,
                                    forces=tau.tolist(), physicsClientId=sim.client)


class HarnessSpring:
    """A cable harness pinched across a joint acts as a torsional spring:
    -``stiffness_Nm_rad`` (q - ``rest_rad``) on the joint."""

    changes_world = False

    def __init__(self, stiffness_Nm_rad: float, rest_rad: float, joints: Any = None) -> None:
        self.joints = resolve_joints(joints)
        self.k = float(stiffness_Nm_rad)
        self.rest = float(rest_rad)

    def reset(self, sim: Any) -> None:
        self._ids = [sim.joint_indices[j] for j in self.joints]

    def substep(self, sim: Any, t: float) -> None:
        st = p.getJointStates(sim.robot, self._ids, physicsClientId=sim.client)
        q = np.array([s[0] for s in st])
        tau = -self.k * (q - self.rest)
        p.setJointMotorControlArray(sim.robot, self._ids, p.TORQUE_CONTROL,
                                    forces=tau.tolist(), physicsClientId=sim.client)


class SetpointSmoother:
    """Some joints' set-points pass a first-order low-pass of ``tau_ms`` in the servo
    board (run at the 100 Hz command rate, starting from the first command)."""

    changes_world = False

    def __init__(self, tau_ms: float, joints: Any = None) -> None:
        self.joints = resolve_joints(joints)
        self.tau_ms = float(tau_ms)
        self._y: np.ndarray | None = None

    def reset(self, sim: Any) -> None:
        self._y = None

    def command(self, u: np.ndarray, t: float) -> np.ndarray:
        u = np.asarray(u, float)
        if self._y is None:
            self._y = u.copy()
        else:
            self._y = self._y + (1.0 - np.exp(-10.0 / self.tau_ms)) * (u - self._y)
        out = u.copy()
        out[self.joints] = self._y[self.joints]
        return out


class MiscountedEncoder:
    """The joint-state publisher converts some encoders' counts with a wrong counts-per-radian:
    reported angle and rate = ``ratio`` x the true ones (the servo's own loop is unaffected)."""

    changes_world = False

    def __init__(self, ratio: float, joints: Any = None) -> None:
        self.joints = resolve_joints(joints)
        self.ratio = float(ratio)

    def measure(self, obs: dict, t: float) -> dict:
        q, dq = obs["q"].copy(), obs["dq"].copy()
        q[self.joints] *= self.ratio
        dq[self.joints] *= self.ratio
        obs["q"], obs["dq"] = q, dq
        return obs


class CablePull:
    """A cable trailing from the body to a far support pulls it with a constant horizontal
    force ``force_N`` towards ``direction_deg`` (odom), at the body's centre of mass."""

    changes_world = False

    def __init__(self, force_N: float, direction_deg: float) -> None:
        a = np.radians(direction_deg)
        self.f = [float(force_N * np.cos(a)), float(force_N * np.sin(a)), 0.0]

    def substep(self, sim: Any, t: float) -> None:
        pos, _ = p.getBasePositionAndOrientation(sim.robot, physicsClientId=sim.client)
        p.applyExternalForce(sim.robot, -1, self.f, pos, p.WORLD_FRAME,
                             physicsClientId=sim.client)


class SafetyTether:
    """An elastic safety tether anchored above where the move starts: once the body is more
    than ``slack_m`` away (horizontally), it is pulled back towards the anchor by
    ``stiffness_N_m`` x (distance - slack)."""

    changes_world = False

    def __init__(self, stiffness_N_m: float, slack_m: float = 0.0) -> None:
        self.k = float(stiffness_N_m)
        self.slack = float(slack_m)
        self._anchor = np.zeros(2)

    def reset(self, sim: Any) -> None:
        pos, _ = p.getBasePositionAndOrientation(sim.robot, physicsClientId=sim.client)
        self._anchor = np.array(pos[:2], float)

    def substep(self, sim: Any, t: float) -> None:
        pos, _ = p.getBasePositionAndOrientation(sim.robot, physicsClientId=sim.client)
        d = np.array(pos[:2]) - self._anchor
        r = float(np.hypot(*d))
        if r <= self.slack or r < 1e-9:
            return
        f = -self.k * (r - self.slack) * d / r
        p.applyExternalForce(sim.robot, -1, [float(f[0]), float(f[1]), 0.0], pos,
                             p.WORLD_FRAME, physicsClientId=sim.client)


class StrappedBox:
    """A box of ``mass_kg`` strapped rigidly to the body at ``offset_m`` (the body frame of the
    recorded pose): a body of its own, without contacts, held by a fixed constraint."""

    def __init__(self, mass_kg: float, offset_m: list[float], size_m: float = 0.04) -> None:
        self.mass = float(mass_kg)
        self.offset = [float(x) for x in offset_m]
        self.size = float(size_m)

    def reset(self, sim: Any) -> None:
        c = sim.client
        pos, orn = p.getBasePositionAndOrientation(sim.robot, physicsClientId=c)
        where, _ = p.multiplyTransforms(pos, orn, self.offset, [0, 0, 0, 1])
        h = 0.5 * self.size
        shape = p.createCollisionShape(p.GEOM_BOX, halfExtents=[h, h, h], physicsClientId=c)
        box = p.createMultiBody(self.mass, shape, basePosition=where, baseOrientation=orn,
                                physicsClientId=c)
        p.setCollisionFilterGroupMask(box, -1, 0, 0, physicsClientId=c)
        lin, ang = p.getBaseVelocity(sim.robot, physicsClientId=c)
        p.resetBaseVelocity(box, lin, ang, physicsClientId=c)
        cid = p.createConstraint(sim.robot, -1, box, -1, p.JOINT_FIXED, [0, 0, 0], self.offset,
                                 [0, 0, 0], physicsClientId=c)
        p.changeConstraint(cid, maxForce=5e3, physicsClientId=c)


class WornFootPad:
    """One foot's rubber pad is worn: its friction coefficient is ``ratio`` times the others'."""

    def __init__(self, ratio: float, leg: str) -> None:
        self.ratio = float(ratio)
        self.leg = _leg_index(leg)

    def reset(self, sim: Any) -> None:
        p.changeDynamics(sim.robot, sim.foot_links[self.leg],
                         lateralFriction=sim.config.foot_friction * self.ratio,
                         physicsClientId=sim.client)
