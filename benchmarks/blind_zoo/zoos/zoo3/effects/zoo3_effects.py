"""Effect plug-ins of the third blind zoo, written from the plug-in protocol only
(docs/interface.md section 5: ``reset(sim)``, ``command(u, t)``, ``substep(sim, t)``,
``measure(obs, t)``), with numpy and pybullet.

Joint torques that are not the servo's are applied as an equal and opposite pair of external
torques about the joint axis, on the joint's child link and on its parent link: pybullet maps
that pair to a generalised force on that joint alone (checked against TORQUE_CONTROL on the
URDF with a fixed base: identical joint accelerations). Servo variations are applied the same
way, as the difference between the varied servo law and the robot's own PD law
``clip(kp (q_des - q) - kd dq, -tau_max, tau_max)`` evaluated on the true joint state.
"""
from __future__ import annotations

from typing import Any

import numpy as np
import pybullet as p

LEGS = ("front_left", "front_right", "back_left", "back_right")
KINDS = ("hip_roll", "hip_pitch", "knee")
NAMES = tuple(f"{leg}_{k}" for leg in LEGS for k in KINDS)
# Joint limits [rad] in NAMES order (the servo receives clamped set-points).
_FRONT = ((-0.6, 0.6), (-3.5, 2.4), (-3.1, 1.0))
_BACK = ((-0.6, 0.6), (-2.4, 3.5), (-1.0, 3.1))
LOWER = np.array([(_FRONT if leg.startswith("front") else _BACK)[j][0] for leg in LEGS for j in range(3)])
UPPER = np.array([(_FRONT if leg.startswith("front") else _BACK)[j][1] for leg in LEGS for j in range(3)])
GRAVITY = 9.81
_PLURAL = {"hip_rolls": "hip_roll", "hip_pitches": "hip_pitch", "knees": "knee"}


def select(spec: str | list[str]) -> np.ndarray:
    """Boolean mask (12,) of the joints named by ``spec``: a joint name, a leg, ``all``,
    ``hip_rolls``/``hip_pitches``/``knees``, ``left``/``right``, or a list of those."""
    specs = [spec] if isinstance(spec, str) else list(spec)
    mask = np.zeros(12, dtype=bool)
    for s in specs:
        hit = np.array([
            s == "all" or s == n or n.startswith(s + "_")
            or (s in _PLURAL and n.endswith(_PLURAL[s]))
            or (s in ("left", "right") and n.split("_")[1] == s)
            for n in NAMES])
        if not hit.any():
            raise ValueError(f"zoo3 effect: unknown joint selection {s!r}")
        mask |= hit
    return mask


def _triple(v: Any) -> np.ndarray:
    return np.tile(np.broadcast_to(np.asarray(v, dtype=float), (3,)), 4)


class _JointTorque:
    """Adds generalised torques on chosen joints through external torque pairs."""

    def _setup(self, sim: Any) -> None:
        self.client, self.robot = sim.client, sim.robot
        self.joints = list(sim.joint_indices)
        infos = [p.getJointInfo(self.robot, j, physicsClientId=self.client) for j in self.joints]
        self.parents = [int(i[16]) for i in infos]
        self.axes = np.array([i[13] for i in infos], dtype=float)
        cfg = sim.config
        self.kp, self.kd = _triple(cfg.kp), _triple(cfg.kd)
        self.tau_max = _triple(cfg.torque_limit)

    def joint_state(self) -> tuple[np.ndarray, np.ndarray]:
        st = p.getJointStates(self.robot, self.joints, physicsClientId=self.client)
        return np.array([s[0] for s in st]), np.array([s[1] for s in st])

    def servo(self, e: np.ndarray, dq: np.ndarray, kp: np.ndarray, tau_max: np.ndarray) -> np.ndarray:
        return np.clip(kp * e - self.kd * dq, -tau_max, tau_max)

    def apply(self, tau: np.ndarray) -> None:
        for i in np.flatnonzero(tau):
            j = self.joints[i]
            ls = p.getLinkState(self.robot, j, computeForwardKinematics=True,
                                physicsClientId=self.client)
            rot = np.array(p.getMatrixFromQuaternion(ls[5])).reshape(3, 3)
            t = (rot @ self.axes[i]) * float(tau[i])
            p.applyExternalTorque(self.robot, j, t.tolist(), p.WORLD_FRAME, physicsClientId=self.client)
            p.applyExternalTorque(self.robot, self.parents[i], (-t).tolist(), p.WORLD_FRAME,
                                  physicsClientId=self.client)


