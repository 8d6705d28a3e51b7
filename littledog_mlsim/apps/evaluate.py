"""The ``evaluate`` and ``rollout`` verbs: score a model file on a dataset's TestPool.

The scoring itself is :mod:`.scoring` (one-step nMSE, rollouts per projection, one result
schema); this module reads the model and the moves, resolves the gate radius of alpha-PROJ
(``radius``, normalised units; or ``radius_quantile``: that quantile of the TrainPool's
leave-move-out nearest-neighbour distances, :func:`trainpool_radius`) and writes the files:

- ``rollout``: ``OUT/rollout.json``, the full result of one projection;
- ``evaluate``: ``OUT/metrics.json`` (one-step nMSE and a summary per projection) and
  ``OUT/rollout_<label>.json`` per projection.

The verbs' default (``radius`` None) is the gated alpha-PROJ with the model's own radius
(``OneStepModel.gate_radius``; label ``alpha_<a>_q0.9``); ``radius=0`` is plain alpha-PROJ.

Outputs are written atomically (temporary file, then rename).
"""
from __future__ import annotations

import json
import os
from pathlib import Path
from typing import Any, Sequence

import numpy as np

from ..data.dataset import load_moves
from ..data.recording import MoveRecording
from ..data.states import features_responses
from ..fileio import atomic_write_text
from ..models.onestep import OneStepModel
from ..projection import radius_from_quantile
from ..rollout.simulate import prepare_test_moves
from ..scoring import ROLLOUT_SUMMARY_KEYS, RolloutSpec, rollout_scores, score_model

PROJECTIONS = ("none", "bound", "alpha")


def projection_label(kind: str, alpha: float, radius: float = 0.0,
                     radius_quantile: float | None = None) -> str:
    """``none``, ``bound``, ``alpha_0.5``; gated: ``alpha_0.5_q0.9`` (radius from a quantile) or
    ``alpha_0.5_r1.2`` (radius given)."""
    if kind != "alpha":
        return kind
    label = f"alpha_{alpha:g}"
    if radius_quantile is not None:
        return f"{label}_q{radius_quantile:g}"
    return f"{label}_r{radius:g}" if radius > 0 else label


def trainpool_radius(model: OneStepModel, data: str | os.PathLike, quantile: float,
                     every: int = 4) -> float:
    """The ``quantile`` of the normalised distances of TrainPool states to the nearest state of
    another TrainPool move (``projection.radius_from_quantile``, every ``every``-th state),
    with the model's TrainPool states (which must be those of ``data``'s TrainPool)."""
    if model.train_states is None:
        raise ValueError("this model holds no TrainPool states for a projection")
    _, Y, groups = features_responses(load_moves(data, split="train"))
    if Y.shape != model.train_states.shape or not np.array_equal(Y, model.train_states):
        raise ValueError(f"the model's TrainPool states are not those of {data}'s TrainPool")
    return radius_from_quantile(model.train_states, groups, quantile, every=every)


def _resolve_radius(model: OneStepModel, data: str | os.PathLike, radius: float | None,
                    radius_quantile: float | None) -> tuple[float, float | None]:
    """(radius, quantile it stands for or None): None = the model's default gate."""
    if radius is None and radius_quantile is None:
        r, _ = model.gate_radius()
        return r, (model.gate or {}).get("quantile") if r > 0 else None
    if radius_quantile is not None:
        if radius:
            raise ValueError("give radius or radius_quantile, not both")
        return trainpool_radius(model, data, radius_quantile), radius_quantile
    radius = float(radius)
    if not (np.isfinite(radius) and radius >= 0):
        raise ValueError(f"radius must be finite and >= 0, got {radius}")
    return radius, None


