"""SEALED. Builds zoo42's gap robot: the ``measured`` robot with many physical parameters moved.

Run once by the zoo's author (``OPENBLAS_NUM_THREADS=1 .venv/bin/python make_gap_robot.py``
from this directory or anywhere); it writes ``gap_robot.json`` next to itself, reads it back
and checks it. It prints no values.

Factors: every number of kp, kd, torque_limit, armature (each entry of the per-joint-kind
triples its own factor), foot_friction, ground_friction, rate_filter_hz, mocap_position_std and
mocap_orientation_std is multiplied by exp(s * u), s = +1 or -1 at random and |log factor| u
uniform between log(1.03) and log(1.45) (3 % to 45 % away from 1, log-uniform). body_mass and
leg_mass get their own factors, likewise between 2 % and 15 % away from 1, either direction.
command_delay_ms (zero on ``measured``) is set uniformly within 0.3-3 ms.
"""
from __future__ import annotations

import dataclasses
import math
from pathlib import Path

import numpy as np

from littledog_mlsim.robot.config import robot_config
from littledog_mlsim.robot.twin import Twin, load_twin, save_twin

SEED = 7719034452861097  # drawn once by the author; sealed
HERE = Path(__file__).resolve().parent
OUT = HERE / "gap_robot.json"

TRIPLE_FIELDS = ("kp", "kd", "torque_limit", "armature")
SCALAR_FIELDS = ("foot_friction", "ground_friction", "rate_filter_hz", "mocap_position_std",
                 "mocap_orientation_std")
MASS_FIELDS = ("body_mass", "leg_mass")


def _factor(rng: np.random.Generator, lo: float, hi: float) -> float:
    """exp(+-u), u uniform in [log(1+lo), log(1+hi)], the sign at random."""
    u = rng.uniform(math.log1p(lo), math.log1p(hi))
    sign = 1.0 if rng.random() < 0.5 else -1.0
    return float(math.exp(sign * u))


def build() -> Twin:
    base = robot_config("measured")
    rng = np.random.default_rng(SEED)
    factors: dict[str, list[float]] = {}
    changes: dict[str, object] = {}
    for name in TRIPLE_FIELDS:
        f = [_factor(rng, 0.03, 0.45) for _ in range(3)]
        factors[name] = f
        changes[name] = tuple(float(v * k) for v, k in zip(getattr(base, name), f))
    for name in SCALAR_FIELDS:
        f = _factor(rng, 0.03, 0.45)
        factors[name] = [f]
        changes[name] = float(getattr(base, name) * f)
    for name in MASS_FIELDS:
        f = _factor(rng, 0.02, 0.15)
        factors[name] = [f]
        changes[name] = float(getattr(base, name) * f)
    changes["command_delay_ms"] = float(rng.uniform(0.3, 3.0))

    flat = [k for f in factors.values() for k in f]
    assert any(k > 1.0 for k in flat) and any(k < 1.0 for k in flat), "factors not both ways"
    assert len(set(flat)) == len(flat) and np.ptp(np.log(flat)) > 0.05, "a common factor"
    assert factors["body_mass"][0] != factors["leg_mass"][0], "masses share a factor"
    assert factors["foot_friction"][0] != factors["ground_friction"][0], "frictions share one"
    assert all(min(abs(math.log(k)) for k in factors[n]) >= math.log1p(0.02) - 1e-12
               for n in factors), "a factor too close to 1"
    assert all(t >= 0.75 * m for t, m in zip(changes["torque_limit"], base.torque_limit)), \
        "a torque limit below 0.75x measured's"
    assert 0.3 <= changes["command_delay_ms"] <= 3.0

    robot = dataclasses.replace(base, name="zoo42-gap", **changes)
    for name in (*TRIPLE_FIELDS, *SCALAR_FIELDS, *MASS_FIELDS, "command_delay_ms"):
        assert getattr(robot, name) != getattr(base, name), name
    return Twin(robot, {"note": "zoo42 sealed gap robot"})


def main() -> None:
    twin = build()
    save_twin(twin, OUT)
    back = load_twin(OUT)
    assert back.robot == twin.robot, "gap_robot.json does not read back equal"
    assert dict(back.provenance) == dict(twin.provenance), "provenance does not read back"
    print(f"wrote {OUT.name} (robot {twin.robot.name!r}); read back equal")


if __name__ == "__main__":
    main()
