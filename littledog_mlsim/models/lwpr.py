"""Locally weighted projection regression (LWPR), written for this project.

Vijayakumar, D'Souza & Schaal (2005), "Incremental online learning in high dimensions",
Neural Computation 17:2602-2634, with the numerical safety heuristics of the authors' reference
library (Klanke, Vijayakumar & Schaal 2008, "A library for locally weighted projection
regression", JMLR 9; C/Matlab, LGPL).  No maintained Python package exists, so this is a
from-scratch NumPy implementation of the same algorithm.

Algorithm (one independent LWPR per output dimension, as in the paper and the library)
-------------------------------------------------------------------------------------
* Receptive field (RF) k has a centre ``c_k``, a distance metric ``D_k = M_k^T M_k`` (``M_k``
  upper triangular, diagonal when ``diag_only``) and a Gaussian kernel
  ``w_k(x) = exp(-0.5 (x - c_k)^T D_k (x - c_k))``.
* Inside each RF an incremental weighted PLS regression: the input and output means (``mean_x``,
  ``beta0``) are tracked with forgetting, then ``R`` projections ``s_r = u_r^T xres_r`` with
  ``xres_{r+1} = xres_r - p_r s_r`` and univariate regressions ``beta_r``; the sufficient
  statistics decay with a per-projection forgetting factor ``lambda`` annealed from
  ``init_lambda`` towards ``final_lambda`` with rate ``tau_lambda``.
* A projection is added when the cross-validated residual MSE of the last projection is below
  ``add_threshold`` times the one before (and enough data has been seen), up to
  ``max_projections``.
* The distance metric is learned by stochastic gradient descent on the leave-one-out cost
  ``J = 1/W sum_i w_i e_cv,i^2 / (1 - w_i s_i^T P s_i)^2 + penalty/d sum_ij D_ij^2`` with
  learning rates ``init_alpha`` (optionally adapted by incremental delta-bar-delta, ``meta``).
* A new RF centred on the sample is created when no RF of that output is activated above
  ``w_gen`` (it copies the metric of the most active RF when that one is trustworthy and
  activated above ``0.1 w_gen``); when two RFs are activated above ``w_prune`` the one with the
  larger ``trace(D)`` (the narrower one) is pruned.
* Prediction is the activation-weighted mean of the local linear models of the trustworthy RFs
  (seen more than ``2 d`` weighted samples) activated above ``cutoff``.

Everything the library does that the paper leaves implicit is kept: RFs start with two
projections, ``lambda_slow`` for the PLS directions, the transient multiplier
``min(1, (sum_e2 / sum_e_cv2)^4)`` on metric steps, halving a learning rate (and skipping the
step) when ``dM > 0.1 max|M|``, the last projection not being used before it has seen ``2 d``
samples, RF creation and pruning exclusive per sample.  Deviations, all documented:

* ``w_update``: only RFs activated above it are updated.  The library hard-codes 0.001; that
  value is the faithful setting (``w_update=0.001``) but the default here is 0.02 for speed,
  see "Cost" below.
* ``max_rfs`` caps the number of RFs per output (the library has no cap); at the cap no new RF
  is created.
* The metric step is skipped when the leverage ``h = w s^T P s >= 1`` (the library divides by
  ``1 - h`` unguarded).
* Far from every RF (no trustworthy RF above ``cutoff``) the library returns 0; here an output
  falls back to the offset ``beta0`` of its RF nearest in its own metric (smallest
  ``(x-c)^T D (x-c)``), so a rollout that leaves the data gets a bounded, data-derived value
  instead of 0 or an extrapolated line. A non-finite query (a diverged rollout) predicts NaN,
  so the divergence is reported rather than hidden.
* Outputs are standardised internally (zero mean, unit variance per output) so that
  ``penalty``, ``add_threshold`` and the meta rate mean the same for every state element; the
  inputs are NOT rescaled: ``init_D`` is in the units of ``X`` (the project feeds features
  normalised to unit variance).
* Pruning removes the RF with the larger ``trace(D)`` (the narrower one), as the library's
  Matlab code and documentation say; its C code has this comparison reversed (marked "TODO").
* Only the Gaussian kernel is implemented; no confidence bounds (``return_std`` is refused).

Vectorisation
-------------
The 33 LWPR models are independent and see the same input ``x`` at every step, so their RFs
live in one packed pool (structure of arrays, padded to the largest projection count) and each
sample is processed ONCE for all outputs: one matrix-vector product gives the squared distance
to every RF of every output (``x^T D x - 2 (D c)^T x + c^T D c``, recomputed exactly for the
candidates), then all activated RFs of all outputs are updated together with array operations,
and RF creation/pruning is decided per output from the two largest activations.  This is the
exact sample-by-sample algorithm — no mini-batching — so the result does not depend on the
vectorisation: ``test/models/test_lwpr.py`` checks it against a plain per-RF, per-projection,
per-metric-element loop written like the library's C code, to 1e-8, including RF creation,
pruning and projection growth, diagonal and full metrics, with and without meta learning.

Prediction uses the equivalent closed form of each local PLS model, ``yhat_k(x) = beta0_k +
slope_k^T (x - mean_x_k)`` with ``slope_k = sum_r beta_r a_r`` and ``a_r = u_r - sum_{q<r}
(u_r^T p_q) a_q`` (what the library caches as ``slope``), so a batch prediction is three
matrix products.

Persistence stores the prediction state only (centres, metric factors ``M``, local means,
offsets, slopes, trust flags, output index, projection counts, output scaling): a loaded model
predicts identically but cannot continue incremental training (``fit`` always restarts from
scratch, as in scikit-learn).

Cost and defaults
-----------------
A sample costs ~O(K d) for the activations (K RFs over all outputs, one float32 GEMV) plus
~O(A R d) for the A RFs it activates above ``w_update`` (R projections). A dominates: RFs are
created where no RF reaches ``w_gen`` but updated down to ``w_update``, so on an m-dimensional
data manifold each sample updates roughly ``(log(1/w_update) / log(1/w_gen))^(m/2)`` RFs per
output; this is why ``w_update`` is the speed/accuracy knob. The library's defaults are kept
except ``init_D`` (the features are normalised, not in [-1, 1]), ``w_gen``, ``w_update``,
``add_threshold``, ``w_prune``, ``init_alpha``, ``max_projections``/``max_rfs`` (bounds) and
``n_epochs``; the measurements behind each choice, the fit times and the paper-scale accuracy
are in ``benchmarks/lwpr_design/README.md``.

Distance metric from GP length-scales (paper Section III)
--------------------------------------------------------
The paper initialised LWPR's metric from the ARD length-scales of the GP.  The ARD kernel
``exp(-0.5 sum_i (x_i - x'_i)^2 / l_i^2)`` is exactly the LWPR kernel with ``D_ii = 1 / l_i^2``;
use :func:`init_D_from_length_scales` (``D_ii = factor / l_i^2``) with ``l`` of shape (d,) or
(n_out, d) — one GP per output, as the paper fitted them; from this project's GPR:
``init_D_from_length_scales(np.exp(gpr.log_params_[:, 1:-1]), factor)`` — and pass the result
as ``init_D``.  ``factor`` > 1 gives narrower RFs than the GP's correlation length (more, more
local models); the RFs must be small enough that the function is locally linear, so try
``factor`` in [1, 4] on a validation split.  Irrelevant features get large ``l_i`` and hence
``D_ii ~ 0``: the RFs do not localise along them, which is what makes LWPR workable in 45-D.
"""
from __future__ import annotations

