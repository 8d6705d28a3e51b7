"""LGPR ablation: hyperparameters per output vs shared, warm vs cold start, blend vs nearest,
delta vs next target; nMSE on the TestPool, fit time, memory, single-query latency.

Usage (repo root; BLAS is pinned to one thread here):

    .venv/bin/python benchmarks/lgpr_ablation/lgpr_ablation.py --data DATASET [--n-train 5000] [--clusters 5]
        [--jobs 2] [--full] [--md benchmarks/lgpr_ablation/lgpr_ablation.md] [--json out.json]
        [--only NAME,NAME]
    .venv/bin/python benchmarks/lgpr_ablation/lgpr_ablation.py --md-from A.json [B.json ...] --md OUT.md
    .venv/bin/python benchmarks/lgpr_ablation/lgpr_ablation.py --time-cmd CMD ...      # wall time, peak RSS
    .venv/bin/python benchmarks/lgpr_ablation/lgpr_ablation.py --data DATASET --paced-latency MODEL [--std]
        [--blend] [--queries 1500]                                     # 100 Hz single queries

Part A fits every variant on the same random TrainPool subset (``--n-train`` points in
``--clusters`` clusters, so about 1000 points per local GP as in the paper) and scores it on the
whole TestPool. Part B (``--full``) fits the default configuration on the whole TrainPool with
1000-point clusters, as ``littledog-mlsim train --method lgpr`` does, and reports wall time and
peak memory of the whole process tree (this process plus its joblib workers, sampled every
0.1 s).

nMSE of element i = mean((pred - true)^2) / Var(true) over the TestPool one-step pairs (the
paper's Table I measure). Latency: ``OneStepModel.predict`` of one raw (45,) feature row (what
the 100 Hz node calls), over 2000 TestPool rows, after a warm-up; "batch" is the per-state cost
of predicting the whole TestPool in one call.
"""
from __future__ import annotations

import os

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
os.environ.setdefault("OMP_NUM_THREADS", "1")
os.environ.setdefault("MKL_NUM_THREADS", "1")

import argparse  # noqa: E402
import json  # noqa: E402
import platform  # noqa: E402
import shlex  # noqa: E402
import shutil  # noqa: E402
import sys  # noqa: E402
import tempfile  # noqa: E402
import threading  # noqa: E402
import time  # noqa: E402
from pathlib import Path  # noqa: E402

import numpy as np  # noqa: E402
import psutil  # noqa: E402
from threadpoolctl import threadpool_limits  # noqa: E402

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))  # benchmarks/: _common
from _common import time_calls  # noqa: E402
from littledog_mlsim.data.dataset import features_responses, load_moves  # noqa: E402
from littledog_mlsim.layout import STATE_NAMES  # noqa: E402
from littledog_mlsim.models.lgpr import LGPR, estimator_bytes  # noqa: E402
from littledog_mlsim.models.onestep import OneStepModel  # noqa: E402

GROUPS = {
    "z,roll,pitch": [0, 4, 5],
    "d_b": [1, 2, 3],
    "d_rpy": [6, 7, 8],
    "q": list(range(9, 21)),
    "dq": list(range(21, 33)),
}


class PeakRSS:
    """Peak summed RSS of this process (unless ``include_self`` is False) and all its
    descendants, sampled in a thread."""

    def __init__(self, interval: float = 0.1, include_self: bool = True) -> None:
        self.interval = interval
        self.include_self = include_self
        self.peak = 0
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._run, daemon=True)

    def _sample(self) -> int:
        me = psutil.Process()
        total = 0
        for p in ([me] if self.include_self else []) + me.children(recursive=True):
            try:
                total += p.memory_info().rss
            except psutil.Error:
                pass
        return total

    def _run(self) -> None:
        while not self._stop.is_set():
            self.peak = max(self.peak, self._sample())
            self._stop.wait(self.interval)

    def __enter__(self) -> "PeakRSS":
        self.peak = self._sample()
        self._thread.start()
        return self

    def __exit__(self, *exc) -> None:
        self._stop.set()
        self._thread.join()
        self.peak = max(self.peak, self._sample())


def nmse(Y: np.ndarray, P: np.ndarray) -> np.ndarray:
    return ((P - Y) ** 2).mean(axis=0) / Y.var(axis=0)


