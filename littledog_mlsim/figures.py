"""The paper's rollout figures on our data (issue 4): Figs 5-7 and the side-by-side animation.

``rollout_figures(data, out, models_dir)`` rolls the best available learned model (LGPR, else the
next in ``PREFERENCE``) out over every TestPool move with each projection (none, BOUND, alpha in
{0.25, 0.5, 0.75, 1}) and, when a tuned physics baseline is available, replays the same commands
on the ``nominal`` pybullet robot, then writes:

- ``fig5.png`` / ``fig6.png``: cumulative (x, y) error vs time for a forward (F) and a
  backward-left (BL) TestPool move, one curve per projection plus the physics baseline;
- ``fig5_6_mean.png``: the same curves averaged over all TestPool moves, with a p10-p90 band;
- ``fig7.png``: element-wise non-cumulative error sums (mean over TestPool moves) for none,
  BOUND and alpha = 0.5 (and the physics baseline);
- ``rollouts.json``: per projection the contract's rollout summary (final (x, y) error mean,
  median, p90, nMSE at horizons, NaN moves) and the rollout speed;
- ``animation.gif``: one move, measured vs learned vs physics, rendered by pybullet.
"""
from __future__ import annotations

import os
import sys
import time
from pathlib import Path
from typing import Any

import numpy as np

from .layout import CONTROL_DT, STATE_NAMES

PREFERENCE = ("lgpr", "sor", "gpr", "lwpr", "lr")
PROJECTIONS: tuple[tuple[str, float], ...] = (("none", 0.0), ("bound", 0.0), ("alpha", 0.25),
                                              ("alpha", 0.5), ("alpha", 0.75), ("alpha", 1.0))
PHYSICS = "physics (pybullet nominal)"


def _label(kind: str, alpha: float) -> str:
    return {"none": "none", "bound": "BOUND"}.get(kind, f"alpha-PROJ {alpha:g}")


def xy_error_curves(moves, predicted) -> np.ndarray:
    """(n_moves, T) cumulative (x, y) error of each move (moves share T)."""
    from .rollout.metrics import xy_error
    from .rollout.simulate import predicted_paths
    paths = predicted_paths(moves, predicted)
    return np.stack([xy_error(p, m.xy) for p, m in zip(paths, moves)])


def element_sums(moves, predicted) -> np.ndarray:
    """(n_moves, 33) sum over the move of |s_t^i - s_t^i*|."""
    from .rollout.metrics import element_error_sum
    return np.stack([element_error_sum(m.states, p) for m, p in zip(moves, predicted)])


def _plot_curves(ax, t: np.ndarray, curves: dict[str, np.ndarray], band: bool) -> None:
    for label, c in curves.items():
        if band:
            mean = np.nanmean(c, axis=0)
            line, = ax.plot(t, mean, label=label)
            ax.fill_between(t, np.nanpercentile(c, 10, axis=0), np.nanpercentile(c, 90, axis=0),
                            color=line.get_color(), alpha=0.12)
        else:
            ax.plot(t, c, label=label)
    ax.set_xlabel("time [s]")
    ax.set_ylabel("cumulative (x, y) error [m]")
    ax.grid(True, alpha=0.3)
    ax.legend(fontsize=8)


