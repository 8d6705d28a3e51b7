"""Data as Demonstrator (DaD): train a one-step model on its own rollouts as well.

A one-step model is fitted on recorded states, but a simulator feeds it its own predictions,
which drift off the recorded trajectory; it is then asked about states it never saw. DaD
(Venkatraman, Hebert and Bagnell, AAAI 2015) rolls the fitted model out along each training
move, from the move's first state with the move's recorded commands, and adds every predicted
state, paired with the next command, as a training input whose target is the *recorded* next
state: the model learns to step from where its own errors take it back towards the data. The
model is then fitted again on both sets; ``rounds`` repeats this with the newest model's
rollouts (the added pairs accumulate).

Here the rollouts use the projection the model is served with (gated alpha-PROJ 0.5 at the
model's own radius, ``OneStepModel.gate_radius``), so the added states are those a simulator
visits. The projection's data and its gate radius stay the recorded TrainPool states: the
added inputs are predictions, not measurements. Only the paper's inputs (state and command)
are supported: inputs with a history would need the predicted history too.
"""
from __future__ import annotations

import logging
from typing import Any, Sequence

import numpy as np

from ..data.recording import MoveRecording
from ..layout import N_STATE
from ..rollout.simulate import prepare_test_moves, rollout_moves

log = logging.getLogger(__name__)

__all__ = ["dad_pairs", "served_projection"]


def served_projection(model: Any):
    """The projection a simulator serves the model with: gated alpha-PROJ 0.5 at its radius."""
    radius, _ = model.gate_radius()
    return model.projection("alpha", alpha=0.5, radius=radius)


def dad_pairs(model: Any, moves: Sequence[MoveRecording], projection: Any = None
              ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(X, Y, move index) of the DaD pairs of ``moves``: each predicted state s^_k (k >= 2),
    with the recorded command u_k, and the recorded next state s_{k+1}.

    ``projection``: of the rollouts (default: :func:`served_projection`). Pairs whose predicted
    state is not finite are left out, and so are moves of fewer than 3 steps (an imported
    recording may hold them); the move index counts the moves kept.
    """
    fs = getattr(model, "feature_set", None)
    if fs is not None and not fs.is_base:
        raise ValueError("DaD supports the paper's inputs only (state and command); this model "
                         "has a feature set with more")
    projection = served_projection(model) if projection is None else projection
    moves = [m for m in moves if m.n_steps >= 3]       # a pair needs two predicted steps
    if not moves:
        raise ValueError("DaD needs a TrainPool move of at least 3 steps")
    tms = prepare_test_moves(moves)
    preds = rollout_moves(model, tms, projection)
    xs, ys, gs = [], [], []
    for i, (m, p) in enumerate(zip(tms, preds)):
        # p[k] = s^_{k+2}, reached with actions[k] = u_{k+1}; the next step applies
        # actions[k+1] = u_{k+2} and the robot reached states[k+1] = s_{k+3}.
        x = np.hstack([p[:-1], m.actions[1:]])
        ok = np.all(np.isfinite(x), axis=1)
        xs.append(x[ok])
        ys.append(m.states[1:][ok])
        gs.append(np.full(int(ok.sum()), i, dtype=np.int64))
    X, Y, g = np.vstack(xs), np.vstack(ys), np.concatenate(gs)
    log.info("DaD: %d pairs from %d moves (mean |s^_k - s_k+1| %.4g per element)", X.shape[0],
             len(tms), float(np.mean(np.abs(X[:, :N_STATE] - Y))) if len(X) else float("nan"))
    return X, Y, g
