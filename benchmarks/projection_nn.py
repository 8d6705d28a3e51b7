"""Nearest TrainPool state for alpha-PROJ: vectorised brute force (GEMM) vs cKDTree, medians.

Usage (from the repo root, in the venv):

    OPENBLAS_NUM_THREADS=1 .venv/bin/python benchmarks/projection_nn.py [--data DIR] [--repeats 300]

TrainPool states: the TrainPool of ``--data`` (a recorded dataset), or, without it, the TrainPool
of the default dataset (20 moves per type, 14 of them TrainPool, seed 0) simulated in memory with
the project's pybullet LittleDog (no bags written). Queries, in the normalised space of
``AlphaProjection``: (1) what alpha-PROJ sees in a rollout, one-step predictions of a linear
regression (fitted on the TrainPool) for the TestPool features; (2) the TestPool states themselves
(a perfect model's predictions); (3) TrainPool states plus Gaussian noise of ``--noise`` TrainPool
std per element (close to the data: the k-d tree's good case); (4) i.i.d. Gaussian points and
queries in 33-D (its worst case).

Times one query (the 100 Hz node) and a batch of ``--batch`` (a TestPool rollout step) for each
method, each call with different queries, medians (and p90); checks that both methods return
points at identical distances. Writes ``benchmarks/projection_nn.json`` and ``.md``.
"""
from __future__ import annotations

import argparse
import json
import os
import platform
import sys
import time
from pathlib import Path

import numpy as np
import scipy

from littledog_mlsim.data.dataset import features_responses, load_moves, n_train
from littledog_mlsim.layout import MOVE_TYPES, N_STATE
from littledog_mlsim.models.lr import LinearRegression
from littledog_mlsim.rollout.projection import AlphaProjection, NearestNeighbour

HERE = Path(__file__).resolve().parent


def simulated_moves(moves_per_type: int, split_at: int, seed: int = 0):
    """(train recordings, test recordings) of the default dataset, simulated in memory."""
    from littledog_mlsim.gait.trot import sample_trot_params, trot_commands
    from littledog_mlsim.record import plan_jobs
    from littledog_mlsim.robot.sim import simulate_move

    train, test = [], []
    for job in plan_jobs(moves_per_type, MOVE_TYPES, seed):
        gait_seed, robot_seed = job.seeds()
        params = sample_trot_params(job.move_type, np.random.default_rng(gait_seed))
        rec = simulate_move(trot_commands(params), robot="measured", seed=robot_seed,
                            name=job.name, move_type=job.move_type)
        (train if job.index < split_at else test).append(rec)
    return train, test


def time_calls(fn, args: list) -> np.ndarray:
    """Wall time [ms] of fn(a) for each a (after one warm-up call)."""
    fn(args[0])
    ts = np.empty(len(args))
    for k, a in enumerate(args):
        t0 = time.perf_counter()
        fn(a)
        ts[k] = time.perf_counter() - t0
    return ts * 1e3


def time_paired(nn: NearestNeighbour, args: list) -> dict[str, np.ndarray]:
    """Wall time [ms] of both methods on each query set, back to back (alternating which goes
    first), so that load from other jobs on the shared cores hits both alike."""
    methods = ("brute", "kdtree")
    for m in methods:
        nn.query(args[0], method=m)                      # warm-up
    ts = {m: np.empty(len(args)) for m in methods}
    for k, a in enumerate(args):
        for m in (methods if k % 2 == 0 else methods[::-1]):
            t0 = time.perf_counter()
            nn.query(a, method=m)
            ts[m][k] = (time.perf_counter() - t0) * 1e3
    return ts


