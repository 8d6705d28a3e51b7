"""Write zoo23's gap robot (``gap_robot.json``): the ``measured`` robot with many physical
parameters moved by a few per cent to a few tens of per cent, drawn from a fixed seed.

SEALED with the truth: the values written here are part of what the diagnosis must not see.

    .venv/bin/python benchmarks/blind_zoo/zoos/zoo23/make_gap_robot.py
"""
from __future__ import annotations

import dataclasses
from pathlib import Path

import numpy as np

from littledog_mlsim.robot.config import robot_config
from littledog_mlsim.robot.twin import Twin, save_twin

SEED = 230_2611
HERE = Path(__file__).resolve().parent


def factor(rng: np.random.Generator, lo: float, hi: float, n: int | None = None):
    """Log-uniform factor(s) in [lo, hi]."""
    v = np.exp(rng.uniform(np.log(lo), np.log(hi), size=n))
    return v if n is not None else float(v)


def main() -> None:
    rng = np.random.default_rng(SEED)
    m = robot_config("measured")
    kp = np.array(m.kp) * factor(rng, 0.80, 1.18, 3)
    kd = np.array(m.kd) * factor(rng, 0.78, 1.25, 3)
    lim = np.array(m.torque_limit) * factor(rng, 0.93, 1.15, 3)
    arm = np.array(m.armature) * factor(rng, 0.70, 1.40, 3)
    gap = dataclasses.replace(
        m,
        name="zoo23-gap",
        kp=tuple(float(round(x, 4)) for x in kp),
        kd=tuple(float(round(x, 4)) for x in kd),
        torque_limit=tuple(float(round(x, 4)) for x in lim),
        armature=tuple(float(x) for x in arm),
        command_delay_ms=float(round(rng.uniform(2.0, 8.0), 2)),
        body_mass=float(round(m.body_mass * factor(rng, 0.90, 1.12), 4)),
        leg_mass=float(round(m.leg_mass * factor(rng, 0.88, 1.15), 4)),
        foot_friction=float(round(m.foot_friction * factor(rng, 0.72, 1.10), 4)),
        ground_friction=float(round(m.ground_friction * factor(rng, 0.75, 1.10), 4)),
        rate_filter_hz=float(round(m.rate_filter_hz * factor(rng, 0.70, 1.30), 3)),
        mocap_position_std=float(m.mocap_position_std * factor(rng, 0.7, 1.6)),
        mocap_orientation_std=float(m.mocap_orientation_std * factor(rng, 0.7, 1.6)),
        settle_time=float(round(m.settle_time * factor(rng, 0.8, 1.3), 3)),
    )
    save_twin(Twin(gap, {"created_by": "zoo23/make_gap_robot.py", "seed": SEED,
                         "base_robot": "measured",
                         "note": "zoo23's sealed gap robot (a stand-in for a real robot)"}),
              HERE / "gap_robot.json")
    print((HERE / "gap_robot.json").read_text())


if __name__ == "__main__":
    main()
