"""A control for zoo9's position false alarms (not an effect): each move starts from its own
place and heading on the floor, drawn from the move's own random stream, so that where the robot
is no longer follows from the move's type and elapsed time."""
from __future__ import annotations

import math

import pybullet as p


class RandomStart:
    """At reset, carry the standing robot (at rest) by a uniform offset of up to
    ``half_span_m`` in x and y and turn it by a uniform yaw in [-pi, pi)."""

    def __init__(self, half_span_m: float = 0.5) -> None:
        self.half_span_m = float(half_span_m)

    def reset(self, sim) -> None:
        c = sim.client
        pos, orn = p.getBasePositionAndOrientation(sim.robot, physicsClientId=c)
        dx, dy = sim.rng.uniform(-self.half_span_m, self.half_span_m, size=2)
        yaw = float(sim.rng.uniform(-math.pi, math.pi))
        turn = p.getQuaternionFromEuler([0.0, 0.0, yaw])
        new_pos = [pos[0] + dx, pos[1] + dy, pos[2]]
        new_orn = p.multiplyTransforms([0, 0, 0], turn, [0, 0, 0], orn)[1]
        p.resetBasePositionAndOrientation(sim.robot, new_pos, new_orn, physicsClientId=c)
        p.resetBaseVelocity(sim.robot, [0, 0, 0], [0, 0, 0], physicsClientId=c)
