"""The paper's state/feature extraction (Eq. 2), path integration and normalisation.

State, action, features (docs/interface.md §4)
-----------------------------------------------
From a recording with measurements k = 0..N (N + 1 of them) and commands u_0..u_{N-1}:

- ``states_from_recording`` gives s_1..s_N, shape (N, 33) (s_0 has no previous pose): z_w;
  d_b = R(t-1)^T (p_t - p_{t-1}) with R = Rz(yaw) Ry(pitch) Rx(roll) at t-1; roll, pitch at t;
  droll/dpitch/dyaw = wrap(rpy_t - rpy_{t-1}) in (-pi, pi]; q_t; dq_t.
- ``actions_from_recording`` gives u_0..u_{N-1}, shape (N, 12).
- ``features_responses`` pairs (s_t, u_t) -> s_{t+1} for t = 1..N-1: N - 1 samples per move.
- ``integrate_path`` inverts the body part: yaw += dyaw, p_w += R(roll, pitch, yaw at t-1) d_b.

Angles are roll-pitch-yaw = ZYX Euler angles (R = Rz(yaw) Ry(pitch) Rx(roll)); quaternions are
(x, y, z, w) as in geometry_msgs.

``Normalizer``: the per-column unit-variance normalisation a one-step model fits on the
TrainPool. Where the moves come from (a dataset directory, its index and split) is
:mod:`.dataset`, which re-exports every name here.
"""
from __future__ import annotations

from typing import Any, Mapping, NamedTuple, Sequence

import numpy as np

from ..layout import N_ACTION, N_FEATURE, N_STATE, S, wrap_angle
from ..rotations import quat_to_rpy, rpy_to_matrix
from .recording import MoveRecording

__all__ = [
    "states_from_recording", "states_from_measurements", "actions_from_recording",
    "features_responses", "InitialPose", "initial_pose", "integrate_path", "Normalizer",
]


def states_from_recording(rec: MoveRecording) -> np.ndarray:
    """s_1..s_N of a recording, (N, 33) in ``layout.STATE_NAMES`` order (docs/interface.md §4)."""
    return states_from_measurements(rec.position, rec.orientation, rec.q, rec.dq)


def states_from_measurements(position, orientation, q, dq) -> np.ndarray:
    """s_1..s_N, (N, 33), from N+1 consecutive measurements: body position (N+1, 3),
    orientation (N+1, 4) xyzw, joint angles and rates (N+1, 12) (the first row only gives the
    previous pose of s_1's deltas). ``states_from_recording`` without a recording, e.g. for
    one live step from two measurements."""
    pos = np.asarray(position, dtype=np.float64)
    rpy = quat_to_rpy(orientation)                             # (N+1, 3)
    n = pos.shape[0] - 1
    R_prev = rpy_to_matrix(rpy[:-1])                            # (N, 3, 3), body(t-1) -> world
    states = np.empty((n, N_STATE), dtype=np.float64)
    states[:, S.z_w] = pos[1:, 2]
    states[:, S.d_b] = np.einsum("nji,nj->ni", R_prev, np.diff(pos, axis=0))  # R^T dp
    states[:, S.roll_pitch] = rpy[1:, :2]
    states[:, S.d_rpy] = wrap_angle(np.diff(rpy, axis=0))
    states[:, S.q] = np.asarray(q)[1:]
    states[:, S.dq] = np.asarray(dq)[1:]
    return states


def actions_from_recording(rec: MoveRecording) -> np.ndarray:
    """u_0..u_{N-1}, (N, 12): the commanded joint angles for step t -> t+1."""
    return np.asarray(rec.cmd, dtype=np.float64).reshape(-1, N_ACTION)


