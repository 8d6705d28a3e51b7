"""Write zoo48's gap robot (``gap_robot.json``): the ``measured`` robot with many physical
parameters moved by a few per cent to a few tens of per cent, drawn from a fresh seed.

Sealed with the truth: the diagnosis side gets this robot only as recordings (and the
weighing named in ``runs/run1/RULE.md``).

    PYTHONPATH=. .venv/bin/python benchmarks/blind_zoo/zoos/zoo48/make_gap_robot.py
"""
from __future__ import annotations

import dataclasses
from pathlib import Path

import numpy as np

from littledog_mlsim.robot.config import robot_config
from littledog_mlsim.robot.twin import Twin, save_twin

SEED = 771_482_048          # drawn for this zoo
HERE = Path(__file__).resolve().parent

# field: (smallest, largest) relative change |factor - 1|; the sign is drawn per number.
# Limits kept where a larger move would make the soft servo drop the robot on its own.
RELATIVE = {
    "kp": (0.04, 0.22),
    "kd": (0.05, 0.30),
    "torque_limit": (0.03, 0.12),
    "armature": (0.05, 0.35),
    "body_mass": (0.03, 0.12),
    "leg_mass": (0.04, 0.20),
    "foot_friction": (0.05, 0.25),
    "ground_friction": (0.03, 0.15),
    "rate_filter_hz": (0.08, 0.35),
    "mocap_position_std": (0.05, 0.40),
    "mocap_orientation_std": (0.05, 0.40),
}
DELAY_MS = (1.5, 6.0)        # a small command latency the twin would not have


def draw(rng: np.random.Generator, lo: float, hi: float) -> float:
    return float(1.0 + rng.choice([-1.0, 1.0]) * rng.uniform(lo, hi))


def main() -> None:
    rng = np.random.default_rng(SEED)
    base = robot_config("measured")
    changes = {}
    for name, (lo, hi) in RELATIVE.items():
        v = getattr(base, name)
        if isinstance(v, tuple):
            changes[name] = tuple(round(x * draw(rng, lo, hi), 6) for x in v)
        else:
            changes[name] = round(v * draw(rng, lo, hi), 6)
    changes["command_delay_ms"] = round(float(rng.uniform(*DELAY_MS)), 2)
    gap = dataclasses.replace(base, name="gap48", **changes)
    save_twin(Twin(gap, {"created_by": "zoo48/make_gap_robot.py", "seed": SEED,
                         "base_robot": "measured"}), HERE / "gap_robot.json")
    print((HERE / "gap_robot.json").read_text())


if __name__ == "__main__":
    main()
