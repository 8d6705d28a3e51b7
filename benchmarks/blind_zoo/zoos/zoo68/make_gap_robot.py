"""Write zoo68's gap robot, ``gap_robot.json`` (a twin file, ``robot.twin.save_twin``).

The ``measured`` robot with many physical parameters each moved by its own random factor,
drawn from this zoo's own seed (``SEED``, drawn once with ``secrets.randbits(62)``): the servo's
P gain and damping per joint kind, the torque limit per joint kind, the armature per joint
kind, the body's and the legs' mass, the foot's and the ground's friction, the encoder rate
filter's cut-off, the motion capture's noise levels, and a command delay of a few ms (zero on
the ``measured`` robot). Each factor moves its parameter by 3 % at least and by at most the
bound given in ``RANGES`` (either direction, the sign drawn too); the bounds keep a robot that
trots (``--walk-check``).

Commands, from the repository root::

    OPENBLAS_NUM_THREADS=1 nice -n 19 .venv/bin/python benchmarks/blind_zoo/zoos/zoo68/make_gap_robot.py
    OPENBLAS_NUM_THREADS=1 nice -n 19 .venv/bin/python benchmarks/blind_zoo/zoos/zoo68/make_gap_robot.py --walk-check

The first writes ``gap_robot.json`` beside this file; the second also trots one move of each of
the 11 types with it (recorded under ``--scratch``, default ``/tmp/z68_author/walk``) and says
whether every move stayed upright (body above 0.07 m, |roll| and |pitch| below 0.7 rad).
"""
from __future__ import annotations

import argparse
import dataclasses
import math
import shutil
import sys
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE.parents[3]))     # the repository root

from littledog_mlsim.robot.config import robot_config  # noqa: E402
from littledog_mlsim.robot.twin import Twin, save_twin  # noqa: E402

SEED = 3847923572504181975  # drawn once with secrets.randbits(62) for zoo68, after RANGES were set; sealed

MIN_CHANGE = 0.03
#: (largest factor below 1, largest factor above 1): a factor is 1 - x or 1 + x with x drawn
#: uniformly between MIN_CHANGE and the bound on its side, the side drawn with equal odds
RANGES = {
    "kp": (0.18, 0.25),
    "kd": (0.25, 0.30),
    "torque_limit_hips": (0.15, 0.25),
    "torque_limit_knee": (0.08, 0.22),      # a weaker knee than this does not trot every move
    "armature": (0.30, 0.35),
    "body_mass": (0.10, 0.12),
    "leg_mass": (0.15, 0.20),
    "foot_friction": (0.20, 0.15),
    "ground_friction": (0.20, 0.15),
    "rate_filter_hz": (0.30, 0.40),
    "mocap_position_std": (0.40, 0.60),
    "mocap_orientation_std": (0.40, 0.60),
}
COMMAND_DELAY_MS = (2.0, 6.0)
FALL_Z, FALL_ANGLE = 0.07, 0.7


def _factor(rng: np.random.Generator, key: str) -> float:
    lo, hi = RANGES[key]
    if rng.random() < 0.5:
        return 1.0 - rng.uniform(MIN_CHANGE, lo)
    return 1.0 + rng.uniform(MIN_CHANGE, hi)


def gap_robot():
    """The gap robot's RobotConfig and the factors drawn (for the provenance)."""
    rng = np.random.default_rng(SEED)
    base = robot_config("measured")
    f: dict[str, object] = {}

    def triple(key, values, kinds=("hip_roll", "hip_pitch", "knee"), keys=None):
        out = []
        for i, (v, kind) in enumerate(zip(values, kinds)):
            k = keys[i] if keys else key
            x = _factor(rng, k)
            f[f"{key}_{kind}"] = x
            out.append(v * x)
        return tuple(out)

    kp = triple("kp", base.kp)
    kd = triple("kd", base.kd)
    lim = triple("torque_limit", base.torque_limit,
                 keys=("torque_limit_hips", "torque_limit_hips", "torque_limit_knee"))
    arm = triple("armature", base.armature)
    scalars = {}
    for key in ("body_mass", "leg_mass", "foot_friction", "ground_friction", "rate_filter_hz",
                "mocap_position_std", "mocap_orientation_std"):
        x = _factor(rng, key)
        f[key] = x
        scalars[key] = getattr(base, key) * x
    delay = float(rng.uniform(*COMMAND_DELAY_MS))
    f["command_delay_ms"] = delay
    config = dataclasses.replace(base, name="gap_robot", kp=kp, kd=kd, torque_limit=lim,
                                 armature=arm, command_delay_ms=round(delay, 3), **scalars)
    return config, f


def walk_check(robot: Path, scratch: Path) -> bool:
    from littledog_mlsim.apps.record import record_dataset
    from littledog_mlsim.data.dataset import load_moves
    from littledog_mlsim.rotations import quat_to_rpy
    if scratch.exists():
        shutil.rmtree(scratch)
    scratch.parent.mkdir(parents=True, exist_ok=True)
    record_dataset(scratch, moves_per_type=1, seed=591, robot=str(robot), jobs=1, progress=False)
    ok = True
    for m in load_moves(scratch, split="all"):
        rpy = quat_to_rpy(m.orientation)
        zmin = float(np.min(m.position[:, 2]))
        amax = float(np.max(np.abs(rpy[:, :2])))
        fell = zmin < FALL_Z or amax > FALL_ANGLE
        ok &= not fell
        print(f"{m.name}: min z {zmin:.3f} m, max |roll|,|pitch| {amax:.3f} rad"
              f"{'  FELL' if fell else ''}")
    print(("every move upright" if ok else "a move fell"))
    return ok


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--walk-check", action="store_true")
    ap.add_argument("--scratch", default="/tmp/z68_author/walk")
    a = ap.parse_args(argv)
    config, factors = gap_robot()
    out = HERE / "gap_robot.json"
    save_twin(Twin(config, {"created_by": "benchmarks/blind_zoo/zoos/zoo68/make_gap_robot.py",
                            "base_robot": "measured", "seed": SEED, "factors": factors}), out)
    print(f"wrote {out}")
    if a.walk_check:
        return 0 if walk_check(out, Path(a.scratch)) else 1
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
