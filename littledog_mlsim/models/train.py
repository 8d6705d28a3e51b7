"""Training a one-step model from a recorded dataset (the ``train`` verb and the trainer node).

``train_from_dataset`` loads the TrainPool bags of a dataset directory, builds the paper's
features and responses (Eq. 2), subsamples when the method has a size cap, and fits a
:class:`.onestep.OneStepModel` around the chosen regressor. The TestPool is never read.

Size caps (``DEFAULT_MAX_TRAIN``): a full GP costs O(n^3) time and O(n^2) memory, so ``gpr``
uses a random subset of 2000 points by default (the paper used 4500 with per-output
hyperparameters on a bigger machine); ``sor`` 10000 (the paper's n for SoR); ``lr``, ``lwpr`` and
``lgpr`` use the whole TrainPool. ``max_train_samples`` overrides the cap for any method. The
subset is drawn uniformly without replacement with ``seed`` and kept in TrainPool order.

The projection data stored in the model are the states of the whole TrainPool, and the data
fingerprint is that of the whole TrainPool (features and responses), whatever subset was used.
"""
from __future__ import annotations

import inspect
import json
import os
import sys
import time
from typing import Any, Mapping

import numpy as np

from ..data.dataset import features_responses, load_moves, read_index
from ..rollout.projection import gate_radius
from .features import FeatureSet
from .onestep import TARGETS, OneStepModel
from .persistence import fingerprint_arrays, get_method

METHOD_NAMES: tuple[str, ...] = ("lr", "lwpr", "gpr", "sor", "lgpr")
DEFAULT_MAX_TRAIN: dict[str, int] = {"gpr": 2000, "sor": 10000}


def make_estimator(method: str, options: Mapping[str, Any] | None = None, *, seed: int = 0,
                   progress: bool = False):
    """The unfitted regressor ``method`` with constructor ``options``.

    ``seed`` fills the estimator's ``random_state`` (or ``seed``) and ``progress`` its
    ``verbose`` argument when it has one and ``options`` does not set it. ValueError (one line)
    for an unknown method or option.
    """
    if method not in METHOD_NAMES:
        raise ValueError(f"unknown method {method!r}; choose from {', '.join(METHOD_NAMES)}")
    cls = get_method(method)
    opts = dict(options or {})
    accepted = set(inspect.signature(cls.__init__).parameters) - {"self"}
    unknown = sorted(set(opts) - accepted)
    if unknown:
        raise ValueError(f"{method} has no option {', '.join(unknown)} "
                         f"(options: {', '.join(sorted(accepted)) or 'none'})")
    for name in ("random_state", "seed"):
        if name in accepted and name not in opts:
            opts[name] = int(seed)
            break
    if "verbose" in accepted and "verbose" not in opts:
        opts["verbose"] = bool(progress)
    return cls(**opts)


def train_from_dataset(data_dir: str | os.PathLike, method: str, *,
                       options: Mapping[str, Any] | None = None,
                       max_train_samples: int | None = None, seed: int = 0,
                       progress: bool = True, target: str = "delta",
                       feature_set: FeatureSet | None = None) -> OneStepModel:
    """Fit ``method`` (lr, lwpr, gpr, sor, lgpr) on the TrainPool of ``data_dir``.

    ``options``: the regressor's constructor arguments (may also hold ``"target"``, which then
    overrides ``target``: ``"delta"`` or ``"next"``, see :mod:`.onestep`). ``max_train_samples``:
    use a random subset of at most this many samples (default: ``DEFAULT_MAX_TRAIN`` for the
    method, else all). ``seed`` seeds the subset and the regressor. ``progress`` prints progress
    lines to stderr. ``feature_set``: the inputs (default: the paper's 45 features). Returns the
    fitted model (not saved). ValueError (one line) on bad input, DatasetError/BagError for an
    unusable dataset.
    """
    opts = dict(options or {})
    target = opts.pop("target", target)
    if target not in TARGETS:
        raise ValueError(f"target must be one of {', '.join(TARGETS)}; got {target!r}")
    estimator = make_estimator(method, opts, seed=seed, progress=progress)
    if max_train_samples is not None and int(max_train_samples) < 2:
        raise ValueError(f"max_train_samples must be >= 2; got {max_train_samples}")

    def say(text: str) -> None:
        if progress:
            print(f"train: {text}", file=sys.stderr, flush=True)

    t0 = time.perf_counter()
    index = read_index(data_dir)
    say(f"loading the TrainPool of {data_dir} ({len(index.names('train'))} bags)")
    moves = load_moves(data_dir, "train")
    if feature_set is None or feature_set.is_base:
        X, Y, groups = features_responses(moves)
    else:
        X, Y, groups = feature_set.features_responses(moves)
    n_pool = X.shape[0]
    cap = max_train_samples if max_train_samples is not None else DEFAULT_MAX_TRAIN.get(method)
    rows = np.arange(n_pool)
    if cap is not None and n_pool > int(cap):
        rows = np.sort(np.random.default_rng(seed).choice(n_pool, size=int(cap), replace=False))
    say(f"{n_pool} samples from {len(moves)} moves in {time.perf_counter() - t0:.1f} s; "
        f"fitting {method} on {rows.size} (target {target})")
    info = {
        "method": method, "options": estimator.get_params(), "target": target,
        "seed": int(seed), "data_dir": os.fspath(data_dir), "n_train_pool": int(n_pool),
        "n_moves": len(moves), "max_train_samples": None if cap is None else int(cap),
        "dataset_info": json.loads(json.dumps(index.info, default=str)),
        "feature_set": (feature_set or FeatureSet()).describe(),
    }
    t1 = time.perf_counter()
    model = OneStepModel.fit(estimator, X[rows], Y[rows], target=target, train_states=Y,
                             data_fingerprint=fingerprint_arrays(X, Y), info=info,
                             feature_set=feature_set)
    say(f"fitted {method} in {time.perf_counter() - t1:.1f} s")
    if np.unique(groups).size >= 2:   # the gated alpha-PROJ's default radius, from the moves
        t2 = time.perf_counter()
        model.gate = gate_radius(Y, groups)
        say(f"gate radius {model.gate['radius']:.4g} (quantile {model.gate['quantile']} of the "
            f"leave-move-out distances) in {time.perf_counter() - t2:.1f} s")
    return model


__all__ = ["train_from_dataset", "make_estimator", "METHOD_NAMES", "DEFAULT_MAX_TRAIN"]
