"""Write zoo17's gap robot (``gap_robot.json``): the ``measured`` robot with many physical
parameters moved, in mixed directions, by a few per cent to a few tens of per cent -- another
unit of the same robot on another floor. SEALED (holds the gap robot's values).

    OPENBLAS_NUM_THREADS=1 .venv/bin/python benchmarks/blind_zoo/zoos/zoo17/make_gap_robot.py
"""
from __future__ import annotations

import dataclasses
from pathlib import Path

import numpy as np

from littledog_mlsim.robot.config import robot_config
from littledog_mlsim.robot.twin import Twin, save_twin

SEED = 170_417
HERE = Path(__file__).resolve().parent

#: field -> (smallest, largest) relative change; the sign is drawn per value
RANGES = {
    "kp": (0.04, 0.14),
    "kd": (0.06, 0.22),
    "torque_limit": (0.03, 0.09),
    "armature": (0.10, 0.30),
    "body_mass": (0.03, 0.09),
    "leg_mass": (0.06, 0.16),
    "foot_friction": (0.10, 0.28),
    "ground_friction": (0.08, 0.25),
    "rate_filter_hz": (0.10, 0.30),
    "mocap_position_std": (0.15, 0.45),
    "mocap_orientation_std": (0.10, 0.35),
}
#: the knee's torque limit (a soft, often saturated servo) moves up only: a lower one would
#: make the open-loop trot fall on some moves
UP_ONLY = {("torque_limit", 2)}


def gap_robot() -> tuple[dict, dict]:
    rng = np.random.default_rng(SEED)
    base = robot_config("measured")
    changes: dict = {}
    fields: dict = {}
    for name, (lo, hi) in RANGES.items():
        v = getattr(base, name)
        vals = list(v) if isinstance(v, tuple) else [v]
        out = []
        for i, x in enumerate(vals):
            mag = rng.uniform(lo, hi)
            sign = 1.0 if (name, i) in UP_ONLY else float(rng.choice([-1.0, 1.0]))
            out.append(round(float(x) * (1.0 + sign * mag), 7))
        fields[name] = tuple(out) if isinstance(v, tuple) else out[0]
        changes[name] = [round(b / a - 1.0, 4) for a, b in zip(vals, out)]
    # a set-point latency of the other unit's bus (the measured robot has none)
    fields["command_delay_ms"] = round(float(rng.uniform(2.0, 6.0)), 2)
    changes["command_delay_ms"] = fields["command_delay_ms"]
    return dataclasses.asdict(dataclasses.replace(base, **fields)), changes


def main() -> None:
    cfg, changes = gap_robot()
    config = dataclasses.replace(robot_config("measured"),
                                 **{k: v for k, v in cfg.items() if k != "name"})
    save_twin(Twin(config, {"created_by": "zoo17 make_gap_robot.py", "seed": SEED,
                            "base_robot": "measured", "relative_changes": changes}),
              HERE / "gap_robot.json")
    print(changes)


if __name__ == "__main__":
    main()
