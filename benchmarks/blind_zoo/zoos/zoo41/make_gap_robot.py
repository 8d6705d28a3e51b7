"""SEALED. Build zoo41's gap robot (gap_robot.json) from the "measured" robot.

Run from the repository root:
    OPENBLAS_NUM_THREADS=1 .venv/bin/python benchmarks/blind_zoo/zoos/zoo41/make_gap_robot.py

Prints no values. Every number moved gets its own factor, drawn from numpy's default_rng with
the seed below:

- kp, kd, torque_limit, armature (each entry of the hip roll / hip pitch / knee triple),
  foot_friction, ground_friction, rate_filter_hz, mocap_position_std, mocap_orientation_std:
  factor (1 + m) ** s, m log-uniform in [0.03, 0.45], s = +1 or -1 with equal odds;
- body_mass, leg_mass: factor 1 + s * m, m uniform in [0.02, 0.15], s = +1 or -1;
- command_delay_ms (zero on measured): set uniformly in [0.3, 3] ms;
- rate_filter_hz: if measured had none, set uniformly in [35, 70] Hz instead of a factor.
"""
from __future__ import annotations

import dataclasses
import math
from pathlib import Path

import numpy as np

from littledog_mlsim.robot.config import robot_config
from littledog_mlsim.robot.twin import Twin, load_twin, save_twin

SEED = 96403203143406
OUT = Path(__file__).with_name("gap_robot.json")

SMALL, LARGE = 0.03, 0.45          # log-uniform size of a factor's step away from 1
MASS_SMALL, MASS_LARGE = 0.02, 0.15
DELAY_MS = (0.3, 3.0)
RATE_FILTER_HZ = (35.0, 70.0)
TRIPLES = ("kp", "kd", "torque_limit", "armature")
SCALARS = ("foot_friction", "ground_friction", "rate_filter_hz", "mocap_position_std",
           "mocap_orientation_std")
MASSES = ("body_mass", "leg_mass")


def _factor(rng: np.random.Generator) -> float:
    m = math.exp(rng.uniform(math.log(SMALL), math.log(LARGE)))
    s = 1.0 if rng.random() < 0.5 else -1.0
    return (1.0 + m) ** s


def _mass_factor(rng: np.random.Generator) -> float:
    m = rng.uniform(MASS_SMALL, MASS_LARGE)
    s = 1.0 if rng.random() < 0.5 else -1.0
    return 1.0 + s * m


def build(seed: int = SEED):
    rng = np.random.default_rng(seed)
    base = robot_config("measured")
    changes: dict = {}
    factors: dict[str, float | tuple] = {}
    for name in TRIPLES:
        f = tuple(_factor(rng) for _ in range(3))
        factors[name] = f
        changes[name] = tuple(float(v * fi) for v, fi in zip(getattr(base, name), f))
    for name in SCALARS:
        v = getattr(base, name)
        if name == "rate_filter_hz" and v is None:
            changes[name] = float(rng.uniform(*RATE_FILTER_HZ))
            continue
        f = _factor(rng)
        factors[name] = f
        changes[name] = float(v * f)
    for name in MASSES:
        f = _mass_factor(rng)
        factors[name] = f
        changes[name] = float(getattr(base, name) * f)
    changes["command_delay_ms"] = float(rng.uniform(*DELAY_MS))
    robot = dataclasses.replace(base, name="zoo41-gap", **changes)

    flat = []
    for f in factors.values():
        flat.extend(f if isinstance(f, tuple) else (f,))
    flat = np.array(flat)
    assert np.all(np.isfinite(flat)) and np.all(flat > 0)
    assert np.any(flat > 1.0) and np.any(flat < 1.0), "factors must go both up and down"
    assert len(np.unique(np.round(flat, 12))) > 1, "the robot must not have one common factor"
    assert factors["body_mass"] != factors["leg_mass"], "the masses need different factors"
    assert factors["foot_friction"] != factors["ground_friction"], \
        "the frictions need different factors"
    assert all(new >= 0.75 * old for new, old in zip(robot.torque_limit, base.torque_limit)), \
        "a torque limit below 0.75x measured's"
    assert DELAY_MS[0] <= robot.command_delay_ms <= DELAY_MS[1]
    assert robot != base
    return robot


def main() -> None:
    robot = build(SEED)
    twin = Twin(robot, {"note": "zoo41 sealed gap robot"})
    save_twin(twin, OUT)
    back = load_twin(OUT)
    assert back.robot == robot, "gap_robot.json does not read back equal"
    assert dict(back.provenance) == dict(twin.provenance), "provenance does not read back equal"
    print(f"wrote {OUT.name} (robot {robot.name!r}); read back equal")


if __name__ == "__main__":
    main()
