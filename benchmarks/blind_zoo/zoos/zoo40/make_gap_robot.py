"""Build zoo40's sealed gap robot: the ``measured`` robot with many physical parameters moved.

SEALED: this script holds the seed the gap robot is drawn from. It prints no values.

Run from the repository root:

    OPENBLAS_NUM_THREADS=1 .venv/bin/python benchmarks/blind_zoo/zoos/zoo40/make_gap_robot.py
"""
from __future__ import annotations

import dataclasses
import math
from pathlib import Path

import numpy as np

from littledog_mlsim.robot.config import robot_config
from littledog_mlsim.robot.twin import Twin, load_twin, save_twin

SEED = 6619043578120937  # the author's own, drawn fresh for zoo40
HERE = Path(__file__).resolve().parent
OUT = HERE / "gap_robot.json"

rng = np.random.default_rng(SEED)
factors: list[float] = []


def factor() -> float:
    """A factor between about 3 % and 45 % away from 1 (log-uniform in the distance), random
    direction."""
    distance = math.exp(rng.uniform(math.log(0.03), math.log(0.45)))
    f = 1.0 + distance if rng.random() < 0.5 else 1.0 - distance
    factors.append(f)
    return f


def mass_factor() -> float:
    """A factor 2 % to 15 % away from 1, either direction."""
    distance = rng.uniform(0.02, 0.15)
    f = 1.0 + distance if rng.random() < 0.5 else 1.0 - distance
    factors.append(f)
    return f


def triple(values) -> tuple[float, float, float]:
    return tuple(float(v) * factor() for v in values)  # type: ignore[return-value]


measured = robot_config("measured")

kp = triple(measured.kp)
kd = triple(measured.kd)
n_before_torque = len(factors)
torque_limit = triple(measured.torque_limit)
torque_factors = factors[n_before_torque:]
armature = triple(measured.armature)
body_factor = mass_factor()
leg_factor = mass_factor()
body_mass = measured.body_mass * body_factor
leg_mass = measured.leg_mass * leg_factor
foot_factor = factor()
ground_factor = factor()
foot_friction = measured.foot_friction * foot_factor
ground_friction = measured.ground_friction * ground_factor
if measured.rate_filter_hz is None:
    rate_filter_hz = float(rng.uniform(35.0, 70.0))
else:
    rate_filter_hz = measured.rate_filter_hz * factor()
mocap_position_std = measured.mocap_position_std * factor()
mocap_orientation_std = measured.mocap_orientation_std * factor()
command_delay_ms = float(rng.uniform(0.3, 3.0))

gap = dataclasses.replace(
    measured, name="zoo40-gap",
    kp=kp, kd=kd, torque_limit=torque_limit, armature=armature,
    body_mass=float(body_mass), leg_mass=float(leg_mass),
    foot_friction=float(foot_friction), ground_friction=float(ground_friction),
    rate_filter_hz=float(rate_filter_hz),
    mocap_position_std=float(mocap_position_std),
    mocap_orientation_std=float(mocap_orientation_std),
    command_delay_ms=command_delay_ms,
)

f = np.array(factors)
assert np.any(f > 1.0) and np.any(f < 1.0), "factors must go both up and down"
assert min(torque_factors) >= 0.75, "a torque limit below 0.75x measured's"
assert np.ptp(f) > 0.05, "the robot must not have one common factor"
assert body_factor != leg_factor, "the two masses need different factors"
assert foot_factor != ground_factor, "the two frictions need different factors"
assert 0.3 <= command_delay_ms <= 3.0

save_twin(Twin(gap, {"note": "zoo40 sealed gap robot"}), OUT)
back = load_twin(OUT)
assert back.robot == gap, "gap_robot.json does not read back equal"
assert back.provenance.get("note") == "zoo40 sealed gap robot"
print(f"wrote {OUT.name}; it reads back equal (no values shown)")
