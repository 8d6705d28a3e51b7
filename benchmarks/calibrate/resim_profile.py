"""Where one of calibrate's re-simulations spends its time: a profile of one evaluation.

    OPENBLAS_NUM_THREADS=1 .venv/bin/python benchmarks/calibrate/resim_profile.py \
        --data REFERENCE --twin TWIN.json [--repeat 3] [--top 25] [--out OUT.txt]

One evaluation of ``calibrate``'s residual re-simulates the fitted TrainPool moves (the first
``moves_per_type`` per type, 22 here) from every ``stride``-th measured state for
``max(horizons)`` control steps (module doc 1 of ``robot/twin_fit.py``). This script runs it
in this one process (no pool, so the profile sees every call), with the twin's robot and the
stride, horizons and starting states of its report, ``--repeat`` times, and prints the wall
time per evaluation and cProfile's functions by their own time. The first evaluation also
builds the starting states (kept for the process's life), so it is timed apart.
"""
from __future__ import annotations

import argparse
import cProfile
import io
import os
import pstats
import sys
import time
from dataclasses import replace
from pathlib import Path

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
ROOT = Path(__file__).resolve().parents[2]
sys.path.insert(0, str(ROOT))


def main() -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    p.add_argument("--data", required=True)
    p.add_argument("--twin", required=True)
    p.add_argument("--repeat", type=int, default=3)
    p.add_argument("--top", type=int, default=25)
    p.add_argument("--out", default=None)
    a = p.parse_args()
    from littledog_mlsim.data.dataset import load_moves
    from littledog_mlsim.robot import baseline as bl
    from littledog_mlsim.robot import twin_fit as tf
    from littledog_mlsim.robot.twin import load_twin

    twin = load_twin(a.twin)
    st = twin.provenance["calibration"]["settings"]
    train = bl.first_per_type(load_moves(a.data, "train"), 2)
    config = replace(twin.robot, sensor_noise=False)
    args = (int(st["stride"]), tuple(st["horizons"]), st["initial_state"])
    with bl.move_pool(train, 1, None) as pool:
        t0 = time.perf_counter()
        raw = tf.twin_residuals(pool, config, *args)
        first = time.perf_counter() - t0
        prof = cProfile.Profile()
        walls = []
        for _ in range(a.repeat):
            t0 = time.perf_counter()
            prof.enable()
            tf.twin_residuals(pool, config, *args)
            prof.disable()
            walls.append(time.perf_counter() - t0)
    n_states = sum(m.shape[0] for m in raw)
    steps = n_states * max(args[1])
    buf = io.StringIO()
    pstats.Stats(prof, stream=buf).sort_stats("tottime").print_stats(a.top)
    text = (f"# One re-simulation of `{a.twin}`'s fitted moves on `{a.data}`\n\n"
            f"{len(train)} moves, {n_states} starting states, {steps} control steps per "
            f"evaluation (stride {args[0]}, horizons {list(args[1])}, {args[2]} states), one "
            f"process.\n\nfirst evaluation {first:.3f} s (builds the starting states); then "
            + ", ".join(f"{w:.3f}" for w in walls) + f" s; {1e3 * min(walls) / steps:.3f} ms "
            "per control step at the fastest.\n\ncProfile over the repeats, by own time "
            "(the profiler's overhead included):\n\n```\n" + buf.getvalue().strip() + "\n```\n")
    print(text)
    if a.out:
        Path(a.out).write_text(text)
    return 0


if __name__ == "__main__":
    sys.exit(main())
