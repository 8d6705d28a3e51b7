"""Write gap_robot.json: the `measured` robot with many physical parameters moved (SEALED values).

Run from the repository root:  .venv/bin/python benchmarks/blind_zoo/zoos/zoo15/make_gap_robot.py
"""
from __future__ import annotations

import dataclasses
import sys
from pathlib import Path

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE.parents[3]))   # the repository root

from littledog_mlsim.robot.config import robot_config  # noqa: E402
from littledog_mlsim.robot.twin import Twin, save_twin  # noqa: E402


def scaled(t, s):
    return tuple(round(a * b, 6) for a, b in zip(t, s))


def main() -> None:
    m = robot_config("measured")
    gap = dataclasses.replace(
        m,
        kp=scaled(m.kp, (0.93, 1.11, 0.91)),            # servo stiffness, mixed per joint kind
        kd=scaled(m.kd, (1.12, 0.88, 1.07)),            # servo damping
        torque_limit=scaled(m.torque_limit, (0.94, 1.08, 1.05)),
        command_delay_ms=4.0,                           # a small transport delay on the bus
        armature=scaled(m.armature, (1.22, 0.86, 1.14)),  # reflected rotor inertia
        body_mass=round(m.body_mass * 1.075, 4),        # heavier body (cabling, battery)
        leg_mass=round(m.leg_mass * 0.91, 4),           # lighter legs
        foot_friction=0.76,                             # worn feet
        ground_friction=1.03,                           # a grippier floor
        encoder_resolution=scaled(m.encoder_resolution, (1.25, 1.25, 0.8)),
        rate_filter_hz=41.0,                            # rate filter cut-off
        mocap_position_std=4.1e-4,                      # motion-capture noise
        mocap_orientation_std=0.8e-3,
        settle_time=1.1,
    )
    save_twin(Twin(gap, {"created_by": "zoo15 author (make_gap_robot.py)",
                         "base_robot": "measured",
                         "note": "gap robot of the blind zoo15; sealed"}),
              HERE / "gap_robot.json")
    print(HERE / "gap_robot.json")


if __name__ == "__main__":
    main()
