"""Subset-of-regressors sparse GP with k-fold-CV support selection (paper Section IV).

SoR keeps m support points X_m per output and predicts, with Kmn = k(X_m, X_train) and
Sigma = (Kmm + Kmn Knm / sn2)^-1,

    mean(x*) = k(x*, X_m) Sigma Kmn y / sn2,     var_f(x*) = k(x*, X_m) Sigma k(X_m, x*)

(Rasmussen & Williams eq. 8.26-8.27). Stable evaluation (as in GPflow's SGPR): Lm = chol(Kmm +
jitter sf2 I), V = Lm^-1 Kmn, B = I + V V^T / sn2 (eigenvalues >= 1, so its Cholesky LB is well
conditioned), weights w = Lm^-T LB^-T LB^-1 V y / sn2, and var_f = ||C^-1 k(X_m, x*)||^2 with
C = Lm LB (lower triangular). Never forms Kmm^-1 or an n x n matrix.

Hyperparameters come from a full GP (:func:`.gp.fit_gp_hyperparameters`) fitted on a random
subset of ``n_hyperparameter_points`` training points. Support points per output element:

- ``support="random"``: one uniform random subset shared by all outputs.
- ``support="cv"``: the paper's "separateness distribution". The training pool is split at random
  into k groups; a full GP (with the fitted hyperparameters) is built on each group and predicts
  the other n - n/k points, so each point collects k - 1 prediction errors; their sum, normalised
  over the pool, is a sampling distribution from which m points are drawn without replacement.
  Computed per output element (each output gets its own support set).

Cost, n training points, m support points, p outputs, d features, k folds:
hyperparameters p x (L-BFGS-B on n_h points, O(n_h^3) per step); CV separateness per output
O(n^3 / (3 k^2)) for the k Cholesky factors plus O(n^2 d) for the cross-kernels; the SoR solve
O(n m d + n m^2) per output, so O(p n m^2) in total; memory O(n m) during fit, p m (d + 1)
floats for the mean and p m^2 more with ``predict_variance``.
"""
from __future__ import annotations

from typing import Any

import numpy as np
import scipy.linalg as sla

from .base import (Regressor, StdNotSupportedError, check_fit_inputs, check_is_fitted,
                   check_predict_inputs, expect_array, sizes_from_meta,
                   standardise_targets)
from .gp import (DEFAULT_JITTER, GPR, fit_gp_hyperparameters, gp_posterior, gp_predict,
                 kernel_cross, kernel_matrix, n_log_params, unpack_log_params)

CV_ERRORS = ("absolute", "squared")
_JITTER_TRIES = 3
_JITTER_GROWTH = 100.0


def cv_separateness(X: np.ndarray, Y: np.ndarray, log_params: np.ndarray, n_folds: int,
                    random_state: Any = None, jitter: float = DEFAULT_JITTER,
                    error: str = "absolute") -> np.ndarray:
    """The paper's k-fold-CV separateness distribution, one column per output: (n, p).

    X (n, d), Y (n, p), log_params (p, d + 2). Points are split at random into ``n_folds``
    groups; a full GP on each group predicts all other points; each point's k - 1 errors
    (``|y - mean|`` or ``(y - mean)^2``) are summed and each column is normalised to sum to 1
    (a column with no error at all becomes uniform).
    """
    if error not in CV_ERRORS:
        raise ValueError(f"error must be one of {CV_ERRORS}; got {error!r}")
    X, Y = check_fit_inputs(X, Y)
    n, p = Y.shape
    if not 2 <= n_folds <= n:
        raise ValueError(f"n_folds must be in [2, n={n}]; got {n_folds}")
    lp = np.broadcast_to(np.atleast_2d(log_params), (p, X.shape[1] + 2))
    rng = np.random.default_rng(random_state)
    folds = np.array_split(rng.permutation(n), n_folds)
    err = np.zeros((n, p))
    for g in folds:
        rest = np.setdiff1d(np.arange(n), g, assume_unique=True)
        alpha, _ = gp_posterior(X[g], Y[g], lp, jitter)
        mean, _ = gp_predict(X[rest], X[g], alpha, lp)
        r = Y[rest] - mean
        err[rest] += np.abs(r) if error == "absolute" else r * r
    tot = err.sum(axis=0)
    return np.where(tot > 0, err / np.where(tot > 0, tot, 1.0), 1.0 / n)


def sample_support(prob: np.ndarray, m: int, rng: np.random.Generator) -> np.ndarray:
    """Draw m distinct indices from the distribution ``prob`` (n,); sorted (m,).

    If fewer than m points have non-zero probability, all of them are taken and the rest are
    drawn uniformly from the zero-probability points.
    """
    n = prob.shape[0]
    nz = np.flatnonzero(prob > 0)
    if nz.size >= m:
        idx = rng.choice(n, size=m, replace=False, p=prob / prob.sum())
    else:
        zero = np.flatnonzero(prob <= 0)
        idx = np.concatenate([nz, rng.choice(zero, size=m - nz.size, replace=False)])
    return np.sort(idx)


