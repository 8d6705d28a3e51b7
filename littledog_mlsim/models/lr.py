"""First-order linear regression with a bias, the paper's baseline (Section III, "LR").

    y = W^T x + b,   fitted by least squares on [X, 1] (numpy.linalg.lstsq, minimum-norm when
    the features are rank-deficient, e.g. constant columns of a standing move).
"""
from __future__ import annotations

from typing import Any

import numpy as np

from .base import (Regressor, check_fit_inputs, check_is_fitted, check_predict_inputs,
                   expect_array, sizes_from_meta)


class LinearRegression(Regressor):
    """Least-squares affine map from features (n, d) to responses (n, p); ``method = "lr"``.

    ``predict(X, return_std=True)`` also returns the training residual std per output, broadcast
    to (m, p) (homoscedastic: the same for every query), so LR drops in wherever a GP does.

    Fitted attributes: ``coef_`` (d, p), ``intercept_`` (p,), ``residual_std_`` (p,),
    ``rank_`` (rank of [X, 1]), ``n_features_in_``, ``n_outputs_``.
    """

    method = "lr"
    supports_std = True

    def __init__(self) -> None:
        pass

    def fit(self, X: np.ndarray, Y: np.ndarray) -> "LinearRegression":
        """X (n, d), Y (n, p) or (n,) -> self."""
        X, Y = check_fit_inputs(X, Y)
        n, d = X.shape
        A = np.empty((n, d + 1))
        A[:, :d] = X
        A[:, d] = 1.0
        W, _, rank, _ = np.linalg.lstsq(A, Y, rcond=None)
        self.coef_ = W[:d]
        self.intercept_ = W[d]
        self.rank_ = int(rank)
        resid = Y - A @ W
        dof = max(n - self.rank_, 1)
        self.residual_std_ = np.sqrt(np.einsum("ij,ij->j", resid, resid) / dof)
        self.n_features_in_ = d
        self.n_outputs_ = Y.shape[1]
        return self

    def predict(self, X: np.ndarray, return_std: bool = False):
        """X (m, d) -> (m, p); with return_std also (m, p) residual std."""
        check_is_fitted(self)
        X = check_predict_inputs(X, self.n_features_in_)
        mean = X @ self.coef_ + self.intercept_
        if not return_std:
            return mean
        return mean, np.broadcast_to(self.residual_std_, mean.shape).copy()

    def get_state(self) -> tuple[dict[str, np.ndarray], dict[str, Any]]:
        check_is_fitted(self)
        arrays = {"coef": self.coef_, "intercept": self.intercept_,
                  "residual_std": self.residual_std_}
        meta = self._size_meta(rank=int(self.rank_))
        return arrays, meta

    @classmethod
    def from_state(cls, params: dict[str, Any], arrays: dict[str, np.ndarray],
                   meta: dict[str, Any]) -> "LinearRegression":
        m = cls.from_params(params)
        d, p = sizes_from_meta(meta)
        m.coef_ = expect_array(arrays, "coef", (d, p)).astype(np.float64)
        m.intercept_ = expect_array(arrays, "intercept", (p,)).astype(np.float64)
        m.residual_std_ = expect_array(arrays, "residual_std", (p,)).astype(np.float64)
        m.rank_ = int(meta["rank"])
        m.n_features_in_, m.n_outputs_ = d, p
        return m