import logging
import math
import time
from typing import Any, ClassVar

import numpy as np

from .base import (Regressor, check_fit_inputs, check_is_fitted, check_predict_inputs,
                   expect_array, sizes_from_meta, standardise_targets)
from .persistence import register

log = logging.getLogger(__name__)

STATE_FORMAT = "lwpr-1"

# field indices of the packed pool arrays
_C, _MX = 0, 1                                           # vec_d: (K, 2, d)
_M, _D, _ALPHA, _B, _HM = 0, 1, 2, 3, 4                  # metric: (K, 5, d) or (K, 5, d, d)
(_BETA, _SS2, _SSY, _SW, _SECV, _ND, _LAM, _H, _RR) = range(9)   # vec_r: (K, 9, R)
_U, _P, _SXY, _SSX = 0, 1, 2, 3                          # mat_rd: (K, 4, R, d)
_BETA0, _SE2, _SSP, _TRUST = 0, 1, 2, 3                  # scal: (K, 4)


def init_D_from_length_scales(length_scales: np.ndarray, factor: float = 1.0) -> np.ndarray:
    """Diagonal distance metric(s) ``D_ii = factor / l_i^2`` from GP ARD length-scales.

    ``length_scales``: (d,) or (n_out, d) (one GP per output); returns the same shape, ready
    for ``LWPR(init_D=...)``.  Length-scales must be > 0; ``inf`` gives ``D_ii = 0``.
    """
    ls = np.asarray(length_scales, dtype=float)
    if ls.ndim not in (1, 2) or np.any(~(ls > 0)):
        raise ValueError("length_scales must be a (d,) or (n_out, d) array of positive values")
    return float(factor) / ls**2


def _project(U: np.ndarray, P: np.ndarray, z: np.ndarray, n_proj: int,
             want_xres: bool) -> tuple[np.ndarray, np.ndarray | None]:
    """PLS projections of mean-zero inputs ``z`` (A, d) for a batch of RFs.

    ``U``, ``P``: (A, R, d) with zero rows for unused (padded) projections.  Returns ``s``
    (A, R) and, if asked, the input residual before each projection ``xres`` (A, R, d).
    """
    A, R, d = U.shape
    s = np.zeros((A, R))
    xres = np.zeros((A, R, d)) if want_xres else None
    z = z.copy()
    for r in range(n_proj):
        if want_xres:
            xres[:, r] = z
        sr = np.einsum("ad,ad->a", U[:, r], z)
        s[:, r] = sr
        if r + 1 < n_proj:
            z -= P[:, r] * sr[:, None]
    return s, xres


def _local_slopes(U: np.ndarray, P: np.ndarray, beta: np.ndarray,
                  n_used: np.ndarray) -> np.ndarray:
    """Input-space slope of each RF's PLS model: yhat = beta0 + slope . (x - mean_x).

    ``s_r = a_r . x`` with ``a_r = u_r - sum_{q<r} (u_r . p_q) a_q``; only the first ``n_used``
    projections of each RF contribute.  U, P: (K, R, d); beta: (K, R); returns (K, d).
    """
    K, R, d = U.shape
    a = np.zeros((K, R, d))
    slope = np.zeros((K, d))
    for r in range(R):
        ar = U[:, r].copy()
        for q in range(r):
            ar -= np.einsum("kd,kd->k", U[:, r], P[:, q])[:, None] * a[:, q]
        a[:, r] = ar
        slope += np.where((r < n_used)[:, None], beta[:, r, None] * ar, 0.0)
    return slope


def metric_derivatives(M: np.ndarray, dx: np.ndarray, pen: float, second: bool,
                       triu: np.ndarray | None = None):
    """Derivatives w.r.t. the Cholesky factor M of q = |M dx|^2 and J2 = pen sum_ij D_ij^2.

    Batch of RFs: ``M`` (A, d) diagonal factors (``triu`` None) or (A, d, d) upper-triangular
    factors (``triu`` the (d, d) upper-triangular mask), ``dx = x - c`` (A, d).  Returns
    ``dq/dM``, ``dJ2/dM`` and, if ``second``, the element-wise second derivatives
    ``d2q/dM2`` and ``d2J2/dM2`` (else None), all shaped like ``M`` and zero below the
    diagonal.  With D = M^T M: dq/dM_nm = 2 (M dx)_n dx_m, dJ2/dM = 4 pen (M D),
    d2q/dM_nm^2 = 2 dx_m^2, d2J2/dM_nm^2 = 4 pen (D_mm + |M_n.|^2 + M_nm^2).
    """
    if triu is None:
        dqdM = 2.0 * M * dx * dx
        dJ2dM = 4.0 * pen * M**3
        if not second:
            return dqdM, dJ2dM, None, None
        return dqdM, dJ2dM, 2.0 * dx * dx, 12.0 * pen * M * M
    Mdx = np.einsum("aij,aj->ai", M, dx)
    D = np.einsum("aki,akj->aij", M, M)
    dqdM = 2.0 * Mdx[:, :, None] * dx[:, None, :] * triu
    dJ2dM = 4.0 * pen * np.einsum("aik,akj->aij", M, D) * triu
    if not second:
        return dqdM, dJ2dM, None, None
    d2qdM2 = 2.0 * (dx * dx)[:, None, :] * triu
    Dmm = np.einsum("aii->ai", D)
    d2J2dM2 = 4.0 * pen * (Dmm[:, None, :] + np.sum(M * M, axis=2)[:, :, None] + M * M) * triu
    return dqdM, dJ2dM, d2qdM2, d2J2dM2


