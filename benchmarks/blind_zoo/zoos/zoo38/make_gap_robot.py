"""Build zoo38's sealed gap robot: the ``measured`` robot with many physical parameters moved.

SEALED: this file holds the seed and therefore the factors. It prints no value.

Run from the repository root:

    OPENBLAS_NUM_THREADS=1 .venv/bin/python benchmarks/blind_zoo/zoos/zoo38/make_gap_robot.py
"""
from __future__ import annotations

import dataclasses
import math
from pathlib import Path

import numpy as np

from littledog_mlsim.robot.config import robot_config
from littledog_mlsim.robot.twin import Twin, load_twin, robot_config_from, save_twin

OUT = "benchmarks/blind_zoo/zoos/zoo38/gap_robot.json"
SEED = 73159

TRIPLE_FIELDS = ("kp", "kd", "torque_limit", "armature")
SCALAR_FIELDS = ("body_mass", "leg_mass", "foot_friction", "ground_friction",
                 "rate_filter_hz", "mocap_position_std", "mocap_orientation_std")
MOVED = TRIPLE_FIELDS + SCALAR_FIELDS + ("command_delay_ms",)


def generic_factor(rng: np.random.Generator) -> float:
    """A factor between about 0.69 and 1.45, at least 4 % from 1, either direction."""
    magnitude = rng.uniform(math.log(1.04), math.log(1.45))
    sign = 1.0 if rng.random() < 0.5 else -1.0
    return float(math.exp(sign * magnitude))


def mass_factor(rng: np.random.Generator) -> float:
    """A factor between 0.85 and 1.15, at least 3 % from 1, either direction."""
    magnitude = rng.uniform(0.03, 0.15)
    sign = 1.0 if rng.random() < 0.5 else -1.0
    return float(1.0 + sign * magnitude)


def build() -> tuple:
    measured = robot_config("measured")
    rng = np.random.default_rng(SEED)
    factors: list[float] = []
    changes: dict = {}
    for name in TRIPLE_FIELDS:
        f = [generic_factor(rng) for _ in range(3)]
        factors += f
        changes[name] = tuple(float(v * fi) for v, fi in zip(getattr(measured, name), f))
    fb, fl = mass_factor(rng), mass_factor(rng)
    while abs(fb - fl) < 0.02:
        fl = mass_factor(rng)
    changes["body_mass"] = float(measured.body_mass * fb)
    changes["leg_mass"] = float(measured.leg_mass * fl)
    ff, fg = generic_factor(rng), generic_factor(rng)
    while abs(ff - fg) < 0.03:
        fg = generic_factor(rng)
    factors += [ff, fg]
    changes["foot_friction"] = float(measured.foot_friction * ff)
    changes["ground_friction"] = float(measured.ground_friction * fg)
    for name in ("rate_filter_hz", "mocap_position_std", "mocap_orientation_std"):
        f = generic_factor(rng)
        factors.append(f)
        changes[name] = float(getattr(measured, name) * f)
    changes["command_delay_ms"] = float(rng.uniform(0.5, 4.0))
    robot = dataclasses.replace(measured, name="zoo38-gap", **changes)
    return measured, robot, factors, (fb, fl)


def main() -> None:
    measured, robot, factors, (fb, fl) = build()
    # factor ranges and directions
    assert all(0.67 <= f <= 1.5 and abs(f - 1.0) >= 0.03 for f in factors)
    assert any(f > 1.0 for f in factors) and any(f < 1.0 for f in factors)
    assert 0.85 <= fb <= 1.15 and 0.85 <= fl <= 1.15 and fb != fl
    assert robot.foot_friction / measured.foot_friction != robot.ground_friction / measured.ground_friction
    assert 0.5 <= robot.command_delay_ms <= 4.0
    # torque limits no lower than 0.75 x measured's
    assert all(t >= 0.75 * m for t, m in zip(robot.torque_limit, measured.torque_limit))

    save_twin(Twin(robot, {"created_by": "benchmarks/blind_zoo/zoos/zoo38/make_gap_robot.py",
                           "base_robot": "measured", "note": "zoo38 sealed gap robot"}), OUT)
    assert Path(OUT).exists()
    assert load_twin(OUT).robot == robot
    assert robot_config_from(OUT) == robot

    for field in dataclasses.fields(measured):
        name = field.name
        mine, theirs = getattr(robot, name), getattr(measured, name)
        if name == "name":
            assert mine == "zoo38-gap"
        elif name in MOVED:
            if isinstance(theirs, tuple):
                assert len(mine) == 3 and all(a != b for a, b in zip(mine, theirs)), name
            else:
                assert mine != theirs, name
        else:
            assert mine == theirs, name
    print("zoo38 gap robot written and checked")


if __name__ == "__main__":
    main()
