"""Write gap_robot.json: the stock ``measured`` LittleDog with many physical parameters moved
by a calibration miss of a few to a few tens of per cent (fixed numbers, deterministic).

    .venv/bin/python benchmarks/blind_zoo/zoos/zoo9/make_gap_robot.py
"""
from __future__ import annotations

import dataclasses
import sys
from pathlib import Path

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE.parents[3]))      # the repository root

from littledog_mlsim.robot.config import robot_config  # noqa: E402
from littledog_mlsim.robot.twin import Twin, save_twin  # noqa: E402


def scaled(triple, factors):
    return tuple(round(v * f, 9) for v, f in zip(triple, factors))


def gap_robot():
    m = robot_config("measured")
    # per joint kind (hip_roll, hip_pitch, knee): factor on the stock value
    changes = dict(
        name="zoo9_gap",
        kp=scaled(m.kp, (1.11, 0.94, 1.07)),
        kd=scaled(m.kd, (1.13, 0.87, 0.84)),
        torque_limit=scaled(m.torque_limit, (0.91, 1.09, 1.11)),
        armature=scaled(m.armature, (1.22, 0.85, 1.16)),
        body_mass=round(m.body_mass * 1.05, 4),
        leg_mass=round(m.leg_mass * 0.905, 4),
        foot_friction=round(m.foot_friction * 0.82, 4),
        ground_friction=round(m.ground_friction * 1.17, 4),
        command_delay_ms=6.0,
        rate_filter_hz=round(m.rate_filter_hz * 0.76, 3),
        mocap_position_std=round(m.mocap_position_std * 1.4, 7),
        mocap_orientation_std=m.mocap_orientation_std * 0.8,
    )
    provenance = {
        "created_by": "benchmarks/blind_zoo/zoos/zoo9/make_gap_robot.py",
        "base_robot": "measured",
        "note": "sealed gap robot of the ninth blind zoo; do not read before its first run",
    }
    return Twin(dataclasses.replace(m, **changes), provenance)


if __name__ == "__main__":
    out = save_twin(gap_robot(), HERE / "gap_robot.json")
    print(out)
