"""Write zoo62's sealed gap robot, ``gap_robot.json`` (a twin file, ``robot.twin.save_twin``).

The robot is the ``measured`` LittleDog with many physical parameters of its configuration
moved, each by its own random factor 1 +- m (sign drawn, m log-uniform between 3 % and 30 %),
then bounded per parameter so that the robot still trots all 11 move types upright (the knee's
torque limit, the servo gains and the contact friction are bounded below more tightly). The
command delay, zero on ``measured``, is drawn as a value (a few ms). The seed is this zoo's own.

    cd /work/main && .venv/bin/python benchmarks/blind_zoo/zoos/zoo62/make_gap_robot.py
    # walk check (every move type, no fall), simulates:
    OPENBLAS_NUM_THREADS=1 .venv/bin/python benchmarks/blind_zoo/zoos/zoo62/make_gap_robot.py --walk-check
"""
from __future__ import annotations

import argparse
import dataclasses
import sys
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE.parents[3]))          # the repository root

from littledog_mlsim.robot.config import robot_config   # noqa: E402
from littledog_mlsim.robot.twin import Twin, save_twin  # noqa: E402

SEED = 3531243046740598126          # drawn once for zoo62 (secrets.randbits(62))
NAME = "zoo62-gap"

#: factor bounds (lo, hi) per parameter; triples per joint kind (hip_roll, hip_pitch, knee)
BOUNDS = {
    "kp": [(0.80, 1.30), (0.80, 1.30), (0.82, 1.30)],
    "kd": [(0.75, 1.30), (0.75, 1.30), (0.75, 1.30)],
    "torque_limit": [(0.80, 1.30), (0.80, 1.30), (0.92, 1.30)],
    "armature": [(0.70, 1.30), (0.70, 1.30), (0.70, 1.30)],
    "body_mass": (0.85, 1.20),
    "leg_mass": (0.80, 1.30),
    "foot_friction": (0.75, 1.30),
    "ground_friction": (0.75, 1.30),
    "rate_filter_hz": (0.70, 1.30),
    "mocap_position_std": (0.70, 1.40),
    "mocap_orientation_std": (0.70, 1.40),
}
DELAY_MS = (2.0, 8.0)               # command_delay_ms, drawn uniformly (measured: 0)


def _factor(rng: np.random.Generator, lo: float, hi: float) -> float:
    m = float(np.exp(rng.uniform(np.log(0.03), np.log(0.30))))
    s = 1.0 if rng.random() < 0.5 else -1.0
    return float(np.clip(1.0 + s * m, lo, hi))


def gap_config():
    rng = np.random.default_rng(SEED)
    base = robot_config("measured")
    changes = {}
    for name, b in BOUNDS.items():
        v = getattr(base, name)
        if isinstance(b, list):
            changes[name] = tuple(float(x * _factor(rng, *bk)) for x, bk in zip(v, b))
        else:
            changes[name] = float(v * _factor(rng, *b))
    changes["command_delay_ms"] = float(rng.uniform(*DELAY_MS))
    return dataclasses.replace(base, name=NAME, **changes)


def walk_check(path: Path) -> int:
    """One move of every type (seed 531), reports the lowest height and largest tilt."""
    from littledog_mlsim.apps.record import record_dataset
    from littledog_mlsim.data.dataset import load_moves
    from littledog_mlsim.rotations import quat_to_rpy
    import tempfile
    with tempfile.TemporaryDirectory() as tmp:
        out = Path(tmp) / "walk"
        record_dataset(out, moves_per_type=1, seed=531, robot=str(path), jobs=2, progress=False)
        bad = 0
        for m in load_moves(out, split="all"):
            rpy = quat_to_rpy(m.orientation)
            zmin, tilt = float(m.position[:, 2].min()), float(np.abs(rpy[:, :2]).max())
            fell = zmin < 0.07 or tilt > 0.7
            bad += fell
            print(f"{m.name:6s} z_min {zmin:.3f} m  max |roll|,|pitch| {tilt:.3f} rad"
                  f"{'  FELL' if fell else ''}")
    print("walk check:", "every move upright" if not bad else f"{bad} moves fell")
    return 1 if bad else 0


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--walk-check", action="store_true")
    a = ap.parse_args()
    path = HERE / "gap_robot.json"
    save_twin(Twin(gap_config(), {"created_by": "benchmarks/blind_zoo/zoos/zoo62/make_gap_robot.py",
                                  "base_robot": "measured",
                                  "note": "zoo62's sealed gap robot"}), path)
    print(f"wrote {path}")
    return walk_check(path) if a.walk_check else 0


if __name__ == "__main__":
    raise SystemExit(main())
