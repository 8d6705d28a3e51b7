"""Writes gap_robot.json: the `measured` robot with many physical parameters moved.

Each parameter is multiplied by a factor drawn (seeded) from its own range of a few per cent to a
few tens of per cent, with a random sign of the change; a draw closer than 3 % to no change is
pushed out to 3 %. Run: .venv/bin/python benchmarks/blind_zoo/zoos/zoo22/make_gap_robot.py
"""
from __future__ import annotations

import dataclasses
from pathlib import Path

import numpy as np

from littledog_mlsim.robot.config import robot_config
from littledog_mlsim.robot.twin import Twin, save_twin

SEED = 22_4711


def factor(rng: np.random.Generator, lo: float, hi: float) -> float:
    """1 +- a relative change drawn uniformly in [lo, hi]."""
    return 1.0 + float(rng.choice([-1.0, 1.0])) * float(rng.uniform(lo, hi))


def triple(rng, base, lo, hi, floor=None):
    out = tuple(round(b * factor(rng, lo, hi), 6) for b in base)
    if floor is not None:
        out = tuple(max(f, v) for f, v in zip(floor, out))
    return out


def main() -> None:
    rng = np.random.default_rng(SEED)
    m = robot_config("measured")
    gap = dataclasses.replace(
        m,
        name="zoo22-gap",
        kp=triple(rng, m.kp, 0.05, 0.18),
        kd=triple(rng, m.kd, 0.05, 0.25),
        # the knee limit is kept no lower than 0.58 N m (lower ones make the trot fall)
        torque_limit=triple(rng, m.torque_limit, 0.04, 0.15, floor=(0.0, 0.0, 0.58)),
        command_delay_ms=round(float(rng.uniform(2.0, 6.0)), 2),
        armature=triple(rng, m.armature, 0.10, 0.35),
        body_mass=round(m.body_mass * factor(rng, 0.04, 0.12), 4),
        leg_mass=round(m.leg_mass * factor(rng, 0.05, 0.20), 4),
        foot_friction=round(m.foot_friction * factor(rng, 0.08, 0.30), 4),
        ground_friction=round(m.ground_friction * factor(rng, 0.05, 0.20), 4),
        rate_filter_hz=round(m.rate_filter_hz * factor(rng, 0.10, 0.35), 2),
        mocap_position_std=round(m.mocap_position_std * factor(rng, 0.15, 0.5), 7),
        mocap_orientation_std=round(m.mocap_orientation_std * factor(rng, 0.15, 0.5), 7),
        solver_iterations=int(m.solver_iterations + rng.choice([-10, 10])),
    )
    changed = {f.name: (getattr(m, f.name), getattr(gap, f.name))
               for f in dataclasses.fields(m) if getattr(m, f.name) != getattr(gap, f.name)}
    out = Path(__file__).with_name("gap_robot.json")
    save_twin(Twin(gap, {"created_by": "zoo22/make_gap_robot.py", "seed": SEED,
                         "base_robot": "measured"}), out)
    for k, (a, b) in changed.items():
        print(f"{k}: {a} -> {b}")
    print(f"wrote {out}")


if __name__ == "__main__":
    main()
