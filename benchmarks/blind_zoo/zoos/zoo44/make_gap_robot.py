"""SEALED: writes zoo44's gap robot, gap_robot.json (SEALED), next to this file.

The gap robot is robot_config("measured") with many physical parameters moved by factors drawn
from numpy's default_rng with the seed below. This script prints no values: it checks the draw,
saves the twin file, reads it back and checks that it is the same robot.

Run: OPENBLAS_NUM_THREADS=1 .venv/bin/python benchmarks/blind_zoo/zoos/zoo44/make_gap_robot.py
"""
from __future__ import annotations

import dataclasses
import math
import sys
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE.parents[3]))   # the repository root

from littledog_mlsim.robot.config import robot_config  # noqa: E402
from littledog_mlsim.robot.twin import Twin, load_twin, save_twin  # noqa: E402

SEED = 2108253094933467172

# every factor exp(+-u): u uniform in [log 1.03, log 1.45]; masses in [log 1.02, log 1.15]
FACTOR_RANGE = (math.log(1.03), math.log(1.45))
MASS_RANGE = (math.log(1.02), math.log(1.15))
DELAY_RANGE_MS = (0.3, 3.0)
TRIPLE_FIELDS = ("kp", "kd", "torque_limit", "armature")
SCALAR_FIELDS = ("foot_friction", "ground_friction", "rate_filter_hz", "mocap_position_std",
                 "mocap_orientation_std")
MASS_FIELDS = ("body_mass", "leg_mass")
NAMED_FIELDS = TRIPLE_FIELDS + SCALAR_FIELDS + MASS_FIELDS + ("command_delay_ms",)


def factor(rng: np.random.Generator, lo_hi: tuple[float, float]) -> float:
    """exp(s u): u uniform in lo_hi, the direction s = +1 or -1 at random."""
    u = rng.uniform(*lo_hi)
    s = 1.0 if rng.integers(0, 2) == 1 else -1.0
    return float(math.exp(s * u))


def draw(seed: int):
    """(gap robot config, {field: factor or list of factors}) for this seed."""
    rng = np.random.default_rng(seed)
    base = robot_config("measured")
    factors: dict[str, object] = {}
    changes: dict[str, object] = {}
    for name in TRIPLE_FIELDS:
        f = [factor(rng, FACTOR_RANGE) for _ in range(3)]
        factors[name] = f
        changes[name] = tuple(float(v * k) for v, k in zip(getattr(base, name), f))
    for name in SCALAR_FIELDS:
        f = factor(rng, FACTOR_RANGE)
        factors[name] = f
        changes[name] = float(getattr(base, name) * f)
    for name in MASS_FIELDS:
        f = factor(rng, MASS_RANGE)
        factors[name] = f
        changes[name] = float(getattr(base, name) * f)
    changes["command_delay_ms"] = float(rng.uniform(*DELAY_RANGE_MS))
    config = dataclasses.replace(base, name="zoo44-gap", **changes)
    return base, config, factors


def check(base, config, factors) -> None:
    """The draw's requirements (AssertionError naming the one that fails; no values)."""
    flat = []
    for name in TRIPLE_FIELDS:
        flat += list(factors[name])
    flat += [factors[n] for n in SCALAR_FIELDS + MASS_FIELDS]
    logs = np.log(np.array(flat))
    assert np.any(logs > 0) and np.any(logs < 0), "factors must go both up and down"
    gaps = np.abs(logs[:, None] - logs[None, :])[np.triu_indices(len(logs), 1)]
    assert np.all(gaps > 1e-6), "factors must all be distinct (no common factor)"
    assert float(np.std(logs)) > 0.05, "factors must be spread in log (no common factor)"
    assert abs(math.log(factors["body_mass"] / factors["leg_mass"])) > 1e-6, \
        "body and leg mass must have different factors"
    assert abs(math.log(factors["foot_friction"] / factors["ground_friction"])) > 1e-6, \
        "foot and ground friction must have different factors"
    for name in TRIPLE_FIELDS:
        k = factors[name]
        assert len(set(k)) == 3, f"{name}: every entry must have its own factor"
    assert all(c >= 0.75 * b for c, b in zip(config.torque_limit, base.torque_limit)), \
        "no torque limit may be below 0.75x measured's"
    for name in NAMED_FIELDS:
        b, c = getattr(base, name), getattr(config, name)
        if isinstance(b, tuple):
            assert all(x != y for x, y in zip(b, c)), f"{name}: every entry must change"
        else:
            assert b != c, f"{name} must change"
    assert base.command_delay_ms == 0.0 and DELAY_RANGE_MS[0] <= config.command_delay_ms \
        <= DELAY_RANGE_MS[1], "command delay out of range"
    # nothing else moved
    others = [f.name for f in dataclasses.fields(base) if f.name not in NAMED_FIELDS + ("name",)]
    assert all(getattr(base, n) == getattr(config, n) for n in others), "an unnamed field moved"


def main() -> None:
    base, config, factors = draw(SEED)
    check(base, config, factors)
    path = HERE / "gap_robot.json"
    save_twin(Twin(config, {"note": "zoo44 sealed gap robot"}), path)
    back = load_twin(path)
    assert back.robot == config, "the twin file does not read back as the same robot"
    assert dict(back.provenance) == {"note": "zoo44 sealed gap robot"}, "provenance differs"
    print(f"wrote {path.name}: robot {config.name!r}, {len(NAMED_FIELDS)} fields moved, "
          f"all checks passed (values sealed)")


if __name__ == "__main__":
    main()
