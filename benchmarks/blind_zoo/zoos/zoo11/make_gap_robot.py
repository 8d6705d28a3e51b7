"""Write gap_robot.json: the stock ``measured`` LittleDog with many physical parameters moved,
as a calibrated twin would miss a real robot (deterministic: fixed seed below).

Each moved parameter is multiplied by exp(+-U(log 1.03, log 1.30)) (a random sign, a change of
3 % to 30 %), except where noted; a small all-joint command delay is added. Run from anywhere:

    .venv/bin/python benchmarks/blind_zoo/zoos/zoo11/make_gap_robot.py
"""
from __future__ import annotations

import dataclasses
import math
import sys
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[4]
sys.path.insert(0, str(ROOT))
from littledog_mlsim.robot.config import robot_config  # noqa: E402
from littledog_mlsim.robot.twin import Twin, save_twin  # noqa: E402

SEED = 1147
LO, HI = 1.03, 1.30


def factor(rng: np.random.Generator, lo: float = LO, hi: float = HI, sign: int | None = None) -> float:
    s = sign if sign is not None else (1 if rng.random() < 0.5 else -1)
    return math.exp(s * rng.uniform(math.log(lo), math.log(hi)))


def triple(rng, values, **kw):
    return tuple(float(v * factor(rng, **kw)) for v in values)


def make() -> Twin:
    rng = np.random.default_rng(SEED)
    m = robot_config("measured")
    kp = triple(rng, m.kp)
    kd = triple(rng, m.kd)
    lim = list(triple(rng, m.torque_limit[:2])) + [
        # the knee's limit already saturates in trotting: moved by at most -3 % .. +20 %
        float(m.torque_limit[2] * factor(rng, 1.0, 1.2, sign=1) * 0.97)]
    arm = triple(rng, m.armature)
    gap = dataclasses.replace(
        m, name="gap_robot", kp=kp, kd=kd, torque_limit=tuple(lim), armature=arm,
        body_mass=float(m.body_mass * factor(rng, 1.02, 1.12)),
        leg_mass=float(m.leg_mass * factor(rng)),
        foot_friction=float(m.foot_friction * factor(rng, 1.03, 1.2)),
        ground_friction=float(m.ground_friction * factor(rng, 1.03, 1.2)),
        rate_filter_hz=float(m.rate_filter_hz * factor(rng)),
        mocap_position_std=float(m.mocap_position_std * factor(rng)),
        mocap_orientation_std=float(m.mocap_orientation_std * factor(rng)),
        command_delay_ms=float(rng.uniform(2.0, 6.0)),
    )
    return Twin(gap, {"created_by": "benchmarks/blind_zoo/zoos/zoo11/make_gap_robot.py",
                      "base_robot": "measured", "seed": SEED,
                      "method": "each parameter x exp(+-U(log 1.03, log 1.30)); knee torque "
                                "limit x 0.97..1.16; body mass x 1.02..1.12 and frictions x 1.03..1.2 "
                                "(either sign); command delay U(2, 6) ms"})


if __name__ == "__main__":
    out = Path(__file__).with_name("gap_robot.json")
    save_twin(make(), out)
    print(f"wrote {out}")