def latency(model: OneStepModel, X: np.ndarray, return_std: bool, n: int = 2000
            ) -> tuple[float, float, float, float]:
    """One-row predict calls: wall-clock median, p99, then this thread's CPU-time median, p99
    [ms] (CPU time leaves out preemption by other jobs on the shared machine)."""
    rows = np.random.default_rng(1).choice(X.shape[0], size=min(n, X.shape[0]), replace=False)
    for i in rows[:50]:
        model.predict(X[i], return_std=return_std)
    wall, cpu = time_calls(lambda x: model.predict(x, return_std=return_std),
                           [X[i].copy() for i in rows])
    return (float(np.median(wall)), float(np.percentile(wall, 99)),
            float(np.median(cpu)), float(np.percentile(cpu, 99)))


def score(name: str, model: OneStepModel, Xt: np.ndarray, Yt: np.ndarray,
          fit_s: float | None, peak: int | None, with_std_latency: bool = True) -> dict:
    t0 = time.perf_counter()
    P = model.predict(Xt)
    batch_s = time.perf_counter() - t0
    e = nmse(Yt, P)
    est = model.estimator
    row = {
        "name": name, "params": {k: v for k, v in est.get_params().items()
                                 if k in ("hyperparameters", "init", "n_hyperparameter_points",
                                          "max_iter", "blend", "n_blend", "blend_weights")},
        "target": model.target, "k": est.n_clusters_,
        "cluster_sizes": [int(v) for v in np.percentile(np.diff(est.offsets_), [0, 50, 100])],
        "fit_s": fit_s, "peak_rss_mb": None if peak is None else peak / 1e6,
        "iters_median": float(np.median(est.n_iter_)),
        "cluster_fit_s_median": float(np.median(est.fit_seconds_)),
        "fit_cpu_s": float(est.fit_cpu_seconds_.sum() + est.global_cpu_seconds_),
        "nmse": dict(zip(STATE_NAMES, e.tolist())),
        "nmse_mean": float(e.mean()), "nmse_median": float(np.median(e)),
        "nmse_groups": {g: float(e[i].mean()) for g, i in GROUPS.items()},
        "batch_us_per_state": batch_s / Xt.shape[0] * 1e6,
    }
    if est.blend:  # the blend needs the variance factors even for the mean: build them first
        model.prepare(return_std=True)
    row["latency_ms"] = latency(model, Xt, False)
    if with_std_latency:
        t0 = time.perf_counter()
        model.prepare(return_std=True)
        row["prepare_variance_s"] = time.perf_counter() - t0
        row["latency_std_ms"] = latency(model, Xt, True)
        Pm, Ps = model.predict(Xt, return_std=True)
        z = (Pm - Yt) / Ps
        row["std_calibration"] = float(np.median(np.mean(z * z, axis=0)))  # ~1 if calibrated
    b = estimator_bytes(est)
    row["stored_mb"] = b["stored"] / 1e6
    row["variance_cache_mb"] = b["variance_cache"] / 1e6
    print(f"  {name}: nMSE mean {row['nmse_mean']:.4f} median {row['nmse_median']:.4f} "
          f"droll {e[6]:.4f}; fit {fit_s if fit_s is None else round(fit_s, 1)} s; "
          f"latency {row['latency_ms'][0]:.3f}/{row['latency_ms'][1]:.3f} ms", flush=True)
    return row


def paced_latency(path: Path, n: int, return_std: bool, blend: bool, X: np.ndarray) -> str:
    """One-row predictions of a saved model every 10 ms (a 100 Hz node), wall and CPU time."""
    model = OneStepModel.load(path)
    if blend:
        model.estimator.blend, model.estimator.n_blend = True, 2
    model.prepare(return_std=return_std or blend)
    rows = np.random.default_rng(2).choice(X.shape[0], n)
    wall, cpu = time_calls(lambda x: model.predict(x, return_std=return_std),
                           [X[i].copy() for i in rows], pace_s=0.01)
    w, c = wall[20:], cpu[20:]
    return (f"{'mean + std' if return_std else 'mean'}{', blend of 2' if blend else ''}: wall "
            f"median {np.median(w):.3f} p99 {np.percentile(w, 99):.3f} max {w.max():.2f} ms; "
            f"CPU median {np.median(c):.3f} p99 {np.percentile(c, 99):.3f} ms; {w.size} queries; "
            f"OPENBLAS_NUM_THREADS={os.environ.get('OPENBLAS_NUM_THREADS')}, nice {os.nice(0)}, "
            f"load average {os.getloadavg()[0]:.1f}")


