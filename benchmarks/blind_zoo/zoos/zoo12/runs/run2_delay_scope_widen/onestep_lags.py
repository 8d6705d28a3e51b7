"""The one-step screen's command-lag candidates on one dataset (zoo12 run2's README, "Question").

Runs the learned route's one-step loop (``select_effects``, the default library with the side
and leg lags, the ``measured`` baseline, seed 0) on a dataset's TrainPool and prints, for the
first round, every command-lag candidate's total held-out gain and significance, and for the
best lag of every scope screened at that lag, the per-joint gain (q + dq) and the body's:

    OPENBLAS_NUM_THREADS=1 .venv/bin/python \\
        benchmarks/blind_zoo/zoos/zoo12/runs/run2_delay_scope_widen/onestep_lags.py DATA [DATA ...]
"""
from __future__ import annotations

import sys
import time

import numpy as np

from littledog_mlsim.data.dataset import load_moves
from littledog_mlsim.diagnose.candidates import default_library, measured_robot_features
from littledog_mlsim.diagnose.selection import SearchModel, select_effects
from littledog_mlsim.layout import STATE_NAMES
from littledog_mlsim.models.feature_library import JOINT_NAMES


def main(paths: list[str]) -> None:
    for data in paths:
        t0 = time.perf_counter()
        sel = select_effects(load_moves(data, "train"), measured_robot_features(),
                             default_library(), search=SearchModel(seed=0), max_rounds=2)
        print(f"## {data.rstrip('/').split('/')[-1]}: accepted "
              f"{[s.label for s in sel.accepted]} in {time.perf_counter() - t0:.0f} s")
        lags = sorted((s for s in sel.rounds[0].scores if s.augmentation.name == "command_lag"),
                      key=lambda s: -s.total_gain)
        for s in lags:
            print(f"{s.label:40s} gain {s.total_gain:+.3f} max {s.max_gain:.3f} "
                  f"p {s.p_value:.2g} significant {s.significant} material {s.material}")
        lag = lags[0].augmentation.lag
        for s in (x for x in lags if x.augmentation.lag == lag):
            g = np.asarray(s.gain)
            body = sum(g[i] for i, n in enumerate(STATE_NAMES) if not n.startswith(("q_", "dq_")))
            print(s.label, f"body {body:+.3f}", " ".join(
                f"{j}:{g[STATE_NAMES.index('q_' + j)] + g[STATE_NAMES.index('dq_' + j)]:+.3f}"
                for j in JOINT_NAMES))


if __name__ == "__main__":
    main(sys.argv[1:])
