"""Joint servos: the robot's 500 Hz torque-mode PD and an idealised pybullet position servo.

Both are called once per physics step (:meth:`apply`) with the desired angles (12,), contract
order, already clamped to the joint limits. pybullet clears applied joint torques after every
``stepSimulation``, so the PD re-sends its (held) torque on every physics step; with the physics
step equal to the 2 ms servo period that is exactly one servo update per step.
"""
from __future__ import annotations

import numpy as np
import pybullet as p

from .config import RobotConfig, per_joint
from .sensors import JointEncoders


class PDTorqueServo:
    """tau = clip(k (q_des - q_enc) - b dq_enc, -tau_max, tau_max), sent in TORQUE_CONTROL.

    q_enc are the quantised encoder angles and dq_enc their unfiltered difference at the servo
    rate (:class:`JointEncoders`). The torque is constant over the physics step.
    """

    needs_encoders = True

    def __init__(self, config: RobotConfig) -> None:
        self.kp = per_joint(config.kp)
        self.kd = per_joint(config.kd)
        self.tau_max = per_joint(config.torque_limit)
        self._tau_min = -self.tau_max
        self.last_torque = np.zeros(12)

    def torque(self, q_des: np.ndarray, q_enc: np.ndarray, dq_enc: np.ndarray) -> np.ndarray:
        """Servo torque [N m], (12,)."""
        tau = self.kp * (q_des - q_enc) - self.kd * dq_enc
        return np.minimum(np.maximum(tau, self._tau_min), self.tau_max)

    def start(self, client: int, body: int, joints: list[int]) -> None:
        """Switch pybullet's default joint velocity motors off (torque mode)."""
        p.setJointMotorControlArray(body, joints, p.VELOCITY_CONTROL, forces=[0.0] * len(joints),
                                    physicsClientId=client)

    def apply(self, client: int, body: int, joints: list[int], q_des: np.ndarray,
              encoders: JointEncoders) -> None:
        self.last_torque = self.torque(q_des, encoders.position, encoders.raw_rate)
        p.setJointMotorControlArray(body, joints, p.TORQUE_CONTROL, forces=self.last_torque.tolist(),
                                    physicsClientId=client)


class PositionServo:
    """pybullet POSITION_CONTROL (solved implicitly by the constraint solver) with explicit forces.

    ``position_gain``/``velocity_gain`` are pybullet's gains; ``forces`` the torque limits. The
    motor targets persist in pybullet, so they are only re-sent when the desired angles change.
    """

    needs_encoders = False

    def __init__(self, config: RobotConfig) -> None:
        self.position_gain = config.position_gain
        self.velocity_gain = config.velocity_gain
        self.tau_max = per_joint(config.torque_limit)
        self._sent: np.ndarray | None = None

    def start(self, client: int, body: int, joints: list[int]) -> None:
        self._sent = None

    def apply(self, client: int, body: int, joints: list[int], q_des: np.ndarray,
              encoders: JointEncoders) -> None:
        if self._sent is not None and np.array_equal(self._sent, q_des):
            return
        n = len(joints)
        p.setJointMotorControlArray(
            body, joints, p.POSITION_CONTROL, targetPositions=q_des, targetVelocities=[0.0] * n,
            forces=self.tau_max, positionGains=[self.position_gain] * n,
            velocityGains=[self.velocity_gain] * n, physicsClientId=client)
        self._sent = q_des.copy()


def make_servo(config: RobotConfig) -> PDTorqueServo | PositionServo:
    """The servo named by ``config.servo``."""
    return PDTorqueServo(config) if config.servo == "pd_torque" else PositionServo(config)
