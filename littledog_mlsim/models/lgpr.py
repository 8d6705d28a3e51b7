"""Local Gaussian process regression (LGPR), the paper's Section V, with an optional blend.

The TrainPool (features already normalised to unit variance, as the paper does) is split by
k-means into k clusters of about m = n / k points; a full GP (:mod:`.gp`: ARD squared-exponential
kernel, hyperparameters re-optimised by L-BFGS-B on the log marginal likelihood) is fitted on each
cluster, and a query is predicted by the local GP whose cluster centre is nearest in Euclidean
distance (= the normalised Euclidean distance of the raw features). Cost O(k m^3) = O(n m^2) to
fit, O(m d) per query; the block-diagonal view of the paper.

Clustering (:func:`.clustering.balanced_clusters`)
--------------------------------------
scikit-learn ``KMeans`` (Lloyd, k-means++ init, seeded, ``n_init=1``) on the training inputs.
k-means on trot data is lopsided (standing and slow moves pile up), and a GP's cost is cubic in
its size, so the partition is balanced afterwards:

- a cluster larger than ``max_cluster_factor * n/k`` is split by k-means into
  ``ceil(size / (n/k))`` parts; a part that is still too large (k-means fails on near-duplicate
  points) is cut into equal-count chunks along its first principal axis;
- a cluster smaller than ``min_cluster_factor * n/k`` is dissolved, its points moving to the
  nearest remaining centre (so the final count ``n_clusters_`` can differ from the request);
- centres are the means of the final clusters, and prediction uses the nearest centre. Training
  points keep their (balanced) cluster even where another centre is nearer (the partition is
  not re-assigned after balancing, which would undo it).

Per-cluster GP (:func:`fit_local_gp`, a module-level function so that joblib/Dask workers can
import it)
--------------------------------------------------------------------------------------------
Targets are standardised per cluster (the cluster's mean is the local prior mean). The
hyperparameters are fitted on at most ``n_hyperparameter_points`` points of the cluster (a seeded
random subset) with at most ``max_iter`` L-BFGS-B iterations; the weights alpha then use all of
the cluster's points. ``hyperparameters``:

- ``"shared"`` (default): one ARD kernel for all p outputs of a cluster (the LML is summed over
  the outputs; outputs are standardised per cluster, so they share length scales and the
  signal/noise ratio), so one Cholesky per cluster serves every output, in fitting and for the
  variance. Its std alone is calibrated only on average over the outputs (hence
  ``output_scale``, below): standardising equalises the outputs' variances, not their noise
  fractions, and the one sn2 (ML for the summed LML) lies between them, too large for the
  low-noise outputs (std conservative) and too small for the noisiest (std over-confident).
- ``"per_output"``: the paper's one GP per state element, p kernels per cluster; p times the fit
  work, and ``return_std`` needs p Cholesky factors per cluster (m^2 8 bytes each).

``init``:

- ``"warm"`` (default): a global GP is fitted first on ``n_global_points`` random points of the
  whole pool (same ``hyperparameters`` mode); each cluster starts from the same GP in raw units:
  the same length scales, and sf2, sn2 rescaled by (global y std / cluster y std)^2 (geometric
  mean over outputs when shared), clipped to the cluster's bounds.
- ``"cold"``: :func:`.gp.default_init` on the cluster's subset (median heuristic).

The defaults (shared kernels, 30 L-BFGS-B iterations on 500 points per cluster, warm start,
nearest-centre prediction) were chosen on ``benchmarks/lgpr_ablation/lgpr_ablation.md``; the
measurements are summarised in ``benchmarks/lgpr_design/README.md``.

If a kernel matrix is not positive definite (at an L-BFGS-B start, or the cluster's full matrix
with hyperparameters from a subset) the jitter is raised along :func:`.gp.jitter_schedule` (up to
1e-2 x sf2 + sn2, in standardised units); the jitter used is stored per cluster (``jitter_``).
Columns that are constant up to rounding inside a cluster (a saturated tanh of the friction
features) get the unit scale for the length-scale bounds and start (see
:func:`.gp.degenerate_columns`), so the warm start no longer meets bounds of ~1e-14. A cluster
that still cannot be fitted raises a one-line ValueError naming the cluster, its size, the start
and the reason.

Predictive std and ``output_scale`` (default True)
--------------------------------------------------
``predict(..., return_std=True)`` gives the std of a noisy observation y (not of the latent f),
as :class:`.gp.GPR`: sqrt(sf2 + sn2 - k*^T K^-1 k*) x the cluster's y std, with K = Kf + (sn2 +
jitter) I; the TestPool targets it is compared with are noisy observations too.

With ``output_scale`` each output j of cluster c also gets the profile-likelihood amplitude of
its whole covariance on the shared kernel (:func:`output_scales`): c_j = y_j^T K^-1 y_j / m
(standardised y_j, all m points of the cluster; stored as ``output_scale_`` (k, p)), and its
predictive variance is multiplied by c_j. Scaling K by c leaves the mean K*^T K^-1 y unchanged
(predictions with and without the option are bit-identical, except in a precision-weighted
blend, whose weights are variances) and c_j is a by-product of the fit (the alpha already
computed: no extra Cholesky, no extra prediction cost). It corrects each output's overall level,
not the shape (signal vs noise share) of its variance. How well the std is calibrated with and
without the option (mean(z^2) per output on generated and recorded data) is measured in
``benchmarks/lgpr_calibration/lgpr_calibration.md`` and summarised in
``benchmarks/lgpr_design/README.md``.

``output_scale=False`` restores the plain shared-kernel std. Model files written before the
option have no ``output_scale`` array and load with c = 1 (their old std).

Blend (the paper's future work: overlapping local models)
---------------------------------------------------------
With ``blend=True`` a query combines the ``n_blend`` local models whose centres are nearest.
Model r (distances d_0 <= d_1 <= ... to the sorted centres) gets the weight

    w_r  proportional to  g_r / v_r,     g_r = d_{n_blend}^2 - d_r^2

(``g_r = 1`` when k <= n_blend): its predictive precision 1/v_r (per output; ``blend_weights =
"precision"`` uses v_r in output units, ``"relative"`` v_r divided by the model's prior variance
(sf2 + sn2) in output units, i.e. how well the model knows x irrespective of its cluster's
output scale) tapered by g_r, which reaches 0 exactly where centre r stops being among the
n_blend nearest. Both factors are continuous in x, so the blended mean is continuous across
cluster boundaries, where the nearest-centre rule jumps. The mean is sum_r w_r mu_r and the
variance that of the mixture, sum_r w_r (v_r + mu_r^2) - mean^2. ``n_blend = 1`` is the
nearest-centre rule. v_r is everywhere the variance ``predict`` would report for model r alone:
with ``output_scale`` the calibrated one, c_j v_r, and the prior variance of ``"relative"`` is
scaled by the same c_j (so those weights, ratios of the two, do not depend on the option, while
``"precision"`` weights and the mixture variance use the calibrated variances). The blend's std
is conservative, because of the mixture's spread term sum_r w_r mu_r^2 - mean^2 (the local
models' disagreement, while the blended mean is better than either); measured in
``benchmarks/lgpr_design/README.md``.

Prediction cost and memory
--------------------------
Stored: centres (k, d), each cluster's training inputs and weights alpha (n d + n p floats in
total), log hyperparameters (k, p, d + 2), per-cluster output mean/std and ``output_scale_``.
One query, nearest rule:
one (k, d) distance pass and one (m, d) cross-kernel pass for all outputs (:func:`.gp.gp_predict`),
no per-output Python loop. ``return_std`` needs the Cholesky factor(s) of the clusters it touches;
they are not stored in the model file (recomputed from X and the hyperparameters, O(m^3 / 3)
each) but built by the first call that needs them, for all clusters at once (as many as fit in
``variance_cache_mb`` megabytes, an LRU cache beyond that), so that no factorisation happens later
inside a 10 ms step; :meth:`LGPR.prepare_variance` does it explicitly (optionally in float32:
half the bytes, the std changed by the float32 solve's rounding; the learned simulator's node
uses it). Shared hyperparameters: one m x m factor per cluster (k m^2 8 bytes); per-output: p
of them per cluster, so only a few clusters fit in the cache (sizes and times:
``benchmarks/lgpr_design/README.md``). :meth:`LGPR.cluster_rows` gives each cluster's training
rows (the learned simulator's gate shortcut uses them as candidate TrainPool states).
A batch of queries without the std (the batched simulator's rollouts) is grouped by cluster
and predicted by ``LGPR._batch_mean``: one kernel-row GEMM and one product with alpha per
cluster visited, everything else (the queries' scaling, |a|^2, the kernel rows' elementwise
steps in one compiled pass (:mod:`.kernel_rows`), one ``exp``, the output units) once over the
whole batch; the mean is the per-cluster loop's bit for bit. It holds the batch's kernel rows
at once, so batches above ``BATCH_MEAN_MAX_ROWS`` queries take the per-cluster loop.

Parallel fitting
----------------
The per-cluster fits (and the per-output global fits of the warm start) run through joblib
(:func:`.parallel.run_tasks`):
``n_jobs`` local processes (loky), or, with ``dask_scheduler="tcp://host:port"``, the workers of
that Dask cluster (``distributed.Client`` + joblib's ``dask`` backend; the workers need this
package importable). Every task's result depends only on its data and its seed (derived from
``random_state`` and the cluster number), and BLAS runs on one thread inside each task, so
``n_jobs=1``, ``n_jobs=2`` and a Dask cluster give the same model (bit for bit when the workers
use the same NumPy/BLAS build, as ``test/models/test_lgpr.py`` checks on one machine).
"""
from __future__ import annotations

