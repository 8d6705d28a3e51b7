"""Write gap_robot.json: the `measured` robot with many physical parameters moved (fixed seed).

Run from the repository root:  .venv/bin/python benchmarks/blind_zoo/zoos/zoo20/make_gap_robot.py
"""
from __future__ import annotations

import dataclasses
from pathlib import Path

import numpy as np

from littledog_mlsim.robot.config import robot_config
from littledog_mlsim.robot.twin import Twin, save_twin

SEED = 20_2026_11_30


def main() -> None:
    rng = np.random.default_rng(SEED)
    m = robot_config("measured")

    def tri(values, lo, hi):
        return tuple(float(round(v * rng.uniform(lo, hi), 6)) for v in values)

    def one(v, lo, hi):
        return float(round(v * rng.uniform(lo, hi), 6))

    gap = dataclasses.replace(
        m,
        name="gap20",
        kp=tri(m.kp, 0.84, 1.14),
        kd=tri(m.kd, 0.80, 1.22),
        torque_limit=(one(m.torque_limit[0], 0.90, 1.10), one(m.torque_limit[1], 0.90, 1.10),
                      one(m.torque_limit[2], 0.97, 1.15)),
        armature=tri(m.armature, 0.70, 1.40),
        body_mass=one(m.body_mass, 0.93, 1.09),
        leg_mass=one(m.leg_mass, 0.90, 1.14),
        foot_friction=one(m.foot_friction, 0.78, 1.08),
        ground_friction=one(m.ground_friction, 0.82, 1.08),
        rate_filter_hz=one(m.rate_filter_hz, 0.75, 1.25),
        mocap_position_std=one(m.mocap_position_std, 0.8, 1.6),
        mocap_orientation_std=one(m.mocap_orientation_std, 0.8, 1.6),
        command_delay_ms=float(round(rng.uniform(1.0, 5.0), 2)),
    )
    out = Path(__file__).with_name("gap_robot.json")
    save_twin(Twin(gap, {"created_by": "zoo20 make_gap_robot.py", "seed": SEED,
                         "base_robot": "measured"}), out)
    print(out)


if __name__ == "__main__":
    main()
