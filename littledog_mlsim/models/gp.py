"""Full Gaussian process regression with an ARD squared-exponential kernel (paper Section III).

Kernel, for inputs x, x' in R^d:

    k(x, x') = sf2 * exp(-0.5 * sum_d (x_d - x'_d)^2 / l_d^2) + (sn2 + jitter) * [x is x']

Hyperparameters live in log space as one vector per output, in scikit-learn's order for
``ConstantKernel(sf2) * RBF(length_scale=l) + WhiteKernel(sn2)``::

    log_params = [log sf2, log l_1, ..., log l_d, log sn2]        shape (d + 2,)

``jitter`` is a fixed constant on the diagonal (scikit-learn's ``alpha``), not a hyperparameter.
If the kernel matrix is not positive definite at the requested jitter (e.g. at an L-BFGS-B
start), the fit raises it along :func:`jitter_schedule` (up to 1e-2 x the prior variance) and
records the jitter used (``GPFit.jitter``, ``GPR.jitter_``); only when that fails too does it
raise :class:`NotPositiveDefiniteError`, with the reason in one line.

Near-constant input columns (:func:`_data_scales`): a column whose std is below
``DEGENERATE_STD_RTOL`` x max(largest column std, |column mean|) -- a constant column whose std
is rounding noise (``np.std`` of 559 copies of 1.3 is 8e-15), a saturated tanh -- carries no
information, and the std-relative length-scale bounds and start would be absurd (l ~ 1e-14). Such
a column gets the unit scale, as an exactly constant one always had: its length scale keeps its
start value (its LML gradient is zero) and it cannot shrink the kernel. Squared distances are
computed on column-centred inputs, so a column's offset never cancels catastrophically against
its spread (before, (x / l)^2 ~ 1e28 for l ~ 1e-14 left garbage in K).

The building blocks are plain functions so that other regressors reuse them (SoR fits its
hyperparameters on a subset with :func:`fit_gp_hyperparameters`; LGPR fits one GP per cluster):

- :func:`lml_and_grad`  log marginal likelihood and its analytic gradient w.r.t. ``log_params``,
  Cholesky based, O(n^3 + n^2 d) time and O(n^2) memory (no n x n x d array).
- :func:`fit_gp_hyperparameters`  L-BFGS-B on one data set, per-output or shared hyperparameters.
- :func:`gp_posterior` / :func:`gp_predict`  weights and predictions for fixed hyperparameters.
- :class:`GPR`  the estimator (``method = "gpr"``).

Multi-output: the paper fits one GP per state element. Every output has its own hyperparameters
(``shared=False``: 33 independent GPs on one X, optimised one after the other or in threads); with
``shared=True`` all outputs share one kernel, so one Cholesky serves every output and the LML is
the sum over outputs. Predictions for all outputs share one pass over the squared per-dimension
differences (see :func:`cross_kernel`).
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import Any, Iterator, Sequence

import numpy as np
import scipy.linalg as sla
from scipy.optimize import minimize

from .base import (Regressor, check_fit_inputs, check_is_fitted, check_predict_inputs,
                   expect_array, sizes_from_meta, standardise_targets)

DEFAULT_JITTER = 1e-10
# Bounds on hyperparameters, relative to the data: length scales as multiples of each input
# dimension's standard deviation, variances as multiples of the output's variance.
DEFAULT_LENGTH_SCALE_BOUNDS = (1e-2, 1e3)
DEFAULT_SIGNAL_VARIANCE_BOUNDS = (1e-3, 1e3)
DEFAULT_NOISE_VARIANCE_BOUNDS = (1e-6, 1e1)
DEFAULT_INIT_NOISE_RATIO = 1e-2
DEFAULT_INIT_LENGTH_SCALE_FACTORS = (1.0, 0.5, 0.25)
# A column whose std is at most this times max(largest column std, |column mean|) is treated as
# constant (unit scale): float64 rounding noise of a constant feature is ~1e-16 of its size.
DEGENERATE_STD_RTOL = 1e-10
# Jitter escalation when K is not positive definite: these multiples of the prior variance
# sf2 + sn2 after the requested jitter (see jitter_schedule).
JITTER_ESCALATION = (1e-8, 1e-6, 1e-4, 1e-2)
_LOG_2PI = float(np.log(2.0 * np.pi))
# Elements per block when building cross-kernels (bounds the temporary (c, n, d) array: 32 MB).
_BLOCK_ELEMENTS = 1 << 22
# Query batches up to this size build all outputs' cross-kernels in one pass over the (ns, n, d)
# differences; larger ones loop over kernels with one GEMM each. At n = 1000, d = 45, p = 33 (BLAS
# on one thread) the one-pass path is 3-25x faster for 1-8 queries and the crossover fell between
# 8 and 32 queries in two runs on the noisy 2-core machine: see the "Cross-kernel paths" table of
# benchmarks/gp_fit_vs_sklearn/gp_fit_vs_sklearn.md (made with --predict-paths).
_FEW_QUERIES = 8


# ----------------------------------------------------------------------------- parameters

def n_log_params(n_features: int) -> int:
    """Length of one output's log-hyperparameter vector: d + 2."""
    return n_features + 2


