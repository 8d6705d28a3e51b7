"""Write zoo43's gap robot (SEALED with truth.yaml): the ``measured`` robot with many physical
parameters moved by factors drawn from a fresh seed, then a walk check of one move per type.

    OPENBLAS_NUM_THREADS=1 PYTHONPATH=. .venv/bin/python \\
        benchmarks/blind_zoo/zoos/zoo43/make_gap_robot.py [--no-walk-check]

Prints no parameter values: only whether the checks passed.
"""
from __future__ import annotations

import argparse
import dataclasses
import sys
import tempfile
from pathlib import Path

import numpy as np

from littledog_mlsim.robot.config import robot_config
from littledog_mlsim.robot.twin import Twin, load_twin, save_twin

HERE = Path(__file__).resolve().parent
OUT = HERE / "gap_robot.json"
SEED = 2312008241660415584          # fresh, drawn for this zoo

TRIPLES = ("kp", "kd", "torque_limit", "armature")
SCALARS = ("foot_friction", "ground_friction", "rate_filter_hz", "mocap_position_std",
           "mocap_orientation_std")
MASSES = ("body_mass", "leg_mass")


def _factor(rng: np.random.Generator, lo: float, hi: float) -> float:
    """Log-uniform distance in [lo, hi] from 1, in a random direction."""
    m = float(np.exp(rng.uniform(np.log(lo), np.log(hi))))
    return 1.0 + m if rng.random() < 0.5 else 1.0 - m


def make() -> Twin:
    base = robot_config("measured")
    rng = np.random.default_rng(SEED)
    changes: dict = {}
    factors: list[float] = []
    for name in TRIPLES:
        old = getattr(base, name)
        new = []
        for v in old:
            while True:
                f = _factor(rng, 0.03, 0.45)
                if name != "torque_limit" or f >= 0.75:
                    break
            factors.append(f)
            new.append(v * f)
        changes[name] = tuple(new)
    for name in SCALARS:
        f = _factor(rng, 0.03, 0.45)
        factors.append(f)
        changes[name] = getattr(base, name) * f
    for name in MASSES:
        f = _factor(rng, 0.02, 0.15)
        factors.append(f)
        changes[name] = getattr(base, name) * f
    changes["command_delay_ms"] = float(rng.uniform(0.3, 3.0))
    gap = dataclasses.replace(base, **changes)

    f = np.array(factors)
    assert np.any(f > 1) and np.any(f < 1), "factors must go both ways"
    assert len(np.unique(np.round(f, 12))) == len(f), "factors must be distinct"
    assert np.all(np.abs(f - 1) >= 0.02 - 1e-12), "every factor at least 2 % from 1"
    tl_ratio = np.array(gap.torque_limit) / np.array(base.torque_limit)
    assert np.all(tl_ratio >= 0.75), "no torque limit below 0.75x measured's"
    for name in (*TRIPLES, *SCALARS, *MASSES, "command_delay_ms"):
        old, new = getattr(base, name), getattr(gap, name)
        if isinstance(old, tuple):
            assert all(a != b for a, b in zip(old, new)), f"{name} unchanged"
        else:
            assert old != new, f"{name} unchanged"
    assert 0.3 <= gap.command_delay_ms <= 3.0
    return Twin(gap, {"created_by": "benchmarks/blind_zoo/zoos/zoo43/make_gap_robot.py",
                      "base_robot": "measured",
                      "note": "zoo43's gap robot (sealed); factors drawn from a fresh seed"})


def walk_check(path: Path) -> bool:
    """One move of each type: the body stays above 0.1 m and upright."""
    from littledog_mlsim.apps.record import record_dataset
    from littledog_mlsim.data.dataset import load_moves
    from littledog_mlsim.rotations import quat_to_matrix
    ok = True
    with tempfile.TemporaryDirectory() as tmp:
        out = Path(tmp) / "walk"
        record_dataset(out, moves_per_type=1, seed=4343, robot=str(path), jobs=2,
                       progress=False)
        moves = load_moves(out, split="all")
        for m in moves:
            up = quat_to_matrix(np.asarray(m.orientation))[:, 2, 2]
            good = bool(np.min(m.position[:, 2]) > 0.1 and np.min(up) > 0.5)
            ok &= good
            print(f"walk check {m.name}: {'ok' if good else 'FELL'}")
    return ok


def main() -> int:
    ap = argparse.ArgumentParser()
    ap.add_argument("--no-walk-check", action="store_true")
    a = ap.parse_args()
    twin = make()
    save_twin(twin, OUT)
    back = load_twin(OUT)
    assert back.robot == twin.robot, "twin file does not read back equal"
    print(f"wrote {OUT.name}; factors both ways, distinct, every named field changed; "
          "read back equal")
    if not a.no_walk_check:
        ok = walk_check(OUT)
        print("walk check: " + ("every move walked without falling" if ok else "A MOVE FELL"))
        return 0 if ok else 1
    return 0


if __name__ == "__main__":
    sys.exit(main())
