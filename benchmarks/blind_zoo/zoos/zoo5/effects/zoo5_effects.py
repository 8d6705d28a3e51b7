"""Effect plug-ins of the fifth blind zoo (docs/interface.md section 5, "Effect plug-ins").

Written without reading the diagnosis or the project's own effect module: every effect here uses
only the documented hooks (``reset``, ``command``, ``substep``, ``measure``) and pybullet calls.
Which effect a zoo entry switches on, and how strongly, is in the ``zNN.yaml`` files and the
sealed ``truth.yaml``.

Joint torques that the servo does not produce are applied as a couple: a torque ``+tau`` about
the joint axis on the child link and ``-tau`` on the parent link (pybullet external torques,
world frame, re-applied before every physics step because pybullet clears them after each step).
Servo-side effects (a gain or a torque limit differing from normal) estimate the servo's own
torque ``clip(kp (u - q) - kd dq)`` from the robot configuration and the true joint state and add
the difference between the altered and the normal servo law.
"""
from __future__ import annotations

import logging
import math
from typing import Any

import numpy as np
import pybullet as p

from littledog_mlsim.layout import JOINT_NAMES, LEGS
from littledog_mlsim.robot.config import per_joint

log = logging.getLogger(__name__)

_GROUPS: dict[str, tuple[str, ...]] = {
    "all": JOINT_NAMES,
    "hip_rolls": tuple(n for n in JOINT_NAMES if n.endswith("hip_roll")),
    "hip_pitches": tuple(n for n in JOINT_NAMES if n.endswith("hip_pitch")),
    "knees": tuple(n for n in JOINT_NAMES if n.endswith("knee")),
    "left": tuple(n for n in JOINT_NAMES if "_left_" in n),
    "right": tuple(n for n in JOINT_NAMES if "_right_" in n),
}
for _leg in LEGS:
    _GROUPS[_leg] = tuple(n for n in JOINT_NAMES if n.startswith(_leg + "_"))


def joint_mask(spec: str | list[str]) -> np.ndarray:
    """Boolean (12,) mask of the joints named by a group, a leg, a joint name or a list of them."""
    names = [spec] if isinstance(spec, str) else list(spec)
    mask = np.zeros(len(JOINT_NAMES), dtype=bool)
    for n in names:
        if n in _GROUPS:
            mask |= np.isin(JOINT_NAMES, _GROUPS[n])
        elif n in JOINT_NAMES:
            mask[JOINT_NAMES.index(n)] = True
        else:
            raise ValueError(f"zoo5 effect: unknown joint or group {n!r}")
    return mask



class _JointTorque:
    """Shared machinery: joint state and joint torques applied as link couples."""

    def __init__(self) -> None:
        self.sim: Any = None
        self.u = None

    def reset(self, sim: Any) -> None:
        self.sim = sim
        self.u = None
        c = sim.client
        self._parent = []
        self._axis_local = []
        for j in sim.joint_indices:
            info = p.getJointInfo(sim.robot, j, physicsClientId=c)
            self._parent.append(int(info[16]))
            self._axis_local.append(np.asarray(info[13], dtype=float))
        cfg = sim.config
        self.kp = per_joint(cfg.kp)
        self.kd = per_joint(cfg.kd)
        self.tau_max = per_joint(cfg.torque_limit)

    def command(self, u: np.ndarray, t: float) -> np.ndarray:
        self.u = np.asarray(u, dtype=float).copy()
        return u

    def joint_state(self) -> tuple[np.ndarray, np.ndarray]:
        s = self.sim
        st = p.getJointStates(s.robot, s.joint_indices, physicsClientId=s.client)
        return np.array([x[0] for x in st]), np.array([x[1] for x in st])

    def servo_torque(self, q: np.ndarray, dq: np.ndarray, kp_scale: np.ndarray | float = 1.0,
                     limit: np.ndarray | None = None) -> np.ndarray:
        lim = self.tau_max if limit is None else limit
        tau = self.kp * kp_scale * (self.u - q) - self.kd * dq
        return np.clip(tau, -lim, lim)

    def apply(self, tau: np.ndarray) -> None:
        """Add joint torques (12,) [N m] as couples on the child and parent links."""
        s = self.sim
        c = s.client
        for k in np.flatnonzero(np.abs(tau) > 0.0):
            j = s.joint_indices[k]
            orn = p.getLinkState(s.robot, j, computeForwardKinematics=True,
                                 physicsClientId=c)[5]
            rot = np.asarray(p.getMatrixFromQuaternion(orn)).reshape(3, 3)
            t_world = (rot @ self._axis_local[k]) * float(tau[k])
            p.applyExternalTorque(s.robot, j, t_world.tolist(), p.WORLD_FRAME, physicsClientId=c)
            p.applyExternalTorque(s.robot, self._parent[k], (-t_world).tolist(), p.WORLD_FRAME,
                                  physicsClientId=c)


