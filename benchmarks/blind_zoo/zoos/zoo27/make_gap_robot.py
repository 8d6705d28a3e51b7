"""Write gap_robot.json: the `measured` robot with many physical parameters moved (fixed seed).

    .venv/bin/python benchmarks/blind_zoo/zoos/zoo27/make_gap_robot.py
"""
from __future__ import annotations

import dataclasses
from pathlib import Path

import numpy as np

from littledog_mlsim.robot.config import robot_config
from littledog_mlsim.robot.twin import Twin, save_twin

SEED = 27_2711
HERE = Path(__file__).resolve().parent


def main() -> None:
    rng = np.random.default_rng(SEED)
    m = robot_config("measured")

    def u(lo: float, hi: float) -> float:
        return float(rng.uniform(lo, hi))

    def tri(base, ranges):
        return tuple(round(b * u(lo, hi), 6) for b, (lo, hi) in zip(base, ranges))

    gap = dataclasses.replace(
        m,
        kp=tri(m.kp, [(1.04, 1.16), (1.06, 1.20), (0.80, 0.90)]),
        kd=tri(m.kd, [(0.85, 1.00), (0.90, 1.10), (1.05, 1.25)]),
        torque_limit=tri(m.torque_limit, [(0.88, 0.98), (0.92, 1.04), (1.02, 1.12)]),
        command_delay_ms=round(u(2.0, 5.0), 3),
        armature=tri(m.armature, [(0.80, 1.10), (0.90, 1.30), (1.10, 1.40)]),
        body_mass=round(m.body_mass * u(1.06, 1.14), 4),
        leg_mass=round(m.leg_mass * u(0.90, 0.98), 5),
        foot_friction=round(m.foot_friction * u(0.78, 0.92), 4),
        ground_friction=round(m.ground_friction * u(0.88, 1.00), 4),
        rate_filter_hz=round(m.rate_filter_hz * u(0.65, 0.85), 3),
        mocap_position_std=round(m.mocap_position_std * u(1.2, 1.8), 7),
        mocap_orientation_std=round(m.mocap_orientation_std * u(1.1, 1.5), 7),
    )
    save_twin(Twin(gap, {"created_by": "benchmarks/blind_zoo/zoos/zoo27/make_gap_robot.py",
                         "seed": SEED}), HERE / "gap_robot.json")
    print((HERE / "gap_robot.json").read_text())


if __name__ == "__main__":
    main()
