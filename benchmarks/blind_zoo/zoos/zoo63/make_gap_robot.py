"""Write zoo63's gap robot, ``gap_robot.json``: the ``measured`` robot with many physical
parameters each moved by its own random factor (sealed: only this zoo's author reads it).

Every listed parameter gets a factor (1 + m) ** s with m drawn uniformly in [LOW, HIGH] (a few
per cent to a few tens of per cent) and s = +1 or -1 at random, then clipped to the parameter's
bounds (``BOUNDS``: narrower where a weaker robot would not trot every move type upright). The
command delay, 0 on the ``measured`` robot, is drawn in ``DELAY_MS``. The draw uses ``SEED``
only, drawn once for this zoo with ``secrets.randbits(62)``.

Commands (from the repository root)::

    OPENBLAS_NUM_THREADS=1 .venv/bin/python benchmarks/blind_zoo/zoos/zoo63/make_gap_robot.py
    OPENBLAS_NUM_THREADS=1 .venv/bin/python benchmarks/blind_zoo/zoos/zoo63/make_gap_robot.py --walk-check

``--walk-check`` trots one move of each of the 11 types with the written robot (seed 541, no
effect) and prints the lowest body height and the largest |roll| and |pitch| of each; it fails
(exit 1) if a move falls (body below 0.07 m, or |roll| or |pitch| beyond 0.7 rad).
"""
from __future__ import annotations

import argparse
import dataclasses
import sys
import tempfile
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE.parents[3]))      # the repository root

from littledog_mlsim.robot.config import robot_config  # noqa: E402
from littledog_mlsim.robot.twin import Twin, save_twin  # noqa: E402

SEED = 276369316795845319          # drawn once for zoo63 (secrets.randbits(62))
LOW, HIGH = 0.03, 0.30             # the size of a factor's change, |factor - 1| before clipping
DELAY_MS = (1.5, 6.0)              # the command delay's range [ms]
OUT = HERE / "gap_robot.json"

#: (field, index in a joint-kind triple or None, (lowest factor, highest factor))
PARAMETERS = [
    ("kp", 0, (0.77, 1.30)), ("kp", 1, (0.77, 1.30)), ("kp", 2, (0.77, 1.30)),
    ("kd", 0, (0.77, 1.30)), ("kd", 1, (0.77, 1.30)), ("kd", 2, (0.77, 1.30)),
    ("torque_limit", 0, (0.85, 1.30)), ("torque_limit", 1, (0.85, 1.30)),
    ("torque_limit", 2, (0.90, 1.30)),
    ("armature", 0, (0.77, 1.30)), ("armature", 1, (0.77, 1.30)), ("armature", 2, (0.77, 1.30)),
    ("body_mass", None, (0.85, 1.15)), ("leg_mass", None, (0.80, 1.25)),
    ("foot_friction", None, (0.80, 1.25)), ("ground_friction", None, (0.80, 1.25)),
    ("rate_filter_hz", None, (0.77, 1.30)),
    ("mocap_position_std", None, (0.77, 1.30)), ("mocap_orientation_std", None, (0.77, 1.30)),
]


def gap_robot():
    """The gap robot's RobotConfig, from SEED."""
    rng = np.random.default_rng(SEED)
    base = robot_config("measured")
    values = {f.name: getattr(base, f.name) for f in dataclasses.fields(base)}
    for name, index, (lo, hi) in PARAMETERS:
        m = rng.uniform(LOW, HIGH)
        s = 1.0 if rng.random() < 0.5 else -1.0
        factor = float(np.clip((1.0 + m) ** s, lo, hi))
        if index is None:
            values[name] = float(values[name]) * factor
        else:
            v = list(values[name])
            v[index] = float(v[index]) * factor
            values[name] = tuple(v)
    values["command_delay_ms"] = float(rng.uniform(*DELAY_MS))
    return dataclasses.replace(base, **{k: v for k, v in values.items() if k != "name"})


def walk_check(path: Path) -> bool:
    from littledog_mlsim.apps.record import record_dataset
    from littledog_mlsim.data.dataset import load_moves
    from littledog_mlsim.rotations import quat_to_rpy
    ok = True
    with tempfile.TemporaryDirectory(prefix="z63walk") as tmp:
        out = Path(tmp) / "walk"
        record_dataset(out, moves_per_type=1, seed=541, robot=str(path), jobs=1, progress=False)
        for rec in load_moves(out, split="all"):
            rpy = quat_to_rpy(rec.orientation)
            zmin = float(rec.position[:, 2].min())
            r, pch = float(np.abs(rpy[:, 0]).max()), float(np.abs(rpy[:, 1]).max())
            fell = zmin < 0.07 or r > 0.7 or pch > 0.7
            ok &= not fell
            print(f"{rec.name}: z min {zmin:.3f} m, |roll| max {r:.3f}, |pitch| max {pch:.3f}"
                  f"{'  FELL' if fell else ''}")
    print("walk check:", "every move upright" if ok else "a move fell")
    return ok


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--walk-check", action="store_true",
                    help="trot one move of each type with the written robot")
    a = ap.parse_args(argv)
    if a.walk_check:
        return 0 if walk_check(OUT) else 1
    save_twin(Twin(gap_robot(), {"created_by": "benchmarks/blind_zoo/zoos/zoo63/make_gap_robot.py",
                                 "note": "zoo63's sealed gap robot"}), OUT)
    print(f"wrote {OUT}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