class LowPassCommand:
    """Set-points pass a first-order low-pass of time constant ``tau_ms`` on the given joints."""

    def __init__(self, tau_ms: float, joints: str | list[str] = "all") -> None:
        if tau_ms <= 0:
            raise ValueError("LowPassCommand: tau_ms must be > 0")
        self.tau = tau_ms / 1000.0
        self.mask = joint_mask(joints)
        self.y = None
        self.a = None

    def reset(self, sim: Any) -> None:
        self.y = None
        self.a = 1.0 - math.exp(-sim.control_dt / self.tau)

    def command(self, u: np.ndarray, t: float) -> np.ndarray:
        u = np.asarray(u, dtype=float)
        if self.y is None:
            self.y = u.copy()
        else:
            self.y = self.y + self.a * (u - self.y)
        return np.where(self.mask, self.y, u)


class TiltedFloor:
    """The floor inclined by ``slope_deg``, rising towards ``uphill_deg`` (odom); gravity stays -z.

    At reset the ground plane is rotated about the point under the robot and the robot is rotated
    rigidly with it, so it starts standing on the incline.
    """

    def __init__(self, slope_deg: float, uphill_deg: float) -> None:
        self.slope = math.radians(slope_deg)
        self.uphill = math.radians(uphill_deg)

    def reset(self, sim: Any) -> None:
        c = sim.client
        # a rotation by +slope about the horizontal axis d x z lifts the uphill direction d
        d = np.array([math.cos(self.uphill), math.sin(self.uphill), 0.0])
        axis = np.cross(d, [0.0, 0.0, 1.0])
        r = p.getQuaternionFromAxisAngle(axis.tolist(), self.slope)
        rot = np.asarray(p.getMatrixFromQuaternion(r)).reshape(3, 3)
        if (rot @ d)[2] <= 0:
            raise RuntimeError("TiltedFloor: the floor does not rise uphill (rotation sign)")
        pos, orn = p.getBasePositionAndOrientation(sim.robot, physicsClientId=c)
        centre = np.array([pos[0], pos[1], 0.0])
        p.resetBasePositionAndOrientation(sim.plane, (centre - rot @ centre).tolist(), r,
                                          physicsClientId=c)
        new_pos = centre + rot @ (np.asarray(pos) - centre)
        _, new_orn = p.multiplyTransforms([0, 0, 0], r, [0, 0, 0], orn)
        p.resetBasePositionAndOrientation(sim.robot, new_pos.tolist(), new_orn, physicsClientId=c)
        p.resetBaseVelocity(sim.robot, [0, 0, 0], [0, 0, 0], physicsClientId=c)


class WorldForce:
    """A constant horizontal force [N] fixed in odom, applied at the body's centre of mass."""

    def __init__(self, force_xy: list[float]) -> None:
        self.f = [float(force_xy[0]), float(force_xy[1]), 0.0]

    def reset(self, sim: Any) -> None:
        self.sim = sim

    def substep(self, sim: Any, t: float) -> None:
        pos, _ = p.getBasePositionAndOrientation(sim.robot, physicsClientId=sim.client)
        p.applyExternalForce(sim.robot, -1, self.f, pos, p.WORLD_FRAME, physicsClientId=sim.client)


class CarriedMass:
    """Extra mass carried at an offset [m] from the body's centre of mass (base_link axes).

    The base link's mass and inertia are raised (parallel axis about the old COM), and the
    weight of the added mass acting off-centre is added as the moment ``offset x (-m g z)``
    (world frame), since pybullet cannot move a base's centre of mass after loading.
    """

    def __init__(self, mass: float, offset: list[float]) -> None:
        self.m = float(mass)
        self.offset = np.asarray(offset, dtype=float)
        self._orig: dict[tuple[int, int], tuple[float, tuple[float, ...]]] = {}

    def reset(self, sim: Any) -> None:
        c = sim.client
        key = (c, sim.robot)
        info = p.getDynamicsInfo(sim.robot, -1, physicsClientId=c)
        mass, inertia = float(info[0]), tuple(info[2])
        if key in self._orig and abs(mass - (self._orig[key][0] + self.m)) < 1e-9:
            mass, inertia = self._orig[key]
        self._orig[key] = (mass, inertia)
        o = self.offset
        par = self.m * np.array([o[1] ** 2 + o[2] ** 2, o[0] ** 2 + o[2] ** 2, o[0] ** 2 + o[1] ** 2])
        p.changeDynamics(sim.robot, -1, mass=mass + self.m,
                         localInertiaDiagonal=(np.asarray(inertia) + par).tolist(),
                         physicsClientId=c)
        self.g = 9.81

    def substep(self, sim: Any, t: float) -> None:
        c = sim.client
        _, orn = p.getBasePositionAndOrientation(sim.robot, physicsClientId=c)
        rot = np.asarray(p.getMatrixFromQuaternion(orn)).reshape(3, 3)
        r = rot @ self.offset
        torque = np.cross(r, [0.0, 0.0, -self.m * self.g])
        p.applyExternalTorque(sim.robot, -1, torque.tolist(), p.WORLD_FRAME, physicsClientId=c)


