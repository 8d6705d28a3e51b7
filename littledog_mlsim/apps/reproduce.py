"""The paper's experiments on our data: Table I, Fig. 4 (issue 3) and Figs 5-7 (issue 4).

``reproduce(data, out, scale)`` trains every method on the TrainPool of ``data`` and scores it on
the whole TestPool:

- ``table1.csv`` / ``table1.md``: one-step nMSE of every one of the 33 state elements per method
  (rows ``lr lwpr gpr sor lgpr``, first column ``method``), plus the mean over elements, fit time,
  prediction time per sample and peak memory (resident set of the process that fitted it; each
  method is fitted in a fresh process).
- ``fig4.png`` / ``fig4.csv``: nMSE of ``droll`` (the paper's hardest element) against the
  training-set size for GPR, SoR with random and with CV-sampled support points, and LGPR
  (single-output models of ``droll``).
- the rollout figures and animation (see :mod:`littledog_mlsim.apps.figures`), when asked.

Scales: ``small`` runs the whole pipeline in minutes (tests, CI); ``paper`` uses the paper's
sizes (LR, LWPR, LGPR on the whole TrainPool; GPR on 4500 samples; SoR n = 10000, m = 2000).
GPR at paper scale takes its hyperparameters from a fit on a 1000-sample subset and then
conditions on all 4500 samples (33 independent ARD fits on 4500 points would take hours on two
cores); ``table1.md`` says so.
"""
from __future__ import annotations

import csv
import json
import os
import logging
import resource
import time
from concurrent.futures import ProcessPoolExecutor
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Sequence

import numpy as np

from ..layout import STATE_INDEX, STATE_NAMES
from ..logs import progress_to_stderr
from ..models.train import METHOD_NAMES, subset_rows

METHODS = METHOD_NAMES   # Table I rows (the registry's paper methods, in the paper's order)
log = logging.getLogger(__name__)


@dataclass(frozen=True)
class Scale:
    """Sizes and options of one reproduction scale."""

    name: str
    n_train: dict[str, int | None]               # None = whole TrainPool
    options: dict[str, dict[str, Any]]
    gpr_hyper_points: int | None                  # GPR: hyperparameters from this many points
    fig4_sizes: dict[str, Sequence[int]]          # method -> training-set sizes (droll only)
    fig4_support_fraction: float = 0.2            # SoR support m = fraction * n (capped)
    fig4_support_max: int = 2000
    notes: tuple[str, ...] = field(default_factory=tuple)


SCALES: dict[str, Scale] = {
    "small": Scale(
        name="small",
        n_train={"lr": None, "lwpr": 2000, "gpr": 200, "sor": 1000, "lgpr": None},
        options={"lr": {}, "lwpr": {"n_epochs": 1},
                 "gpr": {"max_iter": 25, "n_jobs": 2},
                 "sor": {"n_support": 100, "support": "cv", "n_folds": 3, "predict_variance": False,
                         "n_hyperparameter_points": 150, "gp_params": {"max_iter": 25, "n_jobs": 2}},
                 "lgpr": {"cluster_size": 300, "n_jobs": 2, "max_iter": 25,
                          "n_hyperparameter_points": 150, "n_global_points": 200}},
        gpr_hyper_points=None,
        fig4_sizes={"gpr": (100, 200), "sor_random": (500, 1000), "sor_cv": (500, 1000),
                    "lgpr": (500, 1000, 2000)},
        fig4_support_fraction=0.1,
        notes=("small scale: a pipeline check, not the paper's sizes",),
    ),
    "paper": Scale(
        name="paper",
        n_train={"lr": None, "lwpr": None, "gpr": 4500, "sor": 10000, "lgpr": None},
        options={"lr": {}, "lwpr": {}, "gpr": {"n_jobs": 2},
                 "sor": {"n_support": 2000, "support": "cv", "predict_variance": False},
                 "lgpr": {"n_jobs": 2}},
        gpr_hyper_points=1000,
        fig4_sizes={"gpr": (250, 500, 1000, 2000, 4500),
                    "sor_random": (2000, 5000, 10000, 20000),
                    "sor_cv": (2000, 5000, 10000, 20000),
                    "lgpr": (2000, 5000, 10000, 20000, 40000, 10**9)},
        notes=("GPR: hyperparameters fitted on 1000 random samples, then conditioned on 4500",),
    ),
}


