"""Write zoo47's gap robot (``gap_robot.json``, SEALED): the ``measured`` robot with many
physical parameters moved by independent random factors.

Every parameter below gets its own factor ``1 + sign * size``: ``size`` log-uniform between
``SIZE_LO`` and ``SIZE_HI`` (a few per cent to a few tens of per cent), ``sign`` +1 or -1 with
equal odds, all drawn from one numpy ``default_rng(SEED)``. A per-joint-kind triple (hip roll,
hip pitch, knee) gets one factor per kind. Fields the ``measured`` robot has at zero stay at
zero (a factor of zero), and numerical settings (physics step, solver iterations, settle time)
and the encoders' counts per radian (a catalogue number) are not moved.

    .venv/bin/python benchmarks/blind_zoo/zoos/zoo47/make_gap_robot.py [--out gap_robot.json]

The output path defaults to ``gap_robot.json`` beside this script.
"""
from __future__ import annotations

import argparse
import dataclasses
import json
import sys
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE.parents[3]))      # the repository root

from littledog_mlsim.robot.config import robot_config  # noqa: E402
from littledog_mlsim.robot.twin import Twin, save_twin  # noqa: E402

SEED = 4507683785068591590        # drawn once for this zoo (secrets.randbits(62))
SIZE_LO, SIZE_HI = 0.03, 0.30     # relative size of a change: 3 % to 30 %, log-uniform

#: the RobotConfig fields moved (triples: one factor per joint kind), in drawing order
SCALAR_FIELDS = ("body_mass", "leg_mass", "foot_friction", "ground_friction", "rate_filter_hz",
                 "mocap_position_std", "mocap_orientation_std", "command_delay_ms")
TRIPLE_FIELDS = ("kp", "kd", "torque_limit", "armature")


def factors(rng: np.random.Generator, n: int) -> np.ndarray:
    size = np.exp(rng.uniform(np.log(SIZE_LO), np.log(SIZE_HI), size=n))
    sign = rng.choice([-1.0, 1.0], size=n)
    return 1.0 + sign * size


def gap_robot(seed: int = SEED):
    base = robot_config("measured")
    rng = np.random.default_rng(seed)
    changes: dict = {}
    for name in TRIPLE_FIELDS:
        old = np.asarray(getattr(base, name), dtype=float)
        changes[name] = tuple(float(v) for v in old * factors(rng, 3))
    for name in SCALAR_FIELDS:
        old = getattr(base, name)
        f = float(factors(rng, 1)[0])
        changes[name] = None if old is None else float(old) * f
    changes["name"] = "zoo47-gap"
    return base, dataclasses.replace(base, **changes)


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--out", default=str(HERE / "gap_robot.json"))
    a = ap.parse_args(argv)
    base, robot = gap_robot()
    prov = {"created_by": "benchmarks/blind_zoo/zoos/zoo47/make_gap_robot.py",
            "base_robot": "measured", "seed": SEED, "size_bounds": [SIZE_LO, SIZE_HI],
            "moved_fields": list(TRIPLE_FIELDS + SCALAR_FIELDS)}
    save_twin(Twin(robot, prov), a.out)
    print(f"wrote {a.out}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
