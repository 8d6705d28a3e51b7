"""Write gap_robot.json: the `measured` robot with many physical parameters moved (SEALED).

Each moved parameter gets its own factor 1 + s * m, with a random sign s and a magnitude m drawn
uniformly between 4 % and 28 % (fixed seed); the servo torque limits are only allowed to move up
or down a little (m <= 6 % downwards) so that the open-loop trot keeps standing. Run from the
repository root:

    .venv/bin/python benchmarks/blind_zoo/zoos/zoo28/make_gap_robot.py
"""
from __future__ import annotations

import dataclasses
from pathlib import Path

import numpy as np

from littledog_mlsim.robot.config import config_to_dict, robot_config
from littledog_mlsim.robot.twin import Twin, save_twin

SEED = 2828
HERE = Path(__file__).resolve().parent


def main() -> None:
    rng = np.random.default_rng(SEED)
    base = robot_config("measured")
    factors: dict[str, object] = {}

    def f(lo: float = 0.04, hi: float = 0.28, down_max: float | None = None) -> float:
        m = rng.uniform(lo, hi)
        s = rng.choice([-1.0, 1.0])
        if s < 0 and down_max is not None:
            m = min(m, down_max)
        return float(1.0 + s * m)

    def triple(name: str, **kw) -> tuple[float, float, float]:
        fs = [f(**kw) for _ in range(3)]
        factors[name] = fs
        return tuple(float(v * k) for v, k in zip(getattr(base, name), fs))

    def scalar(name: str, **kw) -> float:
        k = f(**kw)
        factors[name] = k
        return float(getattr(base, name) * k)

    changes = {
        "kp": triple("kp"),
        "kd": triple("kd"),
        "torque_limit": triple("torque_limit", down_max=0.06),
        "armature": triple("armature"),
        "body_mass": scalar("body_mass", hi=0.15),
        "leg_mass": scalar("leg_mass"),
        "foot_friction": scalar("foot_friction", hi=0.2),
        "ground_friction": scalar("ground_friction", hi=0.2),
        "encoder_resolution": triple("encoder_resolution"),
        "rate_filter_hz": scalar("rate_filter_hz"),
        "mocap_position_std": scalar("mocap_position_std"),
        "mocap_orientation_std": scalar("mocap_orientation_std"),
    }
    gap = dataclasses.replace(base, name="zoo28-gap", **changes)
    save_twin(Twin(gap, {"created_by": "benchmarks/blind_zoo/zoos/zoo28/make_gap_robot.py",
                         "base_robot": "measured", "seed": SEED,
                         "factors": factors}), HERE / "gap_robot.json")
    print({k: v for k, v in config_to_dict(gap).items() if k in changes})


if __name__ == "__main__":
    main()
