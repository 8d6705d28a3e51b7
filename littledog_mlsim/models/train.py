"""Fitting a one-step model: the one recipe behind ``train``, ``reproduce``, ``diagnose`` and
the trainer node.

- :func:`make_estimator` builds the unfitted regressor of a registered method from its options.
- :func:`fit_onestep` fits a :class:`.onestep.OneStepModel` on recorded moves (or on their
  feature/response arrays) with a feature set: features and responses (the paper's Eq. 2),
  an optional random subset, an optional GPR hyperparameter pilot, the fit, and the provenance
  (``info``) stored in the model.
- :func:`train_from_dataset` is :func:`fit_onestep` on the TrainPool of a dataset directory,
  with the per-method size caps of :data:`DEFAULT_MAX_TRAIN`. The TestPool is never read.

Size caps: a full GP costs O(n^3) time and O(n^2) memory, so ``gpr`` uses a random subset of 2000
points by default (the paper used 4500 with per-output hyperparameters on a bigger machine);
``sor`` 10000 (the paper's n for SoR); ``lr``, ``lwpr`` and ``lgpr`` use the whole TrainPool.
The subset is drawn uniformly without replacement with ``random_state`` and kept in TrainPool
order (:func:`subset_rows`).

The projection data stored in the model are the states of the whole TrainPool, and the data
fingerprint is that of the whole TrainPool (features and responses), whatever subset was used.
"""
from __future__ import annotations

import json
import logging
import os
import time
from typing import Any, Mapping, Sequence

import numpy as np

from ..data.dataset import load_moves, read_index
from ..data.recording import MoveRecording
from ..data.states import features_responses
from ..logs import progress_to_stderr
from ..projection import gate_radius
from .base import Regressor
from .features import FeatureSet
from .onestep import TARGETS, OneStepModel
from .persistence import METHODS, fingerprint_arrays, get_method

log = logging.getLogger(__name__)

#: the paper's five regressors, in the paper's order (Table I rows); all are in ``METHODS``
METHOD_NAMES: tuple[str, ...] = ("lr", "lwpr", "gpr", "sor", "lgpr")
DEFAULT_MAX_TRAIN: dict[str, int] = {"gpr": 2000, "sor": 10000}


def make_estimator(method: str, options: Mapping[str, Any] | None = None, *,
                   random_state: int | None = None, progress: bool = False,
                   seed: int | None = None) -> Regressor:
    """The unfitted regressor ``method`` with constructor ``options``.

    ``random_state`` (``seed`` is its old name) fills the estimator's ``random_state`` when it
    has one and ``options`` does not set it (default 0); ``progress`` fills ``verbose`` likewise.
    ValueError (one line) for an unknown method or option.
    """
    if method not in METHOD_NAMES and method not in METHODS:
        raise ValueError(f"unknown method {method!r}; choose from {', '.join(METHOD_NAMES)}")
    cls = get_method(method)
    opts = dict(options or {})
    for old, new in cls._renamed_params.items():
        if old in opts:
            opts.setdefault(new, opts.pop(old))
    accepted = set(cls.param_names())
    unknown = sorted(set(opts) - accepted)
    if unknown:
        raise ValueError(f"{method} has no option {', '.join(unknown)} "
                         f"(options: {', '.join(sorted(accepted)) or 'none'})")
    if "random_state" in accepted and "random_state" not in opts:
        rs = random_state if random_state is not None else seed
        opts["random_state"] = int(rs if rs is not None else 0)
    if "verbose" in accepted and "verbose" not in opts:
        opts["verbose"] = bool(progress)
    return cls(**opts)


def subset_rows(n_pool: int, n: int | None, random_state: int) -> np.ndarray:
    """Rows of a uniform random subset of at most ``n`` of ``n_pool`` rows, in pool order
    (all rows when ``n`` is None or at least ``n_pool``)."""
    if n is None or n >= n_pool:
        return np.arange(n_pool)
    return np.sort(np.random.default_rng(random_state).choice(n_pool, size=int(n),
                                                              replace=False))


def training_arrays(moves: Sequence[MoveRecording], feature_set: FeatureSet | None = None,
                    *, groups: bool = False) -> tuple[np.ndarray, ...]:
    """Features X (n, feature_set.n_features) and next states Y (n, 33) of ``moves``; with
    ``groups`` also the move index of each row (n,)."""
    if feature_set is None or feature_set.is_base:
        X, Y, g = features_responses(moves)
    else:
        X, Y, g = feature_set.features_responses(moves)
    return (X, Y, g) if groups else (X, Y)


