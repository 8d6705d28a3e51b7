"""Writes zoo26's gap robot (``gap_robot.json``): the ``measured`` robot with many physical
parameters moved by a few per cent to a few tens of per cent, drawn with a fixed seed.

    .venv/bin/python benchmarks/blind_zoo/zoos/zoo26/make_gap_robot.py

Sealed with the truth: the diagnosis side does not read this file or its output before the run.
"""
from __future__ import annotations

import dataclasses
from pathlib import Path

import numpy as np

from littledog_mlsim.robot.config import robot_config
from littledog_mlsim.robot.twin import Twin, save_twin

SEED = 26_19_0171          # the nineteenth gap robot, zoo26
OUT = Path(__file__).with_name("gap_robot.json")


def _scale(rng: np.random.Generator, lo: float, hi: float, sign: int | None = None) -> float:
    """A factor 1 + s * m with m uniform in [lo, hi] and s a random (or given) sign."""
    s = sign if sign is not None else (1 if rng.random() < 0.5 else -1)
    return 1.0 + s * rng.uniform(lo, hi)


def make() -> Twin:
    rng = np.random.default_rng(SEED)
    base = robot_config("measured")

    def triple(values, lo, hi, sign=None):
        return tuple(float(round(v * _scale(rng, lo, hi, sign), 6)) for v in values)

    robot = dataclasses.replace(
        base,
        name="zoo26-gap",
        kp=triple(base.kp, 0.04, 0.16),
        kd=triple(base.kd, 0.05, 0.25),
        # the knee's limit is kept from falling far: the open-loop trot needs it
        torque_limit=(round(base.torque_limit[0] * _scale(rng, 0.03, 0.12), 4),
                      round(base.torque_limit[1] * _scale(rng, 0.03, 0.12), 4),
                      round(base.torque_limit[2] * _scale(rng, 0.02, 0.08, +1), 4)),
        command_delay_ms=float(round(rng.uniform(3.0, 9.0), 2)),
        armature=triple(base.armature, 0.10, 0.35),
        body_mass=float(round(base.body_mass * _scale(rng, 0.04, 0.12), 4)),
        leg_mass=float(round(base.leg_mass * _scale(rng, 0.05, 0.20), 4)),
        foot_friction=float(round(base.foot_friction * _scale(rng, 0.05, 0.20), 3)),
        ground_friction=float(round(base.ground_friction * _scale(rng, 0.03, 0.15), 3)),
        rate_filter_hz=float(round(base.rate_filter_hz * _scale(rng, 0.10, 0.30), 1)),
        mocap_position_std=float(round(base.mocap_position_std * _scale(rng, 0.10, 0.40), 6)),
        mocap_orientation_std=float(round(base.mocap_orientation_std * _scale(rng, 0.10, 0.40), 6)),
    )
    return Twin(robot, {"created_by": "benchmarks/blind_zoo/zoos/zoo26/make_gap_robot.py",
                        "base_robot": "measured", "seed": SEED,
                        "note": "zoo26's gap robot (sealed with the truth)"})


if __name__ == "__main__":
    print(save_twin(make(), OUT))
