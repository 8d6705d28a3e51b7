"""Write zoo31's gap robot (gap_robot.json): the `measured` LittleDog as a rebuilt, recalibrated
lab robot of its size could differ from it.

Run from the repository root:  .venv/bin/python benchmarks/blind_zoo/zoos/zoo31/make_gap_robot.py

Each moved parameter is the measured robot's value times a factor chosen by the zoo author
(a few per cent to a few tens of per cent, different per joint kind where the field is a
(hip_roll, hip_pitch, knee) triple); parameters that describe the simulation rather than the
robot (physics step, solver iterations, settle time) and the encoders' counts per radian (the
same encoder part) are left as they are.
"""
from __future__ import annotations

import dataclasses
from pathlib import Path

from littledog_mlsim.robot.config import robot_config
from littledog_mlsim.robot.twin import Twin, save_twin

HERE = Path(__file__).resolve().parent

# field: factor (a float) or per-joint-kind factors (hip_roll, hip_pitch, knee)
FACTORS = {
    "kp": (0.91, 1.08, 0.87),            # servo stiffness: re-tuned firmware, different motors
    "kd": (1.13, 0.88, 1.19),            # servo damping
    "torque_limit": (0.93, 1.06, 1.09),  # current limits as set on the rebuilt amplifiers
    "armature": (1.17, 0.86, 1.22),      # reflected rotor inertia (other motor/gear batch)
    "body_mass": 1.072,                  # heavier battery and computer stack
    "leg_mass": 0.925,                   # lighter leg links
    "foot_friction": 0.82,               # harder, worn foot caps
    "ground_friction": 1.06,             # this lab's floor
    "rate_filter_hz": 0.86,              # the encoder-rate filter's corner, as configured
    "mocap_position_std": 1.25,          # a noisier motion-capture set-up
    "mocap_orientation_std": 1.35,
}


def gap_robot():
    base = robot_config("measured")
    changes = {}
    for name, f in FACTORS.items():
        v = getattr(base, name)
        if isinstance(v, tuple):
            changes[name] = tuple(round(x * k, 7) for x, k in zip(v, f))
        else:
            changes[name] = round(v * f, 7)
    return base, dataclasses.replace(base, name="zoo31-gap", **changes)


def main() -> None:
    base, robot = gap_robot()
    for name in FACTORS:          # every moved field differs from the default
        assert getattr(robot, name) != getattr(base, name), name
    twin = Twin(robot, {"created_by": "zoo31/make_gap_robot.py",
                        "base_robot": "measured",
                        "note": "hand-made gap robot of the thirty-first blind zoo (sealed)"})
    path = save_twin(twin, HERE / "gap_robot.json")
    print(path)


if __name__ == "__main__":
    main()
