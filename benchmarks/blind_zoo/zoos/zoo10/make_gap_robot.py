"""Write gap_robot.json: the stock ``measured`` robot with many physical parameters moved by a
calibration miss of a few per cent to a few tens of per cent, in both directions, per joint kind.

Deterministic: the factors are drawn from one seeded generator (SEED below). Each factor is
exp(u), |u| drawn uniformly in [LO, HI] per parameter group with a random sign; the command delay
(0 on the stock robot) is drawn in milliseconds. Run from the repository root:

    OPENBLAS_NUM_THREADS=1 .venv/bin/python benchmarks/blind_zoo/zoos/zoo10/make_gap_robot.py
"""
from __future__ import annotations

import dataclasses
import sys
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE.parents[3]))          # the repository root

from littledog_mlsim.robot.config import robot_config  # noqa: E402
from littledog_mlsim.robot.twin import Twin, load_twin, save_twin  # noqa: E402

SEED = 20261127_10

#: (lowest, highest) |log factor| per parameter group
RANGES = {
    "kp": (0.04, 0.22), "kd": (0.05, 0.30), "torque_limit": (0.03, 0.12),
    "armature": (0.08, 0.35), "body_mass": (0.03, 0.10), "leg_mass": (0.05, 0.20),
    "foot_friction": (0.05, 0.25), "ground_friction": (0.05, 0.20),
    "rate_filter_hz": (0.10, 0.35), "mocap_position_std": (0.10, 0.40),
    "mocap_orientation_std": (0.10, 0.40),
}


def factor(rng: np.random.Generator, group: str) -> float:
    lo, hi = RANGES[group]
    return float(np.exp(rng.choice([-1.0, 1.0]) * rng.uniform(lo, hi)))


def main() -> None:
    rng = np.random.default_rng(SEED)
    base = robot_config("measured")
    changes: dict[str, object] = {}
    for name in ("kp", "kd", "torque_limit", "armature"):
        triple = tuple(round(v * factor(rng, name), 6) for v in getattr(base, name))
        changes[name] = triple
    # the knee's torque limit is the one the trot saturates: never below 95 % of the stock one
    tl = list(changes["torque_limit"])
    tl[2] = round(max(tl[2], 0.95 * base.torque_limit[2]), 6)
    changes["torque_limit"] = tuple(tl)
    for name in ("body_mass", "leg_mass", "foot_friction", "ground_friction", "rate_filter_hz",
                 "mocap_position_std", "mocap_orientation_std"):
        changes[name] = round(getattr(base, name) * factor(rng, name), 6)
    changes["command_delay_ms"] = round(float(rng.uniform(1.5, 4.0)), 2)
    gap = dataclasses.replace(base, name="zoo10_gap", **changes)
    out = save_twin(Twin(gap, {"created_by": "zoo10/make_gap_robot.py", "seed": SEED,
                               "base_robot": "measured"}), HERE / "gap_robot.json")
    load_twin(out)                                  # it loads back
    print(f"wrote {out}")


if __name__ == "__main__":
    main()
