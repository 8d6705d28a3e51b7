"""SEALED: builds zoo39's gap robot (gap_robot.json) from robot_config("measured").

Run from the repository root:  OPENBLAS_NUM_THREADS=1 .venv/bin/python benchmarks/blind_zoo/zoos/zoo39/make_gap_robot.py

Every moved number gets its own factor from numpy's default_rng(SEED):
- kp, kd, torque_limit, armature (each entry of each per-joint-kind triple), foot_friction,
  ground_friction, rate_filter_hz, mocap_position_std, mocap_orientation_std: a distance from 1
  drawn log-uniformly in [3 %, 45 %], direction up or down with equal odds (up: 1 + d,
  down: 1 / (1 + d));
- body_mass, leg_mass: a distance from 1 drawn uniformly in [2 %, 15 %], either direction
  (1 + d or 1 - d);
- command_delay_ms (zero on measured): drawn uniformly in [0.3, 3] ms;
- rate_filter_hz: if measured had none, drawn uniformly in [35, 70] Hz instead.
The script prints no values.
"""
from __future__ import annotations

import dataclasses
import math
from pathlib import Path

import numpy as np

from littledog_mlsim.robot.config import robot_config
from littledog_mlsim.robot.twin import Twin, load_twin, save_twin

SEED = 640_913_287
HERE = Path(__file__).resolve().parent
OUT = HERE / "gap_robot.json"

TRIPLES = ("kp", "kd", "torque_limit", "armature")
SCALARS = ("foot_friction", "ground_friction", "rate_filter_hz", "mocap_position_std",
           "mocap_orientation_std")
MASSES = ("body_mass", "leg_mass")


def main() -> None:
    rng = np.random.default_rng(SEED)
    base = robot_config("measured")

    def factor() -> float:
        d = math.exp(rng.uniform(math.log(0.03), math.log(0.45)))
        return 1.0 + d if rng.random() < 0.5 else 1.0 / (1.0 + d)

    def mass_factor() -> float:
        d = rng.uniform(0.02, 0.15)
        return 1.0 + d if rng.random() < 0.5 else 1.0 - d

    factors: dict[str, tuple[float, ...]] = {}
    changes: dict[str, object] = {}
    for name in TRIPLES:
        f = tuple(factor() for _ in range(3))
        factors[name] = f
        changes[name] = tuple(float(v * k) for v, k in zip(getattr(base, name), f))
    for name in SCALARS:
        v = getattr(base, name)
        if name == "rate_filter_hz" and v is None:
            changes[name] = float(rng.uniform(35.0, 70.0))
            continue
        f = factor()
        factors[name] = (f,)
        changes[name] = float(v * f)
    for name in MASSES:
        f = mass_factor()
        factors[name] = (f,)
        changes[name] = float(getattr(base, name) * f)
    assert base.command_delay_ms == 0.0
    changes["command_delay_ms"] = float(rng.uniform(0.3, 3.0))

    gap = dataclasses.replace(base, name="zoo39-gap", **changes)

    # checks (no values printed)
    all_f = np.array([x for fs in factors.values() for x in fs])
    assert (all_f > 1.0).any() and (all_f < 1.0).any(), "factors must go both up and down"
    assert np.all(np.abs(all_f - 1.0) > 0.019), "every factor moves its number"
    assert np.ptp(np.log(all_f)) > 0.1, "the robot must not have one common factor"
    assert factors["body_mass"] != factors["leg_mass"], "masses need different factors"
    assert factors["foot_friction"] != factors["ground_friction"], "frictions need different factors"
    assert all(g >= 0.75 * m for g, m in zip(gap.torque_limit, base.torque_limit)), \
        "no torque limit below 0.75x measured's"
    assert 0.3 <= gap.command_delay_ms <= 3.0
    for name in (*TRIPLES, *SCALARS, *MASSES, "command_delay_ms"):
        assert getattr(gap, name) != getattr(base, name), f"{name} not moved"
    untouched = set(f.name for f in dataclasses.fields(base)) - {
        *TRIPLES, *SCALARS, *MASSES, "command_delay_ms", "name"}
    assert all(getattr(gap, n) == getattr(base, n) for n in untouched)

    twin = Twin(gap, {"note": "zoo39 sealed gap robot"})
    save_twin(twin, OUT)
    back = load_twin(OUT)
    assert back.robot == gap, "gap_robot.json does not read back equal"
    assert dict(back.provenance) == {"note": "zoo39 sealed gap robot"}
    print(f"wrote {OUT.name} (robot 'zoo39-gap'); checks passed")


if __name__ == "__main__":
    main()
