"""zoo46's gap robot: the ``measured`` robot with many physical parameters moved (SEALED).

Writes ``gap_robot.json`` beside this script with the twin module's ``save_twin``, reads it
back and checks that it is the same robot, then records one move of every type, plain and with
0.05 rad of command excitation, and checks that none falls. Prints no parameter values.

Run from the repository root:

    OPENBLAS_NUM_THREADS=1 PYTHONPATH=. .venv/bin/python \
        benchmarks/blind_zoo/zoos/zoo46/make_gap_robot.py
"""
from __future__ import annotations

import dataclasses
import sys
import tempfile
from pathlib import Path

import numpy as np

from littledog_mlsim.apps.record import record_dataset
from littledog_mlsim.data.dataset import load_moves
from littledog_mlsim.robot.config import robot_config
from littledog_mlsim.robot.twin import Twin, load_twin, save_twin
from littledog_mlsim.rotations import quat_to_rpy

HERE = Path(__file__).resolve().parent
OUT = HERE / "gap_robot.json"
SEED = 2505335674800688527          # drawn once for this zoo (secrets.randbits(62))

# Relative change (a few per cent to a few tens of per cent), drawn log-uniformly between the
# two bounds with a random sign: factor = exp(+-u), log(1 + lo) <= u <= log(1 + hi).
RANGES = {
    "kp": (0.05, 0.25),               # P gain, per joint kind
    "kd": (0.05, 0.30),               # damping, per joint kind
    "armature": (0.05, 0.35),         # reflected rotor inertia, per joint kind
    "torque_limit": (0.03, 0.15),     # per joint kind; floored at 0.75x measured below
    "body_mass": (0.01, 0.06),
    "leg_mass": (0.02, 0.08),
    "foot_friction": (0.05, 0.25),
    "ground_friction": (0.05, 0.25),
    "rate_filter_hz": (0.10, 0.35),   # encoder rate filter cut-off
    "mocap_position_std": (0.10, 0.40),
    "mocap_orientation_std": (0.10, 0.40),
}
DELAY_MS = (1.0, 4.0)                 # a small set-point delay, all joints [ms]
TORQUE_FLOOR = 0.75


def _factor(rng: np.random.Generator, lo: float, hi: float, size: int | None = None):
    u = rng.uniform(np.log1p(lo), np.log1p(hi), size=size)
    s = rng.choice([-1.0, 1.0], size=size)
    return np.exp(s * u)


def make_gap_robot(seed: int = SEED):
    base = robot_config("measured")
    rng = np.random.default_rng(seed)
    new = {}
    for name in ("kp", "kd", "armature", "torque_limit"):
        lo, hi = RANGES[name]
        f = _factor(rng, lo, hi, 3)
        v = np.asarray(getattr(base, name)) * f
        if name == "torque_limit":
            v = np.maximum(v, TORQUE_FLOOR * np.asarray(base.torque_limit))
        new[name] = tuple(float(x) for x in v)
    for name in ("body_mass", "leg_mass", "foot_friction", "ground_friction", "rate_filter_hz",
                 "mocap_position_std", "mocap_orientation_std"):
        lo, hi = RANGES[name]
        new[name] = float(getattr(base, name) * _factor(rng, lo, hi))
    new["command_delay_ms"] = float(rng.uniform(*DELAY_MS))
    return dataclasses.replace(base, name="zoo46-gap", **new)


def _falls(directory: Path) -> list[str]:
    """Names of the moves that fall (a body tilted past 0.7 rad, low body or non-finite)."""
    bad = []
    for rec in load_moves(directory, split="all"):
        pos, orn = np.asarray(rec.position), np.asarray(rec.orientation)
        if not (np.isfinite(pos).all() and np.isfinite(orn).all()):
            bad.append(rec.name)
            continue
        rpy = quat_to_rpy(orn)
        if np.abs(rpy[:, :2]).max() > 0.7 or pos[:, 2].min() < 0.06:
            bad.append(rec.name)
    return bad


def main() -> int:
    config = make_gap_robot()
    base = robot_config("measured")
    assert all(a >= TORQUE_FLOOR * b - 1e-12 for a, b in zip(config.torque_limit,
                                                             base.torque_limit))
    twin = Twin(config, {"created_by": "benchmarks/blind_zoo/zoos/zoo46/make_gap_robot.py",
                         "base_robot": "measured"})
    save_twin(twin, OUT)
    back = load_twin(OUT)
    if back.robot != config or dict(back.provenance) != dict(twin.provenance):
        print("FAIL: the twin file read back differs from the robot written")
        return 1
    print(f"wrote {OUT.name}; read back: equal")
    failed = False
    with tempfile.TemporaryDirectory(prefix="zoo46_gap_") as tmp:
        for exc in (0.0, 0.05):
            d = Path(tmp) / f"e{exc:g}"
            record_dataset(d, moves_per_type=1, seed=4646, robot=str(OUT), excitation=exc,
                           jobs=2, progress=False)
            bad = _falls(d)
            n = len(load_moves(d, split="all"))
            print(f"excitation {exc:g}: {n} moves (one of every type), "
                  f"{len(bad)} fell{': ' + ', '.join(bad) if bad else ''}")
            failed |= bool(bad)
    print("FAIL" if failed else "OK: no move falls")
    return 1 if failed else 0


if __name__ == "__main__":
    sys.exit(main())
