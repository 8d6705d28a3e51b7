"""Why a set-point delay's size is hard to read through the reference's model: the held-out
one-step SSE of the column u(t - b - d) - u(t - b) over a grid of (b, d), on read zoos' delays.

    OPENBLAS_NUM_THREADS=1 .venv/bin/python benchmarks/learned_route/delay_size/centre_grid.py \
        WORK19,z06,side:right,25 WORK14,z02,leg:front_left,20 ... > OUT.txt

Each argument: a zoo's recordings (as the blind-zoo harness writes them), the effect's id, its
true scope and delay [ms]. The search model is fitted on the whole reference at the route's
start feature set (as ``delay_size.py``); b is 0 to 2 control steps, d 1 to 5 (steps of 0.5;
a fractional lag linear between neighbouring set-points). For each b, the best d and its SSE,
with the servo's columns and alone (the column and a constant). Where the SSE hardly changes
along b + d/2 = constant, the data fix the column's centre and not the delay.
"""
from __future__ import annotations

import os
import sys
import time
from pathlib import Path

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
sys.path[:0] = [str(Path(__file__).resolve().parents[3])]

import numpy as np  # noqa: E402

from littledog_mlsim.data.dataset import load_moves  # noqa: E402
from littledog_mlsim.diagnose import change as ch  # noqa: E402
from littledog_mlsim.diagnose.candidates import measured_robot_features  # noqa: E402
from littledog_mlsim.diagnose.learned import LearnedOptions, _Route  # noqa: E402
from littledog_mlsim.layout import N_STATE  # noqa: E402
from littledog_mlsim.models.feature_library import JOINT_GROUPS  # noqa: E402

BASES = (0.0, 0.5, 1.0, 1.5, 2.0)
DELAYS = tuple(np.arange(1.0, 5.01, 0.5))
TOP = 8


def main() -> None:
    opts, fs = LearnedOptions(), measured_robot_features()
    quiet = lambda s: None  # noqa: E731
    refs: dict[str, tuple] = {}
    for arg in sys.argv[1:]:
        work, eff, scope, truth = arg.split(",")
        t0 = time.perf_counter()
        if work not in refs:
            ref = _Route(load_moves(f"{work}/reference", "train"), fs, opts, quiet)
            refs[work] = (ref, ref.fit(fs, one_step=True))
        ref, (ref_model, ev_ref) = refs[work]
        route = _Route(load_moves(f"{work}/effects/{eff}", "train"), fs, opts, quiet)
        X, Y, mi = fs.features_responses(route.train)
        Xr, Yr, mir = fs.features_responses(ref.train)
        data, _ = ch._sides(route, ref, ref_model, ev_ref, fs, (X, Y, mi), (Xr, Yr, mir))
        cols = ch._columns_of(ch.scope_joints(scope))
        lag = {0: X[:, [N_STATE + j for j in JOINT_GROUPS[ch.scope_group(scope)]]]}
        for k in range(1, TOP + 1):
            hyp = ch.Hypothesis("command_delay", scope, ch._family_aug("command_delay", scope, k))
            lag[k] = data.of(hyp)[0][:, X.shape[1]:]

        def at(steps: float) -> np.ndarray:
            k = int(np.floor(steps))
            return (1.0 - (steps - k)) * lag[k] + (steps - k) * lag[min(k + 1, TOP)]

        carrier = ch.Hypothesis("command_delay", scope, ch._family_aug("command_delay", scope, 1))
        Xa, R, mia, fold = data.of(carrier)
        for alone in (False, True):
            hyp = ch.replace(carrier, alone=alone)
            best = {}
            for b in BASES:
                for d in DELAYS:
                    Xe = Xa.copy()
                    Xe[:, X.shape[1]:] = at(b + d) - at(b) + lag[0]
                    m = ch.ChangeModel(data.ref_model, fs, hyp).fit(Xe, R, fold, opts.n_folds)
                    sse = float(ch._move_sse(ch._held_out(m, Xe, R, fold, opts.n_folds), mia,
                                             route.mv.n)[:, cols].sum())
                    if b not in best or sse < best[b][1]:
                        best[b] = (d, sse)
            print(f"{eff} {scope} truth {truth} ms, {'alone' if alone else 'with the servo'}: "
                  + "; ".join(f"b={b:g}: d={10 * d:.0f} ms sse={sse:.0f}"
                              for b, (d, sse) in best.items()), flush=True)
        print(f"  ({time.perf_counter() - t0:.0f} s)", flush=True)


if __name__ == "__main__":
    main()
