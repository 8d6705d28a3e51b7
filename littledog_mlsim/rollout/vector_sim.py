"""N learned LittleDogs stepped at once: the batched learned simulator (no rclpy).

:class:`VectorLearnedSimulator` is :class:`.learned_sim.LearnedSimulator` over N robots, vectorised
across them, in the shape of a Gymnasium vector environment's core: ``num_envs`` robots,
``reset(mask)`` (all or some of them) and ``step(actions)`` with ``actions`` (N, 12) desired
joint angles, the observations (N, 33) states coming back, each robot's own initial state and
pose. It has no reward and does not depend on Gymnasium: a task (reward, termination,
observation and action spaces, autoreset) would be a thin wrapper around it, and adds the
dependency only for the user who wants one; the project's own rollouts need none of it. One step is
one ``model.predict`` call on the feature rows of every robot still running and one projection
call on the predictions (the same calls ``rollout.simulate.rollout`` makes, which now runs on
this class), then the pose of each robot as ``LearnedSimulator`` integrates it.

Exactness:

- the states (and stds) are bit for bit those of ``rollout`` for the same robots (it is the
  same computation; ``rollout`` is built on this class and ``test/rollout/test_vector_sim.py``
  also checks it against the loop ``rollout`` had before);
- with N = 1 they are bit for bit ``LearnedSimulator``'s (sim_node's step);
- a robot in a batch of N gets the states it gets alone up to the model's rounding: a GEMM
  over N rows may round its last bits differently from one row (LGPR on the paper-size model:
  below 4e-13 of a state element after one step; LR likewise); the projection and the pose
  are computed row by row.

Divergence: a robot whose prediction is not finite stops (``alive`` False, its state NaN, as in
``rollout``) until it is reset; the others go on. ``reset(mask)`` restarts some robots (at
their initial state and pose). A model with a feature set beyond the paper's 45 keeps one
:class:`..models.features.FeatureHistory` for all N robots; it restarts only with all of them
(``reset()``).

The gate's shortcut (``LearnedSimulator``'s module doc) applies per robot: with a gated
alpha-PROJ and an LGPR model only the predictions outside the gate go to the exact
nearest-neighbour search. Speed over N: ``benchmarks/sim_node_20x`` ("batch").
"""
from __future__ import annotations

from typing import Any

import numpy as np

from ..layout import N_ACTION, N_FEATURE, N_STATE, S, wrap_angle
from ..projection import AlphaProjection, NoProjection, Projection
from ..rotations import rpy_to_matrix
from .learned_sim import gate_candidates, recent_states
from .simulate import _predict, model_feature_set

__all__ = ["VectorLearnedSimulator"]


def _rows(a, n: int | None, width: int, what: str) -> np.ndarray:
    v = np.asarray(a, dtype=np.float64)
    if v.ndim == 1:
        v = v[None]
    if v.ndim != 2 or v.shape[1] != width or (n is not None and v.shape[0] not in (1, n)):
        raise ValueError(f"{what} must be ({'N' if n is None else n}, {width}) or ({width},), "
                         f"got {np.shape(a)}")
    if n is not None and v.shape[0] == 1 and n > 1:
        v = np.repeat(v, n, axis=0)
    return np.array(v, dtype=np.float64)


