"""A servo stiffness drifting with time, in % per second, measured against a reference.

A battery that sags or a motor that warms makes each servo push less for the same tracking
error as a move goes on. The servo's effective stiffness is measured straight from the
recordings (:func:`stiffness_by_time`): in each time bin of the moves, the one-step change of a
joint's rate is regressed on its tracking error u - q, with its rate and angle as covariates
(a PD servo's push, the damping, the load that varies with the pose); the tracking error's
coefficient is the stiffness over the joint's inertia, in that bin. Its relative slope over the
move's time, k(t) = k0 (1 + r t), is the rate r.

A gait's own moves are not stationary either (the first steps start from standing), and the
regression reads that as a stiffness trend: a clean recording has a rate too (the median over
joints -0.080 to +0.009 per second on the gap zoos' references). With a reference of the same
robot, :func:`rate_against_reference` subtracts the reference's rate joint by joint, and the
median over the effect's joints is the drift since the reference (decision 025; dividing the
stiffness by the reference's bin by bin instead read further from the truth on all five gap
zoos' battery sags: ``benchmarks/learned_route/drift_reading/first_run.md``).
"""
from __future__ import annotations

from typing import Any, Sequence

import numpy as np

from ..layout import CONTROL_DT, JOINT_NAMES, StateLayout

__all__ = ["stiffness_by_time", "joint_rates", "rate_against_reference", "TIME_BINS"]

S = StateLayout()
#: time bins over a move in which the stiffness is regressed
TIME_BINS = 8


def _rows(recs: Sequence[Any]) -> tuple[np.ndarray, ...]:
    """(t, u - q, dq, q, one-step change of dq) over every step of ``recs`` (objects with S, U,
    Y arrays per move, :class:`.learned._Moves`)."""
    t, E, DQ, Q, DD = [], [], [], [], []
    for St, Ut, Yt in zip(recs.S, recs.U, recs.Y):
        t.append(np.arange(St.shape[0]) * CONTROL_DT)
        E.append(Ut - St[:, S.q])
        DQ.append(St[:, S.dq])
        Q.append(St[:, S.q])
        DD.append(Yt[:, S.dq] - St[:, S.dq])
    return (np.concatenate(t), np.vstack(E), np.vstack(DQ), np.vstack(Q), np.vstack(DD))


def stiffness_by_time(moves: Any, bins: int = TIME_BINS) -> tuple[np.ndarray, np.ndarray]:
    """(bin centres [s], K (bins, 12)): each joint's effective stiffness over inertia per bin,
    the least-squares coefficient of u - q in d(dq) ~ 1 + (u - q) + dq + q. ``moves``: the
    recordings as arrays (:func:`.learned._moves`)."""
    t, E, DQ, Q, DD = _rows(moves)
    edges = np.linspace(0.0, float(t.max()) + 1e-9, bins + 1)
    K = np.full((bins, E.shape[1]), np.nan)
    for b in range(bins):
        m = (t >= edges[b]) & (t < edges[b + 1])
        if m.sum() < 20:
            continue
        for j in range(E.shape[1]):
            A = np.column_stack([np.ones(m.sum()), E[m, j], DQ[m, j], Q[m, j]])
            K[b, j] = np.linalg.lstsq(A, DD[m, j], rcond=None)[0][1]
    return 0.5 * (edges[1:] + edges[:-1]), K


def _relative_slope(tc: np.ndarray, k: np.ndarray) -> float:
    """The slope of a straight line through k(t) over its intercept (NaN with fewer than 3
    finite bins or a zero intercept)."""
    ok = np.isfinite(k)
    if ok.sum() < 3:
        return float("nan")
    slope, k0 = np.polyfit(tc[ok], k[ok], 1)
    return float(slope / k0) if abs(k0) > 1e-12 else float("nan")


def joint_rates(moves: Any, bins: int = TIME_BINS) -> np.ndarray:
    """(12,) each joint's relative stiffness change per second, from its own recordings:
    :func:`_relative_slope` of its K(t)."""
    tc, K = stiffness_by_time(moves, bins)
    return np.array([_relative_slope(tc, K[:, j]) for j in range(K.shape[1])])


def rate_against_reference(moves: Any, reference: Any, joints: Sequence[int] | None = None
                           ) -> dict[str, Any]:
    """The drift of the servos' stiffness since the reference: {rate_per_s (the median over
    ``joints``, default all, of each joint's own rate minus the reference's), joint_rates (per
    joint name, that difference), data_rate_per_s and reference_rate_per_s (the medians of
    each one's own rate)}."""
    idx = list(range(len(JOINT_NAMES))) if joints is None else list(joints)
    own, ref = joint_rates(moves)[idx], joint_rates(reference)[idx]
    diff = own - ref
    ok = np.isfinite(diff)
    return {"rate_per_s": float(np.median(diff[ok])) if ok.any() else float("nan"),
            "joint_rates": {JOINT_NAMES[j]: float(d) for j, d in zip(idx, diff)},
            "data_rate_per_s": float(np.nanmedian(own)),
            "reference_rate_per_s": float(np.nanmedian(ref))}