class _RFPool:
    """All receptive fields of all outputs, packed as a structure of arrays.

    Rows ``0..K-1`` are live; ``out[k]`` is the output dimension RF k belongs to.  Unused
    projection slots r >= nreg[k] are kept "clean" (zero statistics, ``SSs2 = init_S2``) so
    the vectorised updates can run over the padded width and mask.
    """

    def __init__(self, d: int, R: int, diag: bool, init_S2: float, init_lambda: float,
                 capacity: int = 64, screen_dtype: type = np.float32):
        self.d, self.R, self.diag = d, R, diag
        self.init_S2, self.init_lambda = init_S2, init_lambda
        self.K = 0
        self.mshape = (d,) if diag else (d, d)
        self.vec_d = np.zeros((capacity, 2, d))
        self.metric = np.zeros((capacity, 5) + self.mshape)
        self.vec_r = self._clean_vec_r(capacity, R)
        self.mat_rd = np.zeros((capacity, 4, R, d))
        self.scal = np.zeros((capacity, 4))
        self.nreg = np.zeros(capacity, dtype=np.int64)
        self.out = np.zeros(capacity, dtype=np.int64)
        n_feat = 2 * d if diag else d * d + d
        # [D (flattened), D c] so that q ~ Zq @ feat(x) + cDc: only screens candidates (their
        # q is then recomputed exactly), so float32 halves the memory traffic of the GEMV
        # when the terms are small enough for its rounding (see LWPR._start_training)
        self.Zq = np.zeros((capacity, n_feat), dtype=screen_dtype)
        self.cDc = np.zeros(capacity, dtype=screen_dtype)

    def _clean_vec_r(self, n: int, R: int) -> np.ndarray:
        v = np.zeros((n, 9, R))
        v[:, _SS2] = self.init_S2
        v[:, _LAM] = self.init_lambda
        return v

    @property
    def capacity(self) -> int:
        return self.vec_d.shape[0]

    def reserve(self, n_new: int) -> None:
        need = self.K + n_new
        if need <= self.capacity:
            return
        cap = max(need, 2 * self.capacity)
        for name in ("vec_d", "metric", "mat_rd", "scal", "nreg", "out", "Zq", "cDc"):
            old = getattr(self, name)
            new = np.zeros((cap,) + old.shape[1:], dtype=old.dtype)
            new[: self.K] = old[: self.K]
            setattr(self, name, new)
        new = self._clean_vec_r(cap, self.R)
        new[: self.K] = self.vec_r[: self.K]
        self.vec_r = new

    def grow_projections(self, R_new: int) -> None:
        """Widen the projection storage to R_new slots (new slots clean)."""
        cap, R = self.capacity, self.R
        vr = self._clean_vec_r(cap, R_new)
        vr[:, :, :R] = self.vec_r
        mr = np.zeros((cap, 4, R_new, self.d))
        mr[:, :, :R] = self.mat_rd
        self.vec_r, self.mat_rd, self.R = vr, mr, R_new

    def features(self, x: np.ndarray) -> np.ndarray:
        """feat(x) such that (x-c)^T D (x-c) = Zq @ feat(x) + cDc (in Zq's dtype)."""
        if self.diag:
            f = np.concatenate((x * x, -2.0 * x))
        else:
            f = np.concatenate((np.outer(x, x).ravel(), -2.0 * x))
        return f.astype(self.Zq.dtype, copy=False)

    def refresh_distance(self, rows: np.ndarray) -> None:
        D = self.metric[rows, _D]
        c = self.vec_d[rows, _C]
        d = self.d
        if self.diag:
            Dc = D * c
            self.Zq[rows, :d] = D
        else:
            Dc = np.einsum("kij,kj->ki", D, c)
            self.Zq[rows, : d * d] = D.reshape(len(rows), d * d)
        self.Zq[rows, -d:] = Dc
        self.cDc[rows] = np.einsum("ki,ki->k", Dc, c)

    def remove(self, rows: np.ndarray) -> None:
        """Delete RFs (swap with the last live row)."""
        for k in np.sort(np.unique(rows))[::-1]:
            last = self.K - 1
            if k != last:
                for name in ("vec_d", "metric", "vec_r", "mat_rd", "scal", "nreg", "out",
                             "Zq", "cDc"):
                    arr = getattr(self, name)
                    arr[k] = arr[last]
            self.K -= 1


