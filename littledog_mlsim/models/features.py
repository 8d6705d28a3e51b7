"""Feature sets: the paper's 45 features plus named augmentations, in batch and online.

The paper's one-step model maps x_t = (s_t, u_t) (45 features, ``layout.FEATURE_NAMES``) to
s_{t+1}. A model that carries an *effect* the paper's features miss (a command delay, friction,
a heading-dependent force, ...) needs more inputs, computed from what a simulator sees: the state
and command streams. An :class:`Augmentation` is one such named, parametrised transform; a
:class:`FeatureSet` is the paper's 45 features followed by the columns of its augmentations, in
order. The same object computes the features

- in batch, from recordings (:meth:`FeatureSet.features_responses`, aligned sample for sample
  with :func:`..data.states.features_responses`), and
- online, step by step and batched over B simulated moves (:meth:`FeatureSet.history` ->
  :class:`FeatureHistory`), for the rollout and the 100 Hz node,

and both give the same numbers (``test/diagnose/test_diagnose.py`` checks that they are equal).

What an augmentation may look at (the :class:`Window` it is given), for the sample at step t:

- ``s(k)`` = s_{t-k}, ``u(k)`` = u_{t-k} for 0 <= k <= ``max_lag`` (the state the model is given
  and the commands sent);
- ``pose`` = (x_w, y_w, yaw) at t, the pose the state drops on purpose, integrated from the states
  as the contract says (``integrate_path``: yaw += dyaw, p += R(roll, pitch, yaw at t-1) d_b);
- ``elapsed`` = seconds since the history started.

History rule (the same in both modes): the history starts at the first sample of a move (batch:
s_1 with u_1, the first feature/response pair of ``features_responses``; online: the state the
simulator starts from and the first command it is given). Lags that reach before it repeat the
first state and the first command (the robot is taken to have been at rest holding its first
command), and elapsed time is 0 there. The pose starts from the pose given at the first sample
(batch: the recording's measured pose at measurement 1; the rollout uses the same).

Augmentations with a memory beyond a fixed window (the backlash "play" operator) are recursive:
they carry a state from step to step (``init_carry``/``advance``), run through the same code in
both modes (batch loops over time, batched over the moves).

Files: a model records ``FeatureSet.to_dict()`` in its metadata: the augmentations' registered
names and parameters (plain JSON; nothing executable), plus the column names. ``from_dict``
rebuilds it and fails with a one-line ``FeatureSetError`` for an augmentation this build does not
know. Registered augmentations are listed in :data:`AUGMENTATIONS`.

Modules: this one holds the feature-set machinery (:class:`FeatureSet`, :class:`FeatureHistory`,
:func:`batch_columns`, :func:`integrate_pose`); :mod:`.feature_base` what an augmentation is and
sees (:class:`Augmentation`, :class:`Window`, the registry); :mod:`.feature_library` the
catalogue of augmentations (registered on import). Every public name of the three is
importable from here.
"""
from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any, Mapping, Sequence

import numpy as np

from ..data.states import actions_from_recording, initial_pose, states_from_recording
from ..data.recording import MoveRecording
from ..layout import CONTROL_DT, FEATURE_NAMES, N_ACTION, N_FEATURE, N_STATE, S
from ..rotations import rpy_to_matrix
from .feature_base import (AUGMENTATIONS, Augmentation, FeatureSetError, Window,
                           augmentation_from_dict, register_augmentation)
from .feature_library import (JOINT_GROUPS, STATE_GROUPS, CommandedLift, CommandFilter,
                              CommandIncrement, CommandLag, ElapsedTime, FootHeight, GaitPhase,
                              Heading, JointRateMagnitude, JointRateSign, PlanarPosition, Play,
                              StateLag, TrackingSaturation)

FEATURE_SET_FORMAT_VERSION = 1
BASE_FEATURES = "paper45"

__all__ = [
    "Augmentation", "AUGMENTATIONS", "register_augmentation", "augmentation_from_dict",
    "FeatureSet", "FeatureSetError", "FeatureHistory", "Window", "batch_columns",
    "integrate_pose", "CommandLag", "CommandIncrement", "StateLag", "CommandFilter",
    "TrackingSaturation", "JointRateSign", "JointRateMagnitude", "Play", "Heading",
    "PlanarPosition", "ElapsedTime", "FootHeight", "CommandedLift", "GaitPhase",
    "STATE_GROUPS", "JOINT_GROUPS", "BASE_FEATURES", "FEATURE_SET_FORMAT_VERSION",
]