def rollout_figures(data: str | os.PathLike, out: str | os.PathLike, models_dir: str | os.PathLike,
                    physics_config: Any | None = None, animate: bool = True,
                    progress: bool = True) -> dict[str, Any]:
    """Figs 5-7, rollouts.json and the animation for the best model found in ``models_dir``."""
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from .data.dataset import load_moves
    from .evaluate import write_json
    from .models.onestep import OneStepModel
    from .rollout.metrics import rollout_metrics
    from .rollout.simulate import prepare_test_moves, rollout_moves

    def say(text: str) -> None:
        if progress:
            print(f"figures: {text}", file=sys.stderr, flush=True)

    out, models_dir = Path(out), Path(models_dir)
    method = next((m for m in PREFERENCE if (models_dir / m).is_dir()), None)
    if method is None:
        raise ValueError(f"no trained model under {models_dir}")
    model = OneStepModel.load(models_dir / method)
    recs = load_moves(data, "test")
    moves = prepare_test_moves(recs)
    T = min(m.n_steps for m in moves)
    moves = [m for m in moves if m.n_steps == T]
    recs = [r for r in recs if r.n_steps - 1 == T]
    t = np.arange(1, T + 1) * CONTROL_DT
    curves: dict[str, np.ndarray] = {}
    sums: dict[str, np.ndarray] = {}
    preds: dict[str, list[np.ndarray]] = {}
    summary: dict[str, Any] = {"method": method, "n_moves": len(moves), "projections": {}}
    for kind, alpha in PROJECTIONS:
        label = _label(kind, alpha)
        proj = model.projection(kind, alpha=alpha)
        t0 = time.perf_counter()
        pred = rollout_moves(model, moves, proj)
        wall = time.perf_counter() - t0
        res = rollout_metrics(moves, pred, projection=proj)
        summary["projections"][label] = {
            k: res.get(k) for k in ("final_xy_error_m", "final_xy_error_m_median",
                                    "final_xy_error_m_p90", "nmse_at_horizon", "n_nan_moves")}
        summary["projections"][label].update(rollout_wall_s=wall,
                                             realtime_factor=len(moves) * T * CONTROL_DT / wall)
        curves[label], sums[label], preds[label] = xy_error_curves(moves, pred), element_sums(moves, pred), pred
        say(f"{label}: final (x,y) error {res.get('final_xy_error_m')} m, {wall:.1f} s")
    if physics_config is not None:
        from .baseline import physics_rollouts
        t0 = time.perf_counter()
        pred = physics_rollouts(recs, physics_config, jobs=2)
        res = rollout_metrics(moves, pred)
        summary["projections"][PHYSICS] = {
            k: res.get(k) for k in ("final_xy_error_m", "final_xy_error_m_median",
                                    "final_xy_error_m_p90", "nmse_at_horizon", "n_nan_moves")}
        summary["projections"][PHYSICS]["rollout_wall_s"] = time.perf_counter() - t0
        curves[PHYSICS], sums[PHYSICS], preds[PHYSICS] = xy_error_curves(moves, pred), element_sums(moves, pred), pred
        say(f"physics: final (x,y) error {res.get('final_xy_error_m')} m")

    figs = {"fig5.png": "F", "fig6.png": "BL"}
    picked = {}
    for fname, mtype in figs.items():
        idx = next((i for i, m in enumerate(moves) if m.move_type == mtype), None)
        if idx is None:
            continue
        picked[mtype] = moves[idx].name
        fig, ax = plt.subplots(figsize=(6.5, 4))
        _plot_curves(ax, t, {k: v[idx] for k, v in curves.items()}, band=False)
        ax.set_title(f"Fig. {fname[3]}: {moves[idx].name} ({method.upper()})")
        fig.tight_layout()
        fig.savefig(out / fname, dpi=120)
        plt.close(fig)
    fig, ax = plt.subplots(figsize=(6.5, 4))
    _plot_curves(ax, t, curves, band=True)
    ax.set_title(f"Cumulative (x, y) error, mean over {len(moves)} TestPool moves (band p10-p90)")
    fig.tight_layout()
    fig.savefig(out / "fig5_6_mean.png", dpi=120)
    plt.close(fig)

    fig, ax = plt.subplots(figsize=(11, 4))
    show = [k for k in ("none", "BOUND", "alpha-PROJ 0.5", PHYSICS) if k in sums]
    width = 0.8 / len(show)
    x = np.arange(len(STATE_NAMES))
    for i, k in enumerate(show):
        ax.bar(x + (i - (len(show) - 1) / 2) * width, np.nanmean(sums[k], axis=0), width, label=k)
    ax.set_yscale("log")
    ax.set_xticks(x, STATE_NAMES, rotation=90, fontsize=7)
    ax.set_ylabel("sum over the move of |s - s*| (mean over moves)")
    ax.set_title("Fig. 7: element-wise non-cumulative error sums")
    ax.legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(out / "fig7.png", dpi=120)
    plt.close(fig)
    summary["figure_moves"] = picked
    summary["element_error_sum_mean"] = {k: dict(zip(STATE_NAMES, np.nanmean(v, axis=0).tolist()))
                                         for k, v in sums.items()}

    if animate and "F" in picked:
        from .animate import animate_move
        idx = next(i for i, m in enumerate(moves) if m.name == picked["F"])
        panels = {f"learned ({method.upper()}, alpha 0.5)": preds["alpha-PROJ 0.5"][idx]}
        if PHYSICS in preds:
            panels["physics (nominal)"] = preds[PHYSICS][idx]
        t0 = time.perf_counter()
        animate_move(recs[idx], panels, out / "animation.gif")
        summary["animation_s"] = time.perf_counter() - t0
    write_json(out / "rollouts.json", summary)
    return summary