def fit_onestep(train: Sequence[MoveRecording] | tuple[np.ndarray, ...], method: str, *,
                feature_set: FeatureSet | None = None,
                options: Mapping[str, Any] | None = None, random_state: int = 0,
                n_train: int | None = None, target: str = "delta",
                gpr_pilot_points: int | None = None, progress: bool = False,
                info: Mapping[str, Any] | None = None, gate: bool = True,
                projection_data: tuple[np.ndarray, np.ndarray] | None = None) -> OneStepModel:
    """Fit a one-step model of ``method`` on ``train`` with ``feature_set``.

    ``train``: the recorded moves (the TrainPool), or their arrays ``(X, Y)`` as
    :func:`training_arrays` gives them for ``feature_set``. ``options``: the regressor's
    constructor arguments (may hold ``"target"``, which then overrides ``target``: ``"delta"``
    or ``"next"``, see :mod:`.onestep`). ``n_train``: fit on a random subset of at most this
    many rows (:func:`subset_rows`; None: all). ``random_state`` seeds the subset and the
    regressor. ``gpr_pilot_points`` (gpr only): take the hyperparameters from a fit on that many
    of the rows (seeded by ``random_state + 1``), then condition on all of them.
    ``info``: provenance merged into the model's ``info`` (which also gets method, options,
    target, seed, n_train_pool, fit time). The projection data are the states of all of
    ``train``. ``gate``: also compute the gated alpha-PROJ's default radius from the moves
    (``projection.gate_radius``, stored in the model file as ``gate``); it needs the
    moves or ``(X, Y, groups)`` with at least two moves. ``projection_data``: (states, move
    index) the projection and its gate use instead of ``train``'s (DaD: the recorded states
    only). ValueError (one line) on bad input.
    """
    opts = dict(options or {})
    target = opts.pop("target", target)
    if target not in TARGETS:
        raise ValueError(f"target must be one of {', '.join(TARGETS)}; got {target!r}")
    if n_train is not None and int(n_train) < 2:
        raise ValueError(f"the training subset must hold >= 2 samples; got {n_train}")
    estimator = make_estimator(method, opts, random_state=random_state, progress=progress)
    groups = None
    if isinstance(train, tuple):
        X, Y = train[:2]
        groups = train[2] if len(train) > 2 else None
    else:
        X, Y, groups = training_arrays(train, feature_set, groups=True)
    n_pool = X.shape[0]
    rows = subset_rows(n_pool, n_train, random_state)
    t0 = time.perf_counter()
    pilot_s = None
    if gpr_pilot_points and method == "gpr" and rows.size > gpr_pilot_points:
        sub = rows[subset_rows(rows.size, gpr_pilot_points, random_state + 1)]
        pilot = OneStepModel.fit(make_estimator("gpr", opts, random_state=random_state),
                                 X[sub], Y[sub], feature_set=feature_set)
        pilot_s = time.perf_counter() - t0
        log.info("GPR hyperparameters from %d points in %.1f s", sub.size, pilot_s)
        estimator = make_estimator(method, {**opts, "optimize": False,
                                            "init_log_params": pilot.estimator.log_params_.tolist()},
                                   random_state=random_state, progress=progress)
    log.info("fitting %s on %d of %d samples (target %s)", method, rows.size, n_pool, target)
    meta = {"method": method, "options": estimator.get_params(), "target": target,
            "seed": int(random_state), "n_train_pool": int(n_pool),
            "feature_set": (feature_set or FeatureSet()).describe()}
    if pilot_s is not None:
        meta["hyperparameter_pilot_points"] = int(gpr_pilot_points)
        meta["hyperparameter_pilot_s"] = pilot_s
    meta.update(info or {})
    if projection_data is not None:
        Y_proj, groups = projection_data
    else:
        Y_proj = Y
    model = OneStepModel.fit(estimator, X[rows], Y[rows], target=target, train_states=Y_proj,
                             data_fingerprint=fingerprint_arrays(X, Y), info=meta,
                             feature_set=feature_set)
    log.info("fitted %s in %.1f s", method, time.perf_counter() - t0)
    if gate and groups is not None and np.unique(groups).size >= 2:
        t1 = time.perf_counter()
        model.gate = gate_radius(Y_proj, groups)
        log.info("gate radius %.4g (quantile %g of the leave-move-out distances) in %.1f s",
                 model.gate["radius"], model.gate["quantile"], time.perf_counter() - t1)
    return model