# ---------------------------------------------------------------------------------------------
# data cache shared with the worker processes


def _cache_dataset(data: str | os.PathLike, path: Path) -> dict[str, Any]:
    from ..data.dataset import load_moves
    from ..data.states import features_responses
    train, test = load_moves(data, "train"), load_moves(data, "test")
    X, Y, _ = features_responses(train)
    Xt, Yt, _ = features_responses(test)
    tmp = path.with_name(path.name + ".tmp.npz")
    np.savez(tmp, X=X, Y=Y, Xt=Xt, Yt=Yt)
    os.replace(tmp, path)
    return {"n_train_pool": int(X.shape[0]), "n_test": int(Xt.shape[0]),
            "n_train_moves": len(train), "n_test_moves": len(test)}


def _load_cache(path: str) -> dict[str, np.ndarray]:
    with np.load(path, allow_pickle=False) as z:
        return {k: z[k] for k in z.files}


def _peak_rss_mb() -> float:
    return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024.0   # Linux: kB


def _pin_blas() -> None:
    from threadpoolctl import threadpool_limits
    threadpool_limits(1)


def _stop_loky_workers() -> None:
    """Shut down joblib's reusable loky workers (LGPR's parallel cluster fits) in this process.

    A worker of our ProcessPoolExecutor joins its non-daemonic children before it exits, and
    idle loky workers only leave after their 300 s timeout: without this, every process that
    fitted an LGPR kept the pipeline waiting 5 minutes."""
    from joblib.externals.loky import get_reusable_executor
    get_reusable_executor().shutdown(wait=True)


# ---------------------------------------------------------------------------------------------
# workers (module level: they run in fresh processes)


def fit_and_score(cache: str, method: str, options: dict[str, Any], n_train: int | None,
                  seed: int, gpr_hyper_points: int | None, model_out: str | None) -> dict[str, Any]:
    """Fit one method on the cached TrainPool, score one-step nMSE on the whole TestPool."""
    try:
        return _fit_and_score(cache, method, options, n_train, seed, gpr_hyper_points, model_out)
    finally:   # also when the fit fails: the worker must be able to exit
        _stop_loky_workers()


def _fit_and_score(cache: str, method: str, options: dict[str, Any], n_train: int | None,
                   seed: int, gpr_hyper_points: int | None, model_out: str | None) -> dict[str, Any]:
    _pin_blas()
    from ..models.train import fit_onestep
    from ..scoring import one_step_scores

    d = _load_cache(cache)
    X, Y, Xt, Yt = d["X"], d["Y"], d["Xt"], d["Yt"]
    t0 = time.perf_counter()
    model = fit_onestep((X, Y), method, options=options, random_state=seed, n_train=n_train,
                        gpr_pilot_points=gpr_hyper_points)
    fit_s = time.perf_counter() - t0
    scores = one_step_scores(model, (Xt, Yt))
    if model_out:
        model.save(model_out)
    opts = dict(options)
    if "hyperparameter_pilot_s" in model.info:
        opts["optimize"] = False   # conditioned on the pilot's hyperparameters
    return {"method": method, "n_train": int(model.info["n_train"]), "fit_s": fit_s,
            "hyperparameter_pilot_s": float(model.info.get("hyperparameter_pilot_s", 0.0)),
            "predict_us_per_sample": 1e6 * scores["predict_seconds_per_sample"],
            "peak_rss_mb": _peak_rss_mb(), "nmse": scores["nmse"],
            "nmse_mean": scores["nmse_mean"], "options": opts}


