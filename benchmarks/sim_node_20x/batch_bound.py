"""What the batched simulator's exact mean must read per step, and how fast this machine reads it.

    OPENBLAS_NUM_THREADS=1 .venv/bin/python benchmarks/sim_node_20x/batch_bound.py \
        --model MODEL --data DATA --out benchmarks/sim_node_20x/quiet/batch_bound

The batch target of issue 27 is 1,000x real time per core at N = 64 robots: 64 x 10 ms of robot
time per 0.64 ms of CPU. LGPR predicts each robot from its own cluster; the mean must stay bit
for bit, so a robot's prediction reads every training input (the cluster's Z^T, d x n) and every
weight (alpha, n x p) of its cluster. This script steps the batched simulator
(``VectorLearnedSimulator``, the same robots as ``run.py``'s batch phase, std off, gated
alpha-PROJ) for ``--steps`` steps, records which clusters each step's prediction visits and with
which queries, and then replays the steps in their order three ways, each timed in thread CPU
time per step:

1. ``read``: a BLAS dot product with ones over each visited cluster's Z^T and alpha (every
   value the exact mean needs, read once with a vectorised kernel), minus ``calls``: the same
   number of dot products of one-element arrays (the Python and NumPy call cost of the loop).
   The control ``read_hot`` makes as many reads per step of one cluster's data, which then
   stays in the caches: if the replay reads much slower than that, its time is the memory's,
   not the reader's;
2. ``predict``: the model's own per-cluster prediction (``LGPR._local``) on the recorded queries:
   the mean's whole cost without the rest of the step, as the per-cluster loop makes it;
   ``batch_predict``: the batched mean the simulator uses (``LGPR._batch_mean``, the nearest
   centres included) on each step's queries;
3. the simulator's whole step, as measured while recording.

The steps' queries are recorded at the estimator's ``predict``; each step's visits are its
clusters in increasing order with their rows in batch order, as the per-cluster loop visits
them.

Each figure is turned into the real-time factor per core it would allow alone:
N x 10 ms / time per step. The replay keeps the steps' order, so clusters that stay in the
caches from one step to the next count as they do in a rollout.
"""
from __future__ import annotations

import argparse
import json
import os
import sys
import time
from pathlib import Path

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

import numpy as np  # noqa: E402

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE.parents[1]))
from benchmarks._common import (batch_robots, pct, run_record, time_calls,  # noqa: E402
                                uptime)

CONTROL_DT_S = 0.01


def record(model_path: str, data: str, N: int, steps: int):
    """(per-step visits [(cluster, queries)], per-step queries, per-step CPU ms of the whole
    step, the LGPR). A blended LGPR is refused: its steps visit several clusters per query."""
    from littledog_mlsim.data.dataset import load_moves
    from littledog_mlsim.models.onestep import OneStepModel
    from littledog_mlsim.rollout.simulate import prepare_test_moves
    from littledog_mlsim.rollout.vector_sim import VectorLearnedSimulator

    model = OneStepModel.load(model_path)
    lgpr = model.estimator
    if not hasattr(lgpr, "_local"):
        raise SystemExit(f"{model_path}: not an LGPR model ({type(lgpr).__name__})")
    if lgpr.blend and int(lgpr.n_blend) > 1 and lgpr.n_clusters_ > 1:
        raise SystemExit(f"{model_path}: a blended LGPR; this script reads the nearest-cluster "
                         "prediction only")
    radius = model.gate_radius()[0]
    projection = model.projection("alpha", alpha=0.5, radius=radius)
    projection.nn.prepare()
    model.prepare(return_std=False)
    moves = prepare_test_moves(load_moves(data, split="test"))
    s0, u, pose0 = batch_robots(moves, N)
    T = u.shape[1]
    sim = VectorLearnedSimulator(model, projection, s0, pose0,
                                 use_variance=False, trust_radius=radius)
    for t in range(5):
        sim.step(u[:, t])
    sim.reset()
    predict = lgpr.predict
    queries: list[np.ndarray] = []

    def logged(X, return_std=False):
        queries.append(np.array(X))
        return predict(X, return_std=return_std)

    cpu = np.empty(steps)
    lgpr.predict = logged
    for t in range(steps):
        c0 = time.thread_time_ns()
        sim.step(u[:, t % T])
        cpu[t] = (time.thread_time_ns() - c0) / 1e6
    del lgpr.predict
    # each step's per-cluster visits as the per-cluster loop makes them: the rows of each
    # cluster in their order in the batch, the clusters in increasing order
    visits = []
    for X in queries:
        labels = lgpr.nearest_cluster(X)
        visits.append([(int(c), X[labels == c]) for c in np.unique(labels)])
    return visits, queries, cpu, lgpr


