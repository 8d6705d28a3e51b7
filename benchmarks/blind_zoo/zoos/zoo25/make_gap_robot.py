"""Write zoo25's gap robot (``gap_robot.json``): the ``measured`` robot with many physical
parameters moved by a few per cent to a few tens of per cent, drawn with a fixed seed.

Sealed with the truth: the diagnosis side gets this robot only as recordings.

    OPENBLAS_NUM_THREADS=1 .venv/bin/python benchmarks/blind_zoo/zoos/zoo25/make_gap_robot.py
"""
from __future__ import annotations

import dataclasses
import sys
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE.parents[3]))    # the repository root

from littledog_mlsim.robot.config import config_to_dict, robot_config  # noqa: E402
from littledog_mlsim.robot.twin import Twin, save_twin  # noqa: E402

SEED = 7319025

#: per parameter: (smallest, largest) relative change |factor - 1|, and the allowed signs
#: ("+", "-" or "+-"); per-joint-kind triples draw each kind on its own.
SPREAD = {
    "kp": ((0.04, 0.22), "+-"),
    "kd": ((0.08, 0.35), "+-"),
    "torque_limit": ((0.03, 0.12), "+-"),
    "armature": ((0.10, 0.40), "+-"),
    "body_mass": ((0.03, 0.09), "+-"),
    "leg_mass": ((0.05, 0.20), "+-"),
    "foot_friction": ((0.05, 0.22), "+-"),
    "ground_friction": ((0.04, 0.15), "+-"),
    "rate_filter_hz": ((0.10, 0.30), "+-"),
    "mocap_position_std": ((0.15, 0.50), "+"),
    "mocap_orientation_std": ((0.10, 0.45), "+-"),
}
#: a small transport delay of the real servo bus [ms] (the stock robot has none)
COMMAND_DELAY_MS = (1.5, 6.0)


def factor(rng: np.random.Generator, lo_hi: tuple[float, float], signs: str) -> float:
    mag = rng.uniform(*lo_hi)
    sign = rng.choice([1.0, -1.0]) if signs == "+-" else (1.0 if signs == "+" else -1.0)
    return 1.0 + sign * mag


def main() -> None:
    rng = np.random.default_rng(SEED)
    base = robot_config("measured")
    changes = {}
    for name, (lo_hi, signs) in SPREAD.items():
        v = getattr(base, name)
        if isinstance(v, tuple):
            new = tuple(float(round(x * factor(rng, lo_hi, signs), 8)) for x in v)
        else:
            new = float(round(v * factor(rng, lo_hi, signs), 8))
        changes[name] = new
    changes["command_delay_ms"] = float(round(rng.uniform(*COMMAND_DELAY_MS), 2))
    gap = dataclasses.replace(base, name="zoo25-gap", **changes)
    rel = {}
    for k in changes:
        a, b = np.atleast_1d(getattr(base, k)).astype(float), np.atleast_1d(getattr(gap, k))
        rel[k] = [float(round(x, 4)) for x in (b / a - 1.0)] if np.all(a) else None
    save_twin(Twin(gap, {"created_by": "benchmarks/blind_zoo/zoos/zoo25/make_gap_robot.py",
                         "base_robot": "measured", "seed": SEED,
                         "relative_change": rel,
                         "base_values": {k: config_to_dict(base)[k] for k in changes}}),
              HERE / "gap_robot.json")
    for k in changes:
        print(f"{k:24s} {config_to_dict(base)[k]} -> {config_to_dict(gap)[k]}")


if __name__ == "__main__":
    main()
