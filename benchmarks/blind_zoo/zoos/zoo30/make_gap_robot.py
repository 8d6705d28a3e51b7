"""Write gap_robot.json: the `measured` LittleDog with many physical parameters moved
(sealed with truth.yaml). Run from the repository root or anywhere:

    OPENBLAS_NUM_THREADS=1 /work/main/.venv/bin/python make_gap_robot.py
"""
from __future__ import annotations

import dataclasses
import sys
from pathlib import Path

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE.parents[3]))          # the repository root

from littledog_mlsim.robot.config import robot_config          # noqa: E402
from littledog_mlsim.robot.twin import Twin, save_twin          # noqa: E402


def scaled(triple, factors):
    return tuple(round(v * f, 8) for v, f in zip(triple, factors))


def main() -> None:
    m = robot_config("measured")
    gap = dataclasses.replace(
        m,
        name="lab_dog",
        # servo: stiffness, damping and current limits differ per joint kind
        kp=scaled(m.kp, (0.92, 1.09, 0.90)),
        kd=scaled(m.kd, (1.10, 0.91, 1.13)),
        torque_limit=scaled(m.torque_limit, (0.93, 1.08, 1.07)),
        # set-points reach the servos a few ms late (bus latency)
        command_delay_ms=6.0,
        # rotor inertia reflected through the gears
        armature=scaled(m.armature, (1.22, 0.86, 1.15)),
        # masses: heavier body (battery, wiring), lighter legs
        body_mass=round(m.body_mass * 1.065, 6),
        leg_mass=round(m.leg_mass * 0.92, 6),
        # contact
        foot_friction=0.78,
        ground_friction=0.83,
        # sensing
        rate_filter_hz=42.0,
        mocap_position_std=4.0e-4,
        mocap_orientation_std=1.3e-3,
    )
    prov = {"created_by": "benchmarks/blind_zoo/zoos/zoo30/make_gap_robot.py",
            "base_robot": "measured",
            "note": "zoo30 gap robot (sealed): hand-chosen parameter changes"}
    save_twin(Twin(gap, prov), HERE / "gap_robot.json")
    print(HERE / "gap_robot.json")


if __name__ == "__main__":
    main()
