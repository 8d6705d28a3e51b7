"""Write gap_robot.json: the `measured` robot with many physical parameters moved (zoo19).

Sealed. Run from the repository root:
    OPENBLAS_NUM_THREADS=1 .venv/bin/python benchmarks/blind_zoo/zoos/zoo19/make_gap_robot.py
Each chosen parameter is multiplied by a factor drawn log-uniformly in its range (per joint
kind for triples) from a fixed seed; the command delay, zero on `measured`, is drawn additively.
"""
from __future__ import annotations

import dataclasses
import math
import sys
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[4]
sys.path.insert(0, str(ROOT))
from littledog_mlsim.robot.config import robot_config  # noqa: E402
from littledog_mlsim.robot.twin import Twin, save_twin  # noqa: E402

SEED = 190419
#: field: (low factor, high factor)
RANGES = {
    "kp": (0.80, 1.22),
    "kd": (0.78, 1.25),
    "torque_limit": (0.97, 1.15),
    "armature": (0.70, 1.45),
    "body_mass": (0.92, 1.14),
    "leg_mass": (0.85, 1.22),
    "foot_friction": (0.75, 1.10),
    "ground_friction": (0.80, 1.10),
    "rate_filter_hz": (0.80, 1.25),
    "mocap_position_std": (0.80, 1.50),
    "mocap_orientation_std": (0.80, 1.50),
}
DELAY_MS = (1.0, 5.0)   # command_delay_ms, added (measured: 0)


def factor(rng: np.random.Generator, lo: float, hi: float) -> float:
    return float(math.exp(rng.uniform(math.log(lo), math.log(hi))))


def main() -> None:
    rng = np.random.default_rng(SEED)
    base = robot_config("measured")
    changes, record = {}, {}
    for name, (lo, hi) in RANGES.items():
        v = getattr(base, name)
        if isinstance(v, tuple):
            f = [factor(rng, lo, hi) for _ in v]
            changes[name] = tuple(round(x * fi, 7) for x, fi in zip(v, f))
        else:
            f = factor(rng, lo, hi)
            changes[name] = round(v * f, 7)
        record[name] = f
    changes["command_delay_ms"] = round(float(rng.uniform(*DELAY_MS)), 3)
    cfg = dataclasses.replace(base, name="gap19", **changes)
    out = Path(__file__).with_name("gap_robot.json")
    save_twin(Twin(cfg, {"created_by": "zoo19/make_gap_robot.py", "base_robot": "measured",
                         "seed": SEED, "factors": record}), out)
    print(out)
    for k in list(RANGES) + ["command_delay_ms"]:
        print(f"  {k}: {getattr(base, k)} -> {getattr(cfg, k)}")


if __name__ == "__main__":
    main()