def unpack_log_params(log_params: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """log_params (..., d + 2) -> (sf2 (...,), l (..., d), sn2 (...,)) in natural units."""
    p = np.exp(np.asarray(log_params, dtype=np.float64))
    return p[..., 0], p[..., 1:-1], p[..., -1]


def degenerate_columns(X: np.ndarray) -> np.ndarray:
    """Mask (d,) of the columns of X (n, d) that are constant up to rounding.

    Column j is degenerate if std_j <= ``DEGENERATE_STD_RTOL`` * max(max_k std_k, |mean_j|): its
    spread is rounding noise relative to its own size or negligible next to the other columns.
    """
    sx = X.std(axis=0)
    ref = np.max(sx, initial=0.0)
    return ~(sx > DEGENERATE_STD_RTOL * np.maximum(ref, np.abs(X.mean(axis=0))))


def _data_scales(X: np.ndarray, Y: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Per-dimension std of X (d,) and per-output variance of Y (p,).

    Degenerate columns (:func:`degenerate_columns`: constant up to rounding) get the unit scale
    (features are expected on a normalised scale); a zero output variance becomes 1.
    """
    sx = X.std(axis=0)
    sx = np.where(degenerate_columns(X) | ~np.isfinite(sx), 1.0, sx)
    vy = Y.var(axis=0)
    vy = np.where(np.isfinite(vy) & (vy > 0), vy, 1.0)
    return sx, vy


def median_distance(X: np.ndarray, max_points: int = 1000, random_state: Any = 0) -> float:
    """Median pairwise Euclidean distance between rows of X (on at most ``max_points`` rows)."""
    n = X.shape[0]
    if n > max_points:
        X = X[np.random.default_rng(random_state).choice(n, max_points, replace=False)]
    if X.shape[0] < 2:
        return 1.0
    d2 = _sqdist_self(X)
    iu = np.triu_indices(X.shape[0], 1)
    med = float(np.sqrt(np.median(d2[iu])))
    return med if med > 0 else 1.0


def default_init(X: np.ndarray, Y: np.ndarray,
                 noise_ratio: float = DEFAULT_INIT_NOISE_RATIO,
                 length_scale_factors: Sequence[float] = DEFAULT_INIT_LENGTH_SCALE_FACTORS,
                 max_points: int = 1000, jitter: float = DEFAULT_JITTER) -> np.ndarray:
    """Median-heuristic start point, one row per output: (p, d + 2).

    ``l_d = c * std(X_d) * r`` where ``r`` is the median pairwise distance of the standardised
    inputs (with c = 1 a median pair has kernel value exp(-0.5); on standardised data all l_d
    are equal); ``sf2 = var(y)``, ``sn2 = noise_ratio * var(y)``. The factor c is chosen per
    output among ``length_scale_factors`` by the highest LML on at most ``max_points`` rows: in
    45-D, c = 1 often starts L-BFGS-B in the basin of the "everything is noise" optimum when the
    response depends on a few inputs only (see test_gp.py). ``Y`` may be (n,) or (n, p).
    """
    X, Y = check_fit_inputs(X, Y)
    sx, vy = _data_scales(X, Y)
    Xc = (X - X.mean(axis=0)) / sx
    r = median_distance(Xc, max_points)
    p, d = Y.shape[1], X.shape[1]
    factors = np.asarray(length_scale_factors, dtype=np.float64).ravel()
    cands = np.empty((factors.size, p, d + 2))
    cands[:, :, 0] = np.log(vy)
    cands[:, :, 1:-1] = np.log(np.multiply.outer(factors, sx * r))[:, None, :]
    cands[:, :, -1] = np.log(noise_ratio * vy)
    if factors.size == 1:
        return cands[0]
    rows = np.arange(X.shape[0])
    if rows.size > max_points:
        rows = np.sort(np.random.default_rng(0).choice(rows, max_points, replace=False))
    Xs, Ys = X[rows], Y[rows] - Y[rows].mean(axis=0)
    lml = np.array([[log_marginal_likelihood(cands[f, j], Xs, Ys[:, j], jitter)[0]
                     for j in range(p)] for f in range(factors.size)])  # (factors, p)
    return cands[np.argmax(lml, axis=0), np.arange(p)]


def default_bounds(X: np.ndarray, Y: np.ndarray,
                   length_scale_bounds: Sequence[float] = DEFAULT_LENGTH_SCALE_BOUNDS,
                   signal_variance_bounds: Sequence[float] = DEFAULT_SIGNAL_VARIANCE_BOUNDS,
                   noise_variance_bounds: Sequence[float] = DEFAULT_NOISE_VARIANCE_BOUNDS,
                   ) -> np.ndarray:
    """Bounds on log_params relative to the data, one block per output: (p, d + 2, 2).

    Length scale l_d in ``length_scale_bounds * std(X_d)`` (std 1 for a column that is constant
    up to rounding, see :func:`degenerate_columns`); sf2 in ``signal_variance_bounds * var(y)``;
    sn2 in ``noise_variance_bounds * var(y)``.
    """
    X, Y = check_fit_inputs(X, Y)
    sx, vy = _data_scales(X, Y)
    p, d = Y.shape[1], X.shape[1]
    b = np.empty((p, d + 2, 2))
    b[:, 0, :] = np.log(np.outer(vy, signal_variance_bounds))
    b[:, 1:-1, :] = np.log(np.multiply.outer(sx, np.asarray(length_scale_bounds, float)))[None]
    b[:, -1, :] = np.log(np.outer(vy, noise_variance_bounds))
    return b


# ----------------------------------------------------------------------------- kernel

def _sqdist_self(Z: np.ndarray) -> np.ndarray:
    """Squared Euclidean distances between rows of Z (n, d) -> (n, n), exactly symmetric."""
    s = np.einsum("ij,ij->i", Z, Z)
    D = Z @ Z.T  # syrk: symmetric
    D *= -2.0
    D += s[:, None]
    D += s[None, :]
    np.maximum(D, 0.0, out=D)
    np.fill_diagonal(D, 0.0)
    return D


def _centred(X: np.ndarray, shift: np.ndarray | None = None) -> np.ndarray:
    """X (n, d) minus its column means (or ``shift``): the kernel is translation invariant, and
    |a|^2 + |b|^2 - 2 a.b on centred rows does not cancel a column's offset against its spread."""
    X = np.asarray(X, dtype=np.float64)
    return X - (X.mean(axis=0) if shift is None else shift)


def kernel_matrix(X: np.ndarray, log_params: np.ndarray) -> np.ndarray:
    """Noise-free ARD-SE kernel of X (n, d) with itself for one output's log_params -> (n, n)."""
    sf2, ls, _ = unpack_log_params(log_params)
    D = _sqdist_self(_centred(X) / ls)
    D *= -0.5
    np.exp(D, out=D)
    D *= sf2
    return D


def _sqdist_cross(A: np.ndarray, B: np.ndarray) -> np.ndarray:
    """Squared Euclidean distances between rows of A (na, d) and B (nb, d) -> (na, nb).

    Uses |a|^2 + |b|^2 - 2 a.b (one GEMM), clipped at zero.
    """
    D = A @ B.T
    D *= -2.0
    D += np.einsum("ij,ij->i", A, A)[:, None]
    D += np.einsum("ij,ij->i", B, B)[None, :]
    np.maximum(D, 0.0, out=D)
    return D


def kernel_cross(A: np.ndarray, B: np.ndarray, log_params: np.ndarray) -> np.ndarray:
    """Noise-free ARD-SE cross-kernel k(A, B) for one output's log_params: (na, nb).

    A (na, d), B (nb, d). One (na, d) x (d, nb) GEMM (on inputs centred at B's mean); see
    :func:`cross_kernel` for many kernels.
    """
    sf2, ls, _ = unpack_log_params(log_params)
    B = np.asarray(B, dtype=np.float64)
    shift = B.mean(axis=0)
    D = _sqdist_cross(_centred(A, shift) / ls, _centred(B, shift) / ls)
    D *= -0.5
    np.exp(D, out=D)
    D *= sf2
    return D


def _blocks(n_rows: int, row_cost: int) -> Iterator[slice]:
    """Row slices whose temporaries stay below ``_BLOCK_ELEMENTS``."""
    step = max(1, _BLOCK_ELEMENTS // max(1, row_cost))
    for a in range(0, n_rows, step):
        yield slice(a, min(n_rows, a + step))


def cross_kernel(Xs: np.ndarray, X: np.ndarray, log_params: np.ndarray) -> np.ndarray:
    """Noise-free cross-covariances for q kernels at once: (ns, n, q).

    Xs (ns, d), X (n, d), log_params (q, d + 2) or (d + 2,) (-> q = 1). The squared
    per-dimension differences are formed once per block and contracted with every kernel's
    1/l^2 in one matrix product, so q outputs cost one pass over (ns, n, d) plus an (ns n, d) x
    (d, q) product. Exact differences (no cancellation for nearby points).
    """
    lp = np.atleast_2d(np.asarray(log_params, dtype=np.float64))
    sf2, ls, _ = unpack_log_params(lp)
    inv_l2 = 1.0 / ls**2  # (q, d)
    ns, n, d = Xs.shape[0], X.shape[0], X.shape[1]
    out = np.empty((ns, n, lp.shape[0]))
    for sl in _blocks(ns, n * max(d, lp.shape[0])):
        diff = Xs[sl, None, :] - X[None, :, :]  # (c, n, d)
        np.square(diff, out=diff)
        E = diff.reshape(-1, d) @ inv_l2.T  # (c n, q)
        E *= -0.5
        np.exp(E, out=E)
        E *= sf2
        out[sl] = E.reshape(-1, n, lp.shape[0])
    return out


# ----------------------------------------------------------------------------- likelihood

def _cholesky(K: np.ndarray) -> tuple[np.ndarray, bool]:
    """In-place lower Cholesky factor (scipy ``cho_factor`` form) of K (n, n)."""
    return sla.cho_factor(K, lower=True, overwrite_a=True, check_finite=False)


def lml_and_grad(log_params: np.ndarray, X: np.ndarray, y: np.ndarray,
                 jitter: float = DEFAULT_JITTER) -> tuple[float, np.ndarray]:
    """Log marginal likelihood and its gradient w.r.t. log_params (d + 2,).

    X (n, d); y (n,) or (n, p) — with p > 1 the p columns share the hyperparameters and the LML
    is their sum. Returns (lml, grad (d + 2,)); (-inf, zeros) if K is not positive definite.

    With K = Kf + (sn2 + jitter) I, alpha = K^-1 y and W = alpha alpha^T - p K^-1:
    d lml / d log sf2 = 1/2 sum(W o Kf); d lml / d log sn2 = sn2/2 tr(W); and, because
    dK/d log l_d = Kf o D_d with D_d[i, j] = (x_id - x_jd)^2 / l_d^2, writing M = W o Kf and
    Z = X / l: d lml / d log l_d = (M 1)^T Z_d^2 - Z_d^T M Z_d, i.e. ``r @ Z**2 - sum(Z * (M @ Z))``
    — O(n^2 d) via one (n, n) x (n, d) product.
    """
    lp = np.asarray(log_params, dtype=np.float64)
    X = np.asarray(X, dtype=np.float64)
    Y = np.asarray(y, dtype=np.float64)
    if Y.ndim == 1:
        Y = Y[:, None]
    n, p = Y.shape
    sf2, ls, sn2 = unpack_log_params(lp)
    Z = _centred(X) / ls
    Kf = _sqdist_self(Z)
    Kf *= -0.5
    np.exp(Kf, out=Kf)
    Kf *= sf2
    K = Kf.copy()
    K.flat[:: n + 1] += sn2 + jitter
    try:
        c = _cholesky(K)
    except np.linalg.LinAlgError:
        return -np.inf, np.zeros_like(lp)
    L = c[0]
    alpha = sla.cho_solve(c, Y, check_finite=False)
    lml = float(-0.5 * np.einsum("ij,ij->", Y, alpha) - p * np.log(np.diag(L)).sum()
                - 0.5 * n * p * _LOG_2PI)
    Kinv, info = sla.lapack.dpotri(L, lower=1, overwrite_c=1)
    if info != 0:
        return -np.inf, np.zeros_like(lp)
    W = np.tril(Kinv)
    W += np.tril(Kinv, -1).T
    del Kinv, L, c, K
    W *= -p
    W += alpha @ alpha.T
    trW = float(np.trace(W))
    W *= Kf  # M = W o Kf, in place
    M = W
    grad = np.empty_like(lp)
    grad[0] = 0.5 * M.sum()
    r = M.sum(axis=1)
    grad[1:-1] = r @ (Z * Z) - np.einsum("ij,ij->j", Z, M @ Z)
    grad[-1] = 0.5 * sn2 * trW
    return lml, grad


def log_marginal_likelihood(log_params: np.ndarray, X: np.ndarray, y: np.ndarray,
                            jitter: float = DEFAULT_JITTER) -> np.ndarray:
    """LML per output without the gradient (cheaper: no K^-1). y (n,) or (n, p) -> (p,)."""
    lp = np.asarray(log_params, dtype=np.float64)
    X = np.asarray(X, dtype=np.float64)
    Y = np.asarray(y, dtype=np.float64)
    if Y.ndim == 1:
        Y = Y[:, None]
    n = Y.shape[0]
    _, _, sn2 = unpack_log_params(lp)
    K = kernel_matrix(X, lp)
    K.flat[:: n + 1] += sn2 + jitter
    try:
        c = _cholesky(K)
    except np.linalg.LinAlgError:
        return np.full(Y.shape[1], -np.inf)
    alpha = sla.cho_solve(c, Y, check_finite=False)
    return (-0.5 * np.einsum("ij,ij->j", Y, alpha) - np.log(np.diag(c[0])).sum()
            - 0.5 * n * _LOG_2PI)


# ----------------------------------------------------------------------------- jitter

class NotPositiveDefiniteError(ValueError):
    """The kernel matrix stayed non positive definite along the whole jitter schedule."""


def jitter_schedule(jitter: float, prior_variance: float) -> list[float]:
    """Jitters to try in turn: ``jitter``, then ``JITTER_ESCALATION`` x ``prior_variance``
    (sf2 + sn2) where larger. Kf is positive semi-definite up to rounding (~n eps sf2), so with
    finite hyperparameters the schedule ends on a positive definite matrix."""
    out = [float(jitter)]
    if np.isfinite(prior_variance) and prior_variance > 0:
        out += [f * float(prior_variance) for f in JITTER_ESCALATION
                if f * prior_variance > out[-1]]
    return out


def _prior_variance(log_params: np.ndarray) -> float:
    """Largest sf2 + sn2 over rows of log_params (..., d + 2) (inf if one overflows)."""
    sf2, _, sn2 = unpack_log_params(log_params)
    return float(np.max(sf2 + sn2))


def _npd_reason(log_params: np.ndarray, jitter: float) -> str:
    lp = np.asarray(log_params, dtype=np.float64)
    with np.errstate(over="ignore"):
        natural = np.exp(lp)
    if not np.all(np.isfinite(natural)):
        return (f"non-finite hyperparameters (log params up to {np.max(np.abs(lp)):.3g}: "
                f"exp overflows); check the init and bounds")
    return (f"not positive definite even with jitter {jitter:.3g} "
            f"({jitter / _prior_variance(lp):.0e} x sf2 + sn2)")


def gp_posterior_stable(X: np.ndarray, Y: np.ndarray, log_params: np.ndarray,
                        jitter: float = DEFAULT_JITTER
                        ) -> tuple[np.ndarray, np.ndarray, float]:
    """:func:`gp_posterior` along :func:`jitter_schedule` -> (alpha, lml, jitter used).

    Raises NotPositiveDefiniteError (one line, with the reason) if no jitter of the schedule
    gives positive definite matrices.
    """
    lp = np.atleast_2d(np.asarray(log_params, dtype=np.float64))
    schedule = jitter_schedule(jitter, _prior_variance(lp))
    for j in schedule:
        try:
            alpha, lml = gp_posterior(X, Y, lp, j)
        except np.linalg.LinAlgError:
            continue
        if np.all(np.isfinite(alpha)) and np.all(np.isfinite(lml)):  # potrf passes inf/NaN
            return alpha, lml, j
    raise NotPositiveDefiniteError(f"GP kernel matrix ({np.shape(X)[0]} points): "
                                   f"{_npd_reason(lp, schedule[-1])}")


# ----------------------------------------------------------------------------- fitting

@dataclass
class GPFit:
    """Result of :func:`fit_gp_hyperparameters` for p outputs (rows equal when shared)."""

    log_params: np.ndarray  # (p, d + 2)
    lml: np.ndarray         # (p,) each output's LML at its optimum
    n_iter: np.ndarray      # (p,) L-BFGS-B iterations of the best start
    n_fev: np.ndarray       # (p,) LML evaluations over all starts
    converged: np.ndarray   # (p,) bool, L-BFGS-B reported success for the best start
    shared: bool
    jitter: float = DEFAULT_JITTER  # the jitter the optimisation used (largest over outputs)


def _optimise_escalating(X: np.ndarray, Y: np.ndarray, starts: np.ndarray, bounds: np.ndarray,
                         max_iter: int, jitter: float
                         ) -> tuple[np.ndarray, float, int, int, bool, float]:
    """:func:`_optimise` at ``jitter``, and along :func:`jitter_schedule` while no start gives a
    positive definite K. Returns (log_params, lml, nit, nfev, ok, jitter used)."""
    schedule = jitter_schedule(jitter, _prior_variance(starts))
    fev = 0
    for j in schedule:
        try:
            theta, lml, nit, nfev, ok = _optimise(X, Y, starts, bounds, max_iter, j)
            return theta, lml, nit, fev + nfev, ok, j
        except NotPositiveDefiniteError as e:
            fev += getattr(e, "nfev", 0)
    raise NotPositiveDefiniteError(
        f"GP kernel matrix ({X.shape[0]} points) at every start point: "
        f"{_npd_reason(starts, schedule[-1])}")


def _optimise(X: np.ndarray, Y: np.ndarray, starts: np.ndarray, bounds: np.ndarray,
              max_iter: int, jitter: float) -> tuple[np.ndarray, float, int, int, bool]:
    """L-BFGS-B from each start in ``starts`` (s, d + 2); best (log_params, lml, nit, nfev, ok).

    Raises NotPositiveDefiniteError (``nfev`` attribute) if K is not positive definite at
    every start.
    """
    def objective(theta: np.ndarray) -> tuple[float, np.ndarray]:
        f, g = lml_and_grad(theta, X, Y, jitter)
        if not np.isfinite(f):
            return np.inf, np.zeros_like(theta)
        return -f, -g

    best: tuple[np.ndarray, float, int, int, bool] | None = None
    total_fev = 0
    for x0 in starts:
        res = minimize(objective, x0, jac=True, method="L-BFGS-B", bounds=bounds,
                       options={"maxiter": int(max_iter)})
        total_fev += int(res.nfev)
        lml = -float(res.fun)
        if best is None or lml > best[1]:
            best = (np.asarray(res.x, dtype=np.float64), lml, int(res.nit), 0, bool(res.success))
    assert best is not None
    if not np.isfinite(best[1]):
        err = NotPositiveDefiniteError("GP kernel matrix is not positive definite at any start "
                                       f"point with jitter {jitter:g}")
        err.nfev = total_fev
        raise err
    return best[0], best[1], best[2], total_fev, best[4]


def fit_gp_hyperparameters(X: np.ndarray, Y: np.ndarray, *, shared: bool = False,
                           init: np.ndarray | None = None, bounds: np.ndarray | None = None,
                           max_iter: int = 200, n_restarts: int = 0,
                           restart_log_std: float = 1.0, random_state: Any = None,
                           jitter: float = DEFAULT_JITTER, n_jobs: int = 1) -> GPFit:
    """Maximise the LML of one data set by L-BFGS-B with the analytic gradient.

    X (n, d); Y (n,) or (n, p). ``shared=False``: one hyperparameter vector per output, each fitted
    on its own column; ``shared=True``: one vector for all columns (LML summed; one Cholesky per
    evaluation serves all outputs). ``init``: (d + 2,) or (p, d + 2) log_params, default
    :func:`default_init`. ``bounds``: (d + 2, 2) or (p, d + 2, 2) on log_params, default
    :func:`default_bounds`. ``n_restarts`` extra starts at init + N(0, restart_log_std^2) in log
    space (clipped to bounds); the best LML wins. ``n_jobs`` > 1 fits outputs in threads (LAPACK
    releases the GIL) with BLAS limited to one thread meanwhile. Cost per LML evaluation:
    O(n^3 / 3) Cholesky + O(n^3 / 3) inverse (LAPACK potri) + O(n^2 d); memory about four n x n
    float64 matrices. If K is not positive definite at any start point the jitter is raised
    along :func:`jitter_schedule` (the jitter used is ``GPFit.jitter``, the largest over outputs);
    raises NotPositiveDefiniteError if even the last jitter fails.
    """
    X, Y = check_fit_inputs(X, Y)
    n, d = X.shape
    p = Y.shape[1]
    k = n_log_params(d)
    init_arr = default_init(X, Y) if init is None else np.asarray(init, dtype=np.float64)
    bounds_arr = default_bounds(X, Y) if bounds is None else np.asarray(bounds, dtype=np.float64)
    if init_arr.shape not in ((k,), (p, k)):
        raise ValueError(f"init must be ({k},) or ({p}, {k}); got {init_arr.shape}")
    if bounds_arr.shape not in ((k, 2), (p, k, 2)):
        raise ValueError(f"bounds must be ({k}, 2) or ({p}, {k}, 2); got {bounds_arr.shape}")
    init_arr = np.broadcast_to(init_arr, (p, k))
    bounds_arr = np.broadcast_to(bounds_arr, (p, k, 2))
    rng = np.random.default_rng(random_state)

    def starts_for(x0: np.ndarray, b: np.ndarray) -> np.ndarray:
        x0 = np.clip(x0, b[:, 0], b[:, 1])
        extra = x0 + restart_log_std * rng.standard_normal((n_restarts, k))
        return np.vstack([x0[None], np.clip(extra, b[:, 0], b[:, 1])])

    if shared:
        if init is None:  # average the per-output heuristics
            x0 = init_arr.mean(axis=0)
        else:
            x0 = init_arr[0]
        b = np.stack([bounds_arr[:, :, 0].min(axis=0), bounds_arr[:, :, 1].max(axis=0)], 1)
        theta, _, nit, nfev, ok, jit = _optimise_escalating(X, Y, starts_for(x0, b), b,
                                                            max_iter, jitter)
        lp = np.broadcast_to(theta, (p, k)).copy()
        return GPFit(lp, log_marginal_likelihood(theta, X, Y, jit), np.full(p, nit),
                     np.full(p, nfev), np.full(p, ok), True, jit)

    starts = [starts_for(init_arr[j], bounds_arr[j]) for j in range(p)]  # rng order fixed

    def one(j: int) -> tuple[np.ndarray, float, int, int, bool, float]:
        return _optimise_escalating(X, Y[:, j], starts[j], bounds_arr[j], max_iter, jitter)

    if n_jobs == 1 or p == 1:
        results = [one(j) for j in range(p)]
    else:  # threads (LAPACK and NumPy release the GIL), each with a single-threaded BLAS
        from joblib import Parallel, delayed
        from threadpoolctl import threadpool_limits
        with threadpool_limits(limits=1, user_api="blas"):
            results = Parallel(n_jobs=n_jobs, prefer="threads")(delayed(one)(j)
                                                                for j in range(p))
    return GPFit(np.stack([r[0] for r in results]), np.array([r[1] for r in results]),
                 np.array([r[2] for r in results]), np.array([r[3] for r in results]),
                 np.array([r[4] for r in results]), False, max(r[5] for r in results))


# ----------------------------------------------------------------------------- posterior

def _unique_kernels(log_params: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(p, d + 2) -> (distinct rows (q, d + 2), index (p,) of each output's row)."""
    lp = np.atleast_2d(log_params)
    if np.all(lp == lp[:1]):
        return lp[:1], np.zeros(lp.shape[0], dtype=np.intp)
    return lp, np.arange(lp.shape[0])


def gp_cholesky(X: np.ndarray, log_params: np.ndarray, jitter: float = DEFAULT_JITTER
                ) -> np.ndarray:
    """Lower Cholesky factor of Kf + (sn2 + jitter) I for one output: (n, n) (upper half zero).

    Raises numpy.linalg.LinAlgError if the matrix is not positive definite.
    """
    _, _, sn2 = unpack_log_params(log_params)
    K = kernel_matrix(X, log_params)
    K.flat[:: K.shape[0] + 1] += sn2 + jitter
    return np.tril(_cholesky(K)[0])


def gp_posterior(X: np.ndarray, Y: np.ndarray, log_params: np.ndarray,
                 jitter: float = DEFAULT_JITTER) -> tuple[np.ndarray, np.ndarray]:
    """Weights alpha = (K_j + (sn2_j + jitter) I)^-1 y_j (n, p) and each output's LML (p,).

    X (n, d), Y (n, p), log_params (p, d + 2) (or (d + 2,) shared). Outputs with identical
    hyperparameters share one Cholesky. Raises numpy.linalg.LinAlgError if a K is not positive
    definite.
    """
    X, Y = check_fit_inputs(X, Y)
    n = X.shape[0]
    lp = np.broadcast_to(np.atleast_2d(log_params), (Y.shape[1], X.shape[1] + 2))
    kernels, idx = _unique_kernels(lp)
    alpha = np.empty_like(Y)
    lml = np.empty(Y.shape[1])
    for q, theta in enumerate(kernels):
        cols = np.flatnonzero(idx == q)
        L = gp_cholesky(X, theta, jitter)
        a = sla.cho_solve((L, True), Y[:, cols], check_finite=False)
        alpha[:, cols] = a
        lml[cols] = (-0.5 * np.einsum("ij,ij->j", Y[:, cols], a) - np.log(np.diag(L)).sum()
                     - 0.5 * n * _LOG_2PI)
    return alpha, lml


def pack_lower(chol: np.ndarray, dtype=np.float32) -> np.ndarray:
    """The lower triangle of ``chol`` (n, n), row by row, as one 1-D array of n (n + 1) / 2:
    BLAS's column-major packed upper triangle of its transpose (for stpsv with ``trans=1``)."""
    return np.ascontiguousarray(chol[np.tril_indices(chol.shape[0])], dtype=dtype)


def noisy_variance(chol: np.ndarray, Kq: np.ndarray, sf2: float, sn2: float) -> np.ndarray:
    """Predictive variance (c,) of a noisy observation at c queries, sf2 + sn2 - k*^T K^-1 k*,
    from the lower Cholesky factor (n, n) of K and the kernel rows Kq (c, n).

    A float32 factor (``LGPR.prepare_variance(dtype="float32")``) solves in float32 (half the
    memory traffic) and sums the squares in float64. A 1-D float32 ``chol`` is the factor packed
    (:func:`pack_lower`: its lower triangle row by row, n (n + 1) / 2 numbers, half the memory of
    the square; the solve reads as many bytes), solved by BLAS stpsv one query at a time."""
    if chol.ndim == 1:
        out = np.empty(Kq.shape[0])
        for i, k in enumerate(Kq):
            v = sla.blas.stpsv(Kq.shape[1], chol, k.astype(np.float32), lower=0, trans=1)
            out[i] = np.dot(v, v.astype(np.float64))
        return np.maximum(sf2 + sn2 - out, 0.0)
    if chol.dtype == np.float32:
        if Kq.shape[0] == 1 and chol.flags.c_contiguous:   # one query: BLAS strsv directly
            # (C-order lower L is F-order upper L^T: solve L^T^T v = k without a copy)
            v = sla.blas.strsv(chol.T, Kq[0].astype(np.float32), lower=0, trans=1)[:, None]
        else:
            v = sla.solve_triangular(chol, Kq.T.astype(np.float32), lower=True,
                                     check_finite=False)
        return np.maximum(sf2 + sn2 - np.einsum("ij,ij->j", v, v, dtype=np.float64), 0.0)
    v = sla.solve_triangular(chol, Kq.T, lower=True, check_finite=False)
    return np.maximum(sf2 + sn2 - np.einsum("ij,ij->j", v, v), 0.0)


def gp_predict(Xs: np.ndarray, X: np.ndarray, alpha: np.ndarray, log_params: np.ndarray,
               cholesky: Sequence[np.ndarray] | None = None
               ) -> tuple[np.ndarray, np.ndarray | None]:
    """Posterior mean (ns, p) and, if ``cholesky`` is given, predictive variance (ns, p).

    Xs (ns, d) queries, X (n, d) training inputs, alpha (n, p) from :func:`gp_posterior`,
    log_params (p, d + 2). ``cholesky``: one lower factor (n, n) per distinct kernel, in the
    order of :func:`_unique_kernels` (from :func:`gp_cholesky`). The variance is that of a noisy
    observation, sf2 + sn2 - k*^T K^-1 k* (as scikit-learn reports with a WhiteKernel).

    Up to ``_FEW_QUERIES`` queries (a rollout step) use :func:`cross_kernel` for all outputs at
    once; larger batches loop over the distinct kernels with one GEMM each (:func:`kernel_cross`).
    """
    p = alpha.shape[1]
    lp = np.broadcast_to(np.atleast_2d(log_params), (p, X.shape[1] + 2))
    kernels, idx = _unique_kernels(lp)
    q_count = kernels.shape[0]
    sf2, _, sn2 = unpack_log_params(kernels)
    cols = [np.flatnonzero(idx == q) for q in range(q_count)]
    ns, n = Xs.shape[0], X.shape[0]
    mean = np.empty((ns, p))
    var = None if cholesky is None else np.empty((ns, p))

    def add_variance(sl: slice, q: int, Kq: np.ndarray) -> None:  # Kq (c, n)
        assert var is not None and cholesky is not None
        var[sl, cols[q]] = noisy_variance(cholesky[q], Kq, sf2[q], sn2[q])[:, None]

    if ns <= _FEW_QUERIES:
        Ks = cross_kernel(Xs, X, kernels)  # (ns, n, q)
        if q_count == 1:
            mean[:] = Ks[:, :, 0] @ alpha
        else:
            mean[:] = np.einsum("cnp,np->cp", Ks, alpha)
        if var is not None:
            for q in range(q_count):
                add_variance(slice(None), q, Ks[:, :, q])
        return mean, var
    for sl in _blocks(ns, n):
        for q in range(q_count):
            Kq = kernel_cross(Xs[sl], X, kernels[q])  # (c, n)
            mean[sl, cols[q]] = Kq @ alpha[:, cols[q]]
            if var is not None:
                add_variance(sl, q, Kq)
    return mean, var


# ----------------------------------------------------------------------------- estimator

class GPR(Regressor):
    """Full GP regression, one GP per output (paper Section III), scikit-learn style.

    fit(X (n, d), Y (n, p)) optimises each output's ARD-SE hyperparameters by L-BFGS-B on the
    LML (or uses ``init_log_params`` as they are when ``optimize=False``); predict(X (m, d))
    -> (m, p), with ``return_std=True`` also the predictive std (m, p) of a noisy observation.

    Hyperparameters are expressed for the targets the GP sees: standardised per output when
    ``normalize_y`` (the default), raw otherwise. Bounds are relative to the data (see
    :func:`default_bounds`). Memory: X (n d) + alpha (n p); the first ``return_std`` call caches
    one n x n Cholesky factor per output (p n^2 8 bytes; one in total when shared).

    Fitted attributes: ``X_train_`` (n, d), ``alpha_`` (n, p), ``log_params_`` (p, d + 2),
    ``y_mean_`` (p,), ``y_std_`` (p,), ``lml_`` (p,), ``jitter_`` (the jitter actually used:
    ``jitter`` unless K needed more, see :func:`jitter_schedule`), ``n_features_in_``,
    ``n_outputs_``.
    """

    method = "gpr"
    supports_std = True

    def __init__(self, *, shared_hyperparameters: bool = False, normalize_y: bool = True,
                 optimize: bool = True, init_log_params: list | None = None,
                 max_iter: int = 200, n_restarts: int = 0, restart_log_std: float = 1.0,
                 jitter: float = DEFAULT_JITTER,
                 init_noise_ratio: float = DEFAULT_INIT_NOISE_RATIO,
                 length_scale_bounds: tuple[float, float] = DEFAULT_LENGTH_SCALE_BOUNDS,
                 signal_variance_bounds: tuple[float, float] = DEFAULT_SIGNAL_VARIANCE_BOUNDS,
                 noise_variance_bounds: tuple[float, float] = DEFAULT_NOISE_VARIANCE_BOUNDS,
                 random_state: int | None = 0, n_jobs: int = 1) -> None:
        self.shared_hyperparameters = shared_hyperparameters
        self.normalize_y = normalize_y
        self.optimize = optimize
        self.init_log_params = init_log_params
        self.max_iter = max_iter
        self.n_restarts = n_restarts
        self.restart_log_std = restart_log_std
        self.jitter = jitter
        self.init_noise_ratio = init_noise_ratio
        self.length_scale_bounds = length_scale_bounds
        self.signal_variance_bounds = signal_variance_bounds
        self.noise_variance_bounds = noise_variance_bounds
        self.random_state = random_state
        self.n_jobs = n_jobs

    # -- fitting

    def hyperparameter_options(self, X: np.ndarray, Yn: np.ndarray) -> dict[str, Any]:
        """Keyword arguments for :func:`fit_gp_hyperparameters` from this estimator's settings.

        X (n, d), Yn (n, p) the targets as the GP sees them (standardised if ``normalize_y``).
        """
        init = (default_init(X, Yn, self.init_noise_ratio) if self.init_log_params is None
                else np.asarray(self.init_log_params, dtype=np.float64))
        bounds = default_bounds(X, Yn, self.length_scale_bounds, self.signal_variance_bounds,
                                self.noise_variance_bounds)
        return dict(shared=self.shared_hyperparameters, init=init, bounds=bounds,
                    max_iter=self.max_iter, n_restarts=self.n_restarts,
                    restart_log_std=self.restart_log_std, random_state=self.random_state,
                    jitter=self.jitter, n_jobs=self.n_jobs)

    def _normalise_targets(self, Y: np.ndarray) -> np.ndarray:
        Yn, self.y_mean_, self.y_std_ = standardise_targets(Y, bool(self.normalize_y))
        return Yn

    def fit(self, X: np.ndarray, Y: np.ndarray) -> "GPR":
        """X (n, d), Y (n, p) or (n,) -> self."""
        X, Y = check_fit_inputs(X, Y)
        p, k = Y.shape[1], n_log_params(X.shape[1])
        Yn = self._normalise_targets(Y)
        opts = self.hyperparameter_options(X, Yn)
        jitter = float(self.jitter)
        if self.optimize:
            res = fit_gp_hyperparameters(X, Yn, **opts)
            self.log_params_ = res.log_params
            self.n_iter_ = res.n_iter
            jitter = res.jitter
        else:
            if self.init_log_params is None:
                raise ValueError("optimize=False needs init_log_params")
            init = np.asarray(self.init_log_params, dtype=np.float64)
            if init.shape not in ((k,), (p, k)):
                raise ValueError(f"init_log_params must be ({k},) or ({p}, {k}); "
                                 f"got {init.shape}")
            self.log_params_ = np.broadcast_to(init, (p, k)).copy()
            self.n_iter_ = np.zeros(p, dtype=int)
        self.X_train_ = X
        self.alpha_, self.lml_, self.jitter_ = gp_posterior_stable(X, Yn, self.log_params_,
                                                                   jitter)
        self.n_features_in_ = X.shape[1]
        self.n_outputs_ = p
        self._chol = None
        return self

    # -- prediction

    def _cholesky_factors(self) -> list[np.ndarray]:
        if getattr(self, "_chol", None) is None:
            kernels, _ = _unique_kernels(self.log_params_)
            jitter = float(getattr(self, "jitter_", self.jitter))
            self._chol = [gp_cholesky(self.X_train_, th, jitter) for th in kernels]
        return self._chol

    def predict(self, X: np.ndarray, return_std: bool = False):
        """X (m, d) -> mean (m, p); with return_std also std (m, p) (noisy-observation std)."""
        check_is_fitted(self)
        X = check_predict_inputs(X, self.n_features_in_)
        chol = self._cholesky_factors() if return_std else None
        mean, var = gp_predict(X, self.X_train_, self.alpha_, self.log_params_, chol)
        mean = mean * self.y_std_ + self.y_mean_
        if not return_std:
            return mean
        return mean, np.sqrt(var) * self.y_std_

    # -- persistence

    def get_state(self) -> tuple[dict[str, np.ndarray], dict[str, Any]]:
        check_is_fitted(self)
        arrays = {"X_train": self.X_train_, "alpha": self.alpha_, "log_params": self.log_params_,
                  "y_mean": self.y_mean_, "y_std": self.y_std_, "lml": self.lml_,
                  "jitter": np.asarray(self.jitter_, dtype=np.float64)}
        meta = self._size_meta(n_train=int(self.X_train_.shape[0]))
        return arrays, meta

    @classmethod
    def from_state(cls, params: dict[str, Any], arrays: dict[str, np.ndarray],
                   meta: dict[str, Any]) -> "GPR":
        m = cls.from_params(params)
        (d, p), n = sizes_from_meta(meta), int(meta["n_train"])
        m.X_train_ = expect_array(arrays, "X_train", (n, d)).astype(np.float64)
        m.alpha_ = expect_array(arrays, "alpha", (n, p)).astype(np.float64)
        m.log_params_ = expect_array(arrays, "log_params", (p, d + 2)).astype(np.float64)
        m.y_mean_ = expect_array(arrays, "y_mean", (p,)).astype(np.float64)
        m.y_std_ = expect_array(arrays, "y_std", (p,)).astype(np.float64)
        m.lml_ = expect_array(arrays, "lml", (p,)).astype(np.float64)
        m.jitter_ = (float(expect_array(arrays, "jitter", ())) if "jitter" in arrays
                     else float(m.jitter))  # files written before jitter_ existed
        m.n_features_in_, m.n_outputs_ = d, p
        m.n_iter_ = np.zeros(p, dtype=int)
        m._chol = None
        return m
