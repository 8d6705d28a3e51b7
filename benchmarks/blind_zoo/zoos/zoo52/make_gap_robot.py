"""zoo52's sealed gap robot: ``measured`` with many physical parameters moved (SEALED file).

Every moved parameter gets its own factor ``1 + s * m`` (``s`` a random sign, ``m`` a relative
size between a few per cent and a few tens of per cent), all drawn from this script's own seed;
``command_delay_ms`` (zero on ``measured``) gets a few milliseconds. Draws that would leave the
robot unable to walk (knee or hip torque limit outside its walking range, a contact friction
product outside its range) are drawn again from the same generator, so the robot is a pure
function of the seed. Writes ``gap_robot.json`` beside this script (from the
repository's root)::

    OPENBLAS_NUM_THREADS=1 .venv/bin/python \\
        benchmarks/blind_zoo/zoos/zoo52/make_gap_robot.py
"""
from __future__ import annotations

import dataclasses
import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[4]))   # the repository root
from littledog_mlsim.robot.config import robot_config  # noqa: E402
from littledog_mlsim.robot.twin import Twin, save_twin  # noqa: E402

SEED = 61_552_093
OUT = Path(__file__).with_name("gap_robot.json")

rng = np.random.default_rng(SEED)


def factor(lo: float = 0.03, hi: float = 0.30) -> float:
    """1 + s * m: random sign s, relative size m uniform in [lo, hi]."""
    sign = 1.0 if rng.random() < 0.5 else -1.0
    return 1.0 + sign * float(rng.uniform(lo, hi))


def moved(value: float, lo: float = 0.03, hi: float = 0.30,
          within: tuple[float, float] | None = None) -> float:
    """``value`` times a fresh factor, drawn again until it lies ``within`` (if given)."""
    while True:
        v = value * factor(lo, hi)
        if within is None or within[0] <= v <= within[1]:
            return float(v)


def moved_triple(values, lo=0.03, hi=0.30, within=None):
    within = within or (None, None, None)
    return tuple(moved(v, lo, hi, w) for v, w in zip(values, within))


def main() -> None:
    base = robot_config("measured")
    kp = moved_triple(base.kp)
    kd = moved_triple(base.kd)
    torque_limit = moved_triple(base.torque_limit, 0.03, 0.15,
                                within=((1.45, 1.95), (1.45, 1.95), (0.56, 0.70)))
    armature = moved_triple(base.armature)
    body_mass = moved(base.body_mass, 0.03, 0.15)
    leg_mass = moved(base.leg_mass, 0.03, 0.20)
    while True:
        foot_friction = moved(base.foot_friction)
        ground_friction = moved(base.ground_friction)
        if 0.6 <= foot_friction * ground_friction <= 1.2:
            break
    rate_filter_hz = moved(base.rate_filter_hz)
    mocap_position_std = moved(base.mocap_position_std)
    mocap_orientation_std = moved(base.mocap_orientation_std)
    command_delay_ms = float(rng.uniform(2.0, 7.0))

    config = dataclasses.replace(
        base, name="zoo52-gap", kp=kp, kd=kd, torque_limit=torque_limit, armature=armature,
        body_mass=body_mass, leg_mass=leg_mass, foot_friction=foot_friction,
        ground_friction=ground_friction, rate_filter_hz=rate_filter_hz,
        mocap_position_std=mocap_position_std, mocap_orientation_std=mocap_orientation_std,
        command_delay_ms=command_delay_ms)
    save_twin(Twin(config, {"note": "zoo52 sealed gap robot"}), OUT)
    print(f"wrote {OUT}")


if __name__ == "__main__":
    main()
