"""Write gap_robot.json: the `measured` robot with many physical parameters moved.

Each moved parameter is multiplied by exp(s * m), with a random sign s and a magnitude m drawn
uniformly in [0.04, 0.25] (a few per cent to a few tens of per cent), from a fixed seed; a
few parameters that are zero on the measured robot (the command delay) get a value of their own.
Run from the repository root: python benchmarks/blind_zoo/zoos/zoo21/make_gap_robot.py
"""
from __future__ import annotations

import dataclasses
from pathlib import Path

import numpy as np

from littledog_mlsim.robot.config import robot_config
from littledog_mlsim.robot.twin import Twin, save_twin

SEED = 2121
HERE = Path(__file__).resolve().parent


def main() -> None:
    rng = np.random.default_rng(SEED)
    base = robot_config("measured")

    def f(lo: float = 0.04, hi: float = 0.25) -> float:
        return float(np.exp(rng.choice([-1.0, 1.0]) * rng.uniform(lo, hi)))

    def triple(t, lo=0.04, hi=0.25):
        return tuple(round(v * f(lo, hi), 6) for v in t)

    moved = dict(
        name="zoo21_gap",
        kp=triple(base.kp),
        kd=triple(base.kd),
        # the knee's limit is moved less (the measured knee already saturates while trotting)
        torque_limit=(round(base.torque_limit[0] * f(), 4), round(base.torque_limit[1] * f(), 4),
                      round(base.torque_limit[2] * f(0.03, 0.10), 4)),
        armature=triple(base.armature),
        body_mass=round(base.body_mass * f(0.04, 0.15), 4),
        leg_mass=round(base.leg_mass * f(), 4),
        foot_friction=round(base.foot_friction * f(), 4),
        ground_friction=round(base.ground_friction * f(), 4),
        command_delay_ms=round(float(rng.uniform(2.0, 8.0)), 2),
        rate_filter_hz=round(base.rate_filter_hz * f(), 2),
        mocap_position_std=float(f"{base.mocap_position_std * f():.3g}"),
        mocap_orientation_std=float(f"{base.mocap_orientation_std * f():.3g}"),
        encoder_resolution=triple(base.encoder_resolution, 0.1, 0.5),
    )
    gap = dataclasses.replace(base, **moved)
    prov = {"created_by": "benchmarks/blind_zoo/zoos/zoo21/make_gap_robot.py",
            "base_robot": "measured", "seed": SEED,
            "note": "zoo21 gap robot (sealed with the truth)"}
    save_twin(Twin(gap, prov), HERE / "gap_robot.json")
    for k in moved:
        print(f"{k}: {getattr(base, k)} -> {getattr(gap, k)}")


if __name__ == "__main__":
    main()
