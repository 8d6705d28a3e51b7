"""Write gap_robot.json: the `measured` LittleDog with many physical parameters moved by a few
per cent to a few tens of per cent, as a calibrated twin misses a real robot (SEALED values).

Run from anywhere: python make_gap_robot.py  (writes gap_robot.json beside this file).
Each parameter is multiplied by exp(s * u), u ~ U(log 1.03, log M) with a random sign s, M the
largest factor allowed for that parameter; a few parameters that are zero on `measured` are
given small positive values. Seed below (chosen for this zoo only).
"""
from __future__ import annotations

import dataclasses
import math
from pathlib import Path

import numpy as np

from littledog_mlsim.robot.config import robot_config
from littledog_mlsim.robot.twin import Twin, save_twin

SEED = 1829113   # zoo18, chosen freshly
HERE = Path(__file__).resolve().parent


def main() -> None:
    rng = np.random.default_rng(SEED)
    m = robot_config("measured")

    def f(max_factor: float, lo: float = 1.03, sign: float | None = None) -> float:
        u = rng.uniform(math.log(lo), math.log(max_factor))
        s = sign if sign is not None else rng.choice([-1.0, 1.0])
        return math.exp(s * u)

    def triple(v, max_factor, signs=(None, None, None)):
        return tuple(round(x * f(max_factor, sign=s), 7) for x, s in zip(v, signs))

    # the knee's torque limit is near what the trot needs: it may only grow or shrink slightly
    tl = list(m.torque_limit)
    tl = [round(tl[0] * f(1.25), 4), round(tl[1] * f(1.25), 4),
          round(tl[2] * f(1.12, lo=1.01, sign=1.0), 4)]
    gap = dataclasses.replace(
        m,
        name="zoo18_gap",
        kp=triple(m.kp, 1.30),
        kd=triple(m.kd, 1.35),
        torque_limit=tuple(tl),
        armature=triple(m.armature, 1.40),
        body_mass=round(m.body_mass * f(1.12), 4),
        leg_mass=round(m.leg_mass * f(1.20), 4),
        foot_friction=round(m.foot_friction * f(1.25), 3),
        ground_friction=round(m.ground_friction * f(1.20), 3),
        command_delay_ms=round(float(rng.uniform(2.0, 7.0)), 2),
        rate_filter_hz=round(m.rate_filter_hz * f(1.35), 2),
        encoder_resolution=triple(m.encoder_resolution, 1.5),
        mocap_position_std=round(m.mocap_position_std * f(1.6), 6),
        mocap_orientation_std=round(m.mocap_orientation_std * f(1.6), 6),
    )
    save_twin(Twin(gap, {"created_by": "benchmarks/blind_zoo/zoos/zoo18/make_gap_robot.py",
                         "base_robot": "measured", "seed": SEED,
                         "note": "SEALED: the zoo's gap robot; not for the diagnosis side"}),
              HERE / "gap_robot.json")


if __name__ == "__main__":
    main()
