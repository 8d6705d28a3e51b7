"""The one-step model: what the CLI, evaluation, rollout and ROS node hold (paper Sections II-V).

``OneStepModel`` wraps any fitted regressor (LR, LWPR, GPR, SoR, LGPR) so that its users never
ask which one is inside:

    s_{t+1} = model.predict(x_t)            x_t = (s_t, u_t) raw, (n, 45) -> (n, 33) raw
    mean, std = model.predict(x_t, return_std=True)     (GPs only)

Inside, the features are normalised to unit variance per column on the TrainPool (the paper's
Section II; :class:`..data.dataset.Normalizer`), and the regressor learns a response
representation chosen by ``target``:

- ``"delta"`` (default): r = s_{t+1} - s_t, normalised to unit variance per element; the
  prediction is s_t + r. The state changes little in 10 ms, so the regressor only models the
  change (the GP prior mean, zero, is then "the state stays", not "the state is the TrainPool
  mean"); ``benchmarks/lgpr_ablation.md`` measures it against ``"next"``.
- ``"next"``: the paper's literal response r = s_{t+1}, normalised to unit variance.

The standard deviation is that of s_{t+1} given x_t (s_t is known, so the same for both
targets).

The model also carries what the rollout needs to project predicted states back to the data
(Section VI): the TrainPool states, stored as an alpha-PROJ projection (``rollout.projection``'s
``to_arrays``; ``projection(kind, alpha)`` builds any kind from them), plus the feature names,
the training data fingerprint and free-form ``info`` (how it was trained).

Files: :meth:`OneStepModel.save` / :meth:`OneStepModel.load` go through
:mod:`.persistence` (atomic write, checksum, ModelError on anything wrong). The one-step
settings live in the model's meta under ``"onestep"`` (format version
:data:`ONESTEP_FORMAT_VERSION`), the projection arrays under the extra-array prefix
``projection.``.
"""
from __future__ import annotations

import os
import time
from pathlib import Path
from typing import Any, Mapping, Sequence

import numpy as np

from ..data.dataset import Normalizer
from ..layout import FEATURE_NAMES, N_FEATURE, N_STATE, STATE_NAMES
from .base import Regressor
from .persistence import ModelError, fingerprint_arrays, read_model, save_model

TARGETS: tuple[str, ...] = ("delta", "next")
ONESTEP_FORMAT_VERSION = 1
PROJECTION_PREFIX = "projection."


def _check_xy(X: np.ndarray, Y: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray | None]:
    X = np.asarray(X, dtype=np.float64)
    if X.ndim != 2 or X.shape[1] != N_FEATURE:
        raise ValueError(f"features must be (n, {N_FEATURE}); got {X.shape}")
    if Y is not None:
        Y = np.asarray(Y, dtype=np.float64)
        if Y.shape != (X.shape[0], N_STATE):
            raise ValueError(f"responses must be ({X.shape[0]}, {N_STATE}); got {Y.shape}")
    return X, Y


