"""zoo21's own effect plug-ins (docs/interface.md section 5): written for this zoo only."""
from __future__ import annotations

from collections import deque
from typing import Any

import numpy as np
import pybullet as p

from littledog_mlsim.layout import HOME_POSE
from littledog_mlsim.robot.effects import resolve_joints


class FloorPatch:
    """The floor's friction depends on where a foot stands: inside a disc of ``radius_m`` about
    ``centre_xy`` (odom) the normal floor, outside it a floor whose friction coefficient is
    ``scale`` times the normal one (a mat on a polished floor). Applied as the foot's lateral
    friction, updated every physics step from the foot's position in odom."""

    def __init__(self, scale: float = 0.4, radius_m: float = 0.2,
                 centre_xy: tuple[float, float] = (0.0, 0.0)) -> None:
        self.scale = float(scale)
        self.radius_m = float(radius_m)
        self.centre = np.asarray(centre_xy, dtype=float)
        self._state: dict[int, bool] = {}

    def reset(self, sim: Any) -> None:
        self._state = {}
        self._mu = sim.config.foot_friction

    def substep(self, sim: Any, t: float) -> None:
        c = sim.client
        states = p.getLinkStates(sim.robot, sim.foot_links, computeForwardKinematics=1,
                                 physicsClientId=c)
        for link, st in zip(sim.foot_links, states):
            outside = bool(np.hypot(st[0][0] - self.centre[0], st[0][1] - self.centre[1])
                           > self.radius_m)
            if self._state.get(link) != outside:
                self._state[link] = outside
                p.changeDynamics(sim.robot, link,
                                 lateralFriction=self._mu * (self.scale if outside else 1.0),
                                 physicsClientId=c)


class MocapLatency:
    """The motion-capture pose (and the twist differentiated from it) reaches the recording
    ``steps`` control steps late; the joint readings are on time. Before ``steps`` measurements
    exist, the first is repeated."""

    KEYS = ("position", "orientation", "linear_velocity", "angular_velocity")

    def __init__(self, steps: int = 2) -> None:
        self.steps = int(steps)
        self._hist: deque = deque()

    def reset(self, sim: Any) -> None:
        self._hist = deque()

    def measure(self, obs: dict, t: float) -> dict:
        now = {k: np.asarray(obs[k]).copy() for k in self.KEYS}
        if not self._hist:
            self._hist.extend(now for _ in range(self.steps))
        self._hist.append(now)
        old = self._hist.popleft()
        out = dict(obs)
        out.update({k: v.copy() for k, v in old.items()})
        return out


class Tether:
    """A slack cable from a fixed anchor in odom to the body: no force within ``slack_m`` of the
    anchor (horizontal distance), beyond it a horizontal pull towards the anchor of
    ``stiffness_N_m`` * (distance - slack)."""

    def __init__(self, stiffness_N_m: float = 10.0, slack_m: float = 0.15,
                 anchor_xy: tuple[float, float] = (0.0, 0.0)) -> None:
        self.k = float(stiffness_N_m)
        self.slack = float(slack_m)
        self.anchor = np.asarray(anchor_xy, dtype=float)

    def substep(self, sim: Any, t: float) -> None:
        pos, _ = p.getBasePositionAndOrientation(sim.robot, physicsClientId=sim.client)
        d = np.array(pos[:2]) - self.anchor
        r = float(np.hypot(*d))
        if r <= self.slack:
            return
        f = -self.k * (r - self.slack) * d / r
        p.applyExternalForce(sim.robot, -1, [float(f[0]), float(f[1]), 0.0], pos, p.WORLD_FRAME,
                             physicsClientId=sim.client)


class JointSpring:
    """A parallel elastic element (a rubber band, a stiff cable loom) on some joints: an extra
    torque -stiffness * (q - q0), q0 the home pose's angle, added to the servo's."""

    def __init__(self, stiffness_Nm_rad: float = 1.0, joints: str | list[str] = "hip_pitches"
                 ) -> None:
        self.k = float(stiffness_Nm_rad)
        self.joints = resolve_joints(joints)
        self.q0 = HOME_POSE[self.joints]

    def reset(self, sim: Any) -> None:
        self._ids = [sim.joint_indices[j] for j in self.joints]

    def substep(self, sim: Any, t: float) -> None:
        states = p.getJointStates(sim.robot, self._ids, physicsClientId=sim.client)
        q = np.array([s[0] for s in states])
        p.setJointMotorControlArray(sim.robot, self._ids, p.TORQUE_CONTROL,
                                    forces=(-self.k * (q - self.q0)).tolist(),
                                    physicsClientId=sim.client)
