"""Write gap_robot.json: the stock robot `measured` with many physical parameters moved by a few
per cent to a few tens of per cent (the sealed gap robot of this zoo; its values are the truth).

Run from the repository root: OPENBLAS_NUM_THREADS=1 python benchmarks/blind_zoo/zoos/zoo8/make_gap_robot.py
"""
from __future__ import annotations

import dataclasses
import sys
from pathlib import Path

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE.parents[3]))

from littledog_mlsim.robot.config import robot_config  # noqa: E402
from littledog_mlsim.robot.twin import Twin, save_twin  # noqa: E402


def gap_config():
    m = robot_config("measured")
    arm = m.armature
    return dataclasses.replace(
        m,
        name="gap",
        kp=(6.8, 8.2, 6.0),                    # measured 7.5 / 7.5 / 6.7 N m/rad
        kd=(0.36, 0.28, 0.37),                 # measured 0.32 N m s/rad
        torque_limit=(1.5, 1.85, 0.70),        # measured 1.7 / 1.7 / 0.61 N m
        command_delay_ms=6.0,                  # measured 0 ms
        armature=(arm[0] * 1.25, arm[1] * 0.8, arm[2] * 1.3),
        body_mass=2.47,                        # measured 2.24 kg
        leg_mass=0.21,                         # measured 0.19 kg
        foot_friction=0.80,                    # measured 0.9
        ground_friction=0.78,                  # measured 0.9
        rate_filter_hz=38.0,                   # measured 50 Hz
        mocap_position_std=4.5e-4,             # measured 3.0e-4 m
        mocap_orientation_std=1.4e-3,          # measured 1.0e-3 rad
    )


if __name__ == "__main__":
    cfg = gap_config()
    out = save_twin(Twin(cfg, {"created_by": "zoo8 make_gap_robot.py",
                               "base_robot": "measured",
                               "note": "sealed gap robot of the eighth blind zoo"}),
                    HERE / "gap_robot.json")
    print(out)
