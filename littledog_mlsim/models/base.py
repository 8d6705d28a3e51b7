"""The one estimator contract every regressor follows (scikit-learn's shape).

Why a contract: the one-step model, the trainer, the evaluation and the model files must treat
LR, LWPR, GPR, SoR and LGPR alike, without asking which one they hold. The rules:

- The constructor takes the hyperparameters, keyword-only, stores each under its own name and
  does nothing else; :meth:`Regressor.get_params` reads them back by introspecting the
  constructor's signature, so no estimator keeps a list of its parameters by hand.
- Randomness is seeded by ``random_state`` (an estimator may accept an old name, e.g. LWPR's
  ``seed``, declared in ``_renamed_params``; it is mapped to the new one and never reported).
- ``fit(X, Y)`` returns self; learned state ends in ``_``. ``predict(X)`` returns (n, n_out).
- ``supports_std`` (a class attribute) declares whether ``predict(X, return_std=True)`` returns
  (mean, std), both (n, n_out). Callers check it instead of catching an exception; an estimator
  without it raises :class:`StdNotSupportedError` when asked anyway.
- Calling ``predict`` or ``get_state`` before ``fit`` raises :class:`NotFittedError`.
- Bad input (NaN, wrong shapes, no rows) raises ValueError with one line
  (:func:`check_fit_inputs`, :func:`check_predict_inputs`).
- Persistence (``docs/interface.md`` §7) goes through ``get_state``/``from_state``:
  the learned state as a flat dict of NumPy arrays (saved to .npz, read with
  ``allow_pickle=False``) plus JSON-serialisable metadata (sizes).

``test/models/test_regressor_conformance.py`` checks every registered estimator against these rules.
"""
from __future__ import annotations

import inspect
from typing import Any, ClassVar

import numpy as np

from ..fileio import to_plain

__all__ = ["Regressor", "NotFittedError", "StdNotSupportedError", "check_fit_inputs",
           "check_predict_inputs", "check_is_fitted", "sizes_from_meta", "expect_array", "standardise_targets"]


class NotFittedError(ValueError, AttributeError):
    """An estimator was used (predict, get_state) before ``fit``.

    A ValueError (one-line user error) and an AttributeError (what a missing fitted attribute
    raised before, so older callers catching that still work)."""


class StdNotSupportedError(NotImplementedError, ValueError):
    """``predict(..., return_std=True)`` on an estimator whose ``supports_std`` is False."""


class Regressor:
    """Base class: subclasses set ``method`` and implement fit/predict/get_state/from_state."""

    method: ClassVar[str] = ""
    #: whether ``predict(X, return_std=True)`` gives the predictive std
    supports_std: ClassVar[bool] = False
    #: old constructor argument names accepted for compatibility: {old: new}
    _renamed_params: ClassVar[dict[str, str]] = {}
    #: a fitted attribute that exists exactly when the estimator is fitted
    _fitted_attr: ClassVar[str] = "n_features_in_"

    @classmethod
    def param_names(cls) -> tuple[str, ...]:
        """The hyperparameters: the constructor's keyword arguments (old names excluded)."""
        sig = inspect.signature(cls.__init__)
        return tuple(name for name, p in sig.parameters.items()
                     if name != "self" and name not in cls._renamed_params
                     and p.kind in (p.KEYWORD_ONLY, p.POSITIONAL_OR_KEYWORD))

    @classmethod
    def from_params(cls, params: dict[str, Any]) -> "Regressor":
        """``cls(**params)`` with old parameter names mapped to their new ones; ValueError
        (one line) for a name the constructor does not take."""
        params = dict(params)
        for old, new in cls._renamed_params.items():
            if old in params:
                value = params.pop(old)
                params.setdefault(new, value)
        unknown = sorted(set(params) - set(cls.param_names()))
        if unknown:
            raise ValueError(f"{cls.method or cls.__name__} has no option {', '.join(unknown)} "
                             f"(options: {', '.join(cls.param_names()) or 'none'})")
        return cls(**params)

    def get_params(self) -> dict[str, Any]:
        """Constructor arguments, JSON-serialisable (arrays and tuples as lists)."""
        return {name: to_plain(getattr(self, name)) for name in self.param_names()}

    def fit(self, X: np.ndarray, Y: np.ndarray) -> "Regressor":
        raise NotImplementedError

    def predict(self, X: np.ndarray, return_std: bool = False):
        raise NotImplementedError

    def get_state(self) -> tuple[dict[str, np.ndarray], dict[str, Any]]:
        """Learned state as (arrays, json_meta)."""
        raise NotImplementedError

    @classmethod
    def from_state(cls, params: dict[str, Any], arrays: dict[str, np.ndarray],
                   meta: dict[str, Any]) -> "Regressor":
        """Rebuild a fitted estimator from ``get_params()`` and ``get_state()`` output."""
        raise NotImplementedError

    def _size_meta(self, **extra: Any) -> dict[str, Any]:
        """``get_state`` metadata: the input and output sizes plus ``extra``."""
        return {"n_features_in": int(self.n_features_in_), "n_outputs": int(self.n_outputs_),
                **extra}

    def _check_std(self, return_std: bool) -> None:
        if return_std and not self.supports_std:
            raise StdNotSupportedError(f"{self.method or type(self).__name__} gives no "
                                       f"predictive std (supports_std is False)")

    def __repr__(self) -> str:
        args = ", ".join(f"{k}={v!r}" for k, v in self.get_params().items())
        return f"{type(self).__name__}({args})"


def sizes_from_meta(meta: dict[str, Any]) -> tuple[int, int]:
    """(n_features_in, n_outputs) from ``get_state`` metadata (``Regressor._size_meta``)."""
    return int(meta["n_features_in"]), int(meta["n_outputs"])


def check_is_fitted(estimator: Regressor) -> None:
    """NotFittedError (one line) unless ``estimator`` has been fitted (or loaded)."""
    if not hasattr(estimator, estimator._fitted_attr):
        name = estimator.method or type(estimator).__name__
        raise NotFittedError(f"{name} is not fitted: call fit first")


def standardise_targets(Y: np.ndarray, enabled: bool = True
                        ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(Yn, mean, std) with Yn = (Y - mean) / std per column; a constant column gets std 1.

    ``enabled=False`` gives mean 0 and std 1 (Yn = Y). Every regressor that standardises its
    targets uses this, so they agree on the constant-column rule.
    """
    if not enabled:
        p = Y.shape[1]
        mean, sd = np.zeros(p), np.ones(p)
    else:
        mean = Y.mean(axis=0)
        sd = Y.std(axis=0)
        sd = np.where(sd > 0, sd, 1.0)
    return (Y - mean) / sd, mean, sd


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
    """Validate query features; returns float64 ``X`` (n, n_features) (a 1-D row becomes (1, d)).

    Non-finite queries are allowed (a diverged rollout feeds them; the prediction is then
    non-finite too, and the rollout metrics flag the move)."""
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