def fit_variant(name: str, kw: dict, X: np.ndarray, Y: np.ndarray, Xt: np.ndarray,
                Yt: np.ndarray, target: str, jobs: int) -> tuple[dict, OneStepModel]:
    print(f"fitting {name} ...", flush=True)
    with PeakRSS() as mem:
        t0 = time.perf_counter()
        model = OneStepModel.fit(LGPR(n_jobs=jobs, **kw), X, Y, target=target)
        fit_s = time.perf_counter() - t0
    return score(name, model, Xt, Yt, fit_s, mem.peak), model


# name -> (LGPR arguments beyond n_clusters/n_jobs, target); "default" = LGPR's defaults
def _v(mode: str, init: str, nh: int, it: int, target: str = "delta") -> tuple[dict, str]:
    kw = {"hyperparameters": mode, "init": init, "n_hyperparameter_points": nh, "max_iter": it}
    if nh < 1000:
        kw["n_global_points"] = max(nh, 500)
    return kw, target


VARIANTS: dict[str, tuple[dict, str]] = {
    "default (shared-warm-500-it30)": ({}, "delta"),
    "shared-cold-500-it30": _v("shared", "cold", 500, 30),
    "shared-warm-500-it100": _v("shared", "warm", 500, 100),
    "shared-cold-500-it100": _v("shared", "cold", 500, 100),
    "shared-warm-500-it10": _v("shared", "warm", 500, 10),
    "shared-cold-500-it10": _v("shared", "cold", 500, 10),
    "shared-warm-1000-it30": _v("shared", "warm", 1000, 30),
    "shared-warm-300-it30": _v("shared", "warm", 300, 30),
    "per_output-warm-300-it30": _v("per_output", "warm", 300, 30),
    "default, target next": ({}, "next"),
}
BLEND_BASE = "default (shared-warm-500-it30)"
BLENDS = [(2, "precision"), (2, "relative"), (3, "precision"), (3, "relative")]


def blend_rows(base: OneStepModel, name: str, Xt: np.ndarray, Yt: np.ndarray) -> list[dict]:
    rows = []
    est = base.estimator
    for n_blend, weights in BLENDS:
        est.blend, est.n_blend, est.blend_weights = True, n_blend, weights
        rows.append(score(f"{name}+blend{n_blend}-{weights}", base, Xt, Yt, None, None))
    est.blend, est.n_blend, est.blend_weights = False, 2, "precision"
    return rows


def lat_text(lat) -> str:
    if lat is None:
        return "-"
    return f"{lat[0]:.3f} / {lat[1]:.3f} ({lat[2]:.3f} / {lat[3]:.3f})"


def fmt(v, nd=4):
    return "-" if v is None else f"{v:.{nd}f}"


