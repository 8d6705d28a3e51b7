"""zoo66's own effect plug-ins (sealed, the zoo author's): physical faults and conditions no
built-in plug-in provides (``docs/interface.md`` section 5)."""
from __future__ import annotations

import numpy as np
import pybullet as p

from littledog_mlsim.robot.effects import _ServoTorque, resolve_joints


class ElasticTether:
    """An elastic cord from a fixed anchor in the world (where the body stood when the move
    started) to a point on the body (``attach`` in base_link): beyond ``slack_m`` of horizontal
    stretch it pulls the attachment point back towards the anchor with ``stiffness_N_per_m`` x
    the stretch, horizontal, at most ``max_force_N``."""

    changes_world = False

    def __init__(self, stiffness_N_per_m: float, slack_m: float = 0.0,
                 attach: list[float] = (-0.1, 0.0, 0.03), max_force_N: float = 3.0) -> None:
        self.k = float(stiffness_N_per_m)
        self.slack = float(slack_m)
        self.attach = np.asarray(attach, dtype=float)
        self.fmax = float(max_force_N)
        self._anchor = None

    def _point(self, sim):
        pos, orn = p.getBasePositionAndOrientation(sim.robot, physicsClientId=sim.client)
        R = np.array(p.getMatrixFromQuaternion(orn)).reshape(3, 3)
        return np.asarray(pos) + R @ self.attach

    def reset(self, sim) -> None:
        self._anchor = self._point(sim)[:2].copy()

    def substep(self, sim, t: float) -> None:
        pt = self._point(sim)
        d = pt[:2] - self._anchor
        r = float(np.hypot(*d))
        if r <= self.slack or r < 1e-9:
            return
        f = min(self.fmax, self.k * (r - self.slack))
        fx, fy = -f * d / r
        p.applyExternalForce(sim.robot, -1, [float(fx), float(fy), 0.0], pt.tolist(),
                             p.WORLD_FRAME, physicsClientId=sim.client)


class ConnectorDropout(_ServoTorque):
    """A loose connector on some joints' servos: at random moments (on average
    ``events_per_s`` a second, drawn per control step from the move's generator) the servo
    loses power for ``min_ms``..``max_ms`` and gives no torque (the joint is then free)."""

    def __init__(self, events_per_s: float, joints=None, min_ms: float = 20.0,
                 max_ms: float = 60.0) -> None:
        super().__init__(joints)
        self.rate = float(events_per_s)
        self.min_s, self.max_s = float(min_ms) / 1e3, float(max_ms) / 1e3
        self._until = -1.0
        self._last_step = -1

    def reset(self, sim) -> None:
        super().reset(sim)
        self._rng = np.random.default_rng(sim.rng.integers(2**32))
        self._until = -1.0
        self._last_step = -1
        self._dt = sim.control_dt

    def servo(self, e, dq, t):
        step = int(round(t / self._dt - 0.49))
        if step != self._last_step:
            self._last_step = step
            if t >= self._until and self._rng.random() < self.rate * self._dt:
                self._until = t + self._rng.uniform(self.min_s, self.max_s)
        if t < self._until:
            return np.zeros_like(e)
        return np.clip(self._kp * e - self._kd * dq, -self._lim0, self._lim0)


class SoftEndStop:
    """A rubber bumper (or a stiff cable bundle) limiting some joints' travel: beyond
    ``free_rad`` either side of the angle the joint stood at when the move started, a spring of
    ``stiffness_Nm_per_rad`` pushes the joint back (and a damper of ``damping_Nms_per_rad``
    acts while it is compressed)."""

    changes_world = False

    def __init__(self, free_rad: float, stiffness_Nm_per_rad: float, joints=None,
                 damping_Nms_per_rad: float = 0.02) -> None:
        self.joints = resolve_joints(joints)
        self.free = float(free_rad)
        self.k = float(stiffness_Nm_per_rad)
        self.c = float(damping_Nms_per_rad)

    def reset(self, sim) -> None:
        self._ids = [sim.joint_indices[j] for j in self.joints]
        self._q0 = np.array(sim.joint_state()[0][self.joints])

    def substep(self, sim, t: float) -> None:
        q, dq = sim.joint_state()
        d = q[self.joints] - self._q0
        over = np.sign(d) * np.maximum(np.abs(d) - self.free, 0.0)
        tau = -self.k * over - np.where(over != 0.0, self.c * dq[self.joints], 0.0)
        p.setJointMotorControlArray(sim.robot, self._ids, p.TORQUE_CONTROL,
                                    forces=tau.tolist(), physicsClientId=sim.client)