# ---------------------------------------------------------------------------------------------
# feature sets


@dataclass(frozen=True)
class FeatureSet:
    """The paper's 45 features followed by the columns of ``augmentations``, in order."""

    augmentations: tuple[Augmentation, ...] = field(default_factory=tuple)

    def __post_init__(self) -> None:
        object.__setattr__(self, "augmentations", tuple(self.augmentations))
        for a in self.augmentations:
            if not isinstance(a, Augmentation):
                raise FeatureSetError(f"not an augmentation: {a!r}")
        names = self.names
        if len(set(names)) != len(names):
            dup = sorted({n for n in names if names.count(n) > 1})
            raise FeatureSetError(f"feature set has duplicate columns: {', '.join(dup[:5])}")

    # -- description

    @property
    def extra_names(self) -> tuple[str, ...]:
        return tuple(c for a in self.augmentations for c in a.columns())

    @property
    def names(self) -> tuple[str, ...]:
        return FEATURE_NAMES + self.extra_names

    @property
    def n_features(self) -> int:
        return N_FEATURE + len(self.extra_names)

    @property
    def n_extra(self) -> int:
        return len(self.extra_names)

    @property
    def is_base(self) -> bool:
        return not self.augmentations

    @property
    def max_lag(self) -> int:
        return max((a.max_lag for a in self.augmentations), default=0)

    @property
    def needs_pose(self) -> bool:
        return any(a.needs_pose for a in self.augmentations)

    def with_augmentation(self, aug: Augmentation) -> "FeatureSet":
        return FeatureSet(self.augmentations + (aug,))

    def column_slices(self) -> list[slice]:
        """Column range of each augmentation in the full feature vector."""
        out, start = [], N_FEATURE
        for a in self.augmentations:
            n = len(a.columns())
            out.append(slice(start, start + n))
            start += n
        return out

    def to_dict(self) -> dict[str, Any]:
        return {"format_version": FEATURE_SET_FORMAT_VERSION, "base": BASE_FEATURES,
                "augmentations": [a.to_dict() for a in self.augmentations]}

    @classmethod
    def from_dict(cls, d: Mapping[str, Any] | None) -> "FeatureSet":
        """Inverse of :meth:`to_dict`; None or {} is the paper's feature set."""
        if not d:
            return cls()
        if not isinstance(d, Mapping):
            raise FeatureSetError("feature_set must be a mapping")
        if d.get("format_version") != FEATURE_SET_FORMAT_VERSION:
            raise FeatureSetError(f"unsupported feature_set format_version "
                                  f"{d.get('format_version')!r} (this build reads "
                                  f"{FEATURE_SET_FORMAT_VERSION})")
        if d.get("base", BASE_FEATURES) != BASE_FEATURES:
            raise FeatureSetError(f"unknown base feature set {d.get('base')!r}")
        augs = d.get("augmentations") or []
        if not isinstance(augs, list):
            raise FeatureSetError("feature_set.augmentations must be a list")
        return cls(tuple(augmentation_from_dict(a) for a in augs))

    def describe(self) -> str:
        if self.is_base:
            return "paper (45 features)"
        return "paper (45) + " + " + ".join(a.label() for a in self.augmentations)

    # -- batch

    def _window_batch(self, S_: np.ndarray, U: np.ndarray, pose: np.ndarray | None
                      ) -> Window:
        """Window over (B, T, .) arrays: lags shifted along time, the first row repeated."""
        return _lag_window(S_, U, pose, self.max_lag)

    def _extra_batch(self, S_: np.ndarray, U: np.ndarray, pose: np.ndarray | None) -> np.ndarray:
        """Extra columns (B, T, n_extra) for moves of equal length, from the first sample on."""
        B, T = S_.shape[:2]
        if not self.augmentations:
            return np.empty((B, T, 0))
        w = self._window_batch(S_, U, pose)
        return np.concatenate([_compute_batch(a, w) for a in self.augmentations], axis=-1)

    def move_arrays(self, rec: MoveRecording) -> tuple[np.ndarray, np.ndarray, np.ndarray,
                                                         np.ndarray | None]:
        """(S, U, Y, pose) of one recording: S = s_1..s_{N-1} (T, 33), U = u_1..u_{N-1},
        Y = s_2..s_N, pose (T, 3) at s_1..s_{N-1} integrated from the measured pose at
        measurement 1 (None if no augmentation needs it)."""
        s = states_from_recording(rec)
        u = actions_from_recording(rec)
        if s.shape[0] < 2:
            raise ValueError(f"{rec.name}: needs at least 2 steps for one feature/response pair")
        S_, U, Y = s[:-1], u[1:], s[1:]
        pose = None
        if self.needs_pose:
            p0 = initial_pose(rec, 1)
            pose = integrate_pose(S_[None], np.array([[p0.x0, p0.y0, p0.yaw0]]))[0]
        return S_, U, Y, pose

    def extra_features(self, recs: Sequence[MoveRecording]) -> np.ndarray:
        """Extra columns (n, n_extra), rows aligned with ``data.states.features_responses``."""
        return self.features_responses(recs)[0][:, N_FEATURE:]

    def features_responses(self, recs: Sequence[MoveRecording]
                           ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """X (n, n_features), Y (n, 33), move_index (n,): ``dataset.features_responses`` with
        this set's extra columns appended (same rows, same order)."""
        if len(recs) == 0:
            raise ValueError("features_responses needs at least one recording")
        arrays = [self.move_arrays(r) for r in recs]
        by_len: dict[int, list[int]] = {}
        for i, (S_, _, _, _) in enumerate(arrays):
            by_len.setdefault(S_.shape[0], []).append(i)
        extra: list[np.ndarray | None] = [None] * len(recs)
        for T, idx in by_len.items():
            S_ = np.stack([arrays[i][0] for i in idx])
            U = np.stack([arrays[i][1] for i in idx])
            pose = np.stack([arrays[i][3] for i in idx]) if self.needs_pose else None
            E = self._extra_batch(S_, U, pose)
            for j, i in enumerate(idx):
                extra[i] = E[j]
        X = np.vstack([np.hstack([S_, U, e]) for (S_, U, _, _), e in zip(arrays, extra)])
        Y = np.vstack([a[2] for a in arrays])
        move_index = np.concatenate([np.full(a[0].shape[0], i, dtype=np.int64)
                                     for i, a in enumerate(arrays)])
        return X, Y, move_index

    # -- online

    def history(self, s0: np.ndarray, pose0: np.ndarray | Sequence[float] | None = None
                ) -> "FeatureHistory":
        """An online feature computer starting at state(s) ``s0`` ((33,) or (B, 33)) and pose(s)
        ``pose0`` ((3,) or (B, 3): x_w, y_w, yaw; needed only if ``needs_pose``)."""
        return FeatureHistory(self, s0, pose0)


def _compute_batch(a: Augmentation, w: Window) -> np.ndarray:
    """Columns (B, T, k) of ``a`` on a batch window over (B, T) samples."""
    if not a.recursive:
        return np.asarray(a.compute(w), dtype=np.float64)
    T = w.s(0).shape[1]
    cols = []
    carry = None
    for t in range(T):
        wt = Window([x[:, t] for x in w._s], [x[:, t] for x in w._u],
                    None if w.pose is None else w.pose[:, t], w.elapsed[:, t])
        if carry is None:
            carry = a.init_carry(wt)
        f, carry = a.advance(carry, wt)
        cols.append(f)
    return np.stack(cols, axis=1)


def batch_columns(recs: Sequence[MoveRecording], augmentations: Sequence[Augmentation]
                  ) -> list[np.ndarray]:
    """The columns (n, k_i) of each augmentation on ``recs`` (rows as ``features_responses``),
    sharing the state extraction: what :meth:`FeatureSet.extra_features` gives for each one
    alone, for many at once (the diagnosis screens a whole library)."""
    fs_all = FeatureSet()
    needs_pose = any(a.needs_pose for a in augmentations)
    max_lag = max((a.max_lag for a in augmentations), default=0)
    arrays = []
    for r in recs:
        S_, U, _, _ = fs_all.move_arrays(r)
        pose = None
        if needs_pose:
            p0 = initial_pose(r, 1)
            pose = integrate_pose(S_[None], np.array([[p0.x0, p0.y0, p0.yaw0]]))[0]
        arrays.append((S_, U, pose))
    by_len: dict[int, list[int]] = {}
    for i, (S_, _, _) in enumerate(arrays):
        by_len.setdefault(S_.shape[0], []).append(i)
    per_aug: list[list[np.ndarray | None]] = [[None] * len(recs) for _ in augmentations]
    for T, idx in by_len.items():
        S_ = np.stack([arrays[i][0] for i in idx])
        U = np.stack([arrays[i][1] for i in idx])
        pose = np.stack([arrays[i][2] for i in idx]) if needs_pose else None
        w = _lag_window(S_, U, pose, max_lag)
        for k, a in enumerate(augmentations):
            E = _compute_batch(a, w)
            for j, i in enumerate(idx):
                per_aug[k][i] = E[j]
    return [np.vstack(cols) for cols in per_aug]


def _lag_window(S_: np.ndarray, U: np.ndarray, pose: np.ndarray | None, max_lag: int) -> Window:
    T = S_.shape[1]
    states, actions = [S_], [U]
    for k in range(1, max_lag + 1):
        idx = np.maximum(np.arange(T) - k, 0)
        states.append(S_[:, idx])
        actions.append(U[:, idx])
    elapsed = np.broadcast_to(np.arange(T, dtype=np.float64) * CONTROL_DT, S_.shape[:2])
    return Window(states, actions, pose, elapsed)


def integrate_pose(states: np.ndarray, pose0: np.ndarray) -> np.ndarray:
    """(x_w, y_w, yaw) at each state of (B, T, 33) ``states`` given the pose (B, 3) at the
    first one: the contract's integration (yaw += dyaw, p += R(roll, pitch, yaw at t-1) d_b),
    summed left to right exactly as :class:`FeatureHistory` does step by step. yaw is not
    wrapped (features use sin/cos of it)."""
    s = np.asarray(states, dtype=np.float64)
    B, T = s.shape[:2]
    pose = np.empty((B, T, 3))
    pose[:, 0] = pose0
    if T < 2:
        return pose
    # the yaw first (it needs nothing else), then every step's R and d_b at once: the same
    # element-wise operations as ``_pose_step``; ``np.add.accumulate`` sums left to right
    pose[:, :, 2] = np.add.accumulate(
        np.concatenate([pose[:, :1, 2], s[:, 1:, S.dyaw]], axis=1), axis=1)
    R = rpy_to_matrix(np.stack([s[:, :-1, S.roll], s[:, :-1, S.pitch], pose[:, :-1, 2]],
                               axis=-1))                       # (B, T - 1, 3, 3)
    d = s[:, 1:, S.d_b]
    for i in (0, 1):
        step = R[..., i, 0] * d[..., 0] + R[..., i, 1] * d[..., 1] + R[..., i, 2] * d[..., 2]
        pose[:, :, i] = np.add.accumulate(
            np.concatenate([pose[:, :1, i], step], axis=1), axis=1)
    return pose


def _pose_step(pose: np.ndarray, s_prev: np.ndarray, s_next: np.ndarray) -> np.ndarray:
    """One integration step: pose (B, 3) at s_prev -> pose at s_next (B, 3)."""
    rpy = np.stack([s_prev[:, S.roll], s_prev[:, S.pitch], pose[:, 2]], axis=-1)
    R = rpy_to_matrix(rpy)                                    # (B, 3, 3)
    d = s_next[:, S.d_b]
    dx = R[:, 0, 0] * d[:, 0] + R[:, 0, 1] * d[:, 1] + R[:, 0, 2] * d[:, 2]
    dy = R[:, 1, 0] * d[:, 0] + R[:, 1, 1] * d[:, 1] + R[:, 1, 2] * d[:, 2]
    return np.stack([pose[:, 0] + dx, pose[:, 1] + dy, pose[:, 2] + s_next[:, S.dyaw]], axis=-1)


class FeatureHistory:
    """Online features of a :class:`FeatureSet` for B moves advancing together.

    Per step: ``x = hist.features(u_t)`` gives the (B, n_features) feature rows of the current
    state s_t and the command u_t (remembering u_t), then ``hist.push(s_next)`` advances to
    s_{t+1}. Lagged values come from ring buffers of the last ``max_lag`` states and commands
    (at the first step filled with the first state and command); the pose is integrated from
    ``pose0``; recursive augmentations keep their carry here. A move whose state turned NaN
    keeps producing NaN rows (callers drop them).
    """

    def __init__(self, feature_set: FeatureSet, s0: np.ndarray,
                 pose0: np.ndarray | Sequence[float] | None = None) -> None:
        s0 = np.asarray(s0, dtype=np.float64)
        self.single = s0.ndim == 1
        s0 = np.atleast_2d(s0)
        if s0.ndim != 2 or s0.shape[1] != N_STATE:
            raise ValueError(f"s0 must be ({N_STATE},) or (B, {N_STATE}), got {s0.shape}")
        self.feature_set = feature_set
        self.B = s0.shape[0]
        self.L = feature_set.max_lag
        self._states = [s0.copy() for _ in range(self.L + 1)]   # [s_t, s_{t-1}, ...]
        self._actions: list[np.ndarray] | None = None            # [u_t, u_{t-1}, ...]
        self._pending_u = False
        self.steps = 0
        self.pose = None
        if feature_set.needs_pose:
            if pose0 is None:
                raise ValueError(f"feature set {feature_set.describe()} needs the initial pose "
                                 f"(x_w, y_w, yaw)")
            p = np.asarray(pose0, dtype=np.float64)
            self.pose = np.broadcast_to(p, (self.B, 3)).copy()
        self._carry: dict[int, np.ndarray] = {}          # recursive augmentations' state
        self._pending_carry: dict[int, np.ndarray] = {}  # ... after the current step

    def copy(self) -> "FeatureHistory":
        """An independent copy (to undo a step: keep one, restore it if the step is refused).
        Arrays are never modified in place here, so copying the containers is enough."""
        new = object.__new__(FeatureHistory)
        new.__dict__.update(self.__dict__)
        new._states = list(self._states)
        new._actions = None if self._actions is None else list(self._actions)
        new._carry = dict(self._carry)
        new._pending_carry = dict(self._pending_carry)
        return new

    @property
    def state(self) -> np.ndarray:
        """The current s_t, (B, 33) (or (33,) if started from one state)."""
        return self._states[0][0] if self.single else self._states[0]

    def _window(self) -> Window:
        elapsed = np.full(self.B, self.steps * CONTROL_DT)
        return Window(self._states, self._actions, self.pose, elapsed)

    def features(self, u: np.ndarray) -> np.ndarray:
        """Feature rows (B, n_features) (or (n_features,)) for the current state and command
        ``u`` ((12,) or (B, 12)). Calling it again before ``push`` replaces the command."""
        u = np.asarray(u, dtype=np.float64)
        u2 = np.broadcast_to(np.atleast_2d(u), (self.B, N_ACTION)).copy()
        if self._actions is None:
            self._actions = [u2.copy() for _ in range(self.L + 1)]
        elif self._pending_u:
            self._actions[0] = u2
        else:
            self._actions = [u2] + self._actions[:self.L]
        self._pending_u = True
        fs = self.feature_set
        out = np.empty((self.B, fs.n_features))
        out[:, :N_STATE] = self._states[0]
        out[:, N_STATE:N_FEATURE] = u2
        w = self._window()
        for i, (a, sl) in enumerate(zip(fs.augmentations, fs.column_slices())):
            if not a.recursive:
                out[:, sl] = a.compute(w)
                continue
            carry = self._carry.get(i)
            if carry is None:
                carry = a.init_carry(w)
            out[:, sl], self._pending_carry[i] = a.advance(carry, w)
        return out[0] if self.single else out

    def push(self, s_next: np.ndarray) -> None:
        """Advance to the next state ((33,) or (B, 33)) after ``features`` was called."""
        if not self._pending_u:
            raise RuntimeError("FeatureHistory.push before features(u) for this step")
        s_next = np.asarray(s_next, dtype=np.float64)
        s2 = np.atleast_2d(s_next)
        if s2.shape != (self.B, N_STATE):
            raise ValueError(f"s_next must be ({self.B}, {N_STATE}), got {s_next.shape}")
        if self.pose is not None:
            self.pose = _pose_step(self.pose, self._states[0], s2)
        self._states = [s2.copy()] + self._states[:self.L]
        self._carry.update(self._pending_carry)
        self._pending_carry = {}
        self._pending_u = False
        self.steps += 1
