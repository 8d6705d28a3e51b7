"""Time one of calibrate's re-simulations and save its residuals, for the inlined-PD probe.

    OPENBLAS_NUM_THREADS=1 PYTHONPATH=CHECKOUT .venv/bin/python \
        benchmarks/calibrate/inline_pd_probe/compare.py --data REFERENCE --twin TWIN.json \
        --save OUT.npy [--repeat 5]

Runs ``twin_residuals`` on the first two TrainPool moves per type of REFERENCE (22 moves) with
the twin's robot at stride 40, horizons (1, 10) and smoothed starting states, in this one
process: once to build the starting states, then ``--repeat`` times timed. Prints the wall
times and saves the last residuals flattened, so that two checkouts (with and without
``inline_pd.patch``) can be compared bit for bit (README).
"""
from __future__ import annotations

import argparse
import os
import sys
import time
from dataclasses import replace

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

import numpy as np  # noqa: E402


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--data", required=True)
    ap.add_argument("--twin", required=True)
    ap.add_argument("--save", required=True)
    ap.add_argument("--repeat", type=int, default=5)
    a = ap.parse_args()
    from littledog_mlsim.data.dataset import load_moves
    from littledog_mlsim.robot import baseline as bl
    from littledog_mlsim.robot import twin_fit as tf
    from littledog_mlsim.robot.twin import load_twin

    config = replace(load_twin(a.twin).robot, sensor_noise=False)
    train = bl.first_per_type(load_moves(a.data, "train"), 2)
    args = (40, (1, 10), "smoothed")
    with bl.move_pool(train, 1, None) as pool:
        tf.twin_residuals(pool, config, *args)
        walls = []
        for _ in range(a.repeat):
            t0 = time.perf_counter()
            raw = tf.twin_residuals(pool, config, *args)
            walls.append(time.perf_counter() - t0)
    np.save(a.save, np.concatenate([m.reshape(-1) for m in raw]))
    print(a.save, [round(w, 3) for w in walls])
    return 0


if __name__ == "__main__":
    sys.exit(main())
