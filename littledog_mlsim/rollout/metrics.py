"""Error measures of one-step and sequential prediction (paper Sections III, VI, VII).

- One-step: ``nmse(Y_true, Y_pred)`` per state element, nMSE = MSE / Var(Y_true) (the TestPool
  variance of the response when called on the TestPool).
- Cumulative sequential error (Figs 5, 6): ``sqrt((x - x*)^2 + (y - y*)^2)`` per step, with
  (x, y) from integrating the predicted states (``integrate_path`` from the pose at s_1) and
  (x*, y*) the recorded odometry.
- Non-cumulative sequential error (Fig. 7): ``|s_t^i - s_t^i*|`` per element and step, and its sum
  over the move ``sum_t |s_t^i - s_t^i*|`` (plain differences, also for the wrapped angle deltas).
- Rollout nMSE at horizons (0.1, 0.5, 1, 4 s): the squared error of the state predicted k steps
  after s_1 (k = round(h / 0.01)), averaged over the moves, divided by the variance of the element
  over all TestPool ground-truth states s_2..s_N of the moves evaluated (population variance,
  as for the one-step nMSE) unless ``state_var`` is given (e.g. the TrainPool's). A rollout of a
  4 s move has only T = 399 steps (s_1 is given), so the 4 s horizon is clipped to the longest
  rollout; each horizon reports the ``steps`` and ``time_s`` actually used.

NaN policy (never silently averaged): a move whose rollout or path turns non-finite anywhere is
flagged in ``per_move`` (``nan``, ``first_nan_step``) and listed in ``nan_moves``. Aggregates over
moves are then ``None`` (JSON null) wherever one of the values they would average is non-finite;
``final_xy_error_m_finite`` gives the mean over the finite moves alongside. Order statistics
(median, p90) rank a non-finite error as +inf (a diverged move is worse than any finite one), so
they stay defined while fewer than half (10 %) of the moves diverged. Zero-variance elements have
nMSE ``None``. ``rollout_metrics`` output passes ``json.dumps(..., allow_nan=False)``.
"""
from __future__ import annotations

from typing import Any, Sequence

import numpy as np

from ..layout import CONTROL_DT, N_STATE, STATE_NAMES
from ..projection import Projection
from .simulate import TestMove, predicted_paths

__all__ = ["HORIZONS_S", "nmse", "nmse_array", "xy_error", "element_abs_error",
           "element_error_sum", "first_nonfinite_step", "nmse_at_horizons", "rollout_metrics"]

HORIZONS_S: tuple[float, ...] = (0.1, 0.5, 1.0, 4.0)
_MIN_VAR = 1e-24  # std 1e-12, as Normalizer.min_std: below it an element counts as constant


def _json_float(x: Any) -> float | None:
    x = float(x)
    return x if np.isfinite(x) else None


def _named(values: np.ndarray) -> dict[str, float | None]:
    return {n: _json_float(v) for n, v in zip(STATE_NAMES, values)}


# ---------------------------------------------------------------------------------------------
# one-step


def nmse_array(Y_true: np.ndarray, Y_pred: np.ndarray, var: np.ndarray | None = None) -> np.ndarray:
    """Per-column nMSE (p,) of (n, p) arrays: mean((pred - true)^2) / var.

    ``var`` defaults to the population variance of ``Y_true``; columns with variance < 1e-24 give
    NaN. Non-finite predictions give NaN (or inf) for their column.
    """
    Yt = np.asarray(Y_true, dtype=np.float64)
    Yp = np.asarray(Y_pred, dtype=np.float64)
    if Yt.ndim != 2 or Yt.shape != Yp.shape or Yt.shape[0] == 0:
        raise ValueError(f"Y_true and Y_pred must be equal non-empty (n, p) arrays, got "
                         f"{Yt.shape} and {Yp.shape}")
    v = Yt.var(axis=0) if var is None else np.asarray(var, dtype=np.float64)
    if v.shape != (Yt.shape[1],):
        raise ValueError(f"var must have shape ({Yt.shape[1]},), got {v.shape}")
    with np.errstate(over="ignore", invalid="ignore", divide="ignore"):
        mse = np.mean((Yp - Yt) ** 2, axis=0)
        return np.where(v > _MIN_VAR, mse / np.where(v > _MIN_VAR, v, 1.0), np.nan)


def nmse(Y_true: np.ndarray, Y_pred: np.ndarray,
         var: np.ndarray | None = None) -> dict[str, float]:
    """One-step nMSE per state element: {state name: MSE / Var(Y_true)} for (n, 33) arrays.

    NaN (a float, not None) for a zero-variance element or non-finite predictions.
    """
    values = nmse_array(Y_true, Y_pred, var)
    if values.shape != (N_STATE,):
        raise ValueError(f"nmse expects {N_STATE} state columns, got {values.shape[0]}")
    return {n: float(v) for n, v in zip(STATE_NAMES, values)}


# ---------------------------------------------------------------------------------------------
# sequential