def train_from_dataset(data_dir: str | os.PathLike, method: str, *,
                       options: Mapping[str, Any] | None = None,
                       max_train_samples: int | None = None, seed: int = 0,
                       progress: bool = True, target: str = "delta",
                       feature_set: FeatureSet | None = None,
                       dad_rounds: int = 0) -> OneStepModel:
    """Fit ``method`` (lr, lwpr, gpr, sor, lgpr) on the TrainPool of ``data_dir``.

    :func:`fit_onestep` on the TrainPool with ``n_train`` = ``max_train_samples``, default
    :data:`DEFAULT_MAX_TRAIN` for the method (else all). ``seed`` seeds the subset and the
    regressor. ``progress``: log progress, the regressor's own too (``verbose``), shown on
    stderr unless the program configured logging (:func:`..logs.progress_to_stderr`). ``feature_set``: the inputs (default: the paper's
    45). ``dad_rounds``: after the fit, that many rounds of Data as Demonstrator
    (:mod:`.dad`: the model's own rollouts over the TrainPool added, with the recorded next
    states as targets, and the model fitted again; ``info.dad``; a method's size cap then
    subsamples the recorded and added pairs together). Returns the fitted model (not saved).
    ValueError (one line) on bad input,
    DatasetError/BagError for an unusable dataset.
    """
    if max_train_samples is not None and int(max_train_samples) < 2:
        raise ValueError(f"max_train_samples must be >= 2; got {max_train_samples}")
    make_estimator(method, {k: v for k, v in (options or {}).items() if k != "target"})  # early
    if isinstance(dad_rounds, bool) or int(dad_rounds) != dad_rounds or dad_rounds < 0:
        raise ValueError(f"dad_rounds must be a non-negative integer; got {dad_rounds!r}")
    if dad_rounds and feature_set is not None and not feature_set.is_base:
        raise ValueError("DaD supports the paper's inputs only; drop the feature set or DaD")
    with progress_to_stderr(progress):
        return _train_from_dataset(data_dir, method, options, max_train_samples, seed, progress,
                                   target, feature_set, int(dad_rounds))


def _train_from_dataset(data_dir, method, options, max_train_samples, seed, progress, target,
                        feature_set, dad_rounds=0) -> OneStepModel:
    t0 = time.perf_counter()
    index = read_index(data_dir)
    log.info("loading the TrainPool of %s (%d bags)", data_dir, len(index.names("train")))
    moves = load_moves(data_dir, "train")
    if dad_rounds and not any(m.n_steps >= 3 for m in moves):
        raise ValueError(f"{data_dir}: DaD needs a TrainPool move of at least 3 steps")
    X, Y, groups = training_arrays(moves, feature_set, groups=True)
    log.info("%d samples from %d moves in %.1f s", X.shape[0], len(moves),
             time.perf_counter() - t0)
    cap = max_train_samples if max_train_samples is not None else DEFAULT_MAX_TRAIN.get(method)
    info = {"data_dir": os.fspath(data_dir), "n_moves": len(moves),
            "max_train_samples": None if cap is None else int(cap),
            "dataset_info": json.loads(json.dumps(index.info, default=str))}
    model = fit_onestep((X, Y, groups), method, feature_set=feature_set, options=options,
                        random_state=seed, n_train=cap, target=target, progress=progress,
                        info=info)
    if not dad_rounds:
        return model
    from .dad import dad_pairs
    Xa, Ya, added = X, Y, []
    for r in range(dad_rounds):
        t1 = time.perf_counter()
        Xd, Yd, _ = dad_pairs(model, moves)
        Xa, Ya = np.vstack([Xa, Xd]), np.vstack([Ya, Yd])
        added.append(int(Xd.shape[0]))
        info_r = {**info, "dad": {"rounds": r + 1, "pairs_added": list(added),
                                  "n_recorded": int(X.shape[0])}}
        log.info("DaD round %d: %d pairs added in %.1f s; fitting on %d", r + 1, Xd.shape[0],
                 time.perf_counter() - t1, Xa.shape[0])
        model = fit_onestep((Xa, Ya), method, feature_set=feature_set, options=options,
                            random_state=seed, n_train=cap, target=target, progress=progress,
                            info=info_r, projection_data=(Y, groups))
    return model


__all__ = ["fit_onestep", "train_from_dataset", "make_estimator", "subset_rows",
           "training_arrays", "METHOD_NAMES", "DEFAULT_MAX_TRAIN"]
