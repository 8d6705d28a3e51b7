"""Write gap_robot.json: the `measured` robot with many physical parameters moved by a few per
cent to a few tens of per cent, drawn from this script's own seed (reproducible).

    OPENBLAS_NUM_THREADS=1 .venv/bin/python benchmarks/blind_zoo/zoos/zoo50/make_gap_robot.py
"""
from __future__ import annotations

import dataclasses
import sys
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE.parents[3]))
from littledog_mlsim.robot.config import robot_config  # noqa: E402
from littledog_mlsim.robot.twin import Twin, save_twin  # noqa: E402

SEED = 50_2612_05


def factor(rng: np.random.Generator, lo: float = 0.03, hi: float = 0.25) -> float:
    """1 +- a relative change drawn log-uniformly in [lo, hi], random sign."""
    m = float(np.exp(rng.uniform(np.log(lo), np.log(hi))))
    return 1.0 + m if rng.random() < 0.5 else 1.0 / (1.0 + m)


def main() -> None:
    rng = np.random.default_rng(SEED)
    base = robot_config("measured")
    triple = lambda v, lo=0.03, hi=0.25: tuple(float(x * factor(rng, lo, hi)) for x in v)  # noqa: E731
    kp = triple(base.kp)
    kd = triple(base.kd)
    lim = list(triple(base.torque_limit, 0.03, 0.15))
    lim[2] = max(lim[2], 0.57)        # a knee limit far below 0.61 N m lets trots fall
    arm = triple(base.armature, 0.05, 0.30)
    gap = dataclasses.replace(
        base, name="gap_robot", kp=kp, kd=kd, torque_limit=tuple(lim), armature=arm,
        body_mass=float(base.body_mass * factor(rng, 0.03, 0.15)),
        leg_mass=float(base.leg_mass * factor(rng, 0.03, 0.20)),
        foot_friction=float(base.foot_friction * factor(rng, 0.05, 0.30)),
        ground_friction=float(base.ground_friction * factor(rng, 0.05, 0.30)),
        rate_filter_hz=float(base.rate_filter_hz * factor(rng, 0.03, 0.20)))
    save_twin(Twin(gap, {"created_by": "zoo50/make_gap_robot.py", "seed": SEED,
                         "base_robot": "measured"}), HERE / "gap_robot.json")
    print((HERE / "gap_robot.json").read_text())


if __name__ == "__main__":
    main()