def fig4_point(cache: str, curve: str, n: int, seed: int, scale_name: str) -> dict[str, Any]:
    """nMSE of droll for one (curve, training size): a single-output model of droll."""
    _pin_blas()
    from ..data.states import Normalizer
    from ..models.train import make_estimator
    from ..rollout.metrics import nmse_array

    sc = SCALES[scale_name]
    d = _load_cache(cache)
    X, Y, Xt, Yt = d["X"], d["Y"], d["Xt"], d["Yt"]
    j = STATE_INDEX["droll"]
    rows = subset_rows(X.shape[0], n, seed)
    fn = Normalizer().fit(X[rows])
    method = {"gpr": "gpr", "sor_random": "sor", "sor_cv": "sor", "lgpr": "lgpr"}[curve]
    opts = dict(sc.options[method])
    if "n_jobs" in opts:
        opts["n_jobs"] = 1          # Fig. 4 points already run in parallel processes: no nested pools
    if curve.startswith("sor"):
        opts.update(support=curve.split("_")[1],
                    n_support=int(min(sc.fig4_support_max, sc.fig4_support_fraction * rows.size)))
    est = make_estimator(method, opts, random_state=seed)
    y = Y[rows, j:j + 1] - X[rows, j:j + 1]                     # delta target, as OneStepModel
    t0 = time.perf_counter()
    est.fit(fn.transform(X[rows]), y)
    fit_s = time.perf_counter() - t0
    pred = est.predict(fn.transform(Xt)) + Xt[:, j:j + 1]
    return {"curve": curve, "n": int(rows.size), "nmse_droll": float(nmse_array(Yt[:, j:j + 1], pred)[0]),
            "fit_s": fit_s}


# ---------------------------------------------------------------------------------------------
# tables and figures


def _fmt(v: Any, digits: int = 3) -> str:
    return "n/a" if v is None or (isinstance(v, float) and not np.isfinite(v)) else f"{v:.{digits}f}"


def write_table1(rows: list[dict[str, Any]], out: Path, header_lines: Sequence[str]) -> None:
    with open(out / "table1.csv", "w", newline="") as f:
        w = csv.writer(f)
        w.writerow(["method", *STATE_NAMES, "nmse_mean", "n_train", "fit_s", "predict_us_per_sample",
                    "peak_rss_mb"])
        for r in rows:
            w.writerow([r["method"], *[r["nmse"][s] for s in STATE_NAMES], r["nmse_mean"],
                        r["n_train"], r["fit_s"], r["predict_us_per_sample"], r["peak_rss_mb"]])
    lines = ["# Table I on our data: one-step nMSE on the whole TestPool", "", *header_lines, "",
             "| method | n train | mean nMSE | fit [s] | predict [us/sample] | peak RSS [MB] |",
             "|---|---|---|---|---|---|"]
    for r in rows:
        lines.append(f"| {r['method']} | {r['n_train']} | {_fmt(r['nmse_mean'], 4)} | {r['fit_s']:.1f} | "
                     f"{r['predict_us_per_sample']:.1f} | {r['peak_rss_mb']:.0f} |")
    lines += ["", "nMSE per state element (rows: elements, columns: methods):", "",
              "| element | " + " | ".join(r["method"] for r in rows) + " |",
              "|---|" + "---|" * len(rows)]
    for s in STATE_NAMES:
        lines.append(f"| {s} | " + " | ".join(_fmt(r["nmse"][s], 4) for r in rows) + " |")
    (out / "table1.md").write_text("\n".join(lines) + "\n")