def write_json(path: str | os.PathLike, obj: Any) -> Path:
    """Write JSON atomically (no NaN: non-finite numbers must already be None)."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    return atomic_write_text(path, json.dumps(obj, indent=1, allow_nan=False) + "\n")


def rollout_results(model: OneStepModel, recs: Sequence[MoveRecording], kind: str = "alpha",
                    alpha: float = 0.5, radius: float = 0.0) -> dict[str, Any]:
    """Roll every recording out with the model and projection; the rollout.json document
    (:func:`..scoring.rollout_scores`).

    ``radius`` > 0 (alpha only): gated alpha-PROJ with that radius (normalised units)."""
    spec = RolloutSpec(kind, alpha, radius if kind == "alpha" else 0.0)
    return rollout_scores(model, prepare_test_moves(recs), [spec])[spec.label]


def _load(model_path: str | os.PathLike, data: str | os.PathLike, split: str
          ) -> tuple[OneStepModel, list[MoveRecording]]:
    model = OneStepModel.load(model_path)
    recs = load_moves(data, split=split)
    return model, recs


def rollout_verb(model_path: str | os.PathLike, data: str | os.PathLike, out: str | os.PathLike,
                 kind: str = "alpha", alpha: float = 0.5, split: str = "test",
                 radius: float | None = None, radius_quantile: float | None = None
                 ) -> dict[str, Any]:
    """``littledog-mlsim rollout``: writes ``OUT/rollout.json``; returns the results.

    ``radius``/``radius_quantile``: gated alpha-PROJ (see ``trainpool_radius``); alpha only.
    Neither (the default): the model's own radius (``OneStepModel.gate_radius``)."""
    if kind not in PROJECTIONS:
        raise ValueError(f"--projection must be one of {', '.join(PROJECTIONS)}, got {kind!r}")
    if not 0.0 <= alpha <= 1.0:
        raise ValueError(f"--alpha must be in [0, 1], got {alpha}")
    if kind != "alpha" and (radius or radius_quantile is not None):
        raise ValueError("--radius/--radius-quantile apply to --projection alpha only")
    model, recs = _load(model_path, data, split)
    r, q = (_resolve_radius(model, data, radius, radius_quantile) if kind == "alpha"
            else (0.0, None))
    res = rollout_results(model, recs, kind, alpha, radius=r)
    if q is not None:
        res["radius_quantile"] = float(q)
    res.update(model=str(model_path), data=str(data), split=split)
    write_json(Path(out) / "rollout.json", res)
    return res


def evaluate(model_path: str | os.PathLike, data: str | os.PathLike, out: str | os.PathLike,
             projections: Sequence[str] = PROJECTIONS, alpha: float = 0.5,
             split: str = "test", radius: float | None = None,
             radius_quantile: float | None = None) -> dict[str, Any]:
    """``littledog-mlsim evaluate``: one-step nMSE and rollout errors into ``OUT/metrics.json``.

    ``metrics.json`` = {model, method, data, split, nmse {state: value}, nmse_mean, n_samples,
    predict_seconds_per_sample, rollout {label: {final_xy_error_m, final_xy_error_m_median,
    final_xy_error_m_p90, nmse_at_horizon, element_error_sum_mean, n_nan_moves, rollout_wall_s,
    realtime_factor}}}; the full per-projection results go to ``OUT/rollout_<label>.json``.
    ``radius``/``radius_quantile`` gate the alpha projection (label ``alpha_<a>_r<r>`` or
    ``alpha_<a>_q<quantile>``; its entry also holds ``radius``); neither (the default): the
    model's own radius (label ``alpha_<a>_q0.9``; ``radius=0``: plain, ``alpha_<a>``).
    """
    for kind in projections:
        if kind not in PROJECTIONS:
            raise ValueError(f"projections must be among {', '.join(PROJECTIONS)}, got {kind!r}")
    model, recs = _load(model_path, data, split)
    r, q = (_resolve_radius(model, data, radius, radius_quantile) if "alpha" in projections
            else (0.0, None))
    specs = [RolloutSpec(kind, alpha, r if kind == "alpha" else 0.0,
                         name=projection_label(kind, alpha, r if kind == "alpha" else 0.0,
                                               q if kind == "alpha" else None))
             for kind in projections]
    scores = score_model(model, recs, specs)
    res: dict[str, Any] = {"model": str(model_path), "method": model.method, "data": str(data),
                           "split": split}
    res.update({k: v for k, v in scores.items() if k not in ("method", "rollout")})
    res["rollout"] = {}
    for spec in specs:
        full = scores["rollout"][spec.label]
        if spec.kind == "alpha" and q is not None:
            full["radius_quantile"] = float(q)
        write_json(Path(out) / f"rollout_{spec.label}.json", full)
        res["rollout"][spec.label] = {k: full.get(k) for k in ROLLOUT_SUMMARY_KEYS if k in full}
    write_json(Path(out) / "metrics.json", res)
    return res
