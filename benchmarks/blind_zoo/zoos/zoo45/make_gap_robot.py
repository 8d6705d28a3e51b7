"""Write this zoo's gap robot, gap_robot.json (SEALED: prints no values).

The `measured` robot with many physical parameters moved, each by a factor drawn log-uniform
between 3 % and 45 % away from 1 in a random direction (masses 2-15 %), no torque limit below
0.75x measured's, and a small set-point delay drawn uniform in 0.3-3 ms. The factors are
checked to go both ways, to be distinct and to change every named field; the file is read
back and compared; then every move type is walked once with it (no fall).

    OPENBLAS_NUM_THREADS=1 PYTHONPATH=. .venv/bin/python \
        benchmarks/blind_zoo/zoos/zoo45/make_gap_robot.py [--no-walk]
"""
from __future__ import annotations

import dataclasses
import sys
import tempfile
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE.parents[3]))

from littledog_mlsim.robot.config import robot_config  # noqa: E402
from littledog_mlsim.robot.twin import Twin, load_twin, save_twin  # noqa: E402

SEED = 1281948623737393273                       # drawn fresh for this zoo
TRIPLES = ("kp", "kd", "torque_limit", "armature")   # per joint kind
SCALARS = ("foot_friction", "ground_friction", "rate_filter_hz", "mocap_position_std",
           "mocap_orientation_std")
MASSES = ("body_mass", "leg_mass")
DELAY_MS = (0.3, 3.0)
TORQUE_FLOOR = 0.75


def factor(rng: np.random.Generator, lo: float, hi: float) -> float:
    """exp(+-U(log(1+lo), log(1+hi))): lo..hi away from 1, in a random direction."""
    mag = np.exp(rng.uniform(np.log1p(lo), np.log1p(hi)))
    return float(mag if rng.random() < 0.5 else 1.0 / mag)


def make() -> tuple[object, dict[str, float]]:
    rng = np.random.default_rng(SEED)
    base = robot_config("measured")
    factors: dict[str, float] = {}
    changes: dict[str, object] = {}
    for name in TRIPLES:
        vals = []
        for k, v in enumerate(getattr(base, name)):
            f = factor(rng, 0.03, 0.45)
            while name == "torque_limit" and f < TORQUE_FLOOR:
                f = factor(rng, 0.03, 0.45)
            factors[f"{name}[{k}]"] = f
            vals.append(v * f)
        changes[name] = tuple(vals)
    for name in SCALARS:
        f = factor(rng, 0.03, 0.45)
        factors[name] = f
        changes[name] = getattr(base, name) * f
    for name in MASSES:
        f = factor(rng, 0.02, 0.15)
        factors[name] = f
        changes[name] = getattr(base, name) * f
    changes["command_delay_ms"] = float(rng.uniform(*DELAY_MS))
    gap = dataclasses.replace(base, name="zoo45_gap", **changes)
    # the checks (no value printed)
    f = np.array(list(factors.values()))
    assert (f > 1).any() and (f < 1).any(), "factors must go both ways"
    assert len(set(np.round(f, 9))) == len(f), "factors must be distinct"
    for name in TRIPLES:
        assert all(a != b for a, b in zip(getattr(gap, name), getattr(base, name))), name
    for name in SCALARS + MASSES + ("command_delay_ms",):
        assert getattr(gap, name) != getattr(base, name), name
    assert all(a >= TORQUE_FLOOR * b for a, b in zip(gap.torque_limit, base.torque_limit))
    assert DELAY_MS[0] <= gap.command_delay_ms <= DELAY_MS[1]
    return gap, factors


def walk_check(path: Path) -> int:
    """Record one move of every type with the gap robot; count falls (body below 0.1 m or
    its z axis more than 26 deg from vertical)."""
    from littledog_mlsim.apps.record import record_dataset
    from littledog_mlsim.data.dataset import load_moves
    falls = 0
    with tempfile.TemporaryDirectory() as tmp:
        for exc in (0.0, 0.05):
            out = Path(tmp) / f"walk_e{exc:g}"
            record_dataset(out, moves_per_type=1, seed=9045, robot=str(path), jobs=2,
                           progress=False, excitation=exc)
            for rec in load_moves(out, "all"):
                o = np.asarray(rec.orientation)          # xyzw; z of the body's z axis
                zax = 1.0 - 2.0 * (o[:, 0] ** 2 + o[:, 1] ** 2)
                bad = (np.asarray(rec.position)[:, 2].min() < 0.1
                       or zax.min() < np.cos(np.radians(26)))
                falls += bool(bad)
                print(f"walk {rec.name} (excitation {exc:g}): {'FELL' if bad else 'ok'}")
    return falls


def main() -> int:
    gap, factors = make()
    path = HERE / "gap_robot.json"
    save_twin(Twin(gap, {"created_by": "benchmarks/blind_zoo/zoos/zoo45/make_gap_robot.py",
                         "base_robot": "measured"}), path)
    assert load_twin(path).robot == gap, "read back differs"
    print(f"wrote {path.name}: {len(factors)} factors (both ways, distinct), delay set; "
          f"read back equal")
    if "--no-walk" not in sys.argv:
        falls = walk_check(path)
        print(f"falls: {falls}")
        return 1 if falls else 0
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