def sor_solve(X: np.ndarray, y: np.ndarray, Xm: np.ndarray, log_params: np.ndarray,
              jitter: float, with_variance: bool) -> tuple[np.ndarray, np.ndarray | None]:
    """SoR weights w (m, q) for targets y (n, q) sharing one kernel and support set Xm (m, d).

    Returns (w, C) with C (m, m) lower triangular such that var_f(x*) = ||C^-1 k(Xm, x*)||^2
    (None unless ``with_variance``). ``jitter`` is relative to sf2 (added to Kmm only); if Kmm
    + jitter sf2 I is still not positive definite the jitter grows by 100x, at most twice.
    O(n m d + n m^2).
    """
    sf2, _, sn2 = unpack_log_params(log_params)
    m = Xm.shape[0]
    Kmm0 = kernel_matrix(Xm, log_params)
    for attempt in range(_JITTER_TRIES):  # near-duplicate support points: more jitter
        Kmm = Kmm0.copy()
        Kmm.flat[:: m + 1] += jitter * _JITTER_GROWTH**attempt * sf2
        try:
            Lm = np.tril(sla.cho_factor(Kmm, lower=True, overwrite_a=True,
                                        check_finite=False)[0])
            break
        except np.linalg.LinAlgError:
            continue
    else:
        raise ValueError(f"SoR: Kmm is not positive definite even with jitter "
                         f"{jitter * _JITTER_GROWTH**(_JITTER_TRIES - 1):g} * sf2")
    del Kmm0
    V = sla.solve_triangular(Lm, kernel_cross(Xm, X, log_params), lower=True,
                             check_finite=False)  # (m, n)
    B = V @ V.T
    B /= sn2
    B.flat[:: m + 1] += 1.0
    LB = np.tril(sla.cho_factor(B, lower=True, overwrite_a=True, check_finite=False)[0])
    t = sla.solve_triangular(LB, V @ y / sn2, lower=True, check_finite=False)
    t = sla.solve_triangular(LB, t, lower=True, trans="T", check_finite=False)
    w = sla.solve_triangular(Lm, t, lower=True, trans="T", check_finite=False)
    return w, (Lm @ LB if with_variance else None)


