"""Where the batched mean's time goes: ``LGPR._batch_mean``'s parts timed one by one (thread CPU
time) on the queries of 300 steps of the batched simulator (``alternate.recorded_queries``: the
robots of ``run.py``'s batch phase, std off, gated alpha-PROJ).

    OPENBLAS_NUM_THREADS=1 .venv/bin/python benchmarks/sim_node_20x/batch_mean_1206/parts.py \
        --model MODEL --data DATA --n 64

The parts are timed by ``_batch_mean``'s own ``tick`` hook; each step's result is checked equal
to the batched mean without it.
"""
from __future__ import annotations

import argparse
import os
import sys
import time
from pathlib import Path

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
sys.path.insert(0, str(Path(__file__).resolve().parent))
sys.path.insert(0, str(Path(__file__).resolve().parents[3]))

import numpy as np  # noqa: E402

from alternate import recorded_queries  # noqa: E402

PARTS = ("labels", "prep", "gemm1", "before", "exp", "scale", "gemm2", "out")


def timed_batch_mean(est, X: np.ndarray, spent: dict[str, int]) -> np.ndarray:
    """``est._batch_mean(X, est.nearest_cluster(X))``, its parts' thread CPU ns added to
    ``spent`` (the nearest centres as ``labels``, the rest by ``_batch_mean``'s own ``tick``)."""
    from littledog_mlsim.models.clustering import nearest_rows

    clock = [time.thread_time_ns()]

    def tick(part: str) -> None:
        now = time.thread_time_ns()
        spent[part] += now - clock[0]
        clock[0] = now
    labels = nearest_rows(X, est.centers_)
    tick("labels")
    return est._batch_mean(X, labels, tick)


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--model", required=True)
    ap.add_argument("--data", required=True)
    ap.add_argument("--n", type=int, default=64)
    ap.add_argument("--steps", type=int, default=300)
    a = ap.parse_args()
    est, queries = recorded_queries(a.model, a.data, a.n, a.steps)
    spent = dict.fromkeys(PARTS, 0)
    clusters = []
    for X in queries:
        got = timed_batch_mean(est, X, spent)
        labels = est.nearest_cluster(X)
        if not np.array_equal(got, est._batch_mean(X, labels), equal_nan=True):
            raise SystemExit("the timed parts differ from LGPR._batch_mean")
        clusters.append(len(np.unique(labels)))
    n = len(queries)
    print(f"N={a.n}, {n} steps: us per step (mean)",
          {k: round(v / n / 1e3, 1) for k, v in spent.items()},
          "; clusters per step (mean)", round(float(np.mean(clusters)), 1),
          "; load", os.getloadavg())
    return 0


if __name__ == "__main__":
    sys.exit(main())
