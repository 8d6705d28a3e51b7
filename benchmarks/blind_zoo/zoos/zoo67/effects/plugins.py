"""zoo67's own effect plug-ins (sealed, the zoo author's): physical conditions no built-in
plug-in of ``littledog_mlsim/robot/effects.py`` provides (protocol: ``docs/interface.md``
section 5).

- :class:`OverheadTether`: a cable from a spring reel hung above the move's start point,
  fixed to the body: a pull of constant tension towards the reel.
- :class:`LooseMass`: part of the body's mass (a battery, a payload bay) sits on a soft,
  damped mount instead of being rigidly fixed: a point mass on a spring-damper to the body.
- :class:`EndStop`: a soft mechanical stop at one end of a joint's travel (a cable harness or a
  bent guard that catches the link): a stiff spring-damper torque once the joint passes it.
"""
from __future__ import annotations

from typing import Any

import numpy as np
import pybullet as p

from littledog_mlsim.robot.effects import resolve_joints


def _vec(v, n: int, what: str) -> np.ndarray:
    a = np.asarray(v, dtype=float).reshape(-1)
    if a.size != n or not np.isfinite(a).all():
        raise ValueError(f"{what}: expected {n} finite numbers, got {v!r}")
    return a


class OverheadTether:
    """A cable from a reel ``height_m`` above the floor, over the point where the body's
    ``attach`` point (base_link) is when the move starts, pulls that point towards the reel
    with a constant ``tension_N`` (a spring-loaded reel keeps the tension). The horizontal part
    grows as the robot walks away from the start; the vertical part nearly constant."""

    changes_world = False     # forces only, each step

    def __init__(self, tension_N: float, height_m: float = 0.8,
                 attach: list[float] | tuple[float, float, float] = (-0.05, 0.0, 0.03)) -> None:
        if not (np.isfinite(tension_N) and tension_N >= 0):
            raise ValueError(f"OverheadTether: tension_N must be >= 0, got {tension_N!r}")
        if not (np.isfinite(height_m) and height_m > 0.3):
            raise ValueError(f"OverheadTether: height_m must be > 0.3, got {height_m!r}")
        self.tension_N = float(tension_N)
        self.height_m = float(height_m)
        self.attach = _vec(attach, 3, "OverheadTether.attach")
        self._anchor = np.zeros(3)

    def _attach_world(self, sim: Any) -> np.ndarray:
        pos, orn = p.getBasePositionAndOrientation(sim.robot, physicsClientId=sim.client)
        R = np.array(p.getMatrixFromQuaternion(orn)).reshape(3, 3)
        return np.asarray(pos) + R @ self.attach

    def reset(self, sim: Any) -> None:
        a = self._attach_world(sim)
        self._anchor = np.array([a[0], a[1], self.height_m])

    def substep(self, sim: Any, t: float) -> None:
        a = self._attach_world(sim)
        d = self._anchor - a
        f = self.tension_N * d / max(float(np.linalg.norm(d)), 1e-9)
        p.applyExternalForce(sim.robot, -1, f.tolist(), a.tolist(), p.WORLD_FRAME,
                             physicsClientId=sim.client)


