"""LGPR.predict on a batched simulator's queries: the per-cluster loop against the batched mean,
alternating step by step in one process, and checked equal bit for bit.

    OPENBLAS_NUM_THREADS=1 .venv/bin/python benchmarks/sim_node_20x/batch_mean_1206/alternate.py \
        --model MODEL --data DATA --n 64

The simulator (``VectorLearnedSimulator``, the robots of ``run.py``'s batch phase, std off,
gated alpha-PROJ) steps 300 times and the estimator's queries of each step are kept; then, five
times over, each step's queries are predicted by the per-cluster loop (``LGPR._stacked`` set to
None) and by the batched mean, one after the other, in thread CPU time.
"""
from __future__ import annotations

import argparse
import os
import sys
import time
from pathlib import Path

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
ROOT = Path(__file__).resolve().parents[3]
sys.path.insert(0, str(ROOT))

import numpy as np  # noqa: E402

from benchmarks._common import batch_robots  # noqa: E402


def recorded_queries(model_path: str, data: str, n: int, steps: int):
    """(the LGPR, the estimator's queries of each of ``steps`` steps of the batched simulator
    over ``n`` robots): the robots of ``run.py``'s batch phase, std off, gated alpha-PROJ."""
    from littledog_mlsim.data.dataset import load_moves
    from littledog_mlsim.models.onestep import OneStepModel
    from littledog_mlsim.rollout.simulate import prepare_test_moves
    from littledog_mlsim.rollout.vector_sim import VectorLearnedSimulator

    model = OneStepModel.load(model_path)
    radius = model.gate_radius()[0]
    projection = model.projection("alpha", alpha=0.5, radius=radius)
    projection.nn.prepare()
    moves = prepare_test_moves(load_moves(data, split="test"))
    s0, u, pose0 = batch_robots(moves, n)
    sim = VectorLearnedSimulator(model, projection, s0, pose0, trust_radius=radius)
    est = model.estimator
    queries = []
    predict = est.predict

    def logged(X, return_std=False):
        queries.append(np.array(X))
        return predict(X, return_std=return_std)
    est.predict = logged
    for t in range(steps):
        sim.step(u[:, t % u.shape[1]])
    del est.predict
    return est, queries


def main() -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    p.add_argument("--model", required=True)
    p.add_argument("--data", required=True)
    p.add_argument("--n", type=int, default=64)
    p.add_argument("--steps", type=int, default=300)
    p.add_argument("--repeats", type=int, default=5)
    a = p.parse_args()
    est, queries = recorded_queries(a.model, a.data, a.n, a.steps)
    stacked = est._stacked
    loop, batch = [], []
    for _ in range(a.repeats):
        for X in queries:
            est._stacked = None
            c = time.thread_time_ns()
            m_loop = est.predict(X)
            loop.append(time.thread_time_ns() - c)
            est._stacked = stacked
            c = time.thread_time_ns()
            m_batch = est.predict(X)
            batch.append(time.thread_time_ns() - c)
            if not np.array_equal(m_loop, m_batch, equal_nan=True):
                raise SystemExit("the batched mean differs from the per-cluster loop")
    print(f"N={a.n}: LGPR.predict per step, median over {len(loop)} (alternating): loop "
          f"{np.median(loop) / 1e6:.3f} ms, batched {np.median(batch) / 1e6:.3f} ms, ratio "
          f"{np.median(loop) / np.median(batch):.2f}; equal bit for bit: yes; "
          f"load {os.getloadavg()}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