class HeldSetpoints(_JointTorque):
    """Keeps the (clamped) set-points the servo receives, for servo-law variations."""

    def reset(self, sim: Any) -> None:
        self._setup(sim)
        self.q_des = None

    def command(self, u: np.ndarray, t: float) -> np.ndarray:
        self.q_des = np.clip(np.asarray(u, dtype=float), LOWER, UPPER)
        return u


class ServoGainDrift(HeldSetpoints):
    """The servo's P gain on the chosen joints is ``1 + rate_per_s * t`` times its normal value,
    t the time since the move started (e.g. a supply that sags as the motors draw current)."""

    def __init__(self, rate_per_s: float, joints: str | list[str] = "all") -> None:
        self.rate = float(rate_per_s)
        self.mask = select(joints)

    def substep(self, sim: Any, t: float) -> None:
        if self.q_des is None:
            return
        q, dq = self.joint_state()
        e = self.q_des - q
        ratio = max(0.0, 1.0 + self.rate * t)
        tau = self.servo(e, dq, ratio * self.kp, self.tau_max) - self.servo(e, dq, self.kp, self.tau_max)
        self.apply(np.where(self.mask, tau, 0.0))


class TorqueLimit(HeldSetpoints):
    """The servo's torque limit on the chosen joints is ``limit_Nm`` instead of its normal one."""

    def __init__(self, limit_Nm: float, joints: str | list[str]) -> None:
        self.limit = float(limit_Nm)
        self.mask = select(joints)

    def substep(self, sim: Any, t: float) -> None:
        if self.q_des is None:
            return
        q, dq = self.joint_state()
        e = self.q_des - q
        lim = np.where(self.mask, np.minimum(self.limit, self.tau_max), self.tau_max)
        tau = self.servo(e, dq, self.kp, lim) - self.servo(e, dq, self.kp, self.tau_max)
        self.apply(np.where(self.mask, tau, 0.0))


class DryFriction(_JointTorque):
    """Coulomb friction ``-coulomb_Nm * tanh(dq / smooth_rad_s)`` on the chosen joints."""

    def __init__(self, coulomb_Nm: float, joints: str | list[str], smooth_rad_s: float = 0.3) -> None:
        self.c = float(coulomb_Nm)
        self.v0 = float(smooth_rad_s)
        self.mask = select(joints)

    def reset(self, sim: Any) -> None:
        self._setup(sim)

    def substep(self, sim: Any, t: float) -> None:
        _, dq = self.joint_state()
        self.apply(np.where(self.mask, -self.c * np.tanh(dq / self.v0), 0.0))


class LateJoints:
    """The chosen joints receive their set-points ``steps`` control steps (10 ms each) late."""

    def __init__(self, steps: int, joints: str | list[str]) -> None:
        self.steps = int(steps)
        self.mask = select(joints)

    def reset(self, sim: Any) -> None:
        self.buf: list[np.ndarray] = []

    def command(self, u: np.ndarray, t: float) -> np.ndarray:
        u = np.asarray(u, dtype=float)
        if not self.buf:
            self.buf = [u.copy()] * self.steps
        self.buf.append(u.copy())
        old = self.buf.pop(0)
        return np.where(self.mask, old, u)


class EncoderShift:
    """The chosen joint's encoder reads ``offset_rad`` more than the true angle: the servo closes
    its loop on that reading (the true joint settles ``offset_rad`` short of the set-point) and the
    reported angle carries it too."""

    def __init__(self, offset_rad: float, joints: str | list[str]) -> None:
        self.off = np.where(select(joints), float(offset_rad), 0.0)

    def command(self, u: np.ndarray, t: float) -> np.ndarray:
        return np.asarray(u, dtype=float) - self.off

    def measure(self, obs: dict, t: float) -> dict:
        obs = dict(obs)
        obs["q"] = np.asarray(obs["q"], dtype=float) + self.off
        return obs


class HorizontalPull:
    """A constant horizontal force fixed in odom, applied at the body's centre of mass."""

    def __init__(self, force_N: float, direction_deg: float) -> None:
        a = np.radians(float(direction_deg))
        self.f = [float(force_N) * np.cos(a), float(force_N) * np.sin(a), 0.0]

    def substep(self, sim: Any, t: float) -> None:
        pos, _ = p.getBasePositionAndOrientation(sim.robot, physicsClientId=sim.client)
        p.applyExternalForce(sim.robot, -1, self.f, pos, p.WORLD_FRAME, physicsClientId=sim.client)


