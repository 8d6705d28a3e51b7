"""Write gap_robot.json: the `measured` robot with many physical parameters moved (sealed).

Run from the repository root: .venv/bin/python benchmarks/blind_zoo/zoos/zoo29/make_gap_robot.py
"""
from __future__ import annotations

import dataclasses
from pathlib import Path

from littledog_mlsim.robot.config import robot_config
from littledog_mlsim.robot.twin import Twin, load_twin, save_twin

base = robot_config("measured")
arm = base.armature
gap = dataclasses.replace(
    base,
    name="zoo29_gap",
    kp=(7.05, 8.05, 6.15),                 # -6 %, +7 %, -8 %
    kd=(0.355, 0.295, 0.345),              # +11 %, -8 %, +8 %
    torque_limit=(1.56, 1.80, 0.57),       # -8 %, +6 %, -7 %
    command_delay_ms=3.5,                  # a servo-bus latency the twin does not have
    armature=(arm[0] * 0.82, arm[1] * 1.22, arm[2] * 1.14),
    body_mass=2.40,                        # +7 % (cabling, a heavier battery)
    leg_mass=0.204,                        # +7 %
    foot_friction=0.76,                    # -16 % (worn rubber)
    ground_friction=0.83,                  # -8 %
    rate_filter_hz=42.0,                   # -16 %
    mocap_position_std=4.0e-4,             # +33 %
    mocap_orientation_std=1.3e-3,          # +30 %
    settle_time=1.0,
)
out = Path(__file__).with_name("gap_robot.json")
save_twin(Twin(gap, {"created_by": "zoo29 make_gap_robot.py", "base_robot": "measured",
                     "note": "a sealed gap robot of the twenty-ninth blind zoo"}), out)
print(load_twin(out).robot)
