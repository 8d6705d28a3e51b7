"""Time the pieces of one physics step of the simulator, one by one (timeit, best of 3 x 3000
calls), on a robot standing in its home pose after a reset:

    OPENBLAS_NUM_THREADS=1 .venv/bin/python -P benchmarks/diagnose_speed/step_python/step_pieces.py ROBOT

ROBOT: a robot name or a twin file. The state moves on as the steps are timed, so
`stepSimulation` and the step's times depend on where the robot is by then (a robot in the air
steps faster than one on its feet); the Python pieces do not.
"""
import sys
import timeit

import pybullet as p

from littledog_mlsim.robot.sim import LittleDogSim
from littledog_mlsim.robot.twin import robot_config_from


def main() -> None:
    sim = LittleDogSim(robot_config_from(sys.argv[1]))
    sim.reset()
    q_des = sim.observe()["q"]
    c, r, joints = sim.client, sim.robot, sim.joint_indices
    enc, servo = sim._encoders, sim._servo
    q, dq = sim._joint_state()
    pieces = {
        "stepSimulation": lambda: p.stepSimulation(physicsClientId=c),
        "getJointStates": lambda: p.getJointStates(r, joints, physicsClientId=c),
        "_joint_state": sim._joint_state,
        "joint_state (fresh)": lambda: (sim.forget_joint_state(), sim.joint_state()),
        "encoders.update": lambda: enc.update(q, dq),
        "servo.torque": lambda: servo.torque(q_des, enc.position, enc.raw_rate),
        "servo.apply": lambda: servo.apply(c, r, joints, q_des, enc),
        "setJointMotorControlArray": lambda: p.setJointMotorControlArray(
            r, joints, p.TORQUE_CONTROL, forces=[0.0] * 12, physicsClientId=c),
        "_physics_step": lambda: sim._physics_step(q_des),
        "step (5 physics steps)": lambda: sim.step(q_des),
        "_measure": sim._measure,
    }
    n = 3000
    for name, f in pieces.items():
        print(f"{name:28s} {min(timeit.repeat(f, number=n, repeat=3)) / n * 1e6:7.1f} us")


if __name__ == "__main__":
    main()