import logging
import time
from collections import OrderedDict
from typing import Any, Callable

import numpy as np
from threadpoolctl import threadpool_limits

from .base import (Regressor, check_fit_inputs, check_is_fitted, check_predict_inputs,
                   expect_array, sizes_from_meta, standardise_targets)
from .gp import (
    DEFAULT_INIT_NOISE_RATIO,
    DEFAULT_JITTER,
    DEFAULT_LENGTH_SCALE_BOUNDS,
    DEFAULT_NOISE_VARIANCE_BOUNDS,
    DEFAULT_SIGNAL_VARIANCE_BOUNDS,
    GPR,
    NotPositiveDefiniteError,
    _unique_kernels,
    fit_gp_hyperparameters,
    gp_cholesky,
    gp_posterior_stable,
    gp_predict,
    noisy_variance,
    pack_lower,
    unpack_log_params,
)
from .clustering import _sqdist_to_centres, balanced_clusters, nearest_rows
from .parallel import run_tasks
from .persistence import register

#: batches of at most this many queries without the std take ``LGPR._batch_mean``, which holds
#: the whole batch's kernel rows at once (4096 queries x about 1,000 training points of their
#: clusters: about 33 MB); larger ones (a dataset's scores) the per-cluster loop
BATCH_MEAN_MAX_ROWS = 4096

HYPERPARAMETER_MODES = ("shared", "per_output")
INIT_MODES = ("warm", "cold")
BLEND_WEIGHTS = ("precision", "relative")

log = logging.getLogger(__name__)


# ----------------------------------------------------------------------------- worker tasks