def xy_error(path: np.ndarray, xy_true: np.ndarray) -> np.ndarray:
    """Cumulative error (T,): distance between predicted (T, >=2) and true (T, 2) x_w, y_w."""
    p = np.asarray(path, dtype=np.float64)
    t = np.asarray(xy_true, dtype=np.float64)
    if p.ndim != 2 or t.ndim != 2 or p.shape[0] != t.shape[0] or p.shape[1] < 2 or t.shape[1] != 2:
        raise ValueError(f"path must be (T, >=2) and xy_true (T, 2), got {p.shape}, {t.shape}")
    with np.errstate(over="ignore", invalid="ignore"):
        return np.hypot(p[:, 0] - t[:, 0], p[:, 1] - t[:, 1])


def element_abs_error(states_true: np.ndarray, states_pred: np.ndarray) -> np.ndarray:
    """Non-cumulative error |s_t^i - s_t^i*| (T, 33)."""
    t = np.asarray(states_true, dtype=np.float64)
    p = np.asarray(states_pred, dtype=np.float64)
    if t.shape != p.shape or t.ndim != 2 or t.shape[1] != N_STATE:
        raise ValueError(f"states must be equal (T, {N_STATE}) arrays, got {t.shape}, {p.shape}")
    with np.errstate(over="ignore", invalid="ignore"):
        return np.abs(p - t)


def element_error_sum(states_true: np.ndarray, states_pred: np.ndarray) -> np.ndarray:
    """sum_t |s_t^i - s_t^i*| (33,) (paper Fig. 7); NaN/inf if any step of that element is."""
    with np.errstate(over="ignore", invalid="ignore"):
        return element_abs_error(states_true, states_pred).sum(axis=0)


def first_nonfinite_step(states_pred: np.ndarray, errors: np.ndarray | None = None) -> int | None:
    """1-based step (k steps after s_1) of the first non-finite predicted state or error; None."""
    bad = ~np.isfinite(np.asarray(states_pred, dtype=np.float64)).all(axis=1)
    if errors is not None:
        bad |= ~np.isfinite(np.asarray(errors, dtype=np.float64))
    hits = np.flatnonzero(bad)
    return int(hits[0]) + 1 if hits.size else None


def _quantile(sorted_v: np.ndarray, q: float) -> float:
    """Linear-interpolation quantile (NumPy's default) that keeps +inf values meaningful."""
    pos = q * (sorted_v.shape[0] - 1)
    lo = int(np.floor(pos))
    frac = pos - lo
    if frac == 0.0:
        return float(sorted_v[lo])
    a, b = float(sorted_v[lo]), float(sorted_v[lo + 1])
    return b if np.isinf(b) else a + frac * (b - a)


def _stats(values: np.ndarray) -> tuple[float | None, float | None, float | None]:
    """(mean, median, p90) of a 1-D array; non-finite values count as +inf (see module doc)."""
    v = np.sort(np.where(np.isfinite(values), values, np.inf))
    mean = float(np.mean(v)) if np.all(np.isfinite(v)) else np.inf
    return _json_float(mean), _json_float(_quantile(v, 0.5)), _json_float(_quantile(v, 0.9))


def _horizon_steps(h: float) -> int:
    return max(1, int(round(h / CONTROL_DT)))


def nmse_at_horizons(moves: Sequence[TestMove], predicted: Sequence[np.ndarray],
                     horizons_s: Sequence[float] = HORIZONS_S,
                     state_var: np.ndarray | None = None) -> dict[str, dict[str, Any]]:
    """Rollout nMSE per element at each horizon, keyed ``f"{h:g}"`` ("0.1", "0.5", "1", "4").

    JSON-ready; see the module doc.

    Each entry: ``horizon_s``, ``steps`` and ``time_s`` used (clipped to the longest rollout),
    ``n_moves`` (moves at least that long), ``n_nan_moves`` (of them, non-finite at that step),
    ``nmse`` {state name: value or None}.
    """
    if len(moves) != len(predicted) or not moves:
        raise ValueError(f"need equal, non-empty lists of moves and predictions, got "
                         f"{len(moves)} and {len(predicted)}")
    if state_var is None:
        state_var = np.concatenate([m.states for m in moves]).var(axis=0)
    state_var = np.asarray(state_var, dtype=np.float64)
    if state_var.shape != (N_STATE,):
        raise ValueError(f"state_var must have shape ({N_STATE},), got {state_var.shape}")
    t_max = max(m.n_steps for m in moves)
    out: dict[str, dict[str, Any]] = {}
    for h in horizons_s:
        k = min(_horizon_steps(h), t_max)
        sel = [i for i, m in enumerate(moves) if m.n_steps >= k]
        err = np.stack([np.asarray(predicted[i], dtype=np.float64)[k - 1] - moves[i].states[k - 1]
                        for i in sel])                                    # (n, 33)
        finite = np.isfinite(err).all(axis=1)
        with np.errstate(over="ignore", invalid="ignore"):
            mse = np.mean(err ** 2, axis=0)
            value = np.where(state_var > _MIN_VAR, mse / np.where(state_var > _MIN_VAR,
                                                                  state_var, 1.0), np.nan)
        out[f"{h:g}"] = {"horizon_s": float(h), "steps": k, "time_s": round(k * CONTROL_DT, 10),
                           "n_moves": len(sel), "n_nan_moves": int((~finite).sum()),
                           "nmse": _named(value)}
    return out


