"""Write gap_robot.json: the `measured` robot with many physical parameters moved.

Each listed parameter is multiplied by a factor drawn (seeded) from a log-uniform range of a few
per cent to a few tens of per cent, up or down; the result is a twin file that `record --robot`
reads. Run from anywhere: `python make_gap_robot.py` (writes beside this script).
"""
from __future__ import annotations

import dataclasses
from pathlib import Path

import numpy as np

from littledog_mlsim.robot.config import robot_config
from littledog_mlsim.robot.twin import Twin, save_twin

SEED = 20241130
HERE = Path(__file__).resolve().parent


def factor(rng: np.random.Generator, lo: float, hi: float) -> float:
    """A factor whose size |log f| is uniform in [log(1+lo), log(1+hi)], sign random."""
    mag = np.exp(rng.uniform(np.log1p(lo), np.log1p(hi)))
    return float(mag if rng.random() < 0.5 else 1.0 / mag)


def main() -> Path:
    rng = np.random.default_rng(SEED)
    base = robot_config("measured")

    def triple(values, lo, hi):
        return tuple(round(v * factor(rng, lo, hi), 6) for v in values)

    gap = dataclasses.replace(
        base,
        name="gap24",
        kp=triple(base.kp, 0.04, 0.20),
        kd=triple(base.kd, 0.05, 0.25),
        torque_limit=triple(base.torque_limit, 0.03, 0.15),
        armature=triple(base.armature, 0.10, 0.35),
        body_mass=round(base.body_mass * factor(rng, 0.03, 0.12), 4),
        leg_mass=round(base.leg_mass * factor(rng, 0.05, 0.20), 4),
        foot_friction=round(base.foot_friction * factor(rng, 0.08, 0.30), 4),
        ground_friction=round(base.ground_friction * factor(rng, 0.05, 0.25), 4),
        command_delay_ms=round(float(rng.uniform(3.0, 9.0)), 2),
        rate_filter_hz=round(base.rate_filter_hz * factor(rng, 0.10, 0.35), 2),
        mocap_position_std=round(base.mocap_position_std * factor(rng, 0.10, 0.40), 7),
        mocap_orientation_std=round(base.mocap_orientation_std * factor(rng, 0.10, 0.40), 7),
    )
    changed = {f.name: [getattr(base, f.name), getattr(gap, f.name)]
               for f in dataclasses.fields(base) if getattr(base, f.name) != getattr(gap, f.name)}
    out = save_twin(Twin(gap, {"created_by": "zoo24/make_gap_robot.py", "seed": SEED,
                               "base_robot": "measured"}), HERE / "gap_robot.json")
    for k, (a, b) in changed.items():
        print(f"{k}: {a} -> {b}")
    return out


if __name__ == "__main__":
    main()
