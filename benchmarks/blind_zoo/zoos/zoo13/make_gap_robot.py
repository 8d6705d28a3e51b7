"""Write gap_robot.json: the `measured` robot with many physical parameters moved (sealed)."""
import dataclasses
from pathlib import Path

from littledog_mlsim.robot.config import robot_config
from littledog_mlsim.robot.twin import Twin, save_twin

m = robot_config("measured")
arm = m.armature
gap = dataclasses.replace(
    m,
    name="zoo13_gap",
    kp=(7.0, 8.1, 6.25),                    # -7 %, +8 %, -7 %
    kd=(0.29, 0.355, 0.34),                 # -9 %, +11 %, +6 %
    torque_limit=(1.58, 1.82, 0.67),        # -7 %, +7 %, +10 %
    command_delay_ms=4.0,                   # 0 -> 4 ms transport delay
    armature=(arm[0] * 1.22, arm[1] * 0.86, arm[2] * 1.15),
    body_mass=2.37,                         # +6 %
    leg_mass=0.204,                         # +7 %
    foot_friction=0.76,                     # -16 %
    ground_friction=0.97,                   # +8 %
    rate_filter_hz=38.0,                    # 50 -> 38 Hz
    mocap_position_std=4.2e-4,              # +40 %
    mocap_orientation_std=1.35e-3,          # +35 %
    settle_time=1.2,
)
out = Path(__file__).with_name("gap_robot.json")
save_twin(Twin(gap, {"created_by": "zoo13 make_gap_robot.py",
                     "intent": "a real robot that a calibrated twin of `measured` misses"}), out)
print(out)
