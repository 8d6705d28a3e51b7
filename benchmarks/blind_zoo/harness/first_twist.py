"""The first measured twist of a dataset's moves, and how re-simulations from it end.

Prints, per move, the measured body twist at measurement 0 and 1 (a spurious twist at 0 shows
a start that the recording's first finite difference got wrong), then the final (x, y) error
of the move re-simulated with each given effects file, once from the measured state 0 and once
from the home stance (as ``record`` starts it). This is how LOG.md's z04 numbers ("After
zoo4") were measured:

    OPENBLAS_NUM_THREADS=1 .venv/bin/python benchmarks/blind_zoo/harness/first_twist.py \\
        WORK/effects/z04 F_00,L_00,BL_00 benchmarks/blind_zoo/zoos/zoo4/effects/z04.yaml OURS.yaml

with OURS.yaml a ``littledog_mlsim.robot.effects:GroundTilt`` of the same slope and direction.
"""
from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np

from littledog_mlsim.data.bags import read_bag
from littledog_mlsim.robot.effects import load_effects
from littledog_mlsim.robot.sim import InitialState, simulate_move


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("data", help="dataset directory")
    ap.add_argument("moves", help="comma-separated move names, e.g. F_00,L_00")
    ap.add_argument("effects", nargs="*", help="effects YAML files to re-simulate with")
    a = ap.parse_args()
    for name in a.moves.split(","):
        rec = read_bag(Path(a.data) / name)
        s0, s1 = (InitialState.from_recording(rec, k) for k in (0, 1))
        print(f"{name}: twist at 0: lin {np.round(s0.linear_velocity, 3)} ang "
              f"{np.round(s0.angular_velocity, 3)}; at 1: lin {np.round(s1.linear_velocity, 3)} "
              f"ang {np.round(s1.angular_velocity, 3)}")
        for path in [None] + a.effects:
            for start, initial in (("measured 0", s0), ("home", None)):
                effects = [] if path is None else load_effects(path)
                sim = simulate_move(rec.cmd, effects=effects, initial=initial,
                                    move_type=rec.move_type, seed=0)
                err = np.linalg.norm(sim.position[-1, :2] - rec.position[-1, :2])
                print(f"  {path or 'no effect'} from {start}: final (x, y) error "
                      f"{1000 * err:.1f} mm")


if __name__ == "__main__":
    main()
