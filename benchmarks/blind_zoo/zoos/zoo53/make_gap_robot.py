"""zoo53's sealed gap robot: ``measured`` with many physical parameters moved (SEALED file).

Each moved number is multiplied by its own factor ``1 + s * m``: ``s`` a fair random sign and
``m`` a relative size drawn uniformly between a few per cent and a few tens of per cent (the
span depends on how well such a number is known on a real robot: the torque limits and the body
mass narrower, the gains, armature, frictions, filter and noise wider). ``command_delay_ms``
(zero on ``measured``) is drawn as a few milliseconds. One draw (the two frictions together) is
repeated from the same generator while the contact's friction product falls outside a walkable
span, so the robot is a pure function of the seed. Writes ``gap_robot.json`` beside this
script (from the repository's root)::

    OPENBLAS_NUM_THREADS=1 .venv/bin/python \\
        benchmarks/blind_zoo/zoos/zoo53/make_gap_robot.py
"""
from __future__ import annotations

import dataclasses
import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[4]))   # the repository root
from littledog_mlsim.robot.config import robot_config  # noqa: E402
from littledog_mlsim.robot.twin import Twin, load_twin, save_twin  # noqa: E402

SEED = 8_204_731_566
OUT = Path(__file__).with_name("gap_robot.json")

# relative size spans (lo, hi) of the factor 1 + s * m, per field
SPAN = {
    "kp": (0.04, 0.30),
    "kd": (0.04, 0.30),
    "torque_limit": (0.03, 0.14),
    "armature": (0.05, 0.35),
    "body_mass": (0.03, 0.12),
    "leg_mass": (0.04, 0.25),
    "foot_friction": (0.04, 0.25),
    "ground_friction": (0.04, 0.25),
    "rate_filter_hz": (0.05, 0.30),
    "mocap_position_std": (0.05, 0.35),
    "mocap_orientation_std": (0.05, 0.35),
}
DELAY_MS = (1.5, 6.0)
FRICTION_PRODUCT = (0.60, 1.15)   # foot x ground, the contact's coefficient

rng = np.random.default_rng(SEED)


def factor(field: str) -> float:
    lo, hi = SPAN[field]
    sign = -1.0 if rng.random() < 0.5 else 1.0
    return 1.0 + sign * float(rng.uniform(lo, hi))


def scalar(base, field: str) -> float:
    return float(getattr(base, field)) * factor(field)


def triple(base, field: str) -> tuple[float, float, float]:
    """Each joint kind (hip_roll, hip_pitch, knee) by its own factor."""
    return tuple(float(v) * factor(field) for v in getattr(base, field))  # type: ignore


def main() -> None:
    base = robot_config("measured")
    moved: dict = {}
    for f in ("kp", "kd", "torque_limit", "armature"):
        moved[f] = triple(base, f)
    for f in ("body_mass", "leg_mass"):
        moved[f] = scalar(base, f)
    while True:
        foot, ground = scalar(base, "foot_friction"), scalar(base, "ground_friction")
        if FRICTION_PRODUCT[0] <= foot * ground <= FRICTION_PRODUCT[1]:
            break
    moved["foot_friction"], moved["ground_friction"] = foot, ground
    for f in ("rate_filter_hz", "mocap_position_std", "mocap_orientation_std"):
        moved[f] = scalar(base, f)
    moved["command_delay_ms"] = float(rng.uniform(*DELAY_MS))

    config = dataclasses.replace(base, name="zoo53-gap", **moved)
    save_twin(Twin(config, {"note": "zoo53 sealed gap robot"}), OUT)
    assert load_twin(OUT).robot == config
    print(f"wrote {OUT}")


if __name__ == "__main__":
    main()
