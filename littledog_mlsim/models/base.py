"""The one estimator shape every regressor follows (scikit-learn style).

Constructor arguments are the hyperparameters and nothing else happens in ``__init__``;
``fit(X, Y)`` returns self; learned state ends in ``_``; ``predict(X)`` returns (n, n_out) and GPs
also accept ``return_std=True`` returning (mean, std), both (n, n_out).

Persistence (CONTRACT.md section 7) goes through ``get_state``/``from_state``: an estimator turns
its learned state into a flat dict of NumPy arrays (saved to .npz, loaded with
``allow_pickle=False``) plus a JSON-serialisable dict of metadata (hyperparameters, sizes).
"""
from __future__ import annotations

from typing import Any, ClassVar

import numpy as np


class Regressor:
    """Base class: subclasses set ``method`` and implement fit/predict/get_state/from_state."""

    method: ClassVar[str] = ""

    def fit(self, X: np.ndarray, Y: np.ndarray) -> "Regressor":
        raise NotImplementedError

    def predict(self, X: np.ndarray, return_std: bool = False):
        raise NotImplementedError

    def get_params(self) -> dict[str, Any]:
        """Constructor arguments (JSON-serialisable)."""
        raise NotImplementedError

    def get_state(self) -> tuple[dict[str, np.ndarray], dict[str, Any]]:
        """Learned state as (arrays, json_meta)."""
        raise NotImplementedError

    @classmethod
    def from_state(cls, params: dict[str, Any], arrays: dict[str, np.ndarray],
                   meta: dict[str, Any]) -> "Regressor":
        """Rebuild a fitted estimator from ``get_params()`` and ``get_state()`` output."""
        raise NotImplementedError


def check_fit_inputs(X: np.ndarray, Y: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Validate training data; returns float64 ``X`` (n, d) and ``Y`` (n, p) (1-D ``Y`` -> p = 1).

    Raises ValueError (one line) on wrong dimensions, mismatched row counts, no rows, or NaN/inf.
    """
    X = np.asarray(X, dtype=np.float64)
    Y = np.asarray(Y, dtype=np.float64)
    if Y.ndim == 1:
        Y = Y[:, None]
    if X.ndim != 2 or Y.ndim != 2:
        raise ValueError(f"X must be (n, d) and Y (n, p); got X{X.shape}, Y{Y.shape}")
    if X.shape[0] != Y.shape[0]:
        raise ValueError(f"X has {X.shape[0]} rows but Y has {Y.shape[0]}")
    if X.shape[0] == 0:
        raise ValueError("no training rows")
    if not (np.all(np.isfinite(X)) and np.all(np.isfinite(Y))):
        raise ValueError("training data holds NaN or inf")
    return X, Y


def check_predict_inputs(X: np.ndarray, n_features: int) -> np.ndarray:
    """Validate query features; returns float64 ``X`` (n, n_features) (a 1-D row becomes (1, d))."""
    X = np.asarray(X, dtype=np.float64)
    if X.ndim == 1:
        X = X[None, :]
    if X.ndim != 2 or X.shape[1] != n_features:
        raise ValueError(f"X must be (n, {n_features}); got {X.shape}")
    return X


def expect_array(arrays: dict[str, np.ndarray], name: str,
                 shape: tuple[int | None, ...]) -> np.ndarray:
    """Fetch ``arrays[name]`` for ``from_state`` and check its shape (None = any length).

    Raises ValueError naming the array if it is missing, has the wrong shape or is not numeric.
    """
    if name not in arrays:
        raise ValueError(f"missing array {name!r}")
    a = np.asarray(arrays[name])
    ok = a.ndim == len(shape) and all(s is None or s == t for s, t in zip(shape, a.shape))
    if not ok:
        want = "(" + ", ".join("*" if s is None else str(s) for s in shape) + ")"
        raise ValueError(f"array {name!r} has shape {a.shape}, expected {want}")
    if a.dtype.kind not in "biuf":
        raise ValueError(f"array {name!r} has dtype {a.dtype}, expected a number type")
    return a
