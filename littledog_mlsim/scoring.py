"""Scoring a one-step model on recorded moves: the one recipe behind ``evaluate``, ``rollout``,
``reproduce``, the rollout figures and ``diagnose``.

Two measures (paper Sections III and VI):

- :func:`one_step_scores`: nMSE per state element of s_{t+1} predicted from the measured
  (s_t, u_t) over all samples of the moves (the paper's Table I metric; variance of the
  moves' responses), with the model's own feature set.
- :func:`rollout_scores`: every move rolled out from its measured s_1 with its recorded
  commands, once per :class:`RolloutSpec` (projection kind, alpha, gate radius), scored by
  :func:`..rollout.metrics.rollout_metrics`.

:func:`score_model` runs both and returns one result (the schema below); callers keep the keys
they publish. Result schema::

    {"method": "lgpr",
     "nmse": {state name: float or None}, "nmse_mean": float or None, "n_samples": int,
     "predict_seconds_per_sample": float,
     "rollout": {label: {<rollout_metrics keys: final_xy_error_m, final_xy_error_m_median,
                          final_xy_error_m_p90, xy_error_vs_time, element_error_sum_mean,
                          nmse_at_horizon, per_move, n_nan_moves, ...>,
                         "projection": kind, "alpha": float or None, "method": str,
                         "rollout_wall_s": float, "realtime_factor": float or None,
                         "radius": float (gated alpha only)}}}

Non-finite one-step nMSE values are None (JSON null); ``nmse_mean`` is the mean over the finite
ones. Labels: ``RolloutSpec.label`` (``none``, ``bound``, ``alpha_0.5``, ``alpha_0.5_r1.2``)
unless the spec names its own.
"""
from __future__ import annotations

import time
from dataclasses import dataclass
from typing import Any, Sequence

import numpy as np

from .data.recording import MoveRecording
from .layout import CONTROL_DT
from .rollout.metrics import nmse, rollout_metrics
from .rollout.simulate import TestMove, prepare_test_moves, rollout_moves

__all__ = ["RolloutSpec", "one_step_scores", "rollout_scores", "score_model",
           "ROLLOUT_SUMMARY_KEYS"]

#: the rollout keys a summary (metrics.json, diagnose's report) keeps of a full result
ROLLOUT_SUMMARY_KEYS: tuple[str, ...] = (
    "final_xy_error_m", "final_xy_error_m_median", "final_xy_error_m_p90", "nmse_at_horizon",
    "element_error_sum_mean", "n_nan_moves", "rollout_wall_s", "realtime_factor", "radius")


@dataclass(frozen=True)
class RolloutSpec:
    """One rollout setting: projection ``kind`` (none/bound/alpha), its ``alpha``, the gate
    ``radius`` of alpha-PROJ (normalised units, 0 = plain) and an optional display ``name``."""

    kind: str = "alpha"
    alpha: float = 0.5
    radius: float = 0.0
    name: str | None = None

    @property
    def label(self) -> str:
        """``name`` if given, else ``none``, ``bound``, ``alpha_0.5`` or ``alpha_0.5_r1.2``."""
        if self.name is not None:
            return self.name
        if self.kind != "alpha":
            return self.kind
        base = f"alpha_{self.alpha:g}"
        return f"{base}_r{self.radius:g}" if self.radius > 0 else base


def _features(model: Any, test: Sequence[MoveRecording]) -> tuple[np.ndarray, np.ndarray]:
    from .models.train import training_arrays
    return training_arrays(test, getattr(model, "feature_set", None))


def one_step_scores(model: Any, test: Sequence[MoveRecording] | tuple[np.ndarray, np.ndarray]
                    ) -> dict[str, Any]:
    """One-step nMSE per state name on the moves' samples, plus the mean and timing.

    ``test``: the recordings (features computed with ``model.feature_set``: the paper's 45 plus
    any augmentations it carries) or their ``(X, Y)`` arrays."""
    X, Y = test if isinstance(test, tuple) else _features(model, test)
    t0 = time.perf_counter()
    pred = model.predict(X)
    dt = time.perf_counter() - t0
    per = {k: (float(v) if np.isfinite(v) else None) for k, v in nmse(Y, pred).items()}
    finite = [v for v in per.values() if v is not None]
    return {"nmse": per, "nmse_mean": float(np.mean(finite)) if finite else None,
            "n_samples": int(X.shape[0]),
            "predict_seconds_per_sample": dt / max(X.shape[0], 1)}


def rollout_scores(model: Any, moves: Sequence[TestMove], specs: Sequence[RolloutSpec], *,
                   keep_predictions: bool = False
                   ) -> dict[str, dict[str, Any]] | tuple[dict[str, dict[str, Any]],
                                                          dict[str, list[np.ndarray]]]:
    """Roll ``model`` out over ``moves`` once per spec; {label: full rollout result}.

    With ``keep_predictions`` also {label: predicted states per move} (for figures)."""
    out: dict[str, dict[str, Any]] = {}
    preds: dict[str, list[np.ndarray]] = {}
    robot_time = sum(m.n_steps for m in moves) * CONTROL_DT
    for spec in specs:
        projection = model.projection(spec.kind, alpha=spec.alpha, radius=spec.radius)
        t0 = time.perf_counter()
        predicted = rollout_moves(model, moves, projection)
        wall = time.perf_counter() - t0
        res = rollout_metrics(moves, predicted, projection=projection)
        res.update(projection=spec.kind, alpha=spec.alpha if spec.kind == "alpha" else None,
                   method=model.method, rollout_wall_s=wall,
                   realtime_factor=robot_time / wall if wall > 0 else None)
        if spec.kind == "alpha" and spec.radius > 0:
            res["radius"] = float(spec.radius)
        out[spec.label] = res
        if keep_predictions:
            preds[spec.label] = predicted
    return (out, preds) if keep_predictions else out


def score_model(model: Any, test: Sequence[MoveRecording],
                specs: Sequence[RolloutSpec] = (RolloutSpec(),)) -> dict[str, Any]:
    """One-step scores and rollouts (one per spec) of ``model`` on the recordings ``test``:
    the result schema of the module doc."""
    res: dict[str, Any] = {"method": model.method}
    res.update(one_step_scores(model, test))
    res["rollout"] = rollout_scores(model, prepare_test_moves(test), specs) if specs else {}
    return res