def markdown(res: dict) -> str:
    L = ["# LGPR ablation", "", "Command (repo root):", "", f"    {res['command']}", "",
         f"Machine: {res['machine']}. BLAS pinned to one thread; {res['jobs']} joblib worker "
         f"process(es) for the cluster fits. Dataset: {res['data']} ({res['data_note']}); "
         f"TrainPool {res['n_pool']} pairs, TestPool {res['n_test']} pairs (all used for nMSE). "
         "Timings are wall-clock on a shared machine where other jobs were running (1-minute "
         "load average on the 2 cores: " + "; ".join(
             f"{ld[0]:.1f} at the start, {ld[1]:.1f} at the end of run {i + 1}"
             for i, ld in enumerate(res.get("loadavgs", []))) + "), so they are noisy; "
         "\"fit CPU\" (CPU time of the cluster fits and the warm-start GP, summed over the "
         "worker processes; without k-means and bookkeeping) is the load-independent cost.", ""]

    def table(rows: list[dict], title: str) -> None:
        L.extend([f"## {title}", "",
                  "| variant | target | k (sizes min/med/max) | fit wall [s] | fit CPU [s] | "
                  "peak RSS [MB] | "
                  "iters (median) | nMSE mean | nMSE median | z,roll,pitch | d_b | d_rpy | q | "
                  "dq | droll | 1-query ms median / p99 (CPU: median / p99) | "
                  "with std, same | "
                  "batch us/state | model MB (+ var. cache) |",
                  "|" + "---|" * 19])
        for r in rows:
            g = r["nmse_groups"]
            sizes = "/".join(map(str, r["cluster_sizes"]))
            lat = r["latency_ms"]
            lat_s = r.get("latency_std_ms")
            L.append(
                f"| {r['name']} | {r['target']} | {r['k']} ({sizes}) | {fmt(r['fit_s'], 1)} | "
                f"{fmt(r['fit_cpu_s'] if r['fit_s'] is not None else None, 1)} | "
                f"{fmt(r['peak_rss_mb'], 0)} | {r['iters_median']:.0f} | {r['nmse_mean']:.4f} | "
                f"{r['nmse_median']:.4f} | {g['z,roll,pitch']:.4f} | {g['d_b']:.4f} | "
                f"{g['d_rpy']:.4f} | {g['q']:.5f} | {g['dq']:.4f} | {r['nmse']['droll']:.4f} | "
                f"{lat_text(lat)} | {lat_text(lat_s)} | "
                f"{r['batch_us_per_state']:.0f} | {r['stored_mb']:.0f} (+{r['variance_cache_mb']:.0f}) |")
        L.append("")

    if res.get("part_a"):
        table(res["part_a"], f"A. Variants on {res['n_train']} TrainPool points, "
                             f"{res['clusters']} clusters")
    if res.get("part_b"):
        table(res["part_b"], "B. Whole TrainPool, default configuration (cluster_size 1000)")
        b = res["part_b"][0]
        L.extend([f"Whole-TrainPool fit: {b['fit_s']:.0f} s wall (k-means, balancing, warm-start "
                  f"GP and {b['k']} cluster GPs on {res['jobs']} worker processes), peak RSS "
                  f"of the process tree {b['peak_rss_mb']:.0f} MB; model directory "
                  f"{res.get('model_dir_mb', 0):.0f} MB on disk; building all variance factors "
                  f"took {b.get('prepare_variance_s', 0):.1f} s.", ""])
    L.extend(["## Per-element nMSE", "",
              "| variant | " + " | ".join(STATE_NAMES) + " |",
              "|" + "---|" * (len(STATE_NAMES) + 1)])
    for r in res.get("part_a", []) + res.get("part_b", []):
        L.append(f"| {r['name']} | " + " | ".join(f"{r['nmse'][s]:.4f}" for s in STATE_NAMES)
                 + " |")
    L.append("")
    return "\n".join(L)


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--data", type=Path)
    ap.add_argument("--md-from", type=Path, nargs="+", default=None, metavar="JSON",
                    help="only write --md from earlier --json results (part A and B merged)")
    ap.add_argument("--data-note", default="")
    ap.add_argument("--n-train", type=int, default=5000)
    ap.add_argument("--clusters", type=int, default=5)
    ap.add_argument("--jobs", type=int, default=2)
    ap.add_argument("--only", default=None, help="comma-separated variant names (part A)")
    ap.add_argument("--skip-a", action="store_true")
    ap.add_argument("--full", action="store_true", help="part B: the whole TrainPool")
    ap.add_argument("--md", type=Path, default=None)
    ap.add_argument("--json", type=Path, default=None)
    ap.add_argument("--time-cmd", nargs=argparse.REMAINDER, default=None, metavar="CMD",
                    help="only run CMD; report its wall time and the peak RSS of its process tree")
    ap.add_argument("--paced-latency", type=Path, default=None, metavar="MODEL",
                    help="only time one-row predictions of MODEL every 10 ms (needs --data)")
    ap.add_argument("--queries", type=int, default=1500)
    ap.add_argument("--std", action="store_true", help="--paced-latency with return_std")
    ap.add_argument("--blend", action="store_true", help="--paced-latency with a blend of 2")
    a = ap.parse_args(argv)
    if a.time_cmd:
        import subprocess
        with PeakRSS(include_self=False) as mem:
            t0 = time.perf_counter()
            rc = subprocess.call(a.time_cmd)
            wall = time.perf_counter() - t0
        print(f"exit {rc}; wall {wall:.1f} s; peak RSS of the process tree "
              f"{mem.peak / 1e6:.0f} MB; load average {os.getloadavg()[0]:.1f}")
        return rc
    if a.paced_latency:
        if a.data is None:
            ap.error("--paced-latency needs --data (TestPool rows are the queries)")
        Xt, _, _ = features_responses(load_moves(a.data, "test"))
        print(paced_latency(a.paced_latency, a.queries, a.std, a.blend, Xt))
        return 0
    if a.md_from:
        docs = [json.loads(p.read_text()) for p in a.md_from]
        res = dict(docs[0])
        res["command"] = "\n    ".join(d["command"] for d in docs)
        res["loadavgs"] = [ld for d in docs for ld in d.get("loadavgs", [])]
        res["part_a"] = [r for d in docs for r in d["part_a"]]
        res["part_b"] = [r for d in docs for r in d["part_b"]]
        for d in docs:
            if d["part_b"]:
                res["model_dir_mb"], res["load_s"] = d.get("model_dir_mb"), d.get("load_s")
        if a.md:
            a.md.write_text(markdown(res) + "\n")
        print(markdown(res))
        return 0
    if a.data is None:
        ap.error("--data is required")

    with threadpool_limits(limits=1):
        t0 = time.perf_counter()
        X, Y, _ = features_responses(load_moves(a.data, "train"))
        Xt, Yt, _ = features_responses(load_moves(a.data, "test"))
        print(f"loaded {X.shape[0]} train / {Xt.shape[0]} test pairs in "
              f"{time.perf_counter() - t0:.0f} s", flush=True)
        res = {"command": "OPENBLAS_NUM_THREADS=1 .venv/bin/python benchmarks/lgpr_ablation/lgpr_ablation.py "
                          + shlex.join(sys.argv[1:] if argv is None else argv),
               "machine": f"{psutil.cpu_count()} cores, {psutil.virtual_memory().total / 1e9:.0f}"
                          f" GB, {platform.machine()}, Python {platform.python_version()}, "
                          f"numpy {np.__version__}",
               "data": str(a.data), "data_note": a.data_note, "n_pool": int(X.shape[0]),
               "n_test": int(Xt.shape[0]), "n_train": a.n_train, "clusters": a.clusters,
               "jobs": a.jobs, "part_a": [], "part_b": [],
               "loadavg_start": os.getloadavg()}
        if not a.skip_a:
            rows = np.sort(np.random.default_rng(0).choice(X.shape[0], size=a.n_train,
                                                            replace=False))
            names = list(VARIANTS) if a.only is None else a.only.split(",")
            for name in names:
                kw, target = VARIANTS[name]
                row, model = fit_variant(name, {"n_clusters": a.clusters, **kw}, X[rows],
                                         Y[rows], Xt, Yt, target, a.jobs)
                res["part_a"].append(row)
                if name == BLEND_BASE:
                    res["part_a"].extend(blend_rows(model, name, Xt, Yt))
                del model
        if a.full:
            row, model = fit_variant("default, whole TrainPool", {"cluster_size": 1000}, X, Y,
                                     Xt, Yt, "delta", a.jobs)
            res["part_b"].append(row)
            tmp = Path(tempfile.mkdtemp(prefix="lgpr_ablation_"))
            try:
                model.save(tmp / "model")
                res["model_dir_mb"] = sum(f.stat().st_size for f in (tmp / "model").iterdir()
                                          ) / 1e6
                t0 = time.perf_counter()
                back = OneStepModel.load(tmp / "model")
                res["load_s"] = time.perf_counter() - t0
            finally:
                shutil.rmtree(tmp, ignore_errors=True)
            res["part_b"].extend(blend_rows(back, "default, whole TrainPool", Xt, Yt)[:2])
    res["loadavgs"] = [[res.pop("loadavg_start")[0], os.getloadavg()[0]]]
    if a.json:
        a.json.write_text(json.dumps(res, indent=1))
    if a.md:
        a.md.write_text(markdown(res) + "\n")
    print(markdown(res))
    return 0


if __name__ == "__main__":
    sys.exit(main())