def bench(nn: NearestNeighbour, queries: np.ndarray, batch: int, repeats: int,
          rng: np.random.Generator) -> dict:
    """Median/p90 [ms] of both methods for single queries and batches, and an answer check."""
    singles = [queries[i:i + 1] for i in rng.choice(queries.shape[0], repeats, replace=False)]
    batches = [queries[rng.choice(queries.shape[0], batch, replace=False)]
               for _ in range(max(3, repeats // 10))]
    t1, tb = time_paired(nn, singles), time_paired(nn, batches)
    out: dict = {}
    for method in ("brute", "kdtree"):
        out[method] = {"single_median_ms": float(np.median(t1[method])),
                       "single_p90_ms": float(np.percentile(t1[method], 90)),
                       "single_max_ms": float(t1[method].max()),
                       f"batch_{batch}_median_ms": float(np.median(tb[method]))}
    out["single_median_ratio_kdtree_to_brute"] = float(np.median(t1["kdtree"] / t1["brute"]))
    Q = np.vstack(batches)
    P = nn.points
    ib, ik = nn.query(Q, method="brute"), nn.query(Q, method="kdtree")
    out["same_distances"] = bool(np.array_equal(((Q - P[ib]) ** 2).sum(1),
                                                ((Q - P[ik]) ** 2).sum(1)))
    out["median_nn_distance"] = float(np.median(np.sqrt(((Q - P[ib]) ** 2).sum(1))))
    return out


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--data", help="recorded dataset directory (default: simulate in memory)")
    ap.add_argument("--moves-per-type", type=int, default=20)
    ap.add_argument("--batch", type=int, default=130)
    ap.add_argument("--repeats", type=int, default=300)
    ap.add_argument("--noise", type=float, default=0.1)
    a = ap.parse_args()

    t0 = time.perf_counter()
    if a.data:
        train, test = load_moves(a.data, "train"), load_moves(a.data, "test")
        source = f"dataset {a.data}"
    else:
        train, test = simulated_moves(a.moves_per_type, n_train(a.moves_per_type))
        source = (f"simulated in memory: default dataset ({a.moves_per_type} moves/type, seed 0, "
                  f"robot measured), TrainPool {len(train)} moves, TestPool {len(test)} moves")
    X_train, Y_train, _ = features_responses(train)
    X_test, Y_test, _ = features_responses(test)
    prep_s = time.perf_counter() - t0

    proj = AlphaProjection(Y_train, alpha=0.5)
    proj.nn.build_tree()
    t0 = time.perf_counter()
    NearestNeighbour(proj.train_states / proj.scale).build_tree()
    build_ms = (time.perf_counter() - t0) * 1e3
    rng = np.random.default_rng(0)
    lr = LinearRegression().fit(X_train, Y_train)
    queries = {
        "LR one-step predictions on the TestPool": lr.predict(X_test),
        "TestPool states (what a perfect model predicts)": Y_test,
        f"TrainPool states + N(0, {a.noise}^2) per normalised element":
            Y_train[rng.choice(Y_train.shape[0], Y_test.shape[0], replace=False)]
            + a.noise * proj.scale * rng.standard_normal(Y_test.shape),
    }
    results: dict = {"n_train_states": int(Y_train.shape[0]), "kdtree_build_ms": build_ms,
                     "queries": {}}
    for name, Q in queries.items():
        results["queries"][name] = bench(proj.nn, Q / proj.scale, a.batch, a.repeats, rng)
    G = NearestNeighbour(rng.standard_normal(Y_train.shape))
    results["queries"]["i.i.d. N(0, I) points and queries (k-d tree worst case)"] = bench(
        G, rng.standard_normal((20 * a.batch, N_STATE)), a.batch, a.repeats, rng)

    # the whole projection as the node (one state) and a TestPool rollout step (a batch) call it
    P = queries["LR one-step predictions on the TestPool"]
    t1 = time_calls(proj, [P[i:i + 1] for i in rng.choice(P.shape[0], a.repeats, replace=False)])
    tb = time_calls(proj, [P[rng.choice(P.shape[0], a.batch, replace=False)]
                           for _ in range(max(3, a.repeats // 10))])
    results["alpha_projection_call"] = {"single_median_ms": float(np.median(t1)),
                                        "single_p90_ms": float(np.percentile(t1, 90)),
                                        f"batch_{a.batch}_median_ms": float(np.median(tb))}

    args = " ".join(sys.argv[1:])
    command = f"OPENBLAS_NUM_THREADS=1 .venv/bin/python benchmarks/projection_nn.py {args}".strip()
    meta = {"command": command, "source": source, "prepare_s": prep_s, "noise_std": a.noise,
            "repeats": a.repeats, "batch": a.batch, "cores": os.cpu_count(),
            "openblas_threads": os.environ.get("OPENBLAS_NUM_THREADS"),
            "load_average_1min": os.getloadavg()[0], "python": platform.python_version(),
            "numpy": np.__version__, "scipy": scipy.__version__, "date": time.strftime("%Y-%m-%d")}
    (HERE / "projection_nn.json").write_text(json.dumps({**meta, **results}, indent=2) + "\n")

    B = a.batch
    lines = ["# Nearest TrainPool state for alpha-PROJ: brute force vs cKDTree", "",
             f"Command: `{command}`", "",
             f"Machine: {meta['cores']} shared cores, OPENBLAS_NUM_THREADS="
             f"{meta['openblas_threads']}, Python {meta['python']}, NumPy {meta['numpy']}, "
             f"SciPy {meta['scipy']}, {meta['date']}; 1-min load average at the end "
             f"{meta['load_average_1min']:.1f} (other jobs share the cores; the p90s carry that "
             "noise).",
             "",
             f"TrainPool: {source}: {results['n_train_states']} states in 33-D, searched in the "
             f"normalised space of `AlphaProjection`. cKDTree build: "
             f"{results['kdtree_build_ms']:.0f} ms.",
             f"Single query: {a.repeats} different queries, one call each (median, p90); batch of "
             f"{B}: {max(3, a.repeats // 10)} different batches (median). The two methods run "
             "back to back on each query (alternating order), so load spikes hit both alike. "
             "Both are exact and returned points at identical distances in every case below.", "",
             f"| queries | median NN distance | brute 1 query [ms] median / p90 | kd-tree 1 query "
             f"[ms] median / p90 | kd/brute 1 query, median ratio | brute {B} [ms] | "
             f"kd-tree {B} [ms] | same distances |",
             "|---|---|---|---|---|---|---|---|"]
    for name, r in results["queries"].items():
        b, k = r["brute"], r["kdtree"]
        lines.append(f"| {name} | {r['median_nn_distance']:.2f} | {b['single_median_ms']:.3f} / "
                     f"{b['single_p90_ms']:.3f} | {k['single_median_ms']:.3f} / "
                     f"{k['single_p90_ms']:.3f} | {r['single_median_ratio_kdtree_to_brute']:.2f} | "
                     f"{b[f'batch_{B}_median_ms']:.1f} | "
                     f"{k[f'batch_{B}_median_ms']:.1f} | {r['same_distances']} |")
    c = results["alpha_projection_call"]
    lines += ["", "Whole `AlphaProjection.__call__` (default method brute; limits, search, mixing) "
              f"on LR predictions: one state {c['single_median_ms']:.3f} ms median "
              f"({c['single_p90_ms']:.3f} ms p90); {B} states {c[f'batch_{B}_median_ms']:.1f} ms.",
              "", "Choice: brute force for every batch size (`NearestNeighbour(method='brute')`, "
              "the default). The k-d tree is clearly faster only for queries very close to "
              "TrainPool states. Real predictions lie at a normalised distance of about 1.3 from "
              "their nearest TrainPool state, and so do the true TestPool states (a better model "
              "does not bring the queries closer); there a single k-d tree query costs about the "
              "same as brute force at the median but has a longer tail, batches are several times "
              "slower, and far-off queries (a rollout drifting away) cost it an order of "
              "magnitude more, while brute force costs the same for every query."]
    (HERE / "projection_nn.md").write_text("\n".join(lines) + "\n")
    print("\n".join(lines))
    return 0


if __name__ == "__main__":
    sys.exit(main())