class LooseMass:
    """``mass_kg`` of the body's own mass sits on a soft mount at ``offset`` (base_link): the
    body keeps its mass less ``mass_kg`` (its inertia scaled alike), and a point mass of
    ``mass_kg`` hangs on an isotropic spring-damper of natural frequency ``frequency_hz`` and
    damping ratio ``damping_ratio`` about that point. Total mass unchanged."""

    def __init__(self, mass_kg: float, frequency_hz: float, damping_ratio: float = 0.15,
                 offset: list[float] | tuple[float, float, float] = (0.0, 0.0, 0.0)) -> None:
        if not (np.isfinite(mass_kg) and mass_kg > 0):
            raise ValueError(f"LooseMass: mass_kg must be > 0, got {mass_kg!r}")
        if not (np.isfinite(frequency_hz) and 1.0 <= frequency_hz <= 40.0):
            raise ValueError(f"LooseMass: frequency_hz must be in [1, 40], got {frequency_hz!r}")
        if not (np.isfinite(damping_ratio) and damping_ratio >= 0):
            raise ValueError(f"LooseMass: damping_ratio must be >= 0, got {damping_ratio!r}")
        self.mass_kg = float(mass_kg)
        self.frequency_hz = float(frequency_hz)
        self.damping_ratio = float(damping_ratio)
        self.offset = _vec(offset, 3, "LooseMass.offset")
        w = 2.0 * np.pi * self.frequency_hz
        self.k = self.mass_kg * w * w
        self.c = 2.0 * self.damping_ratio * self.mass_kg * w
        self.body = -1

    def _anchor(self, sim: Any) -> tuple[np.ndarray, np.ndarray]:
        c = sim.client
        pos, orn = p.getBasePositionAndOrientation(sim.robot, physicsClientId=c)
        lin, ang = p.getBaseVelocity(sim.robot, physicsClientId=c)
        R = np.array(p.getMatrixFromQuaternion(orn)).reshape(3, 3)
        r = R @ self.offset
        return np.asarray(pos) + r, np.asarray(lin) + np.cross(np.asarray(ang), r)

    def reset(self, sim: Any) -> None:
        from littledog_mlsim.robot.sim import GRAVITY
        c = sim.client
        mass, _, inertia = p.getDynamicsInfo(sim.robot, -1, physicsClientId=c)[:3]
        if self.mass_kg >= 0.5 * mass:
            raise ValueError("LooseMass: mass_kg must be less than half the body's mass")
        s = (mass - self.mass_kg) / mass
        p.changeDynamics(sim.robot, -1, mass=mass - self.mass_kg,
                         localInertiaDiagonal=[v * s for v in inertia], physicsClientId=c)
        anchor, vel = self._anchor(sim)
        start = anchor - np.array([0.0, 0.0, self.mass_kg * GRAVITY / self.k])   # at rest
        shape = p.createCollisionShape(p.GEOM_SPHERE, radius=0.01, physicsClientId=c)
        self.body = p.createMultiBody(self.mass_kg, shape, basePosition=start.tolist(),
                                      physicsClientId=c)
        p.resetBaseVelocity(self.body, vel.tolist(), [0, 0, 0], physicsClientId=c)
        p.setCollisionFilterGroupMask(self.body, -1, 0, 0, physicsClientId=c)  # no contacts
        p.changeDynamics(self.body, -1, linearDamping=0.0, angularDamping=0.0,
                         physicsClientId=c)

    def substep(self, sim: Any, t: float) -> None:
        c = sim.client
        anchor, va = self._anchor(sim)
        pm, _ = p.getBasePositionAndOrientation(self.body, physicsClientId=c)
        vm, _ = p.getBaseVelocity(self.body, physicsClientId=c)
        f = self.k * (anchor - np.asarray(pm)) + self.c * (va - np.asarray(vm))
        p.applyExternalForce(self.body, -1, f.tolist(), list(pm), p.WORLD_FRAME,
                             physicsClientId=c)
        p.applyExternalForce(sim.robot, -1, (-f).tolist(), anchor.tolist(), p.WORLD_FRAME,
                             physicsClientId=c)


class EndStop:
    """A soft stop on one joint at ``stop_rad``: beyond it (``side`` "below": q < stop_rad;
    "above": q > stop_rad) a torque stiffness_Nm_per_rad x (penetration) plus damping
    damping_Nms_per_rad x (rate into the stop) pushes the joint back (never pulls)."""

    changes_world = False     # torques only, each step

    SIDES = ("below", "above")

    def __init__(self, joint: str, stop_rad: float, side: str = "below",
                 stiffness_Nm_per_rad: float = 20.0, damping_Nms_per_rad: float = 0.05) -> None:
        j = resolve_joints(joint)
        if len(j) != 1:
            raise ValueError(f"EndStop: one joint, got {joint!r}")
        if side not in self.SIDES:
            raise ValueError(f"EndStop: side must be one of {self.SIDES}, got {side!r}")
        if not (np.isfinite(stop_rad) and np.isfinite(stiffness_Nm_per_rad)
                and stiffness_Nm_per_rad >= 0 and np.isfinite(damping_Nms_per_rad)
                and damping_Nms_per_rad >= 0):
            raise ValueError("EndStop: finite stop, non-negative stiffness and damping")
        self.j = int(j[0])
        self.stop = float(stop_rad)
        self.sign = 1.0 if side == "below" else -1.0
        self.k = float(stiffness_Nm_per_rad)
        self.c = float(damping_Nms_per_rad)

    def reset(self, sim: Any) -> None:
        self._id = sim.joint_indices[self.j]

    def substep(self, sim: Any, t: float) -> None:
        q, dq = sim.joint_state()
        pen = self.sign * (self.stop - float(q[self.j]))        # > 0 past the stop
        if pen <= 0.0:
            return
        tau = max(0.0, self.k * pen - self.c * self.sign * float(dq[self.j]))
        p.setJointMotorControlArray(sim.robot, [self._id], p.TORQUE_CONTROL,
                                    forces=[self.sign * tau], physicsClientId=sim.client)
