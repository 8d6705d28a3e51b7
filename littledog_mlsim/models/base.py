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
