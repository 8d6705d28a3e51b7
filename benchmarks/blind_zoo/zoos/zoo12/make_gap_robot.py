"""Write gap_robot.json: the stock `measured` LittleDog with many physical parameters moved by
the size by which a calibrated twin typically misses a real robot (zoo12's gap robot).

Deterministic: a fixed seed below. Each moved parameter is multiplied by (1 + s * m), with a
random sign s and a magnitude m drawn uniformly from the parameter's range (RANGES); the
all-joint command delay is drawn uniformly from its own range in ms. Run from anywhere:

    python benchmarks/blind_zoo/zoos/zoo12/make_gap_robot.py
"""
from __future__ import annotations

import dataclasses
import json
import sys
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE.parents[3]))          # the repository root
from littledog_mlsim.robot.config import robot_config  # noqa: E402
from littledog_mlsim.robot.twin import Twin, save_twin  # noqa: E402

SEED = 20261129_12
#: relative change magnitude ranges (lo, hi); the sign is drawn separately
RANGES = {
    "kp": (0.05, 0.25),               # per joint kind
    "kd": (0.05, 0.30),               # per joint kind
    "torque_limit": (0.03, 0.12),     # per joint kind
    "armature": (0.10, 0.40),         # per joint kind
    "body_mass": (0.03, 0.10),
    "leg_mass": (0.05, 0.15),
    "foot_friction": (0.05, 0.25),
    "ground_friction": (0.05, 0.25),
    "rate_filter_hz": (0.10, 0.30),
    "mocap_position_std": (0.10, 0.50),
    "mocap_orientation_std": (0.10, 0.50),
}
DELAY_MS = (2.0, 8.0)                 # all-joint command delay, uniform


def draw() -> dict:
    rng = np.random.default_rng(SEED)
    base = robot_config("measured")
    changes = {}
    for name, (lo, hi) in RANGES.items():
        v = getattr(base, name)
        if isinstance(v, tuple):
            m = rng.uniform(lo, hi, size=3) * rng.choice([-1.0, 1.0], size=3)
            changes[name] = tuple(float(x * (1 + d)) for x, d in zip(v, m))
        else:
            m = rng.uniform(lo, hi) * rng.choice([-1.0, 1.0])
            changes[name] = float(v * (1 + m))
    changes["command_delay_ms"] = float(rng.uniform(*DELAY_MS))
    return changes


def main() -> None:
    changes = draw()
    config = dataclasses.replace(robot_config("measured"), name="zoo12_gap", **changes)
    save_twin(Twin(config, {"created_by": "benchmarks/blind_zoo/zoos/zoo12/make_gap_robot.py",
                            "base_robot": "measured", "seed": SEED,
                            "ranges": {k: list(v) for k, v in RANGES.items()},
                            "command_delay_ms_range": list(DELAY_MS)}),
              HERE / "gap_robot.json")
    print(json.dumps(changes, indent=1))


if __name__ == "__main__":
    main()
