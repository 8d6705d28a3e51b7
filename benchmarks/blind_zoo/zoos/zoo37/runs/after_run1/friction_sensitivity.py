"""How a contact-rich move answers a tiny parameter change (zoo37, not blind).

The gap robot simulates the commands of the first TrainPool moves of a dataset (noise-free
sensing, one seed) with its own friction coefficients, with the ground's multiplied by
1 + 1e-12, and with the foot's and ground's coefficients exchanged for others of the same
product (pybullet combines them as a product). Per move: the largest joint-angle and body
position differences against the first.

    OPENBLAS_NUM_THREADS=1 .venv/bin/python benchmarks/blind_zoo/zoos/zoo37/runs/after_run1/friction_sensitivity.py \
        DATA benchmarks/blind_zoo/zoos/zoo37/runs/after_run1/friction_sensitivity.json

DATA: a dataset with TrainPool moves (the harness's WORK/reference, seed 287).
"""
from __future__ import annotations

import dataclasses
import json
import sys
from pathlib import Path

import numpy as np

from littledog_mlsim.data.dataset import load_moves
from littledog_mlsim.robot.sim import simulate_move
from littledog_mlsim.robot.twin import robot_config_from

GAP = Path(__file__).resolve().parents[2] / "gap_robot.json"


def main(data: str, out: str, n: int = 4) -> None:
    g = dataclasses.replace(robot_config_from(GAP), sensor_noise=False)
    prod = g.foot_friction * g.ground_friction
    variants = {"ground_x(1+1e-12)": dataclasses.replace(g, ground_friction=g.ground_friction
                                                         * (1 + 1e-12)),
                "same_product_ground_0.95": dataclasses.replace(g, foot_friction=prod / 0.95,
                                                                ground_friction=0.95)}
    rows = []
    for r in load_moves(data, "train")[:n]:
        base = simulate_move(r.cmd, robot=g, seed=1, name=r.name, move_type=r.move_type)
        row = {"move": r.name}
        for label, cfg in variants.items():
            m = simulate_move(r.cmd, robot=cfg, seed=1, name=r.name, move_type=r.move_type)
            row[label] = {"max_joint_rad": float(np.abs(m.q - base.q).max()),
                          "max_position_m": float(np.abs(m.position - base.position).max())}
        rows.append(row)
        print(json.dumps(row), flush=True)
    json.dump({"data": "WORK/reference", "rows": rows}, open(out, "w"), indent=1)


if __name__ == "__main__":
    main(sys.argv[1], sys.argv[2])
