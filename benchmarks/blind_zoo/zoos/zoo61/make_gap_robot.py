"""zoo61's sealed gap robot: ``measured`` with many physical parameters moved (SEALED file).

Every moved parameter gets its own factor ``1 + s * m``: ``s`` a random sign (both directions
equally likely), ``m`` a relative size drawn uniformly between a few per cent and a few tens of
per cent (narrower for the torque limits and the masses, which decide whether the trot stays
upright). ``command_delay_ms`` (zero on ``measured``) gets a few milliseconds. Every draw comes
from this script's own seed; a draw outside a walking range (a torque limit, the contact's
friction product) is drawn again from the same generator, so the robot is a pure function of
the seed. A whole robot that fails the author's walk check (``record``, seed 527, 10 moves per
type: something fell, or a moving type went less than 0.1 m on average along its nominal
direction) is discarded and drawn again from the same generator: ``DISCARDED`` counts those
draws, and the robot written is the next one. Writes ``gap_robot.json`` beside this script
(from the repository's root)::

    OPENBLAS_NUM_THREADS=1 .venv/bin/python \\
        benchmarks/blind_zoo/zoos/zoo61/make_gap_robot.py
"""
from __future__ import annotations

import dataclasses
import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[4]))   # the repository root
from littledog_mlsim.robot.config import robot_config  # noqa: E402
from littledog_mlsim.robot.twin import Twin, save_twin  # noqa: E402

SEED = 1481604243845115456          # drawn once for this zoo (secrets.randbits(62))
OUT = Path(__file__).with_name("gap_robot.json")
DISCARDED = 1   # whole draws that failed the walk check, discarded in order

rng = np.random.default_rng(SEED)


def moved(value: float, lo: float, hi: float,
          within: tuple[float, float] | None = None) -> float:
    """``value`` times ``1 + s * m`` (random sign s, m uniform in [lo, hi]), drawn again until
    it lies ``within`` (if given)."""
    while True:
        sign = -1.0 if rng.random() < 0.5 else 1.0
        v = value * (1.0 + sign * float(rng.uniform(lo, hi)))
        if within is None or within[0] <= v <= within[1]:
            return float(v)


def moved_triple(values, lo, hi, within=(None, None, None)):
    """Each joint kind (hip_roll, hip_pitch, knee) its own factor."""
    return tuple(moved(v, lo, hi, w) for v, w in zip(values, within))


def draw(base):
    """One whole robot drawn from ``rng``."""
    kp = moved_triple(base.kp, 0.04, 0.26)
    kd = moved_triple(base.kd, 0.04, 0.26)
    torque_limit = moved_triple(base.torque_limit, 0.03, 0.13,
                                within=((1.50, 1.90), (1.50, 1.90), (0.56, 0.68)))
    armature = moved_triple(base.armature, 0.05, 0.30)
    body_mass = moved(base.body_mass, 0.03, 0.13)
    leg_mass = moved(base.leg_mass, 0.04, 0.18)
    while True:
        foot_friction = moved(base.foot_friction, 0.04, 0.24)
        ground_friction = moved(base.ground_friction, 0.04, 0.24)
        if 0.62 <= foot_friction * ground_friction <= 1.15:
            break
    rate_filter_hz = moved(base.rate_filter_hz, 0.05, 0.30)
    mocap_position_std = moved(base.mocap_position_std, 0.05, 0.30)
    mocap_orientation_std = moved(base.mocap_orientation_std, 0.05, 0.30)
    command_delay_ms = float(rng.uniform(1.0, 6.0))

    return dataclasses.replace(
        base, name="zoo61-gap", kp=kp, kd=kd, torque_limit=torque_limit, armature=armature,
        body_mass=body_mass, leg_mass=leg_mass, foot_friction=foot_friction,
        ground_friction=ground_friction, rate_filter_hz=rate_filter_hz,
        mocap_position_std=mocap_position_std, mocap_orientation_std=mocap_orientation_std,
        command_delay_ms=command_delay_ms)


def main() -> None:
    base = robot_config("measured")
    for _ in range(DISCARDED + 1):
        config = draw(base)
    save_twin(Twin(config, {"note": "zoo61 sealed gap robot"}), OUT)
    print(f"wrote {OUT}")


if __name__ == "__main__":
    main()