def _gp_options(X: np.ndarray, Yn: np.ndarray, shared: bool, init: np.ndarray | None,
                options: dict[str, Any]) -> dict[str, Any]:
    """fit_gp_hyperparameters keyword arguments, as :class:`.gp.GPR` builds them."""
    gp = GPR(shared_hyperparameters=shared, max_iter=options["max_iter"],
             jitter=options["jitter"], init_noise_ratio=options["init_noise_ratio"],
             length_scale_bounds=options["length_scale_bounds"],
             signal_variance_bounds=options["signal_variance_bounds"],
             noise_variance_bounds=options["noise_variance_bounds"], random_state=0)
    opts = gp.hyperparameter_options(X, Yn)
    if init is not None:
        opts["init"] = np.clip(init, opts["bounds"][..., 0], opts["bounds"][..., 1])
    return opts


def fit_hyperparameters_task(X: np.ndarray, Y: np.ndarray, shared: bool,
                             options: dict[str, Any]) -> dict[str, Any]:
    """Worker task: standardise Y (n, p) and fit GP hyperparameters from the median heuristic.

    Returns {"log_params" (p, d + 2) for standardised Y, "y_std" (p,), "seconds", "cpu_seconds"}.
    Used for the global GP of the warm start (one task, or one per output when not shared).
    """
    t0, c0 = time.perf_counter(), time.process_time()
    try:
        with threadpool_limits(limits=1):
            Yn, _, sd = standardise_targets(np.asarray(Y, dtype=np.float64))
            res = fit_gp_hyperparameters(X, Yn, **_gp_options(X, Yn, shared, None, options))
    except ValueError as e:
        raise _one_line_error(e, f"LGPR global GP of the warm start ({X.shape[0]} points)"
                              ) from None
    return {"log_params": res.log_params, "y_std": sd, "seconds": time.perf_counter() - t0,
            "cpu_seconds": time.process_time() - c0}


def warm_init(global_log_params: np.ndarray, global_y_std: np.ndarray, y_std: np.ndarray,
              shared: bool) -> np.ndarray:
    """Start point (p, d + 2) of a cluster from the global GP: the same GP in raw output units.

    Length scales are kept; sf2 and sn2 are multiplied by (global_y_std / y_std)^2 (the cluster
    standardises its outputs by ``y_std``); shared: by the geometric mean of that ratio.
    """
    lp = np.array(global_log_params, dtype=np.float64)
    log_ratio = 2.0 * (np.log(global_y_std) - np.log(y_std))  # (p,)
    if shared:
        log_ratio = np.full_like(log_ratio, log_ratio.mean())
    lp[:, 0] += log_ratio
    lp[:, -1] += log_ratio
    return lp


def _one_line_error(e: ValueError, where: str) -> ValueError:
    """``where: <first line of e>``, as NotPositiveDefiniteError or ValueError."""
    text = str(e).strip().splitlines()[0] if str(e).strip() else type(e).__name__
    cls = NotPositiveDefiniteError if isinstance(e, NotPositiveDefiniteError) else ValueError
    return cls(f"{where}: {text}")


def output_scales(Yn: np.ndarray, alpha: np.ndarray) -> np.ndarray:
    """Maximum-likelihood amplitude (p,) of each output on its cluster's covariance.

    Yn (m, p) standardised targets, alpha (m, p) = K^-1 Yn. Scaling the whole covariance
    K -> c K (signal, noise and jitter alike) leaves the mean K*^T K^-1 y unchanged, and the
    log-likelihood -1/2 (y^T K^-1 y / c + m log c) is largest at c = y^T K^-1 y / m. An output
    that is constant in the cluster (Yn = 0) keeps c = 1 (nothing to calibrate on).
    """
    m = Yn.shape[0]
    c = np.einsum("ij,ij->j", Yn, alpha) / m
    return np.where(np.any(Yn != 0, axis=0) & (c > 0), c, 1.0)


def fit_local_gp(X: np.ndarray, Y: np.ndarray, shared: bool, init: dict[str, Any] | None,
                 options: dict[str, Any], seed: int, cluster: int | None = None
                 ) -> dict[str, Any]:
    """Worker task: one cluster's GP. X (m, d), Y (m, p) raw cluster targets.

    ``init``: None (cold, median heuristic) or {"log_params" (p, d + 2), "y_std" (p,)} of the
    global GP (warm). Hyperparameters are fitted on at most ``options["n_hyperparameter_points"]``
    rows (seeded by ``seed``), alpha on all rows. Returns a dict of arrays: log_params (p, d + 2),
    alpha (m, p), lml (p,), y_mean, y_std (p,), output_scale (p,) (:func:`output_scales`),
    n_iter (p,), jitter, seconds (wall), cpu_seconds
    (this worker process's CPU time: comparable between runs on a busy machine). ``cluster``
    (the cluster's number) only names it in errors: a failure raises a one-line ValueError
    (NotPositiveDefiniteError for a kernel matrix) with the cluster, its size, the start and the
    reason.
    """
    t0, c0 = time.perf_counter(), time.process_time()
    X = np.asarray(X, dtype=np.float64)
    m = X.shape[0]
    nh = min(m, int(options["n_hyperparameter_points"]))
    try:
        with threadpool_limits(limits=1):
            Yn, y_mean, y_std = standardise_targets(np.asarray(Y, dtype=np.float64))
            rows = (np.arange(m) if nh == m else
                    np.sort(np.random.default_rng(seed).choice(m, size=nh, replace=False)))
            start = (None if init is None else
                     warm_init(init["log_params"], init["y_std"], y_std, shared))
            opts = _gp_options(X[rows], Yn[rows], shared, start, options)
            res = fit_gp_hyperparameters(X[rows], Yn[rows], **opts)
            alpha, lml, jitter = gp_posterior_stable(X, Yn, res.log_params, res.jitter)
            scale = output_scales(Yn, alpha)
    except ValueError as e:
        name = "LGPR cluster" + ("" if cluster is None else f" {cluster}")
        raise _one_line_error(e, f"{name} ({m} points, hyperparameters on {nh}, "
                                 f"{'cold' if init is None else 'warm'} start)") from None
    return {"log_params": res.log_params, "alpha": alpha, "lml": lml, "y_mean": y_mean,
            "y_std": y_std, "output_scale": scale, "n_iter": res.n_iter, "jitter": jitter,
            "seconds": time.perf_counter() - t0, "cpu_seconds": time.process_time() - c0}


