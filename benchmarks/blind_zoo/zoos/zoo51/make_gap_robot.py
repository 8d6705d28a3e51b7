"""Write zoo51's gap robot (gap_robot.json): the `measured` robot with many physical
parameters moved by a few per cent to a few tens of per cent, each drawn anew from this
script's own seed.

    OPENBLAS_NUM_THREADS=1 .venv/bin/python benchmarks/blind_zoo/zoos/zoo51/make_gap_robot.py
"""
from __future__ import annotations

import dataclasses
from pathlib import Path

import numpy as np

from littledog_mlsim.robot.config import robot_config
from littledog_mlsim.robot.twin import Twin, save_twin

SEED = 5_108_221
HERE = Path(__file__).resolve().parent


def draw(rng: np.random.Generator, value: float, lo: float, hi: float) -> float:
    """value x (1 + s r), r uniform in [lo, hi], s a random sign."""
    r = rng.uniform(lo, hi)
    return float(value * (1.0 + (r if rng.random() < 0.5 else -r)))


def triple(rng, values, lo, hi, caps=None):
    out = [draw(rng, v, lo, hi) for v in values]
    if caps is not None:     # (lower, upper) bounds per kind, to keep a robot that walks
        out = [float(np.clip(v, c[0], c[1])) for v, c in zip(out, caps)]
    return tuple(round(v, 6) for v in out)


def main() -> None:
    rng = np.random.default_rng(SEED)
    m = robot_config("measured")
    gap = dataclasses.replace(
        m,
        kp=triple(rng, m.kp, 0.04, 0.22),
        kd=triple(rng, m.kd, 0.04, 0.25),
        torque_limit=triple(rng, m.torque_limit, 0.03, 0.15,
                            caps=[(1.45, 1.95), (1.45, 1.95), (0.56, 0.70)]),
        armature=tuple(float(f"{v:.4g}") for v in triple(rng, m.armature, 0.05, 0.35)),
        body_mass=round(draw(rng, m.body_mass, 0.03, 0.12), 4),
        leg_mass=round(draw(rng, m.leg_mass, 0.03, 0.15), 4),
        foot_friction=round(draw(rng, m.foot_friction, 0.05, 0.25), 4),
        ground_friction=round(float(np.clip(draw(rng, m.ground_friction, 0.03, 0.2), 0.6, 1.1)), 4),
        command_delay_ms=round(float(rng.uniform(2.0, 7.0)), 2),
        rate_filter_hz=round(draw(rng, m.rate_filter_hz, 0.1, 0.35), 2),
        mocap_position_std=float(f"{draw(rng, m.mocap_position_std, 0.1, 0.5):.3g}"),
        mocap_orientation_std=float(f"{draw(rng, m.mocap_orientation_std, 0.1, 0.5):.3g}"),
    )
    save_twin(Twin(gap, {"created_by": "benchmarks/blind_zoo/zoos/zoo51/make_gap_robot.py",
                         "base_robot": "measured", "seed": SEED}), HERE / "gap_robot.json")
    print((HERE / "gap_robot.json").read_text())


if __name__ == "__main__":
    main()