class OneStepModel:
    """A regressor plus feature normalisation, response representation and projection data.

    Build with :meth:`fit` (or :meth:`load`); ``estimator`` is then fitted on normalised
    features and normalised targets. Attributes: ``estimator``, ``feature_normalizer``,
    ``response_normalizer``, ``target``, ``train_states`` (n, 33) TrainPool states or None,
    ``data_fingerprint``, ``info`` (dict), ``feature_names``, ``state_names``.
    """

    feature_names: tuple[str, ...] = FEATURE_NAMES
    state_names: tuple[str, ...] = STATE_NAMES

    def __init__(self, estimator: Regressor, feature_normalizer: Normalizer,
                 response_normalizer: Normalizer, target: str = "delta", *,
                 train_states: np.ndarray | None = None, data_fingerprint: str = "",
                 info: Mapping[str, Any] | None = None) -> None:
        if target not in TARGETS:
            raise ValueError(f"target must be one of {TARGETS}; got {target!r}")
        self.estimator = estimator
        self.feature_normalizer = feature_normalizer
        self.response_normalizer = response_normalizer
        self.target = target
        self.train_states = (None if train_states is None
                             else np.ascontiguousarray(train_states, dtype=np.float64))
        self.data_fingerprint = data_fingerprint
        self.info = dict(info or {})

    # -- building

    @classmethod
    def fit(cls, estimator: Regressor, X: np.ndarray, Y: np.ndarray, *, target: str = "delta",
            train_states: np.ndarray | None = None, data_fingerprint: str | None = None,
            info: Mapping[str, Any] | None = None) -> "OneStepModel":
        """Fit ``estimator`` on raw features X (n, 45) and next states Y (n, 33).

        The normalisers are fitted on X and on the targets (see module doc). ``train_states``:
        TrainPool states for the projection (default: Y). ``data_fingerprint`` default: the
        fingerprint of (X, Y). ``info`` gets ``fit_seconds``, ``n_train`` and ``method`` added.
        """
        if target not in TARGETS:
            raise ValueError(f"target must be one of {TARGETS}; got {target!r}")
        X, Y = _check_xy(X, Y)
        fn = Normalizer().fit(X)
        R = Y - X[:, :N_STATE] if target == "delta" else Y
        rn = Normalizer().fit(R)
        t0 = time.perf_counter()
        estimator.fit(fn.transform(X), rn.transform(R))
        info = dict(info or {})
        info.update(method=estimator.method, n_train=int(X.shape[0]),
                    fit_seconds=round(time.perf_counter() - t0, 3))
        return cls(estimator, fn, rn, target,
                   train_states=Y if train_states is None else train_states,
                   data_fingerprint=(fingerprint_arrays(X, Y) if data_fingerprint is None
                                     else data_fingerprint),
                   info=info)

    @property
    def method(self) -> str:
        return self.estimator.method

    # -- prediction

    def predict(self, X: np.ndarray, return_std: bool = False):
        """Raw features X (n, 45) (or one row (45,)) -> raw s_{t+1} (n, 33) (or (33,)).

        ``return_std=True`` also returns the predictive std of s_{t+1}, same shape (estimators
        without a variance raise ValueError).
        """
        X = np.asarray(X, dtype=np.float64)
        single = X.ndim == 1
        if single:
            X = X[None, :]
        if X.ndim != 2 or X.shape[1] != N_FEATURE:
            raise ValueError(f"features must be (n, {N_FEATURE}) or ({N_FEATURE},); "
                             f"got {X.shape}")
        fn, rn = self.feature_normalizer, self.response_normalizer
        Xn = (X - fn.mean_) / fn.std_
        if return_std:
            try:
                Z, Zs = self.estimator.predict(Xn, return_std=True)
            except (TypeError, NotImplementedError) as e:
                raise ValueError(f"{self.method} gives no predictive std: {e}") from e
        else:
            Z, Zs = self.estimator.predict(Xn), None
        out = Z * rn.std_ + rn.mean_
        if self.target == "delta":
            out += X[:, :N_STATE]
        if Zs is None:
            return out[0] if single else out
        std = Zs * rn.std_
        return (out[0], std[0]) if single else (out, std)

    def prepare(self, return_std: bool = False) -> None:
        """Do one-time work before a real-time loop: build variance factors (LGPR, GPR) and run
        one prediction, so the first real query is as fast as the others."""
        if return_std:
            prep = getattr(self.estimator, "prepare_variance", None)
            if prep is not None:
                prep()
        x = (self.feature_normalizer.mean_ if self.train_states is None
             else np.concatenate([self.train_states[0], self.feature_normalizer.mean_[N_STATE:]]))
        self.predict(x, return_std=return_std)

    # -- projection data

    def projection(self, kind: str = "alpha", alpha: float = 0.5, nn_method: str = "brute"):
        """The rollout projection ``kind`` (none/bound/alpha) built from the TrainPool states."""
        from ..rollout.projection import make_projection
        if kind != "none" and self.train_states is None:
            raise ValueError("this model holds no TrainPool states for a projection")
        return make_projection(kind, self.train_states, alpha=alpha, nn_method=nn_method)

    # -- files

    def _meta(self) -> dict[str, Any]:
        return {
            "feature_names": list(self.feature_names),
            "state_names": list(self.state_names),
            "normalisation": {"features": self.feature_normalizer.to_dict(),
                              "responses": self.response_normalizer.to_dict()},
            "data_fingerprint": self.data_fingerprint,
            "onestep": {"format_version": ONESTEP_FORMAT_VERSION, "target": self.target,
                        "has_train_states": self.train_states is not None},
            "info": self.info,
        }

    def save(self, path: str | os.PathLike) -> Path:
        """Write the model directory atomically (see :func:`.persistence.save_model`)."""
        extra: dict[str, np.ndarray] = {}
        if self.train_states is not None:
            from ..rollout.projection import make_projection
            proj = make_projection("alpha", self.train_states)
            extra = proj.to_arrays(prefix=PROJECTION_PREFIX)
        return save_model(path, self.estimator, self._meta(), extra_arrays=extra)

    @classmethod
    def load(cls, path: str | os.PathLike,
             feature_names: Sequence[str] | None = FEATURE_NAMES) -> "OneStepModel":
        """Read a model written by :meth:`save`; ModelError (one line) on any problem, including
        a feature set other than ``feature_names`` (None: do not check)."""
        estimator, meta, extra = read_model(path, feature_names=feature_names)
        block = meta.get("onestep")
        if not isinstance(block, dict):
            raise ModelError(f"{path}: not a one-step model (no 'onestep' metadata)")
        if block.get("format_version") != ONESTEP_FORMAT_VERSION:
            raise ModelError(f"{path}: unsupported one-step format_version "
                             f"{block.get('format_version')!r} (this build reads "
                             f"{ONESTEP_FORMAT_VERSION})")
        if list(meta.get("state_names", [])) != list(STATE_NAMES):
            raise ModelError(f"{path}: the model's state names differ from this build's")
        try:
            norm = meta["normalisation"]
            fn = Normalizer.from_dict(norm["features"])
            rn = Normalizer.from_dict(norm["responses"])
            if fn.mean_.shape != (N_FEATURE,) or rn.mean_.shape != (N_STATE,):
                raise ValueError("normaliser sizes do not match the layout")
            target = block["target"]
            train_states = None
            if block.get("has_train_states"):
                from ..rollout.projection import Projection
                train_states = Projection.from_arrays(extra, prefix=PROJECTION_PREFIX
                                                      ).train_states
            return cls(estimator, fn, rn, target, train_states=train_states,
                       data_fingerprint=str(meta.get("data_fingerprint", "")),
                       info=meta.get("info") or {})
        except (KeyError, TypeError, ValueError, AttributeError) as e:
            msg = str(e).splitlines()[0] if str(e) else type(e).__name__
            raise ModelError(f"{path}: bad one-step metadata: {msg}") from e


__all__ = ["OneStepModel", "TARGETS", "ONESTEP_FORMAT_VERSION"]
