"""Our GP hyperparameter fit vs scikit-learn's GaussianProcessRegressor on one output.

Same data, same start point, same bounds, same objective (ConstantKernel * RBF(ARD) +
WhiteKernel, jitter/alpha 1e-10), both L-BFGS-B with scipy's default tolerances
(sklearn: ``optimizer="fmin_l_bfgs_b"``, ``n_restarts_optimizer=0``; ours: ``max_iter`` = scipy's
default 15000). BLAS is pinned to one thread for both. Reports medians over repeats of

- one LML + gradient evaluation (at the start point) for several n,
- a whole fit at ``--n-fit``: wall time, reached LML, evaluations and iterations,
- (``--predict-paths``) the two cross-kernel paths of ``gp.gp_predict`` for few queries.

Data: ``--data DIR`` uses a dataset (TrainPool features normalised, response ``--output``);
without it, synthetic smooth 45-D data (see ``synthetic``). Writes a markdown report with the
command line to ``--md``.

    .venv/bin/python benchmarks/gp_fit_vs_sklearn/gp_fit_vs_sklearn.py --md benchmarks/gp_fit_vs_sklearn/gp_fit_vs_sklearn.md
"""
from __future__ import annotations

import argparse
import os
import platform
import shlex
import sys
import time
import warnings
from pathlib import Path
from typing import Callable

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
os.environ.setdefault("OMP_NUM_THREADS", "1")

import numpy as np  # noqa: E402
import scipy  # noqa: E402
import sklearn  # noqa: E402
from sklearn.gaussian_process import GaussianProcessRegressor  # noqa: E402
from sklearn.gaussian_process.kernels import RBF, ConstantKernel, WhiteKernel  # noqa: E402
from threadpoolctl import threadpool_limits  # noqa: E402

from littledog_mlsim.layout import N_FEATURE, STATE_INDEX  # noqa: E402
from littledog_mlsim.models.gp import (GPR, cross_kernel, default_bounds,  # noqa: E402
                                       default_init, kernel_cross, lml_and_grad,
                                       log_marginal_likelihood)

JITTER = 1e-10


def synthetic(n: int, seed: int) -> tuple[np.ndarray, np.ndarray]:
    """Smooth 45-D regression data: X ~ N(0, I); y depends smoothly on 15 of the 45 inputs.

    y = sin(X[:, :10] a) + 0.5 cos(X[:, 10:15] b) + 0.2 x_0 x_1 + 0.05 noise, |a| = |b| = 1.
    """
    rng = np.random.default_rng(seed)
    X = rng.standard_normal((n, N_FEATURE))
    a = rng.standard_normal(10)
    b = rng.standard_normal(5)
    a /= np.linalg.norm(a)
    b /= np.linalg.norm(b)
    y = (np.sin(X[:, :10] @ a) + 0.5 * np.cos(X[:, 10:15] @ b) + 0.2 * X[:, 0] * X[:, 1]
         + 0.05 * rng.standard_normal(n))
    return X, y


def dataset(path: str, output: str, n: int, seed: int) -> tuple[np.ndarray, np.ndarray]:
    """TrainPool features (normalised) and one response of a dataset, n random rows."""
    from littledog_mlsim.data.dataset import Normalizer, features_responses, load_moves
    X, Y, _ = features_responses(load_moves(path, "train"))
    rng = np.random.default_rng(seed)
    rows = rng.choice(X.shape[0], size=min(n, X.shape[0]), replace=False)
    return Normalizer().fit(X).transform(X)[rows], Y[rows, STATE_INDEX[output]]


def sk_kernel(init: np.ndarray, bounds: np.ndarray):
    p, b = np.exp(init), np.exp(bounds)
    return (ConstantKernel(p[0], tuple(b[0])) * RBF(p[1:-1], [tuple(r) for r in b[1:-1]])
            + WhiteKernel(p[-1], tuple(b[-1])))