@register
class LWPR(Regressor):
    """LWPR regressor, one independent LWPR model per output (method ``"lwpr"``).

    Parameters (all hyperparameters; see the module docstring for the tuning rationale)
    ----------
    init_D : scalar, (d,) or (n_out, d) — initial diagonal distance metric of new RFs, in
        units of X (see :func:`init_D_from_length_scales` for the GP-derived one).
    w_gen : a new RF is created when no RF of the output is activated above this.
    w_prune : of two RFs activated above this, the narrower one is pruned.
    init_alpha : initial learning rate of the distance metric (scalar).
    penalty : gamma of the metric smoothness penalty (divided by d, as in the library).
    meta, meta_rate : incremental delta-bar-delta adaptation of the learning rates.
    update_D : learn the distance metric (False keeps init_D).
    diag_only : diagonal metric (True) or full upper-triangular Cholesky factor (False;
        O(d^2) per RF per sample — meant for low-dimensional problems).
    init_lambda, final_lambda, tau_lambda : forgetting factor annealing.
    add_threshold : MSE ratio below which a PLS projection is added.
    max_projections : upper bound on PLS projections per RF (also bounded by d).
    init_S2 : initial value of the projection variance statistic.
    max_rfs : maximum number of RFs per output (None: unbounded).
    cutoff : minimal activation of an RF contributing to a prediction.
    w_update : minimal activation of an RF updated by a sample (library: 0.001; the main
        speed/accuracy knob, see "Cost").
    n_epochs : passes over the training data (each in a fresh random order if ``shuffle``).
    shuffle : present the samples in random order each epoch.
    random_state : seed of the shuffling (``seed``, the old name, is still accepted).
    verbose : log one line per epoch (RF counts, training nMSE, time) at INFO level.

    Fitted attributes (RFs of all outputs, sorted by output; K in total): ``centres_`` (K, d),
    ``M_``/``D_`` (K, d) diagonal or (K, d, d), ``mean_x_`` (K, d), ``beta0_`` (K,),
    ``slope_`` (K, d), ``trustworthy_`` (K,), ``output_`` (K,), ``n_projections_`` (K,),
    ``n_rfs_`` (n_out,), ``n_pruned_`` (n_out,), ``y_mean_``/``y_std_`` (n_out,),
    ``history_`` (per epoch: RFs per output, training nMSE during the pass, seconds, RF updates).
    """

    method: ClassVar[str] = "lwpr"
    supports_std: ClassVar[bool] = False
    _renamed_params: ClassVar[dict[str, str]] = {"seed": "random_state"}

    def __init__(self, *, init_D: Any = 0.2, w_gen: float = 0.2, w_prune: float = 0.9,
                 init_alpha: float = 10.0, penalty: float = 1e-6, meta: bool = False,
                 meta_rate: float = 250.0, update_D: bool = True, diag_only: bool = True,
                 init_lambda: float = 0.999, final_lambda: float = 0.99999,
                 tau_lambda: float = 0.9999, add_threshold: float = 0.9,
                 max_projections: int = 10, init_S2: float = 1e-10,
                 max_rfs: int | None = 400, cutoff: float = 0.001, w_update: float = 0.02,
                 n_epochs: int = 1,
                 shuffle: bool = True, random_state: int | None = 0, verbose: bool = False,
                 seed: int | None = None):
        self.init_D = init_D
        self.w_gen = w_gen
        self.w_prune = w_prune
        self.init_alpha = init_alpha
        self.penalty = penalty
        self.meta = meta
        self.meta_rate = meta_rate
        self.update_D = update_D
        self.diag_only = diag_only
        self.init_lambda = init_lambda
        self.final_lambda = final_lambda
        self.tau_lambda = tau_lambda
        self.add_threshold = add_threshold
        self.max_projections = max_projections
        self.init_S2 = init_S2
        self.max_rfs = max_rfs
        self.cutoff = cutoff
        self.w_update = w_update
        self.n_epochs = n_epochs
        self.shuffle = shuffle
        self.random_state = random_state if seed is None else seed
        self.verbose = verbose

    def _init_D_matrix(self, d: int, n_out: int) -> np.ndarray:
        """init_D as (n_out, d) diagonals."""
        D = np.asarray(self.init_D, dtype=float)
        if D.ndim == 0:
            D = np.full((n_out, d), float(D))
        elif D.shape == (d,):
            D = np.tile(D, (n_out, 1))
        elif D.shape != (n_out, d):
            raise ValueError(f"init_D must be a scalar, ({d},) or ({n_out}, {d}); "
                             f"got shape {D.shape}")
        if np.any(~np.isfinite(D)) or np.any(D < 0):
            raise ValueError("init_D must be finite and >= 0")
        return D

    # ------------------------------------------------------------------ training
    def fit(self, X: np.ndarray, Y: np.ndarray) -> "LWPR":
        """X (n, d), Y (n, n_out) or (n,) -> self (retrains from scratch)."""
        X, Y = check_fit_inputs(X, Y)
        if self.max_projections < 1 or self.n_epochs < 0:
            raise ValueError("max_projections must be >= 1 and n_epochs >= 0")
        n, d = X.shape
        n_out = Y.shape[1]
        Yn, y_mean, y_std = standardise_targets(Y)
        self._start_training(d, n_out, float(np.max(np.einsum("ij,ij->i", X, X))))
        rng = np.random.default_rng(self.random_state)
        history: dict[str, list] = {"n_rfs": [], "train_nmse": [], "seconds": [],
                                    "rf_updates": []}
        for epoch in range(self.n_epochs):
            t0 = time.perf_counter()
            order = rng.permutation(n) if self.shuffle else np.arange(n)
            sq_err = np.zeros(n_out)
            for i in order:
                yp = self._train_sample(X[i], Yn[i])
                sq_err += (Yn[i] - yp) ** 2
            dt = time.perf_counter() - t0
            history["n_rfs"].append(self._counts.tolist())
            history["train_nmse"].append((sq_err / n).tolist())  # Yn has unit variance
            history["seconds"].append(dt)
            history["rf_updates"].append(self._n_rf_updates)
            if self.verbose:
                msg = (f"LWPR epoch {epoch + 1}/{self.n_epochs}: {dt:.1f} s, RFs per output "
                       f"{self._counts.min()}..{self._counts.max()} (total {self._pool.K}), "
                       f"{self._n_rf_updates / ((epoch + 1) * n):.0f} RF updates per sample, "
                       f"training nMSE (during the pass) mean {np.mean(sq_err / n):.4f}")
                log.info(msg)
        self.history_ = history
        self.n_pruned_ = self._n_pruned.copy()
        self._set_prediction_state(self._export_arrays(y_mean, y_std))
        del self._pool  # PLS statistics are not needed for prediction
        return self

    def _start_training(self, d: int, n_out: int, max_sq_norm: float = np.inf) -> None:
        """Empty RF pool and the per-fit constants; ``max_sq_norm`` = max |x|^2 of the data."""
        self._d, self._n_out = d, n_out
        self._R_max = int(min(d, self.max_projections))
        self._nreg0 = min(2 if d > 1 else 1, self._R_max)
        D0 = self._init_D_matrix(d, n_out)
        self._init_M = np.sqrt(D0)  # (n_out, d) diagonal Cholesky factors
        self._init_Dm = D0
        # candidates for the exact activation: anything that could exceed the smallest
        # activation threshold used in training (update, template), with a margin for the
        # float32 rounding of the expanded quadratic form
        w_min = min(self.w_update, 0.1 * self.w_gen) if self.w_gen > 0 else self.w_update
        self._q_cand = -2.0 * math.log(max(w_min, 1e-300)) + 1.0
        # float32 screening is safe while the expanded terms (~ D |x|^2, and D may grow while
        # learning) stay far below 1 / float32 eps * the candidate margin
        small = float(np.max(D0)) * max_sq_norm < 1e3
        self._pool = _RFPool(d, self._nreg0, self.diag_only, self.init_S2, self.init_lambda,
                             screen_dtype=np.float32 if small else np.float64)
        self._counts = np.zeros(n_out, dtype=np.int64)
        self._n_pruned = np.zeros(n_out, dtype=np.int64)
        self._max_rfs = np.iinfo(np.int64).max if self.max_rfs is None else int(self.max_rfs)
        self._triu = None if self.diag_only else np.triu(np.ones((d, d)))
        self._n_rf_updates = 0  # RF updates so far (the cost driver: ~K_active per sample)

    def _train_sample(self, x: np.ndarray, y: np.ndarray) -> np.ndarray:
        """One LWPR update of every output with sample (x, y); returns the outputs' predictions
        made during the update (trustworthy RFs only, 0 where none) for the training error."""
        pool = self._pool
        n_out = self._n_out
        yp_out = np.zeros(n_out)
        w_max = np.zeros(n_out)
        w_sec = np.zeros(n_out)
        i_max = np.full(n_out, -1)
        i_sec = np.full(n_out, -1)
        K = pool.K
        if K:
            q_approx = pool.Zq[:K] @ pool.features(x) + pool.cDc[:K]
            cand = np.flatnonzero(q_approx < self._q_cand)
        else:
            cand = np.empty(0, dtype=np.int64)
        if cand.size:
            dx = x - pool.vec_d[cand, _C]
            if self.diag_only:
                q = np.einsum("kd,kd->k", pool.metric[cand, _D], dx * dx)
            else:
                Mdx = np.einsum("kij,kj->ki", pool.metric[cand, _M], dx)
                q = np.einsum("ki,ki->k", Mdx, Mdx)
            w = np.exp(-0.5 * q)
            out_c = pool.out[cand]
            # the two most activated RFs of every output (before the updates, as the library)
            order = np.lexsort((w, out_c))
            o_sorted = out_c[order]
            is_last = np.ones(order.size, dtype=bool)
            is_last[:-1] = o_sorted[1:] != o_sorted[:-1]
            last_pos = np.flatnonzero(is_last)
            groups = o_sorted[last_pos]
            w_max[groups] = w[order[last_pos]]
            i_max[groups] = cand[order[last_pos]]
            prev = last_pos - 1
            has_sec = prev >= 0
            has_sec[has_sec] = o_sorted[prev[has_sec]] == groups[has_sec]
            w_sec[groups[has_sec]] = w[order[prev[has_sec]]]
            i_sec[groups[has_sec]] = cand[order[prev[has_sec]]]

            act = w > self.w_update
            if act.any():
                a = cand[act]
                self._n_rf_updates += a.size
                out_a = out_c[act]
                wa = w[act]
                yp_a, trust_a = self._update_rfs(a, x, dx[act], y[out_a], wa)
                wt = wa * trust_a
                num = np.bincount(out_a, weights=wt * yp_a, minlength=n_out)
                den = np.bincount(out_a, weights=wt, minlength=n_out)
                yp_out = np.divide(num, den, out=np.zeros(n_out), where=den > 0)

        # new RFs where no RF is activated enough (library: exclusive with pruning)
        need = (w_max <= self.w_gen) & (self._counts < self._max_rfs)
        if need.any():
            self._add_rfs(np.flatnonzero(need), x, y, w_max, i_max)
        prune = (w_max > self.w_gen) & (w_sec > self.w_prune) & (i_sec >= 0)
        if prune.any():
            outs = np.flatnonzero(prune)
            tr_max = self._trace_D(i_max[outs])
            tr_sec = self._trace_D(i_sec[outs])
            victims = np.where(tr_max > tr_sec, i_max[outs], i_sec[outs])
            pool.remove(victims)
            np.subtract.at(self._counts, outs, 1)
            np.add.at(self._n_pruned, outs, 1)
        return yp_out

    def _trace_D(self, rows: np.ndarray) -> np.ndarray:
        D = self._pool.metric[rows, _D]
        return D.sum(axis=1) if self.diag_only else np.trace(D, axis1=1, axis2=2)

    def _add_rfs(self, outs: np.ndarray, x: np.ndarray, y: np.ndarray, w_max: np.ndarray,
                 i_max: np.ndarray) -> None:
        pool = self._pool
        n_new = outs.size
        pool.reserve(n_new)
        rows = np.arange(pool.K, pool.K + n_new)
        pool.K += n_new
        d = self._d
        templ = i_max[outs]
        use_t = (w_max[outs] > 0.1 * self.w_gen) & (templ >= 0)
        use_t[use_t] = pool.scal[templ[use_t], _TRUST] > 0

        pool.out[rows] = outs
        pool.vec_d[rows] = 0.0
        pool.vec_d[rows, _C] = x
        pool.scal[rows] = 0.0
        pool.scal[rows, _BETA0] = y[outs]
        pool.mat_rd[rows] = 0.0
        pool.vec_r[rows] = 0.0
        pool.vec_r[rows, _SS2] = self.init_S2
        pool.vec_r[rows, _LAM] = self.init_lambda
        nreg = np.full(n_new, self._nreg0)
        met = np.zeros((n_new, 5) + pool.mshape)
        if self.diag_only:
            met[:, _M] = self._init_M[outs]
            met[:, _D] = self._init_Dm[outs]
            met[:, _ALPHA] = self.init_alpha
        else:
            eye = np.eye(d)
            met[:, _M] = self._init_M[outs][:, :, None] * eye
            met[:, _D] = self._init_Dm[outs][:, :, None] * eye
            met[:, _ALPHA] = self.init_alpha
        if use_t.any():
            t = templ[use_t]
            met[use_t, _M] = pool.metric[t, _M]
            met[use_t, _D] = pool.metric[t, _D]
            met[use_t, _ALPHA] = pool.metric[t, _ALPHA]
            pool.scal[rows[use_t], _BETA0] = pool.scal[t, _BETA0]
            nreg[use_t] = pool.nreg[t]
        met[:, _B] = np.log(met[:, _ALPHA] + 1e-10)
        pool.metric[rows] = met
        pool.nreg[rows] = nreg
        for r in range(int(nreg.max())):
            sel = rows[nreg > r]
            pool.mat_rd[sel, _U, r, r] = 1.0
            pool.mat_rd[sel, _P, r, r] = 1.0
            pool.vec_r[sel, _SW, r] = 1e-10
            pool.vec_r[sel, _ND, r] = 1e-10
        pool.refresh_distance(rows)
        np.add.at(self._counts, outs, 1)

    def _update_rfs(self, a: np.ndarray, x: np.ndarray, dx: np.ndarray, y: np.ndarray,
                    w: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Update the activated RFs ``a`` (A,) with the sample; ``y`` (A,) is each RF's output
        value, ``dx = x - c`` (A, d), ``w`` (A,) their activations.  Returns each RF's
        prediction during the update and its trust flag (after the update)."""
        pool = self._pool
        d = self._d
        nreg = pool.nreg[a]
        R = n_proj = int(nreg.max())      # work on the used projection slots only
        vd = np.take(pool.vec_d, a, axis=0)
        # (np.take on these strided views would copy the whole pool first)
        vr = pool.vec_r[a, :, :R] if R < pool.R else np.take(pool.vec_r, a, axis=0)
        mr = pool.mat_rd[a, :, :R] if R < pool.R else np.take(pool.mat_rd, a, axis=0)
        sc = np.take(pool.scal, a, axis=0)
        mean_x = vd[:, _MX]
        beta, SSs2, SSY, sum_w, secv, ndata, lam, H, rr = (vr[:, i] for i in range(9))
        U, P, SXY, SSX = mr[:, _U], mr[:, _P], mr[:, _SXY], mr[:, _SSX]
        beta0, sum_e2, SSp, trust = sc[:, _BETA0], sc[:, _SE2], sc[:, _SSP], sc[:, _TRUST]
        A = a.size
        ar = np.arange(A)
        pm = np.arange(R) < nreg[:, None]

        # weighted means (library: update_means)
        swl = sum_w[:, 0] * lam[:, 0]
        inv = 1.0 / (swl + w)
        mean_x[:] = (swl[:, None] * mean_x + w[:, None] * x) * inv[:, None]
        xmz = x - mean_x
        beta0[:] = (swl * beta0 + w * y) * inv
        ymz = y - beta0

        # incremental PLS (library: update_regression)
        s, xres = _project(U, P, xmz, n_proj, want_xres=True)
        yres = np.cumsum(beta * s, axis=1)
        sum_w[:] = np.where(pm, sum_w * lam + w[:, None], sum_w)
        e_cv = ymz[:, None] - yres                     # CV residual after r+1 projections
        ytarget = np.empty_like(e_cv)
        ytarget[:, 0] = ymz
        ytarget[:, 1:] = e_cv[:, :-1]
        # padded slots stay clean without (A, R, d) masks: their s, and here ytarget, are 0
        lam_slow = 0.9 + 0.1 * lam
        wyt = np.where(pm, w[:, None] * ytarget, 0.0)
        SXY *= lam_slow[:, :, None]
        SXY += wyt[:, :, None] * xres
        un2 = np.einsum("ard,ard->ar", SXY, SXY)
        ok_u = pm & (un2 > 1e-24)
        scale = 1.0 / np.sqrt(np.where(ok_u, un2, 1.0))
        np.multiply(SXY, scale[:, :, None], out=U, where=ok_u[:, :, None])
        ws = w[:, None] * s
        SSs2[:] = np.where(pm, lam * SSs2 + s * ws, SSs2)
        SSY[:] = np.where(pm, lam * SSY + ytarget * ws, SSY)
        SSX *= lam[:, :, None]
        SSX += ws[:, :, None] * xres
        inv_s2 = 1.0 / SSs2
        beta[:] = np.where(pm, SSY * inv_s2, 0.0)
        np.multiply(SSX, inv_s2[:, :, None], out=P)
        last = nreg - 1
        SSp[:] = lam[ar, last] * SSp + np.sum(np.where(pm, ws * ws * inv_s2, 0.0), axis=1)

        s, _ = _project(U, P, xmz, n_proj, want_xres=False)   # with the updated model
        last_ok = ndata[ar, last] > 2.0 * d                  # last projection usable yet?
        n_used = nreg - (~last_ok)
        ypred = np.sum(np.where(np.arange(R) < n_used[:, None], beta * s, 0.0), axis=1)
        e_cv_R = np.where(n_used > 0, e_cv[ar, np.maximum(n_used - 1, 0)], ymz)
        e = ymz - ypred
        ok_err = ndata[:, 0] * (1.0 - lam[:, 0]) > 0.1
        sum_e2[:] = np.where(ok_err, sum_e2 * lam[ar, last] + w * e * e, sum_e2)
        secv[:] = np.where(ok_err[:, None] & pm, secv * lam + w[:, None] * e_cv * e_cv, secv)
        yp = ypred + beta0
        trust[:] = np.where(ndata[:, 0] > 2.0 * d, 1.0, trust)

        # distance metric (library: update_distance_metric)
        met = None
        if self.update_D:
            derivok = pm & (ndata * (1.0 - lam[:, :1]) > 0.1)
            h = w * np.sum(np.where(derivok, s * s / SSs2, 0.0), axis=1)
            upd = np.flatnonzero(derivok[:, 0] & (h < 1.0))
            if upd.size:
                met = np.take(pool.metric, a, axis=0)
                e_idx = np.where(nreg == 1, 0, np.where(last_ok, nreg - 1, nreg - 2))
                self._metric_step(met, upd, dx, w, s, e, e_cv_R, h, derivok,
                                  secv[ar, e_idx], sum_w[:, 0], sum_e2, SSs2, lam, H, rr)

        # add a PLS projection?  (library: check_add_projection)
        added = np.empty(0, dtype=np.int64)
        can = (nreg < self._R_max) & (nreg >= 2)
        if can.any():
            i1 = np.maximum(nreg - 1, 0)
            i0 = np.maximum(nreg - 2, 0)
            mse1 = secv[ar, i1] / sum_w[ar, i1] + 1e-10
            mse0 = secv[ar, i0] / sum_w[ar, i0] + 1e-10
            add = (can & (mse1 < self.add_threshold * mse0)
                   & (ndata[ar, i1] > 0.99 * ndata[:, 0])
                   & (ndata[ar, i1] * (1.0 - lam[ar, i1]) > 0.5))
            added = np.flatnonzero(add)
            SSp[added] = 0.0

        # data counts and forgetting-factor annealing (of the existing projections)
        ndata[:] = np.where(pm, ndata * lam + 1.0, ndata)
        lam[:] = np.where(pm, self.tau_lambda * lam
                          + self.final_lambda * (1.0 - self.tau_lambda), lam)

        pool.vec_d[a] = vd
        pool.vec_r[a, :, :R] = vr
        pool.mat_rd[a, :, :R] = mr
        pool.scal[a] = sc
        if added.size:
            # the new slot j = nreg was clean; it starts as in the library (n_data 0, sum_w
            # 1e-10, lambda init) and takes this step's count and annealing like the others
            if int(nreg[added].max()) >= pool.R:
                pool.grow_projections(pool.R + 1)
            rows, j = a[added], nreg[added]
            pool.mat_rd[rows, _U, j, j] = 1.0
            pool.mat_rd[rows, _P, j, j] = 1.0
            pool.vec_r[rows, _SS2, j] = self.init_S2
            pool.vec_r[rows, _SW, j] = 1e-10
            pool.vec_r[rows, _ND, j] = 1.0
            pool.vec_r[rows, _LAM, j] = (self.tau_lambda * self.init_lambda
                                         + self.final_lambda * (1.0 - self.tau_lambda))
            nreg[added] += 1
        pool.nreg[a] = nreg
        if met is not None:
            pool.metric[a] = met
            pool.refresh_distance(a)
        return yp, trust.copy()

    def _metric_step(self, met: np.ndarray, u: np.ndarray, dx: np.ndarray, w: np.ndarray,
                     s: np.ndarray, e: np.ndarray, e_cv: np.ndarray, h: np.ndarray,
                     derivok: np.ndarray, E: np.ndarray, W: np.ndarray, sum_e2: np.ndarray,
                     SSs2: np.ndarray, lam: np.ndarray, H: np.ndarray, rr: np.ndarray) -> None:
        """Stochastic leave-one-out gradient step on M for the rows ``u`` of the gathered
        batch (in place on ``met``, ``H``, ``rr``)."""
        d = self._d
        pen = self.penalty / d
        M = met[u, _M]
        alpha = met[u, _ALPHA]
        w, s, e, e_cv, h, E, W = w[u], s[u], e[u], e_cv[u], h[u], E[u], W[u]
        ok = derivok[u]
        dxu = dx[u]
        tm = np.minimum(1.0, (sum_e2[u] / (E + 1e-10)) ** 4)   # transient multiplier
        Ps = np.where(ok, s / SSs2[u], 0.0)
        Pse = e[:, None] * Ps
        e_cv2 = e_cv * e_cv
        Hu, ru = H[u], rr[u]
        dJ1dw = (-E / W + e_cv2 - np.sum(2.0 * Pse * Hu + 2.0 * Ps * Ps * ru, axis=1)) / W
        dwdq = -0.5 * w
        wW = w / W
        bc = (slice(None),) + (None,) * (M.ndim - 1)
        triu = self._triu
        dqdM, dJ2dM, d2qdM2, d2J2dM2 = metric_derivatives(M, dxu, pen, self.meta, triu)
        dwdM = dwdq[bc] * dqdM
        dJdM = wW[bc] * dJ2dM + dJ1dw[bc] * dwdM
        if self.meta:
            ddwdqdq = 0.25 * w
            sPse = np.sum(s * Pse, axis=1)
            ddJ1 = (2.0 * (e * e * h / w - e_cv2 / W) + E / W**2
                    + np.sum(4.0 * (Pse / W[:, None] + Ps * sPse[:, None]) * Hu, axis=1)) / W
            ddwdMdM = ddwdqdq[bc] * dqdM**2 + dwdq[bc] * d2qdM2
            ddJ2dMdM = d2J2dM2
            ddJdMdM = wW[bc] * ddJ2dMdM + ddwdMdM * dJ1dw[bc] + dwdM**2 * ddJ1[bc]
            hm = met[u, _HM]
            step = np.clip(self.meta_rate * tm[bc] * dJdM * hm, -0.1, 0.1)
            b = np.clip(met[u, _B] - step, -10.0, 10.0)
            alpha = np.exp(b)
            decay = np.maximum(0.0, 1.0 - alpha * ddJdMdM * tm[bc])
            met[u, _HM] = hm * decay - alpha * tm[bc] * dJdM
            met[u, _B] = b
        axes = tuple(range(1, M.ndim))
        maxM = np.max(np.abs(M), axis=axes)
        delta = alpha * tm[bc] * dJdM
        big = delta > 0.1 * maxM[bc]
        alpha = np.where(big, 0.5 * alpha, alpha)
        M = np.where(big, M, M - delta)
        met[u, _M] = M
        met[u, _ALPHA] = alpha
        met[u, _D] = M * M if self.diag_only else np.einsum("aki,akj->aij", M, M)
        lam_u = lam[u]
        H[u] = np.where(ok, lam_u * Hu + (w / (1.0 - h) * e_cv * tm)[:, None] * s, Hu)
        rr[u] = np.where(ok, lam_u * ru
                         + (w * w * e_cv2 / (1.0 - h) * tm)[:, None] * s * s, ru)

    # ------------------------------------------------------------------ prediction state
    def _export_arrays(self, y_mean: np.ndarray, y_std: np.ndarray) -> dict[str, np.ndarray]:
        pool = self._pool
        K, d = pool.K, self._d
        # sort by output so every output's RFs are contiguous
        order = np.argsort(pool.out[:K], kind="stable")
        U = pool.mat_rd[order, _U]
        P = pool.mat_rd[order, _P]
        beta = pool.vec_r[order, _BETA]
        nreg = pool.nreg[order]
        ndata_last = pool.vec_r[order, _ND][np.arange(K), nreg - 1] if K else np.zeros(0)
        n_used = nreg - (ndata_last <= 2.0 * d)
        return {
            "centres": pool.vec_d[order, _C].copy(),
            "M": pool.metric[order, _M].copy(),
            "mean_x": pool.vec_d[order, _MX].copy(),
            "beta0": pool.scal[order, _BETA0].copy(),
            "slope": _local_slopes(U, P, beta, n_used),
            "trustworthy": pool.scal[order, _TRUST] > 0,
            "output": pool.out[order].copy(),
            "n_projections": nreg.copy(),
            "y_mean": np.asarray(y_mean, dtype=float).copy(),
            "y_std": np.asarray(y_std, dtype=float).copy(),
        }

    def _set_prediction_state(self, arrays: dict[str, np.ndarray]) -> None:
        c = np.asarray(arrays["centres"], dtype=float)
        M = np.asarray(arrays["M"], dtype=float)
        K, d = c.shape
        n_out = np.asarray(arrays["y_mean"]).shape[0]
        out = np.asarray(arrays["output"], dtype=np.int64)
        if M.shape not in ((K, d), (K, d, d)) or out.shape != (K,):
            raise ValueError("inconsistent LWPR state arrays")
        if K and (out.min() < 0 or out.max() >= n_out or np.any(np.diff(out) < 0)):
            raise ValueError("LWPR state: output index out of range or unsorted")
        diag = M.ndim == 2
        self.centres_ = c
        self.M_ = M
        self.D_ = M * M if diag else np.einsum("kai,kaj->kij", M, M)
        self.mean_x_ = np.asarray(arrays["mean_x"], dtype=float)
        self.beta0_ = np.asarray(arrays["beta0"], dtype=float)
        self.slope_ = np.asarray(arrays["slope"], dtype=float)
        self.trustworthy_ = np.asarray(arrays["trustworthy"], dtype=bool)
        self.output_ = out
        self.n_projections_ = np.asarray(arrays["n_projections"], dtype=np.int64)
        self.y_mean_ = np.asarray(arrays["y_mean"], dtype=float)
        self.y_std_ = np.asarray(arrays["y_std"], dtype=float)
        self.n_features_in_ = d
        self.n_outputs_ = n_out
        self.n_rfs_ = np.bincount(out, minlength=n_out)
        # prediction cache: distances q = Zq @ feat(x) + cDc, local models b + slope . x
        if diag:
            Dc = self.D_ * c
            self._pred_Zq = np.concatenate((self.D_, Dc), axis=1)
        else:
            Dc = np.einsum("kij,kj->ki", self.D_, c)
            self._pred_Zq = np.concatenate((self.D_.reshape(K, d * d), Dc), axis=1)
        self._pred_cDc = np.einsum("ki,ki->k", Dc, c)
        self._pred_offset = self.beta0_ - np.einsum("ki,ki->k", self.slope_, self.mean_x_)
        self._pred_group = np.zeros((K, n_out))
        self._pred_group[np.arange(K), out] = 1.0
        self._pred_bounds = np.searchsorted(out, np.arange(n_out + 1))

    def predict(self, X: np.ndarray, return_std: bool = False) -> np.ndarray:
        """X (m, d) -> (m, n_out): activation-weighted mean of the local linear models."""
        self._check_std(return_std)
        check_is_fitted(self)
        X = check_predict_inputs(X, self.n_features_in_)
        out = np.empty((X.shape[0], self.n_outputs_))
        chunk = max(1, 2_000_000 // max(1, self.centres_.shape[0]))
        for start in range(0, X.shape[0], chunk):
            out[start:start + chunk] = self._predict_chunk(X[start:start + chunk])
        # a non-finite query (a diverged rollout) has no activation: say so instead of the
        # nearest-RF fallback, which would hand back a finite, made-up state
        out[~np.isfinite(X).all(axis=1)] = np.nan
        return out

    def _predict_chunk(self, X: np.ndarray) -> np.ndarray:
        n, d = X.shape
        n_out = self.n_outputs_
        if self.M_.ndim == 2:
            feat = np.concatenate((X * X, -2.0 * X), axis=1)
        else:
            feat = np.concatenate(((X[:, :, None] * X[:, None, :]).reshape(n, d * d),
                                   -2.0 * X), axis=1)
        q = feat @ self._pred_Zq.T + self._pred_cDc           # (n, K)
        np.maximum(q, 0.0, out=q)
        w = np.exp(-0.5 * q)
        w[:, ~self.trustworthy_] = 0.0
        w[w <= self.cutoff] = 0.0
        y_loc = X @ self.slope_.T + self._pred_offset           # (n, K)
        num = (w * y_loc) @ self._pred_group
        den = w @ self._pred_group
        Yn = np.divide(num, den, out=np.zeros((n, n_out)), where=den > 0)
        # fallback: no trustworthy RF above cutoff -> offset of the nearest RF of the output
        for o in np.flatnonzero(np.any(den <= 0, axis=0)):
            lo, hi = self._pred_bounds[o], self._pred_bounds[o + 1]
            rows = np.flatnonzero(den[:, o] <= 0)
            if hi > lo:
                nearest = lo + np.argmin(q[np.ix_(rows, np.arange(lo, hi))], axis=1)
                Yn[rows, o] = self.beta0_[nearest]
            else:
                Yn[rows, o] = 0.0
        return Yn * self.y_std_ + self.y_mean_

    # ------------------------------------------------------------------ persistence
    def get_state(self) -> tuple[dict[str, np.ndarray], dict[str, Any]]:
        """Prediction state: per-RF arrays (K = sum of n_rfs, sorted by output) + scaling."""
        check_is_fitted(self)
        arrays = {
            "centres": self.centres_, "M": self.M_, "mean_x": self.mean_x_,
            "beta0": self.beta0_, "slope": self.slope_, "trustworthy": self.trustworthy_,
            "output": self.output_, "n_projections": self.n_projections_,
            "y_mean": self.y_mean_, "y_std": self.y_std_,
        }
        meta = {
            "format": STATE_FORMAT,
            "n_features_in": int(self.n_features_in_),
            "n_outputs": int(self.n_outputs_),
            "n_rfs": [int(k) for k in self.n_rfs_],
            "diag_only": bool(self.M_.ndim == 2),
            "history": getattr(self, "history_", None),
            "n_pruned": ([int(k) for k in self.n_pruned_] if hasattr(self, "n_pruned_")
                         else None),
        }
        return {k: np.array(v) for k, v in arrays.items()}, meta

    @classmethod
    def from_state(cls, params: dict[str, Any], arrays: dict[str, np.ndarray],
                   meta: dict[str, Any]) -> "LWPR":
        if meta.get("format") != STATE_FORMAT:
            raise ValueError(f"unknown LWPR state format {meta.get('format')!r} "
                             f"(this version reads {STATE_FORMAT!r})")
        d, p = sizes_from_meta(meta)
        n_rfs = [int(k) for k in meta["n_rfs"]]
        if len(n_rfs) != p:
            raise ValueError(f"n_rfs lists {len(n_rfs)} outputs, expected {p}")
        K = sum(n_rfs)
        m_shape = (K, d) if meta["diag_only"] else (K, d, d)
        state = {name: expect_array(arrays, name, shape) for name, shape in (
            ("centres", (K, d)), ("M", m_shape), ("mean_x", (K, d)), ("beta0", (K,)),
            ("slope", (K, d)), ("trustworthy", (K,)), ("output", (K,)),
            ("n_projections", (K,)), ("y_mean", (p,)), ("y_std", (p,)))}
        if np.any(np.bincount(state["output"].astype(np.int64), minlength=p) != n_rfs):
            raise ValueError("array 'output' does not match n_rfs")
        est = cls.from_params(params)
        est._set_prediction_state(state)
        if meta.get("history") is not None:
            est.history_ = meta["history"]
        if meta.get("n_pruned") is not None:
            est.n_pruned_ = np.asarray(meta["n_pruned"], dtype=np.int64)
        return est
