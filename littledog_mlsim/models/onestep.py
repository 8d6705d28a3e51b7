"""The one-step model: what the CLI, evaluation, rollout and ROS node hold (paper Sections II-V).

``OneStepModel`` wraps any fitted regressor (LR, LWPR, GPR, SoR, LGPR) so that its users never
ask which one is inside:

    s_{t+1} = model.predict(x_t)            x_t = (s_t, u_t) raw, (n, 45) -> (n, 33) raw
    mean, std = model.predict(x_t, return_std=True)     (GPs only)

Inside, the features are normalised to unit variance per column on the TrainPool (the paper's
Section II; :class:`..data.states.Normalizer`), and the regressor learns a response
representation chosen by ``target``:

- ``"delta"`` (default): r = s_{t+1} - s_t, normalised to unit variance per element; the
  prediction is s_t + r. The state changes little in 10 ms, so the regressor only models the
  change (the GP prior mean, zero, is then "the state stays", not "the state is the TrainPool
  mean"). On the recorded data it is the better target for most state elements, ``"next"``
  for a few nearly uncorrelated ones (``benchmarks/lgpr_ablation/lgpr_ablation.md``).
- ``"next"``: the paper's literal response r = s_{t+1}, normalised to unit variance.

The standard deviation is that of s_{t+1} given x_t (s_t is known, so the same for both
targets).

Features: by default the paper's 45 (``layout.FEATURE_NAMES``); a model may be fitted on a
:class:`.features.FeatureSet`, the 45 followed by named augmentations (lagged commands, ...),
which it records (``feature_set``; ``feature_names`` are its column names) so that users can
compute the same columns; ``predict`` then takes (n, ``feature_set.n_features``).

The model also carries what the rollout needs to project predicted states back to the data
(Section VI): the TrainPool states, stored as an alpha-PROJ projection (``littledog_mlsim.projection``'s
``to_arrays``; ``projection(kind, alpha)`` builds any kind from them), plus the feature names,
the training data fingerprint and free-form ``info`` (how it was trained), and the default
radius of the gated alpha-PROJ (``gate``: meta key ``"gate"``, a record of
``projection.gate_radius`` computed at training time from the TrainPool's moves;
:meth:`OneStepModel.gate_radius`). A model file without it (written before) still loads; its
radius is then computed on first use from the stored TrainPool states when the moves can be
told apart (``info``'s ``n_moves`` equal blocks of states), else the gate is off (radius 0,
plain alpha-PROJ), and the log says which.

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

from ..data.states import Normalizer
from ..layout import N_STATE, STATE_NAMES
from ..projection import GATE_QUANTILE, Projection, gate_radius, make_projection
from .base import Regressor, StdNotSupportedError
from .features import FeatureSet, FeatureSetError
from .persistence import ModelError, fingerprint_arrays, read_model, save_model

TARGETS: tuple[str, ...] = ("delta", "next")
ONESTEP_FORMAT_VERSION = 1
PROJECTION_PREFIX = "projection."


def _check_xy(X: np.ndarray, Y: np.ndarray | None, n_features: int
              ) -> tuple[np.ndarray, np.ndarray | None]:
    X = np.asarray(X, dtype=np.float64)
    if X.ndim != 2 or X.shape[1] != n_features:
        raise ValueError(f"features must be (n, {n_features}); got {X.shape}")
    if Y is not None:
        Y = np.asarray(Y, dtype=np.float64)
        if Y.shape != (X.shape[0], N_STATE):
            raise ValueError(f"responses must be ({X.shape[0]}, {N_STATE}); got {Y.shape}")
    return X, Y


def _check_gate(gate: Mapping[str, Any]) -> dict[str, Any]:
    """A ``gate`` record (``projection.gate_radius``): a dict with a finite radius >= 0."""
    if not isinstance(gate, Mapping):
        raise ValueError("gate must be a mapping")
    r = gate.get("radius")
    if isinstance(r, bool) or not isinstance(r, (int, float)) or not (0 <= r < float("inf")):
        raise ValueError(f"gate radius must be a finite number >= 0, got {r!r}")
    return dict(gate)


class OneStepModel:
    """A regressor plus feature normalisation, response representation and projection data.

    Build with :meth:`fit` (or :meth:`load`); ``estimator`` is then fitted on normalised
    features and normalised targets. Attributes: ``estimator``, ``feature_normalizer``,
    ``response_normalizer``, ``target``, ``train_states`` (n, 33) TrainPool states or None,
    ``data_fingerprint``, ``info`` (dict), ``feature_set``, ``feature_names`` (its columns),
    ``state_names``.
    """

    state_names: tuple[str, ...] = STATE_NAMES

    def __init__(self, estimator: Regressor, feature_normalizer: Normalizer,
                 response_normalizer: Normalizer, target: str = "delta", *,
                 train_states: np.ndarray | None = None, data_fingerprint: str = "",
                 info: Mapping[str, Any] | None = None,
                 feature_set: FeatureSet | None = None,
                 gate: Mapping[str, Any] | None = None) -> None:
        if target not in TARGETS:
            raise ValueError(f"target must be one of {TARGETS}; got {target!r}")
        self.gate = None if gate is None else _check_gate(gate)
        self.feature_set = FeatureSet() if feature_set is None else feature_set
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
            info: Mapping[str, Any] | None = None,
            feature_set: FeatureSet | None = None) -> "OneStepModel":
        """Fit ``estimator`` on raw features X (n, 45) and next states Y (n, 33).

        With a ``feature_set``, X is (n, ``feature_set.n_features``) as its
        ``features_responses`` gives it. The normalisers are fitted on X and on the targets (see
        module doc). ``train_states``: TrainPool states for the projection (default: Y).
        ``data_fingerprint`` default: the fingerprint of (X, Y). ``info`` gets ``fit_seconds``,
        ``n_train`` and ``method`` added.
        """
        if target not in TARGETS:
            raise ValueError(f"target must be one of {TARGETS}; got {target!r}")
        fs = FeatureSet() if feature_set is None else feature_set
        X, Y = _check_xy(X, Y, fs.n_features)
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
                   info=info, feature_set=fs)

    @property
    def method(self) -> str:
        return self.estimator.method

    @property
    def supports_std(self) -> bool:
        """Whether ``predict(..., return_std=True)`` works (the regressor's declared capability)."""
        return bool(getattr(self.estimator, "supports_std", False))

    @property
    def feature_names(self) -> tuple[str, ...]:
        return self.feature_set.names

    # -- prediction

    def predict(self, X: np.ndarray, return_std: bool = False):
        """Raw features X (n, 45) (or one row (45,)) -> raw s_{t+1} (n, 33) (or (33,)).

        (n, ``feature_set.n_features``) for a model with an augmented feature set.

        ``return_std=True`` also returns the predictive std of s_{t+1}, same shape (an
        estimator whose ``supports_std`` is False raises :class:`.base.StdNotSupportedError`,
        a ValueError).
        """
        X = np.asarray(X, dtype=np.float64)
        single = X.ndim == 1
        if single:
            X = X[None, :]
        nf = self.feature_normalizer.mean_.shape[0]
        if X.ndim != 2 or X.shape[1] != nf:
            raise ValueError(f"features must be (n, {nf}) or ({nf},); got {X.shape}")
        fn, rn = self.feature_normalizer, self.response_normalizer
        Xn = (X - fn.mean_) / fn.std_
        if return_std:
            if not self.supports_std:
                raise StdNotSupportedError(f"{self.method} gives no predictive std")
            Z, Zs = self.estimator.predict(Xn, return_std=True)
        else:
            Z, Zs = self.estimator.predict(Xn), None
        out = Z * rn.std_ + rn.mean_
        if self.target == "delta":
            out += X[:, :N_STATE]
        if Zs is None:
            return out[0] if single else out
        std = Zs * rn.std_
        return (out[0], std[0]) if single else (out, std)

    def prepare(self, return_std: bool = False, variance_dtype: str = "float64") -> None:
        """Do one-time work before a real-time loop: build variance factors (LGPR, GPR) and run
        one prediction, so the first real query is as fast as the others.
        ``variance_dtype="float32"``: LGPR's factors in float32 (``LGPR.prepare_variance``: a
        faster std, changed in its last digits); other estimators ignore it."""
        if return_std:
            prep = getattr(self.estimator, "prepare_variance", None)
            if prep is not None:
                prep(**({} if variance_dtype == "float64" else {"dtype": variance_dtype}))
        x = self.feature_normalizer.mean_.copy()
        if self.train_states is not None:
            x[:N_STATE] = self.train_states[0]
        self.predict(x, return_std=return_std)
        self.predict(np.stack([x, x]))    # a batch's path too (LGPR compiles its kernel rows)

    # -- projection data

    def projection(self, kind: str = "alpha", alpha: float = 0.5, nn_method: str = "auto",
                   radius: float = 0.0):
        """The rollout projection ``kind`` (none/bound/alpha) built from the TrainPool states;
        ``radius`` > 0 gates alpha-PROJ (``projection.make_projection``)."""
        if kind != "none" and self.train_states is None:
            raise ValueError("this model holds no TrainPool states for a projection")
        return make_projection(kind, self.train_states, alpha=alpha, nn_method=nn_method,
                               radius=radius)

    def gate_radius(self, every_on_load: int = 16) -> tuple[float, str]:
        """The default radius of the gated alpha-PROJ and where it comes from (a phrase for
        the log). Stored in the model (``gate``): that. A model written before the key: the
        ``GATE_QUANTILE`` of the leave-move-out distances of its TrainPool states, computed
        now (every ``every_on_load``-th state, to keep start-up short) if ``info`` tells the
        moves apart (``n_moves`` blocks of equal length, as ``train`` stores them), kept in
        ``gate`` (re-saving the model stores it); otherwise 0 (plain alpha-PROJ)."""
        if self.gate is not None:
            g = self.gate
            how = g.get("source", "stored in the model")
            return float(g["radius"]), (f"{how} (quantile {g.get('quantile', '?')} of the "
                                        f"TrainPool's leave-move-out distances)")
        if self.train_states is None:
            return 0.0, "no TrainPool states in the model: gate off (plain alpha-PROJ)"
        n = self.train_states.shape[0]
        n_moves = self.info.get("n_moves")
        if not (isinstance(n_moves, int) and n_moves >= 2 and n % n_moves == 0
                and self.info.get("n_train_pool", n) == n):
            return 0.0, ("the model stores no gate radius and its TrainPool moves cannot be "
                         "told apart: gate off (plain alpha-PROJ); set the radius")
        groups = np.repeat(np.arange(n_moves), n // n_moves)
        g = gate_radius(self.train_states, groups, GATE_QUANTILE, every=every_on_load)
        g["source"] = "computed on load (the model file predates the stored radius)"
        self.gate = g
        return float(g["radius"]), (f"{g['source']}: quantile {GATE_QUANTILE} of the "
                                    f"TrainPool's leave-move-out distances")

    def state_clusters(self):
        """The estimator's clusters as groups of TrainPool states, for the gate's shortcut
        (``projection.CandidateGroups``): ``(groups, label)`` with ``groups`` a list of index
        arrays into ``train_states`` (the states the cluster's training rows lead to) and
        ``label(X)`` the cluster (n,) of raw feature rows X (n, f): the nearest centre, as
        ``predict`` picks it (by one GEMM: a near-tie may go the other way).

        None if the estimator has no clusters (only LGPR has) or was fitted on other rows
        than ``train_states`` (a subset: the row numbers would not match). The groups only
        make the shortcut fast or slow, never its answer wrong (any TrainPool states bound
        the nearest one's distance)."""
        est = self.estimator
        cached = self.__dict__.get("_cluster_groups")
        if cached is not None and cached[0] is est:
            return cached[1], self._cluster_label
        rows = getattr(est, "cluster_rows", None)
        if rows is None or self.train_states is None \
                or int(self.info.get("n_train", -1)) != self.train_states.shape[0]:
            return None
        groups = rows()
        self._cluster_groups = (est, groups)        # the same objects on every call
        return groups, self._cluster_label

    def _cluster_label(self, X: np.ndarray) -> np.ndarray:
        """The nearest LGPR centre (n,) of raw feature rows X by one GEMM (``predict``'s exact
        rule may differ on a near-tie: the groups only need to be good guesses)."""
        C = self.estimator.centers_
        fn = self.feature_normalizer
        Xn = (np.asarray(X, dtype=np.float64) - fn.mean_) / fn.std_
        return np.argmin(np.einsum("ij,ij->i", C, C) - 2.0 * (Xn @ C.T), axis=1)

    # -- files

    def _meta(self) -> dict[str, Any]:
        gate = {} if self.gate is None else {"gate": {k: v for k, v in self.gate.items()
                                                      if k != "source"}}
        return {**gate,
            "feature_names": list(self.feature_names),
            "feature_set": self.feature_set.to_dict(),
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
            proj = make_projection("alpha", self.train_states)
            extra = proj.to_arrays(prefix=PROJECTION_PREFIX)
        return save_model(path, self.estimator, self._meta(), extra_arrays=extra)

    @classmethod
    def load(cls, path: str | os.PathLike,
             feature_names: Sequence[str] | None = None) -> "OneStepModel":
        """Read a model written by :meth:`save`; ModelError (one line) on any problem: unknown
        format, corrupt or truncated files, features this build cannot compute (an unknown
        augmentation), or, if ``feature_names`` is given (the columns the caller can supply,
        e.g. ``layout.FEATURE_NAMES``), a model whose features differ from them."""
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
            feature_set = FeatureSet.from_dict(meta.get("feature_set"))
        except FeatureSetError as e:
            raise ModelError(f"{path}: this build cannot compute the model's features: "
                             f"{str(e).splitlines()[0]}") from e
        if list(meta.get("feature_names", feature_set.names)) != list(feature_set.names):
            raise ModelError(f"{path}: the model's feature names do not match its feature set")
        try:
            norm = meta["normalisation"]
            fn = Normalizer.from_dict(norm["features"])
            rn = Normalizer.from_dict(norm["responses"])
            if fn.mean_.shape != (feature_set.n_features,) or rn.mean_.shape != (N_STATE,):
                raise ValueError("normaliser sizes do not match the layout")
            target = block["target"]
            train_states = None
            if block.get("has_train_states"):
                train_states = Projection.from_arrays(extra, prefix=PROJECTION_PREFIX
                                                      ).train_states
            return cls(estimator, fn, rn, target, train_states=train_states,
                       data_fingerprint=str(meta.get("data_fingerprint", "")),
                       info=meta.get("info") or {}, feature_set=feature_set,
                       gate=meta.get("gate"))
        except (KeyError, TypeError, ValueError, AttributeError) as e:
            msg = str(e).splitlines()[0] if str(e) else type(e).__name__
            raise ModelError(f"{path}: bad one-step metadata: {msg}") from e


__all__ = ["OneStepModel", "TARGETS", "ONESTEP_FORMAT_VERSION"]