def timed(f: Callable[[], object]) -> tuple[float, object]:
    t0 = time.perf_counter()
    out = f()
    return time.perf_counter() - t0, out


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--n-fit", type=int, default=500, help="points for the whole-fit comparison")
    ap.add_argument("--n-eval", default="500,1000", help="points for the per-evaluation timing")
    ap.add_argument("--repeats", type=int, default=3, help="whole-fit repeats (median)")
    ap.add_argument("--eval-repeats", type=int, default=5)
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--data", help="dataset directory (default: synthetic data)")
    ap.add_argument("--output", default="droll", help="response state name with --data")
    ap.add_argument("--predict-paths", action="store_true",
                    help="also time gp_predict's two cross-kernel paths (n=1000, p=33)")
    ap.add_argument("--md", help="write the markdown report here")
    args = ap.parse_args()
    threadpool_limits(1)
    warnings.filterwarnings("ignore", module="sklearn")

    def get_data(n: int) -> tuple[np.ndarray, np.ndarray]:
        if args.data:
            return dataset(args.data, args.output, n, args.seed)
        return synthetic(n, args.seed)

    source = (f"dataset `{args.data}`, TrainPool, response `{args.output}`" if args.data else
              "synthetic smooth 45-D data (no recorded dataset was available), see `synthetic()`")
    lines = [
        "# GP hyperparameter fit: littledog_mlsim.models.gp vs scikit-learn",
        "",
        "Command (repo root):",
        "",
        "    " + " ".join(shlex.quote(a) for a in [".venv/bin/python"] + sys.argv),
        "",
        f"Machine: {os.cpu_count()} cores ({platform.processor() or platform.machine()}), shared "
        "with other jobs (timings are noisy); BLAS pinned to 1 thread for both. "
        f"Python {platform.python_version()}, numpy {np.__version__}, scipy {scipy.__version__}, "
        f"scikit-learn {sklearn.__version__}.",
        f"Data: {source}; y standardised; one output. Kernel: ConstantKernel * RBF(45 ARD length "
        "scales) + WhiteKernel (47 hyperparameters), jitter/alpha 1e-10. Start point: "
        "`default_init` (median heuristic); bounds: `default_bounds`; identical for both.",
        "",
        "## One LML + gradient evaluation at the start point",
        "",
        f"Median of {args.eval_repeats} calls. ours: `gp.lml_and_grad`; sklearn: "
        "`GaussianProcessRegressor.log_marginal_likelihood(theta, eval_gradient=True)`.",
        "",
        "| n | ours [ms] | sklearn [ms] | sklearn / ours | max rel. grad diff |",
        "|---|---|---|---|---|",
    ]
    for n in [int(v) for v in args.n_eval.split(",") if v]:
        X, y = get_data(n)
        y = (y - y.mean()) / y.std()
        init, bounds = default_init(X, y)[0], default_bounds(X, y)[0]
        sk = GaussianProcessRegressor(sk_kernel(init, bounds), alpha=JITTER,
                                      optimizer=None).fit(X, y)
        t_ours, t_sk = [], []
        for _ in range(args.eval_repeats):
            t, (f1, g1) = timed(lambda: lml_and_grad(init, X, y, JITTER))
            t_ours.append(t)
            t, (f2, g2) = timed(lambda: sk.log_marginal_likelihood(init, eval_gradient=True))
            t_sk.append(t)
        a, b = np.median(t_ours), np.median(t_sk)
        rel = float(np.max(np.abs(g1 - g2)) / np.max(np.abs(g2)))
        lines.append(f"| {n} | {1e3 * a:.1f} | {1e3 * b:.1f} | {b / a:.1f} | {rel:.1e} |")
        print(lines[-1], flush=True)

    n = args.n_fit
    X, y = get_data(n)
    y = (y - y.mean()) / y.std()
    init, bounds = default_init(X, y)[0], default_bounds(X, y)[0]
    rows = []
    for r in range(args.repeats):
        ours = GPR(normalize_y=False, init_log_params=init.tolist(), max_iter=15000,
                   jitter=JITTER)
        t_o, _ = timed(lambda: ours.fit(X, y))
        sk = GaussianProcessRegressor(sk_kernel(init, bounds), alpha=JITTER,
                                      optimizer="fmin_l_bfgs_b", n_restarts_optimizer=0)
        t_s, _ = timed(lambda: sk.fit(X, y))
        lml_o = float(ours.lml_[0])
        lml_s = float(sk.log_marginal_likelihood_value_)
        # each optimum scored by the other implementation's likelihood (consistency)
        cross_o = float(sk.log_marginal_likelihood(ours.log_params_[0]))
        cross_s = float(log_marginal_likelihood(sk.kernel_.theta, X, y, JITTER)[0])
        rows.append((t_o, t_s, lml_o, lml_s, cross_o, cross_s, int(ours.n_iter_[0])))
        print(f"repeat {r}: ours {t_o:.2f} s LML {lml_o:.4f} (sklearn scores it {cross_o:.4f}); "
              f"sklearn {t_s:.2f} s LML {lml_s:.4f} (we score it {cross_s:.4f})", flush=True)
    t_o, t_s = np.median([r[0] for r in rows]), np.median([r[1] for r in rows])
    lml_start = float(log_marginal_likelihood(init, X, y, JITTER)[0])
    lines += [
        "",
        f"## Whole fit, n = {n} (one output, median of {args.repeats} repeats)",
        "",
        f"`GPR(normalize_y=False, init_log_params=init, max_iter=15000).fit` vs "
        f"`GaussianProcessRegressor(optimizer='fmin_l_bfgs_b', n_restarts_optimizer=0).fit`. "
        f"LML at the start point: {lml_start:.4f}.",
        "",
        "| | median wall time [s] | reached LML | same optimum scored by the other code |",
        "|---|---|---|---|",
        f"| ours ({rows[0][6]} L-BFGS-B iterations) | {t_o:.2f} | {rows[0][2]:.4f} | "
        f"{rows[0][4]:.4f} |",
        f"| sklearn | {t_s:.2f} | {rows[0][3]:.4f} | {rows[0][5]:.4f} |",
        "",
        f"Wall-time ratio sklearn / ours: **{t_s / t_o:.1f}x** (per-repeat times ours "
        f"{', '.join(f'{r[0]:.2f}' for r in rows)} s; sklearn "
        f"{', '.join(f'{r[1]:.2f}' for r in rows)} s).",
    ]
    if args.predict_paths:
        lines += predict_paths(args.eval_repeats)
    text = "\n".join(lines) + "\n"
    print(text)
    if args.md:
        Path(args.md).write_text(text)


