"""Re-simulate a few recorded moves under every family of the diagnosis's library and print
one SHA-256 over every output, with the seconds the re-simulations took.

Run it with two checkouts on the same recording and robot: equal digests mean the two codes
give the same re-simulations, bit for bit; the seconds compare their speed. Each family is
tried at its probe magnitude (a vector family along the unit diagonal of its components) at
its first and last scope, on ``--moves`` TrainPool moves spread over the recording, in the
diagnosis's ``segs`` mode (the four 1 s segments from measured starts), in this process.

    OPENBLAS_NUM_THREADS=1 PYTHONPATH=CHECKOUT .venv/bin/python -P \\
        benchmarks/diagnose_speed/step_python/resim_identity.py ROBOT DATASET
"""
from __future__ import annotations

import argparse
import hashlib
import time

import numpy as np

from littledog_mlsim.data.dataset import load_moves
from littledog_mlsim.diagnose.families import FAMILIES
from littledog_mlsim.diagnose.physical.channels import seg_starts
from littledog_mlsim.diagnose.physical.resim import Move, init_worker, simulate
from littledog_mlsim.robot.sim import InitialState
from littledog_mlsim.robot.twin import robot_config_from


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("robot", help="a robot name (measured, nominal) or a twin file")
    ap.add_argument("data", help="a recorded dataset directory")
    ap.add_argument("--moves", type=int, default=3)
    a = ap.parse_args()
    robot = robot_config_from(a.robot)
    recs = load_moves(a.data, split="train")
    recs = recs[::max(1, len(recs) // a.moves)][:a.moves]
    moves = []
    for r in recs:
        ss = seg_starts(r.cmd.shape[0])
        moves.append(Move(r.name, r.move_type, r.cmd, {k: InitialState.at(r, k) for k in ss}, ss))
    init_worker(robot, moves)
    digest, runs = hashlib.sha256(), 0
    t0 = time.perf_counter()
    for name, spec in FAMILIES.items():
        scopes = list(spec.scopes())
        nc = len(spec.components)
        for scope in dict.fromkeys(scopes[:1] + scopes[-1:]):
            if nc > 1:
                par = spec.params_from(spec.probe, np.ones(nc) / np.sqrt(nc))
            else:
                par = spec.params_from(spec.neutral + spec.probe, None)
            for i in range(len(moves)):
                out = simulate((i, [(name, scope, par)], "segs"))
                for k in sorted(out):
                    digest.update(np.ascontiguousarray(out[k]).tobytes())
                runs += 1
    seconds = time.perf_counter() - t0
    print(f"{runs} re-simulations, sha256 {digest.hexdigest()}, {seconds:.1f} s")


if __name__ == "__main__":
    main()