# ----------------------------------------------------------------------------- estimator

@register
class LGPR(Regressor):
    """Local GP regression: k-means clusters, one full GP each, nearest-centre prediction.

    Parameters (constructor = hyperparameters, scikit-learn style):

    - ``n_clusters`` k, or None: ``round(n / cluster_size)`` (at least 1). The final count
      ``n_clusters_`` can differ after balancing (see :func:`balanced_clusters`).
    - ``cluster_size`` target points per cluster when ``n_clusters`` is None (paper: ~1000).
    - ``max_cluster_factor``, ``min_cluster_factor``: balance limits relative to n/k.
    - ``hyperparameters`` "shared" or "per_output"; ``init`` "warm" or "cold" (module doc).
    - ``n_hyperparameter_points`` rows of a cluster the hyperparameters are fitted on;
      ``n_global_points`` rows of the warm start's global GP; ``max_iter`` L-BFGS-B iterations.
    - ``jitter``, ``init_noise_ratio``, ``*_bounds``: as :class:`.gp.GPR` (bounds relative to the
      cluster's data).
    - ``output_scale`` (default True): multiply each output's predictive variance by its
      profile-likelihood amplitude c_j on the cluster's kernel (``output_scale_``), which
      calibrates the std of the shared-kernel mode per output; the mean is unchanged (module
      doc, "Predictive std and output_scale"). False: the plain kernel's std.
    - ``blend``, ``n_blend``, ``blend_weights``: the blend of the nearest local models.
    - ``n_jobs``, ``dask_scheduler``: where the fits run; ``variance_cache_mb`` the Cholesky cache
      budget; ``random_state`` seeds k-means and the subsets; ``verbose`` logs progress (logger
      ``littledog_mlsim.models.lgpr``, INFO).

    Fitted attributes: ``centers_`` (k, d); ``offsets_`` (k + 1,): cluster c's rows of
    ``X_train_`` (n, d) and ``alpha_`` (n, p) are ``offsets_[c]:offsets_[c+1]``; ``train_index_``
    (n,) the row of ``fit``'s X each stored row came from; ``log_params_`` (k, p, d + 2);
    ``y_mean_``, ``y_std_``, ``output_scale_`` (the amplitudes c_j), ``lml_``, ``n_iter_``
    (k, p); ``jitter_`` (k,); ``fit_seconds_`` (k,) per-cluster wall time in its worker,
    ``fit_cpu_seconds_`` (k,) its CPU time, ``global_cpu_seconds_`` the warm start's;
    ``global_log_params_`` (p, d + 2) or None (cold).
    """

    method = "lgpr"
    supports_std = True

    def __init__(self, *, n_clusters: int | None = None, cluster_size: int = 1000,
                 max_cluster_factor: float = 1.5, min_cluster_factor: float = 0.25,
                 hyperparameters: str = "shared", init: str = "warm",
                 n_hyperparameter_points: int = 500, n_global_points: int = 1000,
                 max_iter: int = 30, jitter: float = DEFAULT_JITTER,
                 init_noise_ratio: float = DEFAULT_INIT_NOISE_RATIO,
                 length_scale_bounds: tuple[float, float] = DEFAULT_LENGTH_SCALE_BOUNDS,
                 signal_variance_bounds: tuple[float, float] = DEFAULT_SIGNAL_VARIANCE_BOUNDS,
                 noise_variance_bounds: tuple[float, float] = DEFAULT_NOISE_VARIANCE_BOUNDS,
                 output_scale: bool = True,
                 blend: bool = False, n_blend: int = 2, blend_weights: str = "precision",
                 n_jobs: int = 1, dask_scheduler: str | None = None,
                 variance_cache_mb: float = 2048.0, random_state: int = 0,
                 verbose: bool = False) -> None:
        self.n_clusters = n_clusters
        self.cluster_size = cluster_size
        self.max_cluster_factor = max_cluster_factor
        self.min_cluster_factor = min_cluster_factor
        self.hyperparameters = hyperparameters
        self.init = init
        self.n_hyperparameter_points = n_hyperparameter_points
        self.n_global_points = n_global_points
        self.max_iter = max_iter
        self.jitter = jitter
        self.init_noise_ratio = init_noise_ratio
        self.length_scale_bounds = length_scale_bounds
        self.signal_variance_bounds = signal_variance_bounds
        self.noise_variance_bounds = noise_variance_bounds
        self.output_scale = output_scale
        self.blend = blend
        self.n_blend = n_blend
        self.blend_weights = blend_weights
        self.n_jobs = n_jobs
        self.dask_scheduler = dask_scheduler
        self.variance_cache_mb = variance_cache_mb
        self.random_state = random_state
        self.verbose = verbose

    # -- fitting

    def _check_params(self) -> None:
        if self.hyperparameters not in HYPERPARAMETER_MODES:
            raise ValueError(f"hyperparameters must be one of {HYPERPARAMETER_MODES}; "
                             f"got {self.hyperparameters!r}")
        if self.init not in INIT_MODES:
            raise ValueError(f"init must be one of {INIT_MODES}; got {self.init!r}")
        if self.blend_weights not in BLEND_WEIGHTS:
            raise ValueError(f"blend_weights must be one of {BLEND_WEIGHTS}; "
                             f"got {self.blend_weights!r}")
        if int(self.n_blend) < 1:
            raise ValueError(f"n_blend must be >= 1; got {self.n_blend}")
        if self.n_clusters is None and int(self.cluster_size) < 1:
            raise ValueError(f"cluster_size must be >= 1; got {self.cluster_size}")
        if int(self.n_hyperparameter_points) < 2 or int(self.n_global_points) < 2:
            raise ValueError("n_hyperparameter_points and n_global_points must be >= 2")

    def _task_options(self) -> dict[str, Any]:
        return {"max_iter": int(self.max_iter), "jitter": float(self.jitter),
                "init_noise_ratio": float(self.init_noise_ratio),
                "length_scale_bounds": tuple(map(float, self.length_scale_bounds)),
                "signal_variance_bounds": tuple(map(float, self.signal_variance_bounds)),
                "noise_variance_bounds": tuple(map(float, self.noise_variance_bounds)),
                "n_hyperparameter_points": int(self.n_hyperparameter_points)}

    def _log(self, text: str) -> None:
        if self.verbose:
            log.info("%s", text)

    def _global_init(self, X: np.ndarray, Y: np.ndarray, rng: np.random.Generator
                     ) -> dict[str, np.ndarray]:
        n, p = Y.shape
        ng = min(n, int(self.n_global_points))
        rows = np.sort(rng.choice(n, size=ng, replace=False))
        shared = self.hyperparameters == "shared"
        opts = self._task_options()
        if shared:
            args = [(X[rows], Y[rows], True, opts)]
        else:
            args = [(X[rows], Y[rows, j:j + 1], False, opts) for j in range(p)]
        t0 = time.perf_counter()
        res = run_tasks(fit_hyperparameters_task, args, n_jobs=self.n_jobs,
                        dask_scheduler=self.dask_scheduler)
        self._log(f"global GP for the warm start on {ng} points: "
                  f"{time.perf_counter() - t0:.1f} s")
        lp = np.vstack([r["log_params"] for r in res])
        sd = np.concatenate([r["y_std"] for r in res])
        self.global_cpu_seconds_ = float(sum(r["cpu_seconds"] for r in res))
        if shared:
            lp = np.broadcast_to(lp[:1], (p, lp.shape[1])).copy()
        return {"log_params": lp, "y_std": sd}

    def fit(self, X: np.ndarray, Y: np.ndarray) -> "LGPR":
        """X (n, d) normalised features, Y (n, p) or (n,) -> self."""
        self._check_params()
        X, Y = check_fit_inputs(X, Y)
        n, d = X.shape
        p = Y.shape[1]
        k_req = (int(self.n_clusters) if self.n_clusters is not None
                 else max(1, int(round(n / int(self.cluster_size)))))
        seed = int(self.random_state) if self.random_state is not None else 0
        rng = np.random.default_rng(seed)
        t0 = time.perf_counter()
        labels, centres = balanced_clusters(X, k_req, max_cluster_factor=self.max_cluster_factor,
                                            min_cluster_factor=self.min_cluster_factor,
                                            random_state=seed)
        k = centres.shape[0]
        sizes = np.bincount(labels, minlength=k)
        self._log(f"{k} clusters (asked {k_req}) of {sizes.min()}..{sizes.max()} points "
                  f"(median {int(np.median(sizes))}) in {time.perf_counter() - t0:.1f} s")
        self.global_cpu_seconds_ = 0.0
        init = self._global_init(X, Y, rng) if self.init == "warm" else None
        self.global_log_params_ = None if init is None else init["log_params"]
        order = np.argsort(labels, kind="stable")
        offsets = np.concatenate([[0], np.cumsum(sizes)]).astype(np.int64)
        opts = self._task_options()
        shared = self.hyperparameters == "shared"
        seeds = np.random.SeedSequence(seed).spawn(k)
        args = [(X[order[offsets[c]:offsets[c + 1]]], Y[order[offsets[c]:offsets[c + 1]]],
                 shared, init, opts, int(seeds[c].generate_state(1)[0]), c) for c in range(k)]
        t1 = time.perf_counter()

        def progress(i: int, r: dict[str, Any]) -> None:
            self._log(f"cluster {i + 1}/{k} fitted ({sizes[i]} points, {r['seconds']:.1f} s; "
                      f"{time.perf_counter() - t1:.0f} s elapsed)")

        res = run_tasks(fit_local_gp, args, n_jobs=self.n_jobs,
                        dask_scheduler=self.dask_scheduler, on_result=progress)
        self.centers_ = centres
        self.offsets_ = offsets
        self.train_index_ = order.astype(np.int64)
        self.X_train_ = X[order]
        self.alpha_ = np.vstack([r["alpha"] for r in res])
        self.log_params_ = np.stack([r["log_params"] for r in res])
        self.y_mean_ = np.stack([r["y_mean"] for r in res])
        self.y_std_ = np.stack([r["y_std"] for r in res])
        self.output_scale_ = np.stack([r["output_scale"] for r in res])
        self.lml_ = np.stack([r["lml"] for r in res])
        self.n_iter_ = np.stack([np.asarray(r["n_iter"], dtype=np.int64) for r in res])
        self.jitter_ = np.array([r["jitter"] for r in res], dtype=np.float64)
        self.fit_seconds_ = np.array([r["seconds"] for r in res])
        self.fit_cpu_seconds_ = np.array([r["cpu_seconds"] for r in res])
        self.n_features_in_, self.n_outputs_ = d, p
        self._prepare_prediction()
        return self

    # -- prediction

    def _prepare_prediction(self) -> None:
        """Per-cluster views and constants of the hot path (no copies)."""
        k = self.centers_.shape[0]
        o = self.offsets_
        self._X = [self.X_train_[o[c]:o[c + 1]] for c in range(k)]
        self._alpha = [self.alpha_[o[c]:o[c + 1]] for c in range(k)]
        self._kernels = [_unique_kernels(self.log_params_[c]) for c in range(k)]
        sf2, _, sn2 = unpack_log_params(self.log_params_)
        self._prior_var = sf2 + sn2  # (k, p) in standardised units
        self._rows = [self._row_factors(c) for c in range(k)]
        self._stacked = self._stacked_rows()
        self._chol: OrderedDict[int, list[np.ndarray]] = OrderedDict()
        self._chol_bytes = 0
        self._variance_prepared = False
        self._variance_dtype = "float64"

    @property
    def n_clusters_(self) -> int:
        return int(self.centers_.shape[0])

    def nearest_cluster(self, X: np.ndarray) -> np.ndarray:
        """Index (n,) of the centre nearest to each row of X (n, d) (first of equal minima)."""
        X = check_predict_inputs(X, self.n_features_in_)
        return nearest_rows(X, self.centers_)

    def cluster_rows(self) -> list[np.ndarray]:
        """The training rows (indices into the ``X`` given to ``fit``) of each cluster."""
        check_is_fitted(self)
        o = self.offsets_
        return [self.train_index_[o[c]:o[c + 1]] for c in range(self.n_clusters_)]

    def _factors(self, c: int) -> list[np.ndarray]:
        """Cholesky factors of cluster c (one per distinct kernel), LRU-cached."""
        f = self._chol.get(c)
        if f is not None:
            self._chol.move_to_end(c)
            return f
        kernels, _ = self._kernels[c]
        f = [gp_cholesky(self._X[c], th, float(self.jitter_[c])) for th in kernels]
        if self._variance_dtype == "float32":
            f = [pack_lower(a) for a in f]
        size = sum(a.nbytes for a in f)
        budget = float(self.variance_cache_mb) * 1e6
        while self._chol and self._chol_bytes + size > budget:
            _, old = self._chol.popitem(last=False)
            self._chol_bytes -= sum(a.nbytes for a in old)
        if size <= budget:
            self._chol[c] = f
            self._chol_bytes += size
        return f

    def prepare_variance(self, dtype: str = "float64") -> int:
        """Build the Cholesky factors for ``return_std`` ahead of time (as many clusters as fit
        in ``variance_cache_mb``); returns the number of clusters cached.

        ``dtype="float32"`` keeps the factors in float32, packed (``gp.pack_lower``: the lower
        triangle only; a run-time choice, not stored in the model): a quarter of float64's
        memory, and half its memory traffic per std, which is what a std costs when the
        learned simulator's step moves to a cluster whose factor is not in cache
        (``benchmarks/sim_node_20x/std_tail``; packing halves the memory, not the traffic). The variance changes by the float32 solve's
        rounding, which is relative to the prior variance (the std's relative change on the
        paper-size model is in that study), by a few per cent where the variance is 1e-4 of
        the prior or less; the mean is untouched. Calling it again with the other dtype
        rebuilds the factors."""
        if dtype not in ("float64", "float32"):
            raise ValueError(f"dtype must be float64 or float32, got {dtype!r}")
        if dtype != self._variance_dtype:
            self._chol.clear()
            self._chol_bytes = 0
            self._variance_dtype = dtype
        budget = float(self.variance_cache_mb) * 1e6
        for c in range(self.n_clusters_):
            m = self._X[c].shape[0]
            # float32 factors are packed (half the square), float64 ones square
            per = m * (m + 1) // 2 * 4 if dtype == "float32" else m * m * 8
            need = self._kernels[c][0].shape[0] * per
            if c not in self._chol and self._chol_bytes + need > budget:
                break  # full: later clusters would only evict earlier ones
            self._factors(c)
        self._variance_prepared = True
        return len(self._chol)

    def _row_factors(self, c: int) -> tuple[np.ndarray, ...] | None:
        """For a cluster whose outputs share one kernel: its inputs centred and divided by the
        length-scales, Z (n, d), stored as (shift, 1 / l, Z^T, |z_i|^2, sf2, sn2), so that the
        kernel rows of queries take one GEMM: |a - z|^2 = |a|^2 + |z|^2 - 2 a.z with
        a = (x - shift) / l. None with per-output kernels (``gp_predict`` serves those)."""
        kernels, _ = self._kernels[c]
        if kernels.shape[0] != 1:
            return None
        sf2, ls, sn2 = unpack_log_params(kernels)
        X = self._X[c]
        shift = X.mean(axis=0)
        inv_l = 1.0 / ls[0]
        Z = (X - shift) * inv_l
        return (shift, inv_l, np.ascontiguousarray(Z.T), np.einsum("ij,ij->i", Z, Z),
                float(sf2[0]), float(sn2[0]))

    def _stacked_rows(self) -> dict[str, np.ndarray] | None:
        """Every cluster's row factors side by side for :meth:`_batch_mean` (shift and 1 / l
        (k, d), the |z|^2 of all clusters in one array with each cluster's start, sf2 (k,));
        None where a cluster has per-output kernels."""
        if any(r is None for r in self._rows):
            return None
        zz = [r[3] for r in self._rows]
        return {"shift": np.stack([r[0] for r in self._rows]),
                "inv_l": np.stack([r[1] for r in self._rows]),
                "zz": np.concatenate(zz),
                "zz_start": np.concatenate([[0], np.cumsum([z.shape[0] for z in zz])[:-1]]
                                           ).astype(np.int64),
                "width": np.array([z.shape[0] for z in zz], dtype=np.int64),
                "sf2": np.array([r[4] for r in self._rows])}

    def _batch_mean(self, X: np.ndarray, labels: np.ndarray,
                    tick: Callable[[str], None] | None = None) -> np.ndarray:
        """The mean of :meth:`_by_cluster` (without the variance), bit for bit, with the
        per-cluster NumPy calls cut to the two products: the queries' scaling, |a|^2 and the
        output units over the whole batch, the kernel rows' elementwise steps in one compiled
        pass (:mod:`.kernel_rows`) and one ``exp`` (the batched simulator's hot path,
        ``benchmarks/sim_node_20x``). ``tick(part)``, where given, is called after each part
        (``prep``, ``gemm1``, ``before``, ``exp``, ``scale``, ``gemm2``, ``out``): a profiler's
        clock (``benchmarks/sim_node_20x/batch_mean_1206/parts.py``)."""
        from .kernel_rows import before_exp, scale_blocks

        tick = tick or (lambda part: None)
        st = self._stacked
        ns, p = X.shape[0], self.n_outputs_
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
            np.matmul(A[r0[b]:r1[b]], self._rows[cl[b]][2],
                      out=K[b0[b]:b1[b]].reshape(r1[b] - r0[b], width[b]))
        tick("gemm1")
        before_exp(K, b0, r0, r1, width, st["zz_start"][cl], aa, st["zz"])
        tick("before")
        np.exp(K, out=K)
        tick("exp")
        scale_blocks(K, b0, b1, st["sf2"][cl])
        tick("scale")
        for b in range(cl.shape[0]):
            np.matmul(K[b0[b]:b1[b]].reshape(r1[b] - r0[b], width[b]), self._alpha[cl[b]],
                      out=mean[r0[b]:r1[b]])
        tick("gemm2")
        mean *= self.y_std_[lab]
        mean += self.y_mean_[lab]
        out = np.empty((ns, p))
        out[order] = mean
        tick("out")
        return out

    def kernel_rows(self, c: int, Xq: np.ndarray) -> tuple[np.ndarray, float, float]:
        """The kernel rows (nq, n_c) of queries Xq against shared-kernel cluster c's training
        inputs by one GEMM, with the kernel's signal and noise variances (sf2, sn2)."""
        shift, inv_l, ZT, zz, sf2, sn2 = self._rows[c]
        A = (Xq - shift) * inv_l
        K = A @ ZT
        K *= -2.0
        K += np.einsum("ij,ij->i", A, A)[:, None]
        K += zz
        np.maximum(K, 0.0, out=K)
        K *= -0.5
        np.exp(K, out=K)
        K *= sf2
        return K, sf2, sn2

    def _shared_kernel_predict(self, c: int, Xq: np.ndarray, want_var: bool
                               ) -> tuple[np.ndarray, np.ndarray | None]:
        """Standardised mean (nq, p) and variance of a shared-kernel cluster from GEMM kernel
        rows (the rollout's hot path: ~1.7x faster than per-dimension differences for a few
        queries, equal to them to rounding; ``benchmarks/rollout_speed/rollout_speed.md``)."""
        K, sf2, sn2 = self.kernel_rows(c, Xq)
        mean = K @ self._alpha[c]
        if not want_var:
            return mean, None
        vq = noisy_variance(self._factors(c)[0], K, sf2, sn2)
        return mean, np.repeat(vq[:, None], mean.shape[1], axis=1)

    def _local(self, c: int, Xq: np.ndarray, want_var: bool
               ) -> tuple[np.ndarray, np.ndarray | None]:
        """Cluster c's GP at Xq (nq, d): mean (nq, p) in output units, variance or None."""
        if want_var and not self._variance_prepared:
            self.prepare_variance()  # all at once: no factorisation later inside a 10 ms step
        if self._rows[c] is not None:
            mean, var = self._shared_kernel_predict(c, Xq, want_var)
        else:
            chol = self._factors(c) if want_var else None
            mean, var = gp_predict(Xq, self._X[c], self._alpha[c], self.log_params_[c], chol)
        mean *= self.y_std_[c]
        mean += self.y_mean_[c]
        if var is not None:
            var *= self._variance_units(c)
        return mean, var

    def _variance_units(self, c: np.ndarray | int) -> np.ndarray:
        """Factor from standardised GP variance to output units for cluster(s) c: y_std^2, times
        the profiled amplitude ``output_scale_`` when ``output_scale`` is on."""
        units = self.y_std_[c] ** 2
        if self.output_scale:
            units = units * self.output_scale_[c]
        return units

    def _by_cluster(self, X: np.ndarray, labels: np.ndarray, want_var: bool
                    ) -> tuple[np.ndarray, np.ndarray | None]:
        ns, p = X.shape[0], self.n_outputs_
        if ns == 1:
            return self._local(int(labels[0]), X, want_var)
        if (not want_var and ns <= BATCH_MEAN_MAX_ROWS
                and getattr(self, "_stacked", None) is not None):   # ns > 1
            return self._batch_mean(X, labels), None
        mean = np.empty((ns, p))
        var = np.empty((ns, p)) if want_var else None
        order = np.argsort(labels, kind="stable")
        bounds = np.flatnonzero(np.diff(labels[order])) + 1
        for rows in np.split(order, bounds):
            mu, v = self._local(int(labels[rows[0]]), X[rows], want_var)
            mean[rows] = mu
            if var is not None:
                var[rows] = v
        return mean, var

    def _blend_weights(self, X: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """(ranks (ns, r) cluster indices, taper g (ns, r)) of the r = min(n_blend, k) nearest."""
        k = self.n_clusters_
        r = min(int(self.n_blend), k)
        D2 = _sqdist_to_centres(X, self.centers_)  # (ns, k)
        take = min(r + 1, k)
        if take < k:
            part = np.argpartition(D2, take - 1, axis=1)[:, :take]
        else:
            part = np.broadcast_to(np.arange(k), (X.shape[0], k))
        d_part = np.take_along_axis(D2, part, axis=1)
        srt = np.lexsort((part, d_part), axis=1)  # by distance, then centre index
        ranks = np.take_along_axis(part, srt, axis=1)
        d_sorted = np.take_along_axis(d_part, srt, axis=1)
        if k > r:
            g = d_sorted[:, r:r + 1] - d_sorted[:, :r]
            dead = ~(g.sum(axis=1) > 0)  # all r + 1 equidistant: nearest only
            g[dead] = 0.0
            g[dead, 0] = 1.0
        else:
            g = np.ones((X.shape[0], r))
        return ranks[:, :r], g

    def predict(self, X: np.ndarray, return_std: bool = False):
        """X (ns, d) -> mean (ns, p); with return_std also the noisy-observation std (ns, p)
        (scaled per output by sqrt(``output_scale_``) when ``output_scale`` is on)."""
        check_is_fitted(self)
        X = check_predict_inputs(X, self.n_features_in_)
        if not self.blend or int(self.n_blend) == 1 or self.n_clusters_ == 1:
            labels = nearest_rows(X, self.centers_)
            mean, var = self._by_cluster(X, labels, return_std)
            if not return_std:
                return mean
            return mean, np.sqrt(var)
        ranks, g = self._blend_weights(X)
        r = ranks.shape[1]
        mus, vs = [], []
        for j in range(r):
            mu, v = self._by_cluster(X, ranks[:, j], True)
            mus.append(mu)
            vs.append(np.maximum(v, np.finfo(np.float64).tiny))
        if self.blend_weights == "relative":  # variance relative to the model's prior variance
            scale = [self._prior_var[ranks[:, j]] * self._variance_units(ranks[:, j])
                     for j in range(r)]
            prec = [s / v for s, v in zip(scale, vs)]
        else:
            prec = [1.0 / v for v in vs]
        w = np.stack([g[:, j:j + 1] * prec[j] for j in range(r)])  # (r, ns, p)
        w /= w.sum(axis=0)
        mu = np.stack(mus)
        mean = np.einsum("rnp,rnp->np", w, mu)
        if not return_std:
            return mean
        second = np.einsum("rnp,rnp->np", w, np.stack(vs) + mu * mu)
        return mean, np.sqrt(np.maximum(second - mean * mean, 0.0))

    # -- persistence

    def get_state(self) -> tuple[dict[str, np.ndarray], dict[str, Any]]:
        check_is_fitted(self)
        arrays = {"centers": self.centers_, "offsets": self.offsets_,
                  "train_index": self.train_index_, "X_train": self.X_train_,
                  "alpha": self.alpha_, "log_params": self.log_params_, "y_mean": self.y_mean_,
                  "y_std": self.y_std_, "output_scale": self.output_scale_, "lml": self.lml_,
                  "n_iter": self.n_iter_, "jitter": self.jitter_, "fit_seconds": self.fit_seconds_,
                  "fit_cpu_seconds": self.fit_cpu_seconds_}
        if self.global_log_params_ is not None:
            arrays["global_log_params"] = self.global_log_params_
        meta = self._size_meta(n_clusters=int(self.n_clusters_),
                               n_train=int(self.X_train_.shape[0]),
                               has_global=self.global_log_params_ is not None,
                               global_cpu_seconds=float(self.global_cpu_seconds_))
        return arrays, meta

    @classmethod
    def from_state(cls, params: dict[str, Any], arrays: dict[str, np.ndarray],
                   meta: dict[str, Any]) -> "LGPR":
        m = cls.from_params(params)
        m._check_params()
        d, p = sizes_from_meta(meta)
        k, n = int(meta["n_clusters"]), int(meta["n_train"])
        f64 = np.float64
        m.centers_ = expect_array(arrays, "centers", (k, d)).astype(f64)
        m.offsets_ = expect_array(arrays, "offsets", (k + 1,)).astype(np.int64)
        if (m.offsets_[0] != 0 or m.offsets_[-1] != n or np.any(np.diff(m.offsets_) < 1)):
            raise ValueError("array 'offsets' is not an increasing partition of the rows")
        m.train_index_ = expect_array(arrays, "train_index", (n,)).astype(np.int64)
        m.X_train_ = expect_array(arrays, "X_train", (n, d)).astype(f64)
        m.alpha_ = expect_array(arrays, "alpha", (n, p)).astype(f64)
        m.log_params_ = expect_array(arrays, "log_params", (k, p, d + 2)).astype(f64)
        m.y_mean_ = expect_array(arrays, "y_mean", (k, p)).astype(f64)
        m.y_std_ = expect_array(arrays, "y_std", (k, p)).astype(f64)
        m.output_scale_ = (expect_array(arrays, "output_scale", (k, p)).astype(f64)
                           if "output_scale" in arrays else np.ones((k, p)))  # older files
        m.lml_ = expect_array(arrays, "lml", (k, p)).astype(f64)
        m.n_iter_ = expect_array(arrays, "n_iter", (k, p)).astype(np.int64)
        m.jitter_ = expect_array(arrays, "jitter", (k,)).astype(f64)
        m.fit_seconds_ = expect_array(arrays, "fit_seconds", (k,)).astype(f64)
        m.fit_cpu_seconds_ = expect_array(arrays, "fit_cpu_seconds", (k,)).astype(f64)
        m.global_cpu_seconds_ = float(meta.get("global_cpu_seconds", 0.0))
        m.global_log_params_ = (expect_array(arrays, "global_log_params", (p, d + 2)).astype(f64)
                                if meta.get("has_global") else None)
        m.n_features_in_, m.n_outputs_ = d, p
        m._prepare_prediction()
        return m


def estimator_bytes(model: LGPR) -> dict[str, int]:
    """Memory of a fitted LGPR's arrays: {"stored": file arrays, "variance_cache": factors}."""
    arrays, _ = model.get_state()
    return {"stored": int(sum(a.nbytes for a in arrays.values())),
            "variance_cache": int(model._chol_bytes)}


__all__ = ["LGPR", "HYPERPARAMETER_MODES", "INIT_MODES", "BLEND_WEIGHTS", "balanced_clusters",
           "fit_local_gp", "fit_hyperparameters_task", "warm_init", "run_tasks",
           "estimator_bytes"]