def predict_paths(repeats: int) -> list[str]:
    """Time gp_predict's cross-kernel paths: all outputs at once vs one GEMM per kernel."""
    rng = np.random.default_rng(0)
    n, d, p = 1000, N_FEATURE, 33
    X = rng.standard_normal((n, d))
    lp = np.c_[np.zeros(p), np.log(3 * rng.uniform(1, 3, (p, d))), np.full(p, -3.0)]
    out = ["", f"## Cross-kernel paths of `gp_predict` (n = {n}, d = {d}, p = {p} kernels)", "",
           f"Median of {repeats} calls, milliseconds; decides `gp._FEW_QUERIES`.", "",
           "| queries | all outputs in one pass (`cross_kernel`) | one GEMM per kernel "
           "(`kernel_cross`) |", "|---|---|---|"]
    for ns in (1, 2, 4, 8, 16, 32, 64):
        Xs = rng.standard_normal((ns, d))
        a = np.median([timed(lambda: cross_kernel(Xs, X, lp))[0] for _ in range(repeats)])
        b = np.median([timed(lambda: [kernel_cross(Xs, X, lp[j]) for j in range(p)])[0]
                       for _ in range(repeats)])
        out.append(f"| {ns} | {1e3 * a:.2f} | {1e3 * b:.2f} |")
        print(out[-1], flush=True)
    return out


if __name__ == "__main__":
    main()
