"""Write gap_robot.json: the `measured` LittleDog with many physical parameters moved (sealed).

A plausible other unit of the same robot, on another floor: servos tuned a little differently,
a heavier battery pack and lighter legs, gearboxes of another batch, another floor's friction,
slightly different sensing. Run from the repository root:

    OPENBLAS_NUM_THREADS=1 .venv/bin/python benchmarks/blind_zoo/zoos/zoo16/make_gap_robot.py
"""
from __future__ import annotations

import dataclasses
import sys
from pathlib import Path

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE.parents[3]))

from littledog_mlsim.robot.config import robot_config  # noqa: E402
from littledog_mlsim.robot.twin import Twin, save_twin  # noqa: E402

base = robot_config("measured")
arm = base.armature
changes = dict(
    kp=(6.8, 8.2, 6.2),                    # N m/rad: hips -9 % / +9 %, knee -7 %
    kd=(0.35, 0.29, 0.345),                # N m s/rad: +9 %, -9 %, +8 %
    torque_limit=(1.6, 1.8, 0.66),         # N m: -6 %, +6 %, +8 %
    command_delay_ms=3.0,                  # ms of servo bus latency (was 0)
    armature=(arm[0] * 1.22, arm[1] * 1.15, arm[2] * 0.85),   # another gearbox batch
    body_mass=2.40,                        # kg (+7 %: a bigger battery)
    leg_mass=0.176,                        # kg per leg (-7 %)
    foot_friction=0.78,                    # worn rubber feet (-13 %)
    ground_friction=0.72,                  # another floor (-20 %)
    encoder_resolution=tuple(r * 1.1 for r in base.encoder_resolution),
    rate_filter_hz=42.0,                   # -16 %
    mocap_position_std=4.0e-4,             # +33 %
    mocap_orientation_std=1.25e-3,         # +25 %
)
gap = dataclasses.replace(base, **changes)
out = save_twin(Twin(gap, {"created_by": "zoo16 author (make_gap_robot.py)",
                           "base_robot": "measured",
                           "note": "a gap robot: the measured robot with many parameters moved"}),
                HERE / "gap_robot.json")
print(out)