class VectorLearnedSimulator:
    """N learned LittleDogs: ``reset(mask=None)``, ``step(actions)``, then read the attributes.

    Args:
        model: ``predict(X) -> (n, 33)`` raw (``OneStepModel``); a model with an augmented
            feature set is stepped through a ``FeatureHistory`` (module doc).
        projection: applied to every prediction (None: ``none``).
        initial_states: (N, 33) s_0 of each robot (or (33,) for all; then ``num_envs``).
        initial_poses: (N, 3) or (3,) x, y, yaw in odom at s_0 (None: zeros; a model whose
            features use the pose gets None passed on, as ``rollout`` does).
        use_variance: also the model's predictive std of each step (``std``).
        trust_radius: r > 0: robots whose prediction is further than r from the TrainPool are
            ``extrapolating`` (as ``LearnedSimulator``); 0: never.
        gate_shortcut: the gate's shortcut (``LearnedSimulator``); the states do not depend on
            it.
        track_pose: integrate the pose (``pose``); off for rollouts that only need states.
        num_envs: N when ``initial_states`` is one state.

    Attributes after ``reset``/``step``: ``states`` (N, 33) (NaN for a robot that diverged),
    ``std`` (N, 33) or None, ``pose`` (N, 3) x, y, yaw (yaw wrapped to (-pi, pi]), ``alive``
    (N,) bool, ``nn_distance`` (N,) of the last step's predictions (NaN where not known),
    ``extrapolating`` (N,) bool, ``steps`` (N,) since each robot's last reset.
    """

    def __init__(self, model: Any, projection: Projection | None, initial_states: np.ndarray,
                 initial_poses: np.ndarray | None = None, use_variance: bool = False,
                 trust_radius: float = 0.0, gate_shortcut: bool = True,
                 track_pose: bool = True, num_envs: int | None = None) -> None:
        self.model = model
        self.projection = NoProjection() if projection is None else projection
        s0 = _rows(initial_states, num_envs, N_STATE, "initial_states")
        self.num_envs = n = s0.shape[0]
        self.initial_states = s0
        self._pose_given = initial_poses is not None
        self.initial_poses = (np.zeros((n, 3)) if initial_poses is None
                              else _rows(initial_poses, n, 3, "initial_poses"))
        self.use_variance = bool(use_variance)
        self.trust_radius = float(trust_radius)
        if not (np.isfinite(self.trust_radius) and self.trust_radius >= 0):
            raise ValueError(f"trust_radius must be finite and >= 0, got {trust_radius}")
        self.track_pose = bool(track_pose)
        self.feature_set = model_feature_set(model)
        self._alpha = isinstance(self.projection, AlphaProjection)
        self._candidates, self._label = gate_candidates(model, self.projection, gate_shortcut)
        self._X = np.empty((n, N_FEATURE))
        self._last = np.full(n, -1, dtype=np.int64)    # gate shortcut: the last state named
        self.reset()

    # -- state

    def reset(self, mask: np.ndarray | None = None) -> np.ndarray:
        """Robots ``mask`` (N,) bool (None: all) back to their initial state and pose; returns
        the states (N, 33) (a copy)."""
        n = self.num_envs
        if mask is None:
            m = np.ones(n, dtype=bool)
        else:
            m = np.asarray(mask, dtype=bool).reshape(-1)
            if m.shape != (n,):
                raise ValueError(f"mask must be ({n},) bool, got {np.shape(mask)}")
        if self.feature_set is not None and not m.all():
            raise ValueError("a model with an augmented feature set restarts all robots at "
                             "once: reset() without a mask")
        if m.all():
            self.states = self.initial_states.copy()
            self.pose = self.initial_poses.copy()
            self.alive = np.isfinite(self.states).all(axis=1)
            self.std = np.full((n, N_STATE), np.nan) if self.use_variance else None
            self.nn_distance = np.full(n, np.nan)
            self.extrapolating = np.zeros(n, dtype=bool)
            self.steps = np.zeros(n, dtype=np.int64)
            self._history = (None if self.feature_set is None else self.feature_set.history(
                self.initial_states, self.initial_poses if self._pose_given else None))
        else:
            self.states[m] = self.initial_states[m]
            self.pose[m] = self.initial_poses[m]
            self.alive[m] = np.isfinite(self.states[m]).all(axis=1)
            if self.std is not None:
                self.std[m] = np.nan
            self.nn_distance[m] = np.nan
            self.extrapolating[m] = False
            self.steps[m] = 0
        self.states[~self.alive] = np.nan     # a non-finite initial state: stopped, all NaN
        self._X[:, :N_STATE] = self.states
        self._last[m] = -1
        return self.states.copy()

    def step(self, actions: np.ndarray) -> np.ndarray:
        """Advance every running robot 10 ms with its desired joint angles ``actions`` (N, 12)
        (finite; rows of stopped robots are ignored); returns the states (N, 33) (a copy)."""
        n = self.num_envs
        u = np.asarray(actions, dtype=np.float64)
        if u.shape != (n, N_ACTION):
            raise ValueError(f"actions must be ({n}, {N_ACTION}), got {u.shape}")
        idx = np.flatnonzero(self.alive)
        if idx.size == 0:
            return self.states.copy()
        every = idx.size == n
        if np.any(~np.isfinite(u[idx])):
            raise ValueError("actions hold NaN or inf")
        h = self._history
        if h is None:
            X = self._X
            X[:, N_STATE:] = u
            Xa = X if every else X[idx]
        else:
            Xh = h.features(u)
            Xa = Xh if every else Xh[idx]
        with np.errstate(over="ignore", invalid="ignore"):   # divergence is reported
            mean, std = _predict(self.model, Xa, self.use_variance)
            if self._candidates is not None:
                index = np.empty(idx.size, dtype=np.int64)
                nxt, d = self.projection.project_distance(
                    mean, (self._candidates, self._label(Xa),
                           recent_states(self._last if every else self._last[idx])), index)
                self._last[idx] = index
            elif self._alpha:
                nxt, d = self.projection.project_distance(mean)
            else:
                nxt, d = self.projection(mean), np.full(idx.size, np.nan)
        ok = np.isfinite(nxt).all(axis=1)
        if self.track_pose:
            self._advance_pose(idx, nxt, ok)
        self.states[idx] = nxt
        self._X[idx, :N_STATE] = nxt
        self.alive[idx] = ok
        if not every:                  # stopped robots: nothing known about this step
            self.nn_distance[:] = np.nan
            self.extrapolating[:] = False
            if self.std is not None:
                self.std[:] = np.nan
        if self.std is not None:
            self.std[idx] = std
        self.nn_distance[idx] = d
        r = self.trust_radius
        self.extrapolating[idx] = (d > r) if r > 0 else False
        self.steps[idx] += 1
        if h is not None:
            s_next = np.full((n, N_STATE), np.nan)
            s_next[idx] = nxt
            h.push(s_next)
        return self.states.copy()

    def _advance_pose(self, idx: np.ndarray, nxt: np.ndarray, ok: np.ndarray) -> None:
        """x, y, yaw of robots idx from their new states (``LearnedSimulator.step``'s update:
        yaw += dyaw, (x, y) += R(roll_t, pitch_t, yaw_t)[:2] d_b; NaN for a diverged one)."""
        prev = self.states[idx]
        pose = self.pose[idx]
        rpy = np.stack([prev[:, S.roll], prev[:, S.pitch], pose[:, 2]], axis=1)
        with np.errstate(over="ignore", invalid="ignore"):
            R = rpy_to_matrix(rpy)[:, :2]                               # (n, 2, 3)
            dp = np.einsum("nij,nj->ni", R, nxt[:, S.d_b])
            new = np.column_stack([pose[:, 0] + dp[:, 0], pose[:, 1] + dp[:, 1],
                                   wrap_angle(pose[:, 2] + nxt[:, S.dyaw])])
        new[~ok] = np.nan
        self.pose[idx] = new