class FootFriction:
    """One foot's friction coefficient is ``scale`` times the normal one."""

    def __init__(self, leg: str, scale: float) -> None:
        if leg not in LEGS:
            raise ValueError(f"FootFriction: unknown leg {leg!r}")
        self.leg = LEGS.index(leg)
        self.scale = float(scale)

    def reset(self, sim: Any) -> None:
        link = sim.foot_links[self.leg]
        p.changeDynamics(sim.robot, link, lateralFriction=sim.config.foot_friction * self.scale,
                         physicsClientId=sim.client)


class Play:
    """Play (backlash) of total width ``width`` [rad] between the set-point and the joint.

    The position the joint is driven to follows the set-point only once the set-point has crossed
    the dead band: y = u - w/2 when u > y + w/2, y = u + w/2 when u < y - w/2, else y holds.
    """

    def __init__(self, width: float, joints: str | list[str]) -> None:
        self.half = 0.5 * float(width)
        self.mask = joint_mask(joints)
        self.y = None

    def reset(self, sim: Any) -> None:
        self.y = None

    def command(self, u: np.ndarray, t: float) -> np.ndarray:
        u = np.asarray(u, dtype=float)
        if self.y is None:
            self.y = u.copy()
        else:
            self.y = np.clip(self.y, u - self.half, u + self.half)
        return np.where(self.mask, self.y, u)


class EncoderBias:
    """The encoder of the given joints reads ``offset`` [rad] more than the true angle.

    The servo closes its loop on the encoder, so it holds the true angle ``offset`` below the
    set-point; the reported angle is the biased one.
    """

    def __init__(self, offset: float, joints: str | list[str]) -> None:
        self.off = float(offset) * joint_mask(joints)

    def reset(self, sim: Any) -> None:
        pass

    def command(self, u: np.ndarray, t: float) -> np.ndarray:
        return np.asarray(u, dtype=float) - self.off

    def measure(self, obs: dict, t: float) -> dict:
        obs = dict(obs)
        obs["q"] = np.asarray(obs["q"], dtype=float) + self.off
        return obs


class ServoLaw(_JointTorque):
    """The servo's stiffness scaled by ``gain`` and its torque limit set to ``limit`` [N m]
    (None: normal) on the given joints; ``gain_rate`` [1/s] makes the gain drift linearly with
    the time since the move started (gain(t) = gain * (1 + gain_rate t))."""

    def __init__(self, joints: str | list[str] = "all", gain: float = 1.0,
                 limit: float | None = None, gain_rate: float = 0.0) -> None:
        super().__init__()
        self.mask = joint_mask(joints)
        self.gain = float(gain)
        self.limit = limit
        self.rate = float(gain_rate)

    def substep(self, sim: Any, t: float) -> None:
        if self.u is None:
            return
        q, dq = self.joint_state()
        g = self.gain * (1.0 + self.rate * t)
        scale = np.where(self.mask, g, 1.0)
        lim = self.tau_max.copy()
        if self.limit is not None:
            lim = np.where(self.mask, np.minimum(lim, float(self.limit)), lim)
        tau = self.servo_torque(q, dq, scale, lim) - self.servo_torque(q, dq)
        self.apply(np.where(self.mask, tau, 0.0))


class CoulombFriction(_JointTorque):
    """Extra Coulomb friction ``coulomb`` [N m] on the given joints, smoothed below ``v0`` rad/s."""

    def __init__(self, coulomb: float, joints: str | list[str], v0: float = 0.25) -> None:
        super().__init__()
        self.c = float(coulomb)
        self.mask = joint_mask(joints)
        self.v0 = float(v0)

    def substep(self, sim: Any, t: float) -> None:
        _, dq = self.joint_state()
        self.apply(np.where(self.mask, -self.c * np.tanh(dq / self.v0), 0.0))


class SwingDrag:
    """A drag of ``force`` [N] on one foot while it is off the ground (swing), opposing the foot's
    horizontal velocity (full force above ``v0`` m/s, proportional below)."""

    def __init__(self, leg: str, force: float, v0: float = 0.1) -> None:
        if leg not in LEGS:
            raise ValueError(f"SwingDrag: unknown leg {leg!r}")
        self.leg = LEGS.index(leg)
        self.f = float(force)
        self.v0 = float(v0)

    def reset(self, sim: Any) -> None:
        pass

    def substep(self, sim: Any, t: float) -> None:
        c = sim.client
        link = sim.foot_links[self.leg]
        if p.getContactPoints(sim.robot, sim.plane, linkIndexA=link, physicsClientId=c):
            return
        st = p.getLinkState(sim.robot, link, computeLinkVelocity=True,
                            computeForwardKinematics=True, physicsClientId=c)
        v = np.array([st[6][0], st[6][1], 0.0])
        speed = float(np.hypot(v[0], v[1]))
        f = -self.f * v / max(speed, self.v0)
        p.applyExternalForce(sim.robot, link, f.tolist(), st[0], p.WORLD_FRAME, physicsClientId=c)