def plot_fig4(points: list[dict[str, Any]], out: Path) -> None:
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    with open(out / "fig4.csv", "w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=["curve", "n", "nmse_droll", "fit_s"])
        w.writeheader()
        w.writerows(points)
    labels = {"gpr": "GPR", "sor_random": "SoR (random support)", "sor_cv": "SoR (CV-sampled support)",
              "lgpr": "LGPR"}
    fig, ax = plt.subplots(figsize=(6, 4))
    for curve, label in labels.items():
        pts = sorted((p["n"], p["nmse_droll"]) for p in points if p["curve"] == curve)
        if pts:
            ax.plot(*zip(*pts), marker="o", label=label)
    ax.set_xscale("log")
    ax.set_xlabel("training-set size n")
    ax.set_ylabel("nMSE of droll (TestPool)")
    ax.set_title("Fig. 4: droll nMSE vs training size")
    ax.grid(True, which="both", alpha=0.3)
    ax.legend()
    fig.tight_layout()
    fig.savefig(out / "fig4.png", dpi=120)
    plt.close(fig)


# ---------------------------------------------------------------------------------------------
# the pipeline


def reproduce(data: str | os.PathLike, out: str | os.PathLike, scale: str = "small",
              methods: Sequence[str] = METHODS, seed: int = 0, fig4: bool = True,
              rollouts: bool = True, jobs: int = 2, physics_config: str | os.PathLike | None = None,
              progress: bool = True) -> dict[str, Any]:
    """Run Table I and Fig. 4 (and the rollout figures) into ``out``; returns a summary dict.

    ``progress``: progress lines on stderr unless the program configured logging."""
    with progress_to_stderr(progress):
        return _reproduce(data, out, scale, methods, seed, fig4, rollouts, jobs, physics_config,
                          progress)


def _reproduce(data, out, scale, methods, seed, fig4, rollouts, jobs, physics_config,
               progress) -> dict[str, Any]:
    if scale not in SCALES:
        raise ValueError(f"--scale must be one of {', '.join(SCALES)}, got {scale!r}")
    bad = [m for m in methods if m not in METHODS]
    if bad:
        raise ValueError(f"unknown method(s) {', '.join(bad)}; choose from {', '.join(METHODS)}")
    sc = SCALES[scale]
    out = Path(out)
    (out / "models").mkdir(parents=True, exist_ok=True)

    say = log.info

    t_start = time.perf_counter()
    cache = out / ".features.npz"
    say(f"loading {data}")
    sizes = _cache_dataset(data, cache)
    say(f"TrainPool {sizes['n_train_pool']} samples ({sizes['n_train_moves']} moves), "
        f"TestPool {sizes['n_test']} samples ({sizes['n_test_moves']} moves)")
    from ..workers import worker_context
    ctx = worker_context()
    rows = []
    try:
        for m in methods:
            say(f"fitting {m} (n = {sc.n_train[m] or 'all'})")
            with ProcessPoolExecutor(max_workers=1, mp_context=ctx) as pool:
                r = pool.submit(fit_and_score, str(cache), m, sc.options[m], sc.n_train[m], seed,
                                sc.gpr_hyper_points if m == "gpr" else None,
                                str(out / "models" / m)).result()
            say(f"{m}: mean nMSE {r['nmse_mean']:.4f}, fit {r['fit_s']:.1f} s, "
                f"peak {r['peak_rss_mb']:.0f} MB")
            rows.append(r)
        header = [f"Data: `{data}` ({sizes['n_train_pool']} TrainPool / {sizes['n_test']} TestPool "
                  f"samples). Scale `{scale}`, seed {seed}. Targets: s_{{t+1}} - s_t (delta), "
                  "features normalised to unit variance. nMSE = MSE / variance of the TestPool "
                  "response.", *[f"Note: {n}" for n in sc.notes]]
        write_table1(rows, out, header)
        points: list[dict[str, Any]] = []
        if fig4:
            todo = [(c, n) for c, ns in sc.fig4_sizes.items() for n in ns
                    if n <= sizes["n_train_pool"] or n == max(ns)]
            say(f"Fig. 4: {len(todo)} single-output fits")
            with ProcessPoolExecutor(max_workers=max(1, jobs), mp_context=ctx) as pool:
                futs = [pool.submit(fig4_point, str(cache), c, min(n, sizes["n_train_pool"]), seed,
                                    scale) for c, n in todo]
                points = [f.result() for f in futs]
            plot_fig4(points, out)
        summary = {"data": str(data), "scale": scale, "seed": seed, **sizes, "table1": rows,
                   "fig4": points}
        if rollouts:
            from .figures import rollout_figures
            physics = None
            if physics_config is not None:
                from ..robot.baseline import load_robot_config
                physics = load_robot_config(physics_config)
            say("rollout figures" + (f" (physics baseline {physics_config})" if physics else ""))
            summary["rollouts"] = rollout_figures(data, out, out / "models", physics_config=physics,
                                                  progress=progress)
        summary["wall_s"] = time.perf_counter() - t_start
        (out / "reproduce.json").write_text(json.dumps(summary, indent=1, default=float) + "\n")
        say(f"done in {summary['wall_s']:.0f} s")
        return summary
    finally:
        cache.unlink(missing_ok=True)
