"""Sequential prediction: feed the one-step model's predictions back (paper Sections I, VI).

A model is anything with ``predict(X) -> Y``: ``X`` (n, 45) raw features ``[s_t, u_t]`` in
``layout.FEATURE_NAMES`` order, ``Y`` (n, 33) raw ``s_{t+1}``; with ``return_std=True`` also a
(n, 33) predictive std. Every predicted state goes through a ``Projection`` (none, BOUND,
alpha-PROJ) before it becomes the next step's feature vector.

Test moves: from a recording with measurements k = 0..N (``states_from_recording`` gives
s_1..s_N), a rollout starts at the recorded s_1, applies the recorded u_1..u_{N-1} and is compared
with the recorded s_2..s_N (T = N - 1 predicted states; 399 for a 4 s move). The world path of a
state sequence s_2.. is ``integrate_path(states, *initial_pose(rec, 1))``; the reference path is the
recorded odometry position at measurements 2..N.

Models with a feature set beyond the paper's 45 (``model.feature_set``, see
``models/features.py``): ``rollout`` keeps a :class:`..models.features.FeatureHistory` per batch
(lagged states and commands, the integrated pose, recursive terms) and asks it for each step's
feature rows, so such a model is rolled out exactly like a 45-feature one; the pose starts from
``pose0`` (``rollout_moves`` passes each move's measured pose at s_1). ``step`` takes the
history as an argument (the node keeps one per simulated robot).
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import Any, Sequence

import numpy as np

from ..data.states import (
    InitialPose, actions_from_recording, initial_pose, integrate_path, states_from_recording,
)
from ..data.recording import MoveRecording
from ..layout import N_ACTION, N_FEATURE, N_STATE
from ..projection import NoProjection, Projection

__all__ = ["TestMove", "prepare_test_move", "prepare_test_moves", "rollout", "step",
           "rollout_moves", "predicted_paths"]


@dataclass
class TestMove:
    """One TestPool move prepared for a rollout (T = N - 1 steps)."""

    __test__ = False  # not a pytest class

    name: str               # bag name, e.g. "BL_15"
    move_type: str
    s0: np.ndarray          # (33,)  recorded s_1, the rollout's initial state
    actions: np.ndarray     # (T, 12) recorded u_1..u_{N-1}
    states: np.ndarray      # (T, 33) recorded s_2..s_N, the ground truth
    pose0: InitialPose      # measured pose at measurement 1 (initial condition of the path)
    xy: np.ndarray          # (T, 2) recorded odometry x_w, y_w at measurements 2..N

    @property
    def n_steps(self) -> int:
        return int(self.actions.shape[0])


def prepare_test_move(rec: MoveRecording) -> TestMove:
    """Prepare one recording for a rollout (needs N >= 2 commands)."""
    s = states_from_recording(rec)            # rows: s_1..s_N
    u = actions_from_recording(rec)           # rows: u_0..u_{N-1}
    if s.shape[0] < 2:
        raise ValueError(f"{rec.name}: a rollout needs at least 2 steps, got {s.shape[0]}")
    pos = np.asarray(rec.position, dtype=np.float64)
    return TestMove(name=rec.name, move_type=rec.move_type, s0=s[0].copy(),
                    actions=u[1:].copy(), states=s[1:].copy(), pose0=initial_pose(rec, 1),
                    xy=pos[2:, :2].copy())


def prepare_test_moves(recs: Sequence[MoveRecording]) -> list[TestMove]:
    """``prepare_test_move`` of each recording, in order."""
    return [prepare_test_move(r) for r in recs]


def _predict(model: Any, X: np.ndarray, return_std: bool):
    if return_std:
        mean, std = model.predict(X, return_std=True)
        mean, std = np.asarray(mean, dtype=np.float64), np.asarray(std, dtype=np.float64)
        if std.shape != (X.shape[0], N_STATE):
            raise ValueError(f"model std has shape {std.shape}, expected {(X.shape[0], N_STATE)}")
    else:
        mean, std = np.asarray(model.predict(X), dtype=np.float64), None
    if mean.shape != (X.shape[0], N_STATE):
        raise ValueError(f"model prediction has shape {mean.shape}, "
                         f"expected {(X.shape[0], N_STATE)}")
    return mean, std


def model_feature_set(model: Any):
    """The model's :class:`..models.features.FeatureSet` if it goes beyond the paper's 45
    features (then stepping it needs a FeatureHistory), else None."""
    fs = getattr(model, "feature_set", None)
    return None if fs is None or fs.is_base else fs


def rollout(model: Any, s0: np.ndarray, actions: np.ndarray, projection: Projection | None = None,
            return_std: bool = False, pose0: np.ndarray | None = None):
    """Predict T steps ahead for B moves at once, feeding predictions back.

    Args:
        model: ``predict(X (n, 45)) -> (n, 33)`` (raw units); with ``return_std`` it must accept
            ``return_std=True``.
        s0: (B, 33) initial states (or (33,) for one move); used as given, not projected.
        actions: (B, T, 12) u for each step (or (T, 12)).
        projection: applied to every predicted state; None = ``none``.
        return_std: also return the model's one-step predictive std at each step, evaluated at
            the fed-back (predicted, projected) state; it is not propagated through the dynamics.
        pose0: (B, 3) or (3,) x_w, y_w, yaw at s0; needed only by a model whose feature set
            uses the pose.

    Returns:
        states (B, T, 33): ``states[:, k]`` is the projected prediction k + 1 steps after s0
        (or (T, 33)); with ``return_std`` also std of the same shape.

    One ``model.predict`` call per step covers all moves still finite; a move whose state became
    NaN (non-finite prediction, see ``Projection``) stays NaN for the rest of the rollout and is no
    longer passed to the model. The steps are those of the batched learned simulator
    (:class:`.vector_sim.VectorLearnedSimulator`, B robots).
    """
    projection = NoProjection() if projection is None else projection
    s = np.asarray(s0, dtype=np.float64)
    u = np.asarray(actions, dtype=np.float64)
    single = s.ndim == 1
    if single:
        s, u = s[None], u[None]
    if s.ndim != 2 or s.shape[1] != N_STATE:
        raise ValueError(f"s0 must be (B, {N_STATE}) or ({N_STATE},), got {np.shape(s0)}")
    if u.ndim != 3 or u.shape[0] != s.shape[0] or u.shape[2] != N_ACTION:
        raise ValueError(f"actions must be (B, T, {N_ACTION}) with B = {s.shape[0]}, "
                         f"got {np.shape(actions)}")
    if not np.all(np.isfinite(u)):
        raise ValueError("actions hold NaN or inf")
    B, T = u.shape[:2]
    out = np.full((B, T, N_STATE), np.nan)
    std_out = np.full((B, T, N_STATE), np.nan) if return_std else None
    from .vector_sim import VectorLearnedSimulator   # (it imports this module)
    sim = VectorLearnedSimulator(model, projection, s, pose0, use_variance=return_std,
                                 track_pose=False)
    for t in range(T):
        if not sim.alive.any():
            break
        sim.step(u[:, t])
        out[:, t] = sim.states
        if return_std:
            std_out[:, t] = sim.std
    if single:
        out = out[0]
        std_out = std_out[0] if return_std else None
    return (out, std_out) if return_std else out


def step(model: Any, s: np.ndarray, u: np.ndarray, projection: Projection | None = None,
         return_std: bool = False, history: Any = None):
    """One simulator step for the 100 Hz node: s_t (33,) or (B, 33), u_t (12,) or (B, 12).

    Returns the projected s_{t+1} of the same leading shape (and the model's std with
    ``return_std``). A non-finite prediction comes back as all-NaN; the caller decides what to do.

    A model with a feature set beyond the paper's 45 needs ``history``, the
    :class:`..models.features.FeatureHistory` of this simulated robot
    (``model.feature_set.history(s_0, pose_0)``, made again on every reset): its current state
    must be ``s``; it gives the feature row and is advanced to s_{t+1} here.
    """
    projection = NoProjection() if projection is None else projection
    s = np.asarray(s, dtype=np.float64)
    u = np.asarray(u, dtype=np.float64)
    single = s.ndim == 1
    fs = model_feature_set(model)
    if fs is not None and history is None:
        raise ValueError(f"this model's features ({fs.describe()}) need a FeatureHistory: "
                         f"pass history=model.feature_set.history(s0, pose0)")
    if history is not None:
        X = np.atleast_2d(history.features(u))
        if not np.array_equal(np.atleast_2d(s), X[:, :N_STATE], equal_nan=True):
            raise ValueError("history's current state is not s (push every step, reset it "
                             "with the simulator)")
    else:
        X = np.concatenate([np.atleast_2d(s), np.atleast_2d(u)], axis=1)
        if X.shape[1] != N_FEATURE:
            raise ValueError(f"s must have {N_STATE} and u {N_ACTION} elements, got "
                             f"{s.shape} and {u.shape}")
    with np.errstate(over="ignore", invalid="ignore"):
        mean, std = _predict(model, X, return_std)
        nxt = projection(mean)
    if history is not None:
        history.push(nxt)
    if single:
        nxt = nxt[0]
        std = std[0] if return_std else None
    return (nxt, std) if return_std else nxt


def rollout_moves(model: Any, moves: Sequence[TestMove], projection: Projection | None = None,
                  return_std: bool = False):
    """Roll out every test move; moves of equal length advance together in one batch.

    Returns a list of (T_i, 33) predicted states s_2..s_N per move, in order (and a list of stds
    with ``return_std``).
    """
    preds: list[np.ndarray | None] = [None] * len(moves)
    stds: list[np.ndarray | None] = [None] * len(moves)
    by_len: dict[int, list[int]] = {}
    for i, m in enumerate(moves):
        by_len.setdefault(m.n_steps, []).append(i)
    for T, idx in by_len.items():
        s0 = np.stack([moves[i].s0 for i in idx])
        u = np.stack([moves[i].actions for i in idx])
        pose0 = np.array([[moves[i].pose0.x0, moves[i].pose0.y0, moves[i].pose0.yaw0]
                          for i in idx])
        res = rollout(model, s0, u, projection, return_std=return_std, pose0=pose0)
        mean, std = res if return_std else (res, None)
        for j, i in enumerate(idx):
            preds[i] = mean[j]
            if return_std:
                stds[i] = std[j]
    return (preds, stds) if return_std else preds


def predicted_paths(moves: Sequence[TestMove], predicted: Sequence[np.ndarray]) -> list[np.ndarray]:
    """World (x_w, y_w, yaw) (T_i, 3) of each move's predicted states, from its pose at s_1."""
    if len(moves) != len(predicted):
        raise ValueError(f"{len(moves)} moves but {len(predicted)} predictions")
    with np.errstate(over="ignore", invalid="ignore"):
        return [integrate_path(p, *m.pose0) for m, p in zip(moves, predicted)]
