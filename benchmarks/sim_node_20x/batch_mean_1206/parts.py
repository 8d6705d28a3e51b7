"""Where the batched mean's time goes: ``LGPR._batch_mean``'s parts timed one by one (thread CPU
time) on the queries of 300 steps of the batched simulator (``alternate.recorded_queries``: the
robots of ``run.py``'s batch phase, std off, gated alpha-PROJ).

    OPENBLAS_NUM_THREADS=1 .venv/bin/python benchmarks/sim_node_20x/batch_mean_1206/parts.py \
        --model MODEL --data DATA --n 64

The parts repeat ``_batch_mean``'s code with a clock between them (keep the two the same); each
step's result is checked equal to the model's own batched mean.
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
    ``spent``."""
    from littledog_mlsim.models.clustering import nearest_rows
    from littledog_mlsim.models.kernel_rows import before_exp, scale_blocks

    clock = [time.thread_time_ns()]

    def tick(part: str) -> None:
        now = time.thread_time_ns()
        spent[part] += now - clock[0]
        clock[0] = now
    labels = nearest_rows(X, est.centers_)
    tick("labels")
    st = est._stacked
    ns, p = X.shape[0], est.n_outputs_
    order = np.argsort(labels, kind="stable")
    lab = labels[order]
    cut = np.flatnonzero(np.diff(lab)) + 1
    r0 = np.concatenate([[0], cut]).astype(np.int64)
    r1 = np.concatenate([cut, [ns]]).astype(np.int64)
    cl = lab[r0]
    A = (X[order] - st["shift"][lab]) * st["inv_l"][lab]
    aa = np.einsum("ij,ij->i", A, A)
    width = st["width"][cl]
    size = (r1 - r0) * width
    b1 = np.cumsum(size)
    b0 = b1 - size
    K = np.empty(int(b1[-1]))
    mean = np.empty((ns, p))
    tick("prep")
    for b in range(cl.shape[0]):
        np.matmul(A[r0[b]:r1[b]], est._rows[cl[b]][2],
                  out=K[b0[b]:b1[b]].reshape(r1[b] - r0[b], width[b]))
    tick("gemm1")
    before_exp(K, b0, r0, r1, width, st["zz_start"][cl], aa, st["zz"])
    tick("before")
    np.exp(K, out=K)
    tick("exp")
    scale_blocks(K, b0, b1, st["sf2"][cl])
    tick("scale")
    for b in range(cl.shape[0]):
        np.matmul(K[b0[b]:b1[b]].reshape(r1[b] - r0[b], width[b]), est._alpha[cl[b]],
                  out=mean[r0[b]:r1[b]])
    tick("gemm2")
    mean *= est.y_std_[lab]
    mean += est.y_mean_[lab]
    out = np.empty((ns, p))
    out[order] = mean
    tick("out")
    return out


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
