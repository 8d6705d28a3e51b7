"""Nearest TrainPool state for alpha-PROJ: brute force (old default) vs the PCA-bound search.

Usage (from the repo root, in the venv):

    OPENBLAS_NUM_THREADS=1 .venv/bin/python benchmarks/projection_nn/projection_nn.py --data bags/default

TrainPool/TestPool: those of ``--data`` (a recorded dataset), or, without it, the default dataset
(20 moves per type, 14 of them TrainPool, seed 0) simulated in memory with the project's
pybullet LittleDog (no bags written). The one-step model: a linear regression
(``OneStepModel.fit(LinearRegression(), ...)`` on the TrainPool, target ``delta``), or
``--model DIR`` (a saved ``OneStepModel``).

Queries, in the normalised space of ``AlphaProjection`` (each element divided by its TrainPool
std):

1. what alpha-PROJ sees in a rollout: the model's predictions at every step of the alpha = 0.5
   rollout of all TestPool moves together (one batch of 66 per step);
2. the TestPool states plus Gaussian noise of 0.3, 0.8 and 1.5 normalised std;
3. the model's one-step predictions on the TestPool, and the TestPool states themselves;
4. i.i.d. N(0, I) points and queries in 33-D (no dominant axes: ``auto`` picks brute force; and
   with ``method="pca"`` forced, the bounds' worst case).

For each: one query (the 100 Hz node; ``--repeats`` different queries) and a batch of 66 (a
TestPool rollout step; ``--repeats / 10`` different batches), brute force vs ``method="auto"``
(the new default, here the PCA-bound search), wall time per call, median and p90 over 3 rounds;
in each round each method runs all the queries in a row, the order alternating between rounds,
so that load from other jobs on the shared cores hits both alike. And whether both return the
same indices (they must: both are exact, with the naive loop's tie rule).

Then the whole alpha-PROJ rollout (alpha = 0.5) of the model over all TestPool moves, per method
(``--rollouts`` runs, alternating; median wall and CPU time, and x real time = simulated seconds
/ wall seconds), plus the rollout without projection (the model's own share).

All of it ``--runs`` times (default 3); the report gives the medians over the runs, the JSON also
each run. Writes ``benchmarks/projection_nn/projection_nn.json`` and ``.md`` (``--out`` to write them
elsewhere).
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
from littledog_mlsim.layout import CONTROL_DT, MOVE_TYPES, N_STATE
from littledog_mlsim.models.lr import LinearRegression
from littledog_mlsim.models.onestep import OneStepModel
from littledog_mlsim.projection import NearestNeighbour
from littledog_mlsim.rollout.simulate import prepare_test_moves, rollout_moves

HERE = Path(__file__).resolve().parent
METHODS = ("brute", "auto")
BATCH = 66


def simulated_moves(moves_per_type: int, split_at: int, seed: int = 0):
    """(train recordings, test recordings) of the default dataset, simulated in memory."""
    from littledog_mlsim.gait.trot import sample_trot_params, trot_commands
    from littledog_mlsim.apps.record import plan_jobs
    from littledog_mlsim.robot.sim import simulate_move

    train, test = [], []
    for job in plan_jobs(moves_per_type, MOVE_TYPES, seed):
        gait_seed, robot_seed = job.seeds()
        params = sample_trot_params(job.move_type, np.random.default_rng(gait_seed))
        rec = simulate_move(trot_commands(params), robot="measured", seed=robot_seed,
                            name=job.name, move_type=job.move_type)
        (train if job.index < split_at else test).append(rec)
    return train, test


def time_blocks(nns: dict[str, NearestNeighbour], args: list, rounds: int = 3
                ) -> dict[str, np.ndarray]:
    """Wall time [ms] of each call of each method: ``rounds`` rounds, in each every method runs
    all ``args`` in a row (as in a rollout: its own data stays in the caches), the order of the
    methods alternating between rounds, so that load from other jobs hits both alike."""
    names = list(nns)
    ts = {name: [] for name in names}
    for r in range(rounds):
        for name in (names if r % 2 == 0 else names[::-1]):
            nns[name].query(args[0])                     # warm-up
            for a in args:
                t0 = time.perf_counter()
                nns[name].query(a)
                ts[name].append((time.perf_counter() - t0) * 1e3)
    return {name: np.array(v) for name, v in ts.items()}


def bench(nns: dict[str, NearestNeighbour], singles: list, batches: list) -> dict:
    """Median/p90 [ms] per method for single queries and batches, and the answer check."""
    t1, tb = time_blocks(nns, singles), time_blocks(nns, batches)
    out: dict = {"n_single": len(singles), "n_batches": len(batches)}
    for name in nns:
        out[name] = {"single_median_ms": float(np.median(t1[name])),
                     "single_p90_ms": float(np.percentile(t1[name], 90)),
                     "single_max_ms": float(t1[name].max()),
                     f"batch_{BATCH}_median_ms": float(np.median(tb[name])),
                     f"batch_{BATCH}_p90_ms": float(np.percentile(tb[name], 90))}
    a, b = METHODS
    out["single_speedup"] = float(np.median(t1[a]) / np.median(t1[b]))
    out["batch_speedup"] = float(np.median(tb[a]) / np.median(tb[b]))
    Q = np.vstack(singles + batches)
    idx = {name: nn.query(Q) for name, nn in nns.items()}
    out["same_indices"] = bool(np.array_equal(idx[a], idx[b]))
    P = nns[a].points
    out["median_nn_distance"] = float(np.median(np.sqrt(((Q - P[idx[a]]) ** 2).sum(1))))
    return out


def median_of_runs(runs: list):
    """Element-wise over equally shaped results: median of numbers, all() of booleans."""
    first = runs[0]
    if isinstance(first, dict):
        return {k: median_of_runs([r[k] for r in runs]) for k in first}
    if isinstance(first, (bool, np.bool_)):
        return bool(all(runs))
    if isinstance(first, (int, float)):
        return float(np.median(runs))
    return first


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--data", help="recorded dataset directory (default: simulate in memory)")
    ap.add_argument("--model", help="saved OneStepModel directory (default: fit an LR)")
    ap.add_argument("--moves-per-type", type=int, default=20)
    ap.add_argument("--repeats", type=int, default=300)
    ap.add_argument("--rollouts", type=int, default=5, help="rollouts per method and run")
    ap.add_argument("--runs", type=int, default=3,
                    help="repeat all timings this often; the report gives medians over runs")
    ap.add_argument("--alpha", type=float, default=0.5)
    ap.add_argument("--out", default=str(HERE), help="directory for projection_nn.json/.md")
    a = ap.parse_args()

    t0 = time.perf_counter()
    if a.data:
        train, test = load_moves(a.data, "train"), load_moves(a.data, "test")
        source = f"dataset `{a.data}`"
    else:
        train, test = simulated_moves(a.moves_per_type, n_train(a.moves_per_type))
        source = (f"default dataset simulated in memory ({a.moves_per_type} moves/type, seed 0, "
                  "robot measured)")
    X_train, Y_train, _ = features_responses(train)
    X_test, Y_test, _ = features_responses(test)
    moves = prepare_test_moves(test)
    if a.model:
        model = OneStepModel.load(a.model)
        model_note = f"saved OneStepModel `{a.model}` ({model.method})"
    else:
        model = OneStepModel.fit(LinearRegression(), X_train, Y_train)
        model_note = "linear regression fitted on the TrainPool (OneStepModel, target delta)"
    if model.train_states is None or not np.array_equal(model.train_states, Y_train):
        print("note: the model's TrainPool states differ from the dataset's; using the model's")
    prep_s = time.perf_counter() - t0

    proj = {m: model.projection("alpha", alpha=a.alpha, nn_method=m) for m in METHODS}
    scale = proj["auto"].scale
    Pn = proj["auto"].train_states / scale
    build_ms = {}
    for m in METHODS:
        t = time.perf_counter()
        NearestNeighbour(Pn, method=m).prepare()
        build_ms[m] = (time.perf_counter() - t) * 1e3
    nns = {m: p.nn.prepare() for m, p in proj.items()}

    # what alpha-PROJ sees in the rollout: capture the batches passed to the search
    seen: list[np.ndarray] = []
    nn_auto = nns["auto"]
    plain_query = nn_auto.query
    nn_auto.query = lambda X, method=None: (seen.append(np.array(X)), plain_query(X, method))[1]
    rollout_moves(model, moves, proj["auto"])
    del nn_auto.query
    steps = [b for b in seen if b.shape[0] == BATCH]

    rng = np.random.default_rng(0)
    n_b = max(3, a.repeats // 10)

    def singles_of(Q):
        return [Q[i:i + 1] for i in rng.choice(Q.shape[0], a.repeats, replace=False)]

    def batches_of(Q):
        return [Q[rng.choice(Q.shape[0], BATCH, replace=False)] for _ in range(n_b)]

    Tn = Y_test / scale
    sets = {}
    rollout_q = np.vstack(seen)
    sets[f"alpha rollout: the LR model's predictions at each step ({len(steps)} steps of "
         f"{BATCH} moves)"] = (singles_of(rollout_q),
                               [steps[i] for i in np.linspace(0, len(steps) - 1, n_b).astype(int)])
    for s in (0.3, 0.8, 1.5):
        Q = Tn + s * rng.standard_normal(Tn.shape)
        sets[f"TestPool states + N(0, {s}^2) per normalised element"] = (singles_of(Q),
                                                                       batches_of(Q))
    Q = model.predict(X_test) / scale
    sets["LR one-step predictions on the TestPool"] = (singles_of(Q), batches_of(Q))
    sets["TestPool states (what a perfect model predicts)"] = (singles_of(Tn), batches_of(Tn))
    G = rng.standard_normal(Pn.shape)
    Gq = rng.standard_normal((20 * BATCH, N_STATE))
    gs, gb = singles_of(Gq)[:max(30, a.repeats // 5)], batches_of(Gq)[:5]
    worst = "i.i.d. N(0, I) points and queries in 33-D (no dominant axes): auto = brute here"
    forced = "same, with `method=\"pca\"` forced in place of auto (the bounds' worst case)"
    iid = {worst: ({m: NearestNeighbour(G, method=m).prepare() for m in METHODS}, gs, gb),
           forced: ({"brute": NearestNeighbour(G, method="brute"),
                     "auto": NearestNeighbour(G, method="pca").prepare()}, gs, gb)}
    sim_s = sum(m.n_steps for m in moves) * CONTROL_DT
    projs = {**proj, "none": model.projection("none")}
    per_run = []
    for run in range(a.runs):
        res: dict = {"queries": {}, "load_average_1min": {"start": os.getloadavg()[0]}}
        for name, (singles, batches) in sets.items():
            res["queries"][name] = bench(nns, singles, batches)
        for name, (nn2, singles, batches) in iid.items():
            res["queries"][name] = bench(nn2, singles, batches)
        res["load_average_1min"]["after_queries"] = os.getloadavg()[0]
        # the whole rollout, per method (alternating), and without projection
        times: dict[str, list] = {m: [] for m in projs}
        preds = {}
        for r in range(a.rollouts):
            for m in (list(projs) if r % 2 == 0 else list(projs)[::-1]):
                w, c = time.perf_counter(), time.process_time()
                preds[m] = np.stack(rollout_moves(model, moves, projs[m]))
                times[m].append((time.perf_counter() - w, time.process_time() - c))
        roll = {"same_predictions": bool(np.array_equal(preds["brute"], preds["auto"]))}
        for m, v in times.items():
            v = np.array(v)
            roll[m] = {"wall_median_s": float(np.median(v[:, 0])),
                       "wall_min_s": float(v[:, 0].min()),
                       "cpu_median_s": float(np.median(v[:, 1])),
                       "x_real_time": float(sim_s / np.median(v[:, 0]))}
        res["rollout"] = roll
        res["load_average_1min"]["end"] = os.getloadavg()[0]
        per_run.append(res)
        print(f"run {run + 1}/{a.runs}:", json.dumps(res), flush=True)
    results = {"n_train_states": int(Pn.shape[0]), "build_ms": build_ms,
               **median_of_runs(per_run), "per_run": per_run}
    results["rollout"].update(n_moves=len(moves), simulated_s=sim_s, runs=a.rollouts)
    load = results.pop("load_average_1min")
    load["runs"] = [r["load_average_1min"] for r in per_run]

    args = " ".join(sys.argv[1:])
    command = f"OPENBLAS_NUM_THREADS=1 .venv/bin/python benchmarks/projection_nn/projection_nn.py {args}".strip()
    meta = {"command": command, "source": source, "model": model_note, "prepare_s": prep_s,
            "repeats": a.repeats, "batch": BATCH, "alpha": a.alpha, "runs": a.runs,
            "cores": os.cpu_count(),
            "openblas_threads": os.environ.get("OPENBLAS_NUM_THREADS"),
            "load_average_1min": load, "python": platform.python_version(),
            "numpy": np.__version__, "scipy": scipy.__version__, "date": time.strftime("%Y-%m-%d")}
    out_dir = Path(a.out)
    (out_dir / "projection_nn.json").write_text(json.dumps({**meta, **results}, indent=2) + "\n")
    (out_dir / "projection_nn.md").write_text(report(meta, results) + "\n")
    print(report(meta, results))
    return 0


def report(meta: dict, results: dict) -> str:
    B = meta["batch"]
    ld = meta["load_average_1min"]
    roll = results["rollout"]
    lines = [
        "# Nearest TrainPool state for alpha-PROJ: brute force vs PCA bounds", "",
        f"Command: `{meta['command']}`", "",
        f"Machine: {meta['cores']} shared cores, OPENBLAS_NUM_THREADS="
        f"{meta['openblas_threads']}, Python {meta['python']}, NumPy {meta['numpy']}, SciPy "
        f"{meta['scipy']}, {meta['date']}. All timings were repeated in {meta['runs']} runs; "
        "the tables give the median over the runs (`projection_nn.json` has each run). 1-min "
        "load average per run (start / after the search timings / end): "
        + "; ".join(f"{r['start']:.1f} / {r['after_queries']:.1f} / {r['end']:.1f}"
                    for r in ld["runs"])
        + ". Other jobs shared the two cores throughout, so absolute times are inflated and "
        "the p90s noisy; both methods ran on the same queries, in alternating rounds.", "",
        f"Data: {meta['source']}: TrainPool {results['n_train_states']} states in 33-D, searched "
        f"in the normalised space of `AlphaProjection`; {roll['n_moves']} TestPool moves. "
        f"Model: {meta['model']}.", "",
        f"Build: brute {results['build_ms']['brute']:.0f} ms, auto (PCA index) "
        f"{results['build_ms']['auto']:.0f} ms.", "",
        "## Search times", "",
        f"`brute`: the old default (a GEMM over all points). `auto`: the new default, here the "
        f"PCA-bound search (`method=\"pca\"`). One query: {meta['repeats']} different queries "
        f"(fewer for the i.i.d. case); batch of {B}: different batches; wall time per call, "
        "median / p90 over 3 rounds (in each, one method runs all the queries in a row, then "
        "the other; order alternating), then the median over the runs. "
        "Same indices: whether both methods returned identical indices for every query timed "
        "(both are exact, ties to the smallest index).", "",
        f"| queries | median NN distance | brute 1 query [ms] | auto 1 query [ms] | speed-up | "
        f"brute {B} [ms] | auto {B} [ms] | speed-up | same indices |",
        "|---|---|---|---|---|---|---|---|---|"]
    for name, r in results["queries"].items():
        b, p = r["brute"], r["auto"]
        lines.append(
            f"| {name} | {r['median_nn_distance']:.2f} | {b['single_median_ms']:.3f} / "
            f"{b['single_p90_ms']:.3f} | {p['single_median_ms']:.3f} / {p['single_p90_ms']:.3f} "
            f"| {r['single_speedup']:.1f}x | {b[f'batch_{B}_median_ms']:.2f} / "
            f"{b[f'batch_{B}_p90_ms']:.2f} | {p[f'batch_{B}_median_ms']:.2f} / "
            f"{p[f'batch_{B}_p90_ms']:.2f} | {r['batch_speedup']:.1f}x | {r['same_indices']} |")
    lines += [
        "", "## Whole alpha-PROJ rollout", "",
        f"All {roll['n_moves']} TestPool moves rolled out together (one model call and one "
        f"search per step), alpha = {meta['alpha']}, {roll['simulated_s']:.1f} s simulated; "
        f"{roll['runs']:.0f} rollouts per method in each run, alternating; median (wall also "
        "min) within a run, then the median over the runs.", "",
        "| projection search | wall [s] median (min) | CPU [s] median | x real time |",
        "|---|---|---|---|"]
    for m, label in (("brute", "brute (old default)"), ("auto", "auto (new default)"),
                     ("none", "no projection (model and loop only)")):
        r = roll[m]
        lines.append(f"| {label} | {r['wall_median_s']:.2f} ({r['wall_min_s']:.2f}) | "
                     f"{r['cpu_median_s']:.2f} | {r['x_real_time']:.0f} |")
    lines += ["", f"Identical predicted states with both searches: {roll['same_predictions']}."]
    return "\n".join(lines)


if __name__ == "__main__":
    sys.exit(main())