class Payload:
    """A point mass rigidly carried at ``offset_m`` (base_link frame, from the body's centre of
    mass): the body's mass and inertia grow (parallel axis), and the weight's moment about the
    body's centre of mass is applied as an external torque. Put on when the move starts."""

    def __init__(self, mass_kg: float, offset_m: list[float]) -> None:
        self.m = float(mass_kg)
        self.r = np.asarray(offset_m, dtype=float)
        self.base: tuple[float, np.ndarray] | None = None

    def reset(self, sim: Any) -> None:
        if self.base is None:
            info = p.getDynamicsInfo(sim.robot, -1, physicsClientId=sim.client)
            self.base = (float(info[0]), np.asarray(info[2], dtype=float))
        m0, i0 = self.base
        r = self.r
        inertia = i0 + self.m * (r @ r - r * r)
        p.changeDynamics(sim.robot, -1, mass=m0 + self.m, localInertiaDiagonal=inertia.tolist(),
                         physicsClientId=sim.client)

    def substep(self, sim: Any, t: float) -> None:
        _, quat = p.getBasePositionAndOrientation(sim.robot, physicsClientId=sim.client)
        rot = np.array(p.getMatrixFromQuaternion(quat)).reshape(3, 3)
        # The added mass already weighs at the centre of mass; add the moment of its offset.
        torque = np.cross(rot @ self.r, [0.0, 0.0, -self.m * GRAVITY])
        p.applyExternalTorque(sim.robot, -1, torque.tolist(), p.WORLD_FRAME, physicsClientId=sim.client)


class InclinedFloor:
    """The ground plane is inclined by ``slope_deg``, rising towards ``uphill_direction_deg``
    (odom). It is placed just below the standing robot's feet when the move starts."""

    def __init__(self, slope_deg: float, uphill_direction_deg: float) -> None:
        self.s = np.radians(float(slope_deg))
        self.phi = np.radians(float(uphill_direction_deg))

    def reset(self, sim: Any) -> None:
        c = sim.client
        d = np.array([np.cos(self.phi), np.sin(self.phi), 0.0])
        # Rotation about the horizontal axis z x d: a positive angle would lower d, so -s lifts it.
        axis = np.cross([0.0, 0.0, 1.0], d)
        quat = p.getQuaternionFromAxisAngle(axis.tolist(), -float(self.s))  # raises +d
        feet = np.array([p.getLinkState(sim.robot, f, physicsClientId=c)[0] for f in sim.foot_links])
        rise = np.tan(self.s) * (feet[:, :2] @ d[:2])
        # Plane height h(x, y) = tan(s) (x, y).d + z0: through the origin shifted down so no foot
        # starts inside it (the feet stand on z = 0).
        z0 = -float(rise.max())
        p.resetBasePositionAndOrientation(sim.plane, [0.0, 0.0, z0], quat, physicsClientId=c)


class FootPad:
    """One foot's friction coefficient is ``scale`` times its normal value."""

    def __init__(self, scale: float, leg: str) -> None:
        self.scale = float(scale)
        self.leg = LEGS.index(leg)
        self.mu0: float | None = None

    def reset(self, sim: Any) -> None:
        foot = sim.foot_links[self.leg]
        if self.mu0 is None:
            self.mu0 = float(p.getDynamicsInfo(sim.robot, foot, physicsClientId=sim.client)[1])
        p.changeDynamics(sim.robot, foot, lateralFriction=self.scale * self.mu0,
                         physicsClientId=sim.client)


class SwingDrag:
    """While the chosen foot is off the ground, a horizontal force of ``force_N`` opposes its
    horizontal velocity (smoothed below ``smooth_m_s``); nothing while it stands."""

    def __init__(self, force_N: float, leg: str, smooth_m_s: float = 0.05) -> None:
        self.f = float(force_N)
        self.leg = LEGS.index(leg)
        self.v0 = float(smooth_m_s)

    def substep(self, sim: Any, t: float) -> None:
        c, robot = sim.client, sim.robot
        foot = sim.foot_links[self.leg]
        if p.getContactPoints(robot, sim.plane, linkIndexA=foot, physicsClientId=c):
            return
        ls = p.getLinkState(robot, foot, computeLinkVelocity=True, physicsClientId=c)
        v = np.array([ls[6][0], ls[6][1], 0.0])
        speed = float(np.hypot(v[0], v[1]))
        if speed < 1e-9:
            return
        force = -self.f * np.tanh(speed / self.v0) * v / speed
        p.applyExternalForce(robot, foot, force.tolist(), list(ls[0]), p.WORLD_FRAME, physicsClientId=c)