def replay(visits, queries, lgpr, repeats: int = 3) -> dict:
    distinct = [list({c for c, _ in step}) for step in visits]   # each step's clusters
    visited = {c for cs in distinct for c in cs}
    if any(lgpr._rows[c] is None for c in visited):
        raise SystemExit("a visited cluster has per-output kernels: this script reads the "
                         "shared-kernel form only")
    arrays = {c: (lgpr._rows[c][2].ravel(), lgpr._alpha[c].ravel()) for c in visited}
    size = {c: sum(a.nbytes for a in arrays[c]) for c in visited}
    ones = np.ones(max(a.size for pair in arrays.values() for a in pair))
    tiny = np.zeros(1)

    def timed(fn, items) -> np.ndarray:
        """Thread CPU ms of ``fn(item)`` per item, the median over ``repeats`` passes."""
        return np.median([time_calls(fn, items)[1] for _ in range(repeats)], axis=0)

    def read(cs):                # a BLAS dot with ones: a vectorised read of every value
        for c in cs:
            zt, al = arrays[c]
            np.dot(zt, ones[:zt.size])
            np.dot(al, ones[:al.size])

    def calls(cs):
        for _ in cs:
            np.dot(tiny, tiny)
            np.dot(tiny, tiny)

    def predict(step):
        for c, Xq in step:
            lgpr._local(c, Xq, False)

    def batch_predict(X):
        lgpr._batch_mean(X, lgpr.nearest_cluster(X))

    # the control: the same reads of one cluster's data again and again (in the caches), as
    # many per step as the steps visit, so the replay's time is the memory's, not the reader's
    c0 = max(visited, key=size.get)
    n_vis = [len(cs) for cs in distinct]
    return {"bytes": np.array([sum(size[c] for c in cs) for cs in distinct], dtype=float),
            "read_ms": timed(read, distinct), "calls_ms": timed(calls, distinct),
            "predict_ms": timed(predict, visits),
            "batch_predict_ms": (timed(batch_predict, queries)
                                 if getattr(lgpr, "_stacked", None) is not None
                                 else np.full(len(queries), np.nan)),
            "hot_ms": timed(read, [[c0] * n for n in n_vis]),
            "hot_bytes": np.array([n * size[c0] for n in n_vis], dtype=float),
            "clusters": np.array(n_vis, dtype=float)}


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    p.add_argument("--model", required=True, help="a paper-size LGPR model directory")
    p.add_argument("--data", required=True, help="its dataset (the TestPool moves drive it)")
    p.add_argument("--n", type=int, default=64, help="robots in the batch")
    p.add_argument("--steps", type=int, default=300)
    p.add_argument("--out", default=None, help="write OUT.json and OUT.md")
    a = p.parse_args(argv)
    doc = run_record("sim_node_20x/batch_bound.py", argv)
    doc["load_before"] = uptime()
    visits, queries, step_ms, lgpr = record(a.model, a.data, a.n, a.steps)
    r = replay(visits, queries, lgpr)
    doc["load_after"] = uptime()
    net = r["read_ms"] - r["calls_ms"]
    robot_ms = a.n * CONTROL_DT_S * 1e3

    def rtf(ms: np.ndarray) -> float:
        return float(robot_ms / np.median(ms))
    doc["result"] = {
        "N": a.n, "steps": a.steps, "clusters_per_step": pct(r["clusters"]),
        "mbytes_per_step": pct(r["bytes"] / 1e6),
        "read_ms": pct(r["read_ms"]), "calls_ms": pct(r["calls_ms"]), "read_net_ms": pct(net),
        "read_gb_per_s": float(np.median(r["bytes"]) / np.median(net) / 1e6),
        "read_hot_ms": pct(r["hot_ms"] - r["calls_ms"]),
        "read_hot_gb_per_s": float(np.median(r["hot_bytes"]) /
                                   np.median(r["hot_ms"] - r["calls_ms"]) / 1e6),
        "predict_ms": pct(r["predict_ms"]), "batch_predict_ms": pct(r["batch_predict_ms"]),
        "step_ms": pct(step_ms),
        "rtf_if_only_read": rtf(net), "rtf_if_only_predict": rtf(r["predict_ms"]),
        "rtf_if_only_batch_predict": rtf(r["batch_predict_ms"]),
        "rtf_step": rtf(step_ms), "target_ms_per_step": robot_ms / 1000.0}
    res = doc["result"]
    lines = [f"# What the exact mean reads per batched step (N = {a.n}, {a.steps} steps)", "",
             f"Command: `OPENBLAS_NUM_THREADS={doc['openblas_num_threads']} .venv/bin/python "
             f"{doc['command']}`  ", f"Code: {doc['git']}; date {doc['date']}; load before "
             f"`{doc['load_before']}`, after `{doc['load_after']}`", "",
             "| per step | median | p99 |", "|---|---|---|"]
    for key, name in [("clusters_per_step", "clusters visited"),
                      ("mbytes_per_step", "MB of Z^T and alpha in them"),
                      ("read_net_ms", "reading them once [ms] (calls subtracted)"),
                      ("calls_ms", "the loop's calls alone [ms]"),
                      ("read_hot_ms", "as many reads of one cluster's data, in the caches "
                       "[ms] (calls subtracted)"),
                      ("predict_ms", "the per-cluster predictions [ms]"),
                      ("batch_predict_ms", "the batched mean, labels included [ms]"),
                      ("step_ms", "the whole batched step [ms]")]:
        lines.append(f"| {name} | {res[key]['p50']:.3f} | {res[key]['p99']:.3f} |")
    lines += ["", f"Read bandwidth: {res['read_gb_per_s']:.1f} GB/s over the steps' clusters, "
              f"{res['read_hot_gb_per_s']:.1f} GB/s over one cluster's data in the caches. "
              f"The target (1,000x at "
              f"N = {a.n}) allows {res['target_ms_per_step']:.2f} ms per step; alone, the read "
              f"would allow {res['rtf_if_only_read']:.0f}x, the predictions "
              f"{res['rtf_if_only_predict']:.0f}x, the batched mean "
              f"{res['rtf_if_only_batch_predict']:.0f}x, and the whole step gives "
              f"{res['rtf_step']:.0f}x real time per core."]
    text = "\n".join(lines) + "\n"
    print(text)
    if a.out:
        Path(a.out + ".json").write_text(json.dumps(doc, indent=1) + "\n")
        Path(a.out + ".md").write_text(text)
    return 0


if __name__ == "__main__":
    sys.exit(main())