def rollout_metrics(moves: Sequence[TestMove], predicted: Sequence[np.ndarray],
                    horizons_s: Sequence[float] = HORIZONS_S,
                    state_var: np.ndarray | None = None,
                    projection: Projection | None = None) -> dict[str, Any]:
    """The JSON-ready rollout results (docs/interface.md §5, ``rollout.json``).

    ``moves`` and ``predicted`` (T_i, 33) per move (``rollout_moves`` output). Keys:
    ``final_xy_error_m`` (mean over moves of the cumulative (x, y) error at the end of the move),
    ``final_xy_error_m_finite`` / ``_median`` / ``_p90``, ``xy_error_vs_time`` (``step``,
    ``time_s`` = seconds after s_1, ``mean``/``median``/``p90``/``n_moves``/``n_nan`` per step),
    ``element_error_sum_mean`` (mean over moves of sum_t |s_t^i - s_t^i*|), ``nmse_at_horizon``
    (``nmse_at_horizons``), ``nmse_variance`` (``"TestPool"`` or ``"given"``), ``by_move_type``,
    ``per_move`` (name, move_type, n_steps, final_xy_error_m, element_error_sum, nan,
    first_nan_step), ``n_moves``, ``n_nan_moves``, ``nan_moves``, ``dt_s``, ``projection``.
    """
    if len(moves) != len(predicted) or not moves:
        raise ValueError(f"need equal, non-empty lists of moves and predictions, got "
                         f"{len(moves)} and {len(predicted)}")
    for m, p in zip(moves, predicted):
        if np.shape(p) != m.states.shape:
            raise ValueError(f"{m.name}: prediction shape {np.shape(p)} != {m.states.shape}")
    paths = predicted_paths(moves, predicted)
    errs = [xy_error(path, m.xy) for m, path in zip(moves, paths)]
    sums = [element_error_sum(m.states, p) for m, p in zip(moves, predicted)]

    per_move, nan_moves = [], []
    for m, p, e, es in zip(moves, predicted, errs, sums):
        first = first_nonfinite_step(p, e)
        if first is not None:
            nan_moves.append(m.name)
        per_move.append({"name": m.name, "move_type": m.move_type, "n_steps": m.n_steps,
                         "final_xy_error_m": _json_float(e[-1]),
                         "element_error_sum": _named(es),
                         "nan": first is not None, "first_nan_step": first})

    final = np.array([e[-1] for e in errs])
    finite_final = final[np.isfinite(final)]
    mean, med, p90 = _stats(final)

    def vs_time(err_list: list[np.ndarray]) -> dict[str, list]:
        t_max = max(e.shape[0] for e in err_list)
        rows: dict[str, list] = {"step": [], "time_s": [], "mean": [], "median": [], "p90": [],
                                 "n_moves": [], "n_nan": []}
        for k in range(t_max):
            v = np.array([e[k] for e in err_list if e.shape[0] > k])
            st = _stats(v)
            rows["step"].append(k + 1)
            rows["time_s"].append(round((k + 1) * CONTROL_DT, 10))
            rows["mean"].append(st[0])
            rows["median"].append(st[1])
            rows["p90"].append(st[2])
            rows["n_moves"].append(int(v.shape[0]))
            rows["n_nan"].append(int((~np.isfinite(v)).sum()))
        return rows

    by_type: dict[str, Any] = {}
    for mt in dict.fromkeys(m.move_type for m in moves):
        idx = [i for i, m in enumerate(moves) if m.move_type == mt]
        f = final[idx]
        by_type[mt] = {"n_moves": len(idx), "n_nan_moves": int((~np.isfinite(f)).sum()),
                       "final_xy_error_m": _stats(f)[0],
                       "xy_error_vs_time": vs_time([errs[i] for i in idx])}

    with np.errstate(over="ignore", invalid="ignore"):
        sum_mean = np.mean(np.stack(sums), axis=0)
    return {
        "n_moves": len(moves),
        "n_nan_moves": len(nan_moves),
        "nan_moves": nan_moves,
        "dt_s": CONTROL_DT,
        "projection": projection.describe() if projection is not None else None,
        "final_xy_error_m": mean,
        "final_xy_error_m_finite": _json_float(finite_final.mean()) if finite_final.size else None,
        "final_xy_error_m_median": med,
        "final_xy_error_m_p90": p90,
        "xy_error_vs_time": vs_time(errs),
        "element_error_sum_mean": _named(sum_mean),
        "nmse_variance": "TestPool" if state_var is None else "given",
        "nmse_at_horizon": nmse_at_horizons(moves, predicted, horizons_s, state_var),
        "by_move_type": by_type,
        "per_move": per_move,
    }