def features_responses(recs: Sequence[MoveRecording]) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Regression data of the paper: X = (s_t, u_t) (n, 45), Y = s_{t+1} (n, 33), t = 1..N-1.

    ``move_index`` (n,) gives the position in ``recs`` of each sample's move (N - 1 samples per
    move, in time order), for per-move splits and rollouts.
    """
    if len(recs) == 0:
        raise ValueError("features_responses needs at least one recording")
    Xs, Ys, idx = [], [], []
    for i, rec in enumerate(recs):
        s = states_from_recording(rec)          # row j is s_{j+1}
        u = actions_from_recording(rec)         # row j is u_j
        if s.shape[0] < 2:
            raise ValueError(f"{rec.name}: needs at least 2 steps for one feature/response pair")
        Xs.append(np.hstack([s[:-1], u[1:]]))   # (s_t, u_t), t = 1..N-1
        Ys.append(s[1:])                        # s_{t+1}
        idx.append(np.full(s.shape[0] - 1, i, dtype=np.int64))
    X, Y = np.vstack(Xs), np.vstack(Ys)
    assert X.shape[1] == N_FEATURE and Y.shape[1] == N_STATE
    return X, Y, np.concatenate(idx)


class InitialPose(NamedTuple):
    """Initial condition of ``integrate_path``; ``integrate_path(states, *pose)`` works."""

    x0: float | np.ndarray
    y0: float | np.ndarray
    yaw0: float | np.ndarray
    roll_pitch0: np.ndarray       # (2,) or (B, 2)


def initial_pose(rec: MoveRecording, t: int = 0) -> InitialPose:
    """Measured pose at measurement ``t``: the initial condition for integrating s_{t+1}, ...

    ``integrate_path(states_from_recording(rec)[t:], *initial_pose(rec, t))`` reproduces
    x, y, yaw of measurements t+1..N.
    """
    rpy = quat_to_rpy(np.asarray(rec.orientation)[t])
    p = np.asarray(rec.position, dtype=np.float64)[t]
    return InitialPose(float(p[0]), float(p[1]), float(rpy[2]), rpy[:2].copy())


def integrate_path(states: np.ndarray, x0, y0, yaw0, roll_pitch0) -> np.ndarray:
    """Recover x_w, y_w, yaw from a state sequence (docs/interface.md §4).

    ``states``: (T, 33) or batched (B, T, 33): s_1..s_T, recorded or predicted. The initial
    condition is the pose at t = 0: ``x0, y0, yaw0`` (scalars or (B,)) and ``roll_pitch0`` =
    (roll, pitch) at t = 0 ((2,) or (B, 2)), needed because step t rotates d_b by
    R(roll, pitch, yaw at t-1) and s_0 is not part of ``states``; the later steps take roll and
    pitch from the previous state. ``initial_pose(rec, t)`` supplies all four.

    Returns (T, 3) or (B, T, 3): x_w, y_w, yaw at t = 1..T, yaw wrapped to (-pi, pi].
    """
    s = np.asarray(states, dtype=np.float64)
    if s.ndim not in (2, 3) or s.shape[-1] != N_STATE:
        raise ValueError(f"states must be (T, {N_STATE}) or (B, T, {N_STATE}), got {s.shape}")
    batch = s.shape[:-2]
    x0 = np.broadcast_to(np.asarray(x0, dtype=np.float64), batch)
    y0 = np.broadcast_to(np.asarray(y0, dtype=np.float64), batch)
    yaw0 = np.broadcast_to(np.asarray(yaw0, dtype=np.float64), batch)
    rp0 = np.broadcast_to(np.asarray(roll_pitch0, dtype=np.float64), batch + (2,))

    yaw = yaw0[..., None] + np.cumsum(s[..., S.dyaw], axis=-1)                 # at t = 1..T
    yaw_prev = np.concatenate([yaw0[..., None], yaw[..., :-1]], axis=-1)       # at t-1
    rp_prev = np.concatenate([rp0[..., None, :], s[..., :-1, S.roll_pitch]], axis=-2)
    R = rpy_to_matrix(np.concatenate([rp_prev, yaw_prev[..., None]], axis=-1))  # (..., T, 3, 3)
    dp = np.einsum("...ij,...j->...i", R[..., :2, :], s[..., S.d_b])          # world dx, dy
    xy = np.stack([x0, y0], -1)[..., None, :] + np.cumsum(dp, axis=-2)
    return np.concatenate([xy, wrap_angle(yaw)[..., None]], axis=-1)


# ---------------------------------------------------------------------------------------------
# normalisation


class Normalizer:
    """Per-column unit-variance normalisation fitted on the TrainPool (z = (x - mean) / std).

    Columns whose std is below ``min_std`` (constant columns) get std 1, so they are only
    centred. ``inverse_transform_std`` scales predicted standard deviations back.
    """

    def __init__(self, min_std: float = 1e-12) -> None:
        self.min_std = min_std

    def fit(self, X: np.ndarray) -> "Normalizer":
        X = np.asarray(X, dtype=np.float64)
        if X.ndim != 2 or X.shape[0] == 0:
            raise ValueError(f"Normalizer.fit needs a non-empty (n, d) array, got {X.shape}")
        if not np.all(np.isfinite(X)):
            raise ValueError("Normalizer.fit: X holds NaN or inf")
        self.mean_ = X.mean(axis=0)
        std = X.std(axis=0)
        self.std_ = np.where(std < self.min_std, 1.0, std)
        return self

    def _check(self, X: np.ndarray) -> np.ndarray:
        if not hasattr(self, "mean_"):
            raise RuntimeError("Normalizer is not fitted")
        X = np.asarray(X, dtype=np.float64)
        if X.shape[-1] != self.mean_.shape[0]:
            raise ValueError(f"expected {self.mean_.shape[0]} columns, got {X.shape[-1]}")
        return X

    def transform(self, X: np.ndarray) -> np.ndarray:
        return (self._check(X) - self.mean_) / self.std_

    def inverse_transform(self, Z: np.ndarray) -> np.ndarray:
        return self._check(Z) * self.std_ + self.mean_

    def inverse_transform_std(self, std_z: np.ndarray) -> np.ndarray:
        """Standard deviations in normalised units -> original units."""
        return self._check(std_z) * self.std_

    def to_dict(self) -> dict[str, Any]:
        """JSON-serialisable state (floats survive a JSON round trip exactly)."""
        if not hasattr(self, "mean_"):
            raise RuntimeError("Normalizer is not fitted")
        return {"min_std": float(self.min_std), "mean": self.mean_.tolist(),
                "std": self.std_.tolist()}

    @classmethod
    def from_dict(cls, d: Mapping[str, Any]) -> "Normalizer":
        try:
            mean = np.asarray(d["mean"], dtype=np.float64)
            std = np.asarray(d["std"], dtype=np.float64)
            norm = cls(min_std=float(d.get("min_std", 1e-12)))
        except (KeyError, TypeError, ValueError) as exc:
            raise ValueError(f"invalid Normalizer state: {exc!r}") from None
        if mean.ndim != 1 or mean.shape != std.shape:
            raise ValueError("invalid Normalizer state: mean and std must be equal-length lists")
        if not (np.all(np.isfinite(mean)) and np.all(np.isfinite(std)) and np.all(std > 0)):
            raise ValueError("invalid Normalizer state: non-finite mean or non-positive std")
        norm.mean_, norm.std_ = mean, std
        return norm
