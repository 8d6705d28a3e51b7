"""Write zoo64's gap robot (``gap_robot.json``, a twin file) from the zoo's own seed.

The gap robot is the ``measured`` robot with many physical parameters each moved by its own
random factor: the servo's P gain and damping per joint kind, the torque limit per joint kind,
the armature per joint kind, the body's and the legs' mass, the foot's and the ground's
friction, the encoder rate filter's cut-off, the motion capture's noise levels, and a command
delay of a few milliseconds (zero on ``measured``). Each factor is 1 +- m, m drawn uniformly
between 3 % and the parameter's largest change (a few tens of per cent), the sign at random,
then kept inside bounds where a weaker robot would not trot.

``SEED`` was drawn once for this zoo with ``secrets.randbits(62)`` (different from every other
zoo's) and written here; the file is a pure function of it.

Commands (from the repository root)::

    OPENBLAS_NUM_THREADS=1 .venv/bin/python benchmarks/blind_zoo/zoos/zoo64/make_gap_robot.py
    OPENBLAS_NUM_THREADS=1 .venv/bin/python benchmarks/blind_zoo/zoos/zoo64/make_gap_robot.py --walk-check

The first writes ``gap_robot.json`` beside this file; ``--walk-check`` writes it too, then
trots one move of each of the 11 types with it (seed 551, the zoo's effect seed) and checks
that none falls (body below 0.07 m, or |roll| or |pitch| beyond 0.7 rad).
"""
from __future__ import annotations

import argparse
import dataclasses
import sys
import tempfile
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE.parents[3]))   # the repository root

from littledog_mlsim.robot.config import robot_config  # noqa: E402
from littledog_mlsim.robot.twin import Twin, save_twin  # noqa: E402

SEED = 3494492645481789256   # secrets.randbits(62), drawn once for zoo64

OUT = HERE / "gap_robot.json"
KINDS = ("hip_roll", "hip_pitch", "knee")

#: (field, index in a per-joint-kind triple or None, largest change, lowest factor, highest factor)
SPECS: tuple[tuple[str, int | None, float, float, float], ...] = (
    ("kp", 0, 0.25, 0.85, 1.25), ("kp", 1, 0.25, 0.85, 1.25), ("kp", 2, 0.25, 0.88, 1.25),
    ("kd", 0, 0.30, 0.75, 1.30), ("kd", 1, 0.30, 0.75, 1.30), ("kd", 2, 0.30, 0.75, 1.30),
    ("torque_limit", 0, 0.20, 0.85, 1.20), ("torque_limit", 1, 0.20, 0.85, 1.20),
    ("torque_limit", 2, 0.20, 0.92, 1.20),
    ("armature", 0, 0.30, 0.75, 1.30), ("armature", 1, 0.30, 0.75, 1.30),
    ("armature", 2, 0.30, 0.75, 1.30),
    ("body_mass", None, 0.12, 0.90, 1.12),
    ("leg_mass", None, 0.15, 0.85, 1.15),
    ("foot_friction", None, 0.25, 0.80, 1.20),
    ("ground_friction", None, 0.25, 0.80, 1.20),
    ("rate_filter_hz", None, 0.30, 0.75, 1.30),
    ("mocap_position_std", None, 0.40, 0.65, 1.40),
    ("mocap_orientation_std", None, 0.40, 0.65, 1.40),
)
DELAY_MS = (1.5, 6.0)      # command delay drawn uniformly in this range [ms]


def gap_robot():
    """(RobotConfig of the gap robot, {parameter: factor})."""
    rng = np.random.default_rng(SEED)
    base = robot_config("measured")
    values = {f.name: getattr(base, f.name) for f in dataclasses.fields(base)}
    factors = {}
    for field, index, most, lo, hi in SPECS:
        m = rng.uniform(0.03, most)
        sign = 1.0 if rng.random() < 0.5 else -1.0
        factor = float(np.clip(1.0 + sign * m, lo, hi))
        name = field if index is None else f"{field}_{KINDS[index]}"
        factors[name] = factor
        if index is None:
            values[field] = float(values[field]) * factor
        else:
            triple = list(values[field])
            triple[index] = float(triple[index]) * factor
            values[field] = tuple(triple)
    values["command_delay_ms"] = float(rng.uniform(*DELAY_MS))
    values["name"] = "gap"
    return dataclasses.replace(base, **values), factors


def write() -> Path:
    config, factors = gap_robot()
    provenance = {"created_by": "benchmarks/blind_zoo/zoos/zoo64/make_gap_robot.py",
                  "base_robot": "measured", "seed": SEED, "factors": factors,
                  "command_delay_ms": config.command_delay_ms}
    return save_twin(Twin(config, provenance), OUT)


def walk_check(path: Path, seed: int = 551) -> bool:
    from littledog_mlsim.apps.record import record_dataset
    from littledog_mlsim.data.dataset import load_moves
    from littledog_mlsim.data.states import states_from_recording
    ok = True
    with tempfile.TemporaryDirectory(prefix="z64_walk_") as tmp:
        out = Path(tmp) / "walk"
        record_dataset(out, moves_per_type=1, seed=seed, robot=str(path), jobs=2,
                       progress=False)
        for rec in load_moves(out, split="all"):
            s = states_from_recording(rec)
            z, roll, pitch = s[:, 0].min(), np.abs(s[:, 4]).max(), np.abs(s[:, 5]).max()
            fell = z < 0.07 or roll > 0.7 or pitch > 0.7
            ok &= not fell
            print(f"{rec.name:6s} min z {z:.3f} m  max |roll| {roll:.3f}  max |pitch| {pitch:.3f}"
                  f"  {'FELL' if fell else 'upright'}")
    print("walk check:", "every move upright" if ok else "a move fell")
    return ok


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--walk-check", action="store_true",
                    help="trot one move of each type with the gap robot and check it stays up")
    a = ap.parse_args()
    path = write()
    print(f"wrote {path}")
    if a.walk_check:
        return 0 if walk_check(path) else 1
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