class SoR(Regressor):
    """Subset-of-regressors sparse GP, one per output element; ``method = "sor"``.

    Parameters: ``n_support`` m (capped at n); ``support`` "cv" (separateness sampling) or
    "random"; ``n_folds`` k for "cv"; ``cv_error`` "absolute" or "squared";
    ``n_hyperparameter_points`` size of the random subset the full GP's hyperparameters are
    fitted on; ``predict_variance``
    keep the m x m factors needed by ``return_std`` (p m^2 floats, also in the model file);
    ``jitter`` on Kmm relative to sf2; ``normalize_y`` standardise each output over the whole pool;
    ``gp_params`` :class:`.gp.GPR` constructor arguments for the hyperparameter fit and the CV
    GPs (its ``normalize_y`` is ignored; ``optimize=False`` with ``init_log_params`` fixes the
    hyperparameters).

    Fitted attributes: ``support_X_`` (p, m, d), ``support_index_`` (p, m) rows of the training
    pool, ``weights_`` (p, m), ``log_params_`` (p, d + 2), ``y_mean_``/``y_std_`` (p,),
    ``chol_`` (p, m, m) or None, ``separateness_`` (n, p) when support="cv" (not persisted).
    """

    method = "sor"

    def __init__(self, *, n_support: int = 1000, support: str = "cv", n_folds: int = 10,
                 cv_error: str = "absolute", n_hyperparameter_points: int = 1000,
                 predict_variance: bool = True, jitter: float = 1e-8, normalize_y: bool = True,
                 gp_params: dict[str, Any] | None = None, random_state: int | None = 0) -> None:
        self.n_support = n_support
        self.support = support
        self.n_folds = n_folds
        self.cv_error = cv_error
        self.n_hyperparameter_points = n_hyperparameter_points
        self.predict_variance = predict_variance
        self.jitter = jitter
        self.normalize_y = normalize_y
        self.gp_params = gp_params
        self.random_state = random_state

    @property
    def supports_std(self) -> bool:  # type: ignore[override]
        """True unless built with ``predict_variance=False`` (then no m x m factors are kept)."""
        return bool(self.predict_variance)

    def _hyperparameters(self, X: np.ndarray, Yn: np.ndarray, rng: np.random.Generator
                         ) -> np.ndarray:
        gp = GPR(**(self.gp_params or {}))
        n, p, k = X.shape[0], Yn.shape[1], n_log_params(X.shape[1])
        if not gp.optimize:
            if gp.init_log_params is None:
                raise ValueError("gp_params with optimize=False needs init_log_params")
            init = np.asarray(gp.init_log_params, dtype=np.float64)
            if init.shape not in ((k,), (p, k)):
                raise ValueError(f"init_log_params must be ({k},) or ({p}, {k}); "
                                 f"got {init.shape}")
            return np.broadcast_to(init, (p, k)).copy()
        nh = min(n, int(self.n_hyperparameter_points))
        sub = np.sort(rng.choice(n, size=nh, replace=False))
        return fit_gp_hyperparameters(X[sub], Yn[sub],
                                      **gp.hyperparameter_options(X[sub], Yn[sub])).log_params

    def fit(self, X: np.ndarray, Y: np.ndarray) -> "SoR":
        """X (n, d), Y (n, p) or (n,) -> self."""
        if self.support not in ("cv", "random"):
            raise ValueError(f"support must be 'cv' or 'random'; got {self.support!r}")
        X, Y = check_fit_inputs(X, Y)
        n, d = X.shape
        p = Y.shape[1]
        Yn, self.y_mean_, self.y_std_ = standardise_targets(Y, bool(self.normalize_y))
        rng = np.random.default_rng(self.random_state)
        lp = self._hyperparameters(X, Yn, rng)
        m = min(int(self.n_support), n)
        if m < 1:
            raise ValueError(f"n_support must be >= 1; got {self.n_support}")
        self.separateness_ = None
        if m == n:
            support = np.broadcast_to(np.arange(n), (p, n))
        elif self.support == "random":
            support = np.broadcast_to(np.sort(rng.choice(n, size=m, replace=False)), (p, m))
        else:
            gp_jitter = GPR(**(self.gp_params or {})).jitter
            self.separateness_ = cv_separateness(X, Yn, lp, self.n_folds, rng, gp_jitter,
                                                 self.cv_error)
            support = np.stack([sample_support(self.separateness_[:, j], m, rng)
                                for j in range(p)])
        weights = np.empty((p, m))
        chol = np.empty((p, m, m)) if self.predict_variance else None
        same = bool(np.all(support == support[:1]) and np.all(lp == lp[:1]))
        groups = [np.arange(p)] if same else [np.array([j]) for j in range(p)]
        for cols in groups:
            j = cols[0]
            w, C = sor_solve(X, Yn[:, cols], X[support[j]], lp[j], self.jitter,
                             self.predict_variance)
            weights[cols] = w.T
            if chol is not None:
                chol[cols] = C
        self.support_index_ = np.ascontiguousarray(support, dtype=np.int64)
        self.support_X_ = X[self.support_index_]
        self.weights_ = weights
        self.chol_ = chol
        self.log_params_ = lp
        self.n_features_in_, self.n_outputs_ = d, p
        return self

    def predict(self, X: np.ndarray, return_std: bool = False):
        """X (m, d) -> mean (m, p); with return_std also std (m, p) (noisy-observation std)."""
        check_is_fitted(self)
        X = check_predict_inputs(X, self.n_features_in_)
        if return_std and self.chol_ is None:
            raise StdNotSupportedError("this SoR was fitted with predict_variance=False")
        p = self.n_outputs_
        mean = np.empty((X.shape[0], p))
        std = np.empty((X.shape[0], p)) if return_std else None
        for j in range(p):
            Ks = kernel_cross(X, self.support_X_[j], self.log_params_[j])  # (ns, m)
            mean[:, j] = Ks @ self.weights_[j]
            if std is not None:
                _, _, sn2 = unpack_log_params(self.log_params_[j])
                v = sla.solve_triangular(self.chol_[j], Ks.T, lower=True, check_finite=False)
                std[:, j] = np.sqrt(np.einsum("ij,ij->j", v, v) + sn2)
        mean = mean * self.y_std_ + self.y_mean_
        if std is None:
            return mean
        return mean, std * self.y_std_

    def get_state(self) -> tuple[dict[str, np.ndarray], dict[str, Any]]:
        check_is_fitted(self)
        arrays = {"support_X": self.support_X_, "support_index": self.support_index_,
                  "weights": self.weights_, "log_params": self.log_params_,
                  "y_mean": self.y_mean_, "y_std": self.y_std_}
        if self.chol_ is not None:
            arrays["chol"] = self.chol_
        meta = self._size_meta(n_support=int(self.weights_.shape[1]),
                               has_variance=self.chol_ is not None)
        return arrays, meta

    @classmethod
    def from_state(cls, params: dict[str, Any], arrays: dict[str, np.ndarray],
                   meta: dict[str, Any]) -> "SoR":
        s = cls.from_params(params)
        (d, p), m = sizes_from_meta(meta), int(meta["n_support"])
        s.support_X_ = expect_array(arrays, "support_X", (p, m, d)).astype(np.float64)
        s.support_index_ = expect_array(arrays, "support_index", (p, m)).astype(np.int64)
        s.weights_ = expect_array(arrays, "weights", (p, m)).astype(np.float64)
        s.log_params_ = expect_array(arrays, "log_params", (p, d + 2)).astype(np.float64)
        s.y_mean_ = expect_array(arrays, "y_mean", (p,)).astype(np.float64)
        s.y_std_ = expect_array(arrays, "y_std", (p,)).astype(np.float64)
        s.chol_ = (expect_array(arrays, "chol", (p, m, m)).astype(np.float64)
                   if meta.get("has_variance") else None)
        s.separateness_ = None
        s.n_features_in_, s.n_outputs_ = d, p
        return s
