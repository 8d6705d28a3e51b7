"""The paper's rollout figures on our data (issue 4): Figs 5-7 and the side-by-side animation.

``rollout_figures(data, out, models_dir)`` rolls every learned model found in ``models_dir``
(``PREFERENCE`` order) out over every TestPool move with each projection (none, BOUND, alpha in
{0.25, 0.5, 0.75, 1}) and, when a tuned physics baseline is available, replays the same commands
on the ``nominal`` pybullet robot, then writes:

- ``fig5.png`` / ``fig6.png``: cumulative (x, y) error vs time for a forward (F) and a
  backward-left (BL) TestPool move, one curve per projection plus the physics baseline, for the
  primary model (the first of ``PREFERENCE`` found: LGPR when trained);
- ``fig5_6_mean.png``: the same curves averaged over all TestPool moves, with a p10-p90 band;
- ``fig7.png``: element-wise non-cumulative error sums (mean over TestPool moves) for none,
  BOUND and alpha = 0.5 (and the physics baseline);
- ``fig5_6_mean_by_method.png``: the mean curves for every model, one panel each;
- ``fig_projection_by_method.png``: mean final (x, y) error per model and projection, the
  physics baseline as a line;
- ``rollouts.md``: that table, with alpha = 0.5 against none and BOUND, and how far the fed-back
  states drift from the TrainPool (median normalised distance to the nearest TrainPool state at
  the last step: whether a model leaves the feasible data region, the paper's premise);
- ``rollouts.json``: for the primary model per projection the contract's rollout summary (final
  (x, y) error mean, median, p90, nMSE at horizons, NaN moves) and the rollout speed, and the
  same for every model under ``by_method``;
- ``animation.gif``: one move, measured vs learned vs physics, rendered by pybullet.
"""
from __future__ import annotations

import logging
import os
import time
from pathlib import Path
from typing import Any

import numpy as np

from ..layout import CONTROL_DT, STATE_NAMES

from ..models.train import METHOD_NAMES

# primary model first: the paper's methods from the most to the least capable
PREFERENCE: tuple[str, ...] = tuple(reversed(METHOD_NAMES))
PROJECTIONS: tuple[tuple[str, float], ...] = (("none", 0.0), ("bound", 0.0), ("alpha", 0.25),
                                              ("alpha", 0.5), ("alpha", 0.75), ("alpha", 1.0))
PHYSICS = "physics (pybullet nominal)"

log = logging.getLogger(__name__)


def _label(kind: str, alpha: float) -> str:
    return {"none": "none", "bound": "BOUND"}.get(kind, f"alpha-PROJ {alpha:g}")


def xy_error_curves(moves, predicted) -> np.ndarray:
    """(n_moves, T) cumulative (x, y) error of each move (moves share T)."""
    from ..rollout.metrics import xy_error
    from ..rollout.simulate import predicted_paths
    paths = predicted_paths(moves, predicted)
    return np.stack([xy_error(p, m.xy) for p, m in zip(paths, moves)])


def element_sums(moves, predicted) -> np.ndarray:
    """(n_moves, 33) sum over the move of |s_t^i - s_t^i*|."""
    from ..rollout.metrics import element_error_sum
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


SUMMARY_KEYS = ("final_xy_error_m", "final_xy_error_m_median", "final_xy_error_m_p90",
                "nmse_at_horizon", "n_nan_moves")
DRIFT_STEPS = (100, 399)


def drift(nn, predicted, steps: tuple[int, ...] = DRIFT_STEPS) -> dict[str, float | None]:
    """Median over the moves of the normalised distance of the fed-back state ``k`` steps after
    s_1 to its nearest TrainPool state (``nn``: an alpha projection on the TrainPool); None when a
    move is no longer finite there. Applied to the measured TestPool states it gives the distance
    real held-out states keep (``drift_measured`` in rollouts.json)."""
    out: dict[str, float | None] = {}
    for k in steps:
        s = np.array([p[min(k, p.shape[0]) - 1] for p in predicted])
        ok = np.isfinite(s).all(axis=1)
        out[f"step{k}"] = float(np.median(nn.distance(s))) if ok.all() else None
    return out


def roll_projections(model, moves, nn=None):
    """Roll ``model`` out over ``moves`` with every projection of ``PROJECTIONS``
    (:func:`..scoring.rollout_scores`).

    Returns ``(summary, curves, sums, preds)``, each keyed by the projection's label: the rollout
    summary (``SUMMARY_KEYS``, wall time, real-time factor, drift from the TrainPool when ``nn``
    is given), the (n_moves, T) cumulative (x, y) errors, the (n_moves, 33) element-wise error
    sums and the predicted states."""
    from ..scoring import RolloutSpec, rollout_scores

    specs = [RolloutSpec(kind, alpha, name=_label(kind, alpha)) for kind, alpha in PROJECTIONS]
    full, preds = rollout_scores(model, moves, specs, keep_predictions=True)
    summary: dict[str, Any] = {}
    curves: dict[str, np.ndarray] = {}
    sums: dict[str, np.ndarray] = {}
    for label, res in full.items():
        pred = preds[label]
        summary[label] = {k: res.get(k) for k in SUMMARY_KEYS}
        summary[label].update(rollout_wall_s=res["rollout_wall_s"],
                              realtime_factor=res["realtime_factor"])
        if nn is not None:
            summary[label]["drift_nn_distance_median"] = drift(nn, pred)
        curves[label], sums[label] = xy_error_curves(moves, pred), element_sums(moves, pred)
        log.info("%s %s: final (x,y) error %s m, %.1f s", model.method, label,
                 res.get("final_xy_error_m"), res["rollout_wall_s"])
    return summary, curves, sums, preds


def rollout_figures(data: str | os.PathLike, out: str | os.PathLike, models_dir: str | os.PathLike,
                    physics_config: Any | None = None, animate: bool = True,
                    progress: bool = True) -> dict[str, Any]:
    """Figs 5-7, the by-model comparison, rollouts.json/md and the animation for the models
    found in ``models_dir``. ``progress``: progress lines on stderr unless the program
    configured logging."""
    from ..logs import progress_to_stderr

    with progress_to_stderr(progress):
        return _rollout_figures(data, out, models_dir, physics_config, animate)


def _rollout_figures(data, out, models_dir, physics_config, animate) -> dict[str, Any]:
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from ..data.dataset import load_moves
    from .evaluate import write_json
    from ..fileio import atomic_write_text
    from ..models.onestep import OneStepModel
    from ..rollout.metrics import rollout_metrics
    from ..projection import make_projection
    from ..rollout.simulate import prepare_test_moves

    out, models_dir = Path(out), Path(models_dir)
    methods = [m for m in PREFERENCE if (models_dir / m).is_dir()]
    if not methods:
        raise ValueError(f"no trained model under {models_dir}")
    method = methods[0]
    recs = load_moves(data, "test")
    moves = prepare_test_moves(recs)
    T = min(m.n_steps for m in moves)
    moves = [m for m in moves if m.n_steps == T]
    recs = [r for r in recs if r.n_steps - 1 == T]
    t = np.arange(1, T + 1) * CONTROL_DT
    by_method: dict[str, dict[str, Any]] = {}
    mean_curves: dict[str, dict[str, np.ndarray]] = {}
    nn, nn_states = None, None
    for m in methods:
        model = OneStepModel.load(models_dir / m)
        if nn is None or not np.array_equal(model.train_states, nn_states):
            nn_states = model.train_states
            nn = make_projection("alpha", nn_states)
        summ, cur, sm, pr = roll_projections(model, moves, nn)
        by_method[m] = summ
        mean_curves[m] = cur
        if m == method:
            curves, sums, preds = dict(cur), dict(sm), dict(pr)
    summary: dict[str, Any] = {"method": method, "n_moves": len(moves),
                               "projections": dict(by_method[method]), "by_method": by_method,
                               "drift_measured": drift(nn, [m.states for m in moves])}
    if physics_config is not None:
        from ..robot.baseline import physics_rollouts
        t0 = time.perf_counter()
        pred = physics_rollouts(recs, physics_config, jobs=2)
        res = rollout_metrics(moves, pred)
        phys = {k: res.get(k) for k in SUMMARY_KEYS}
        phys["rollout_wall_s"] = time.perf_counter() - t0
        phys["drift_nn_distance_median"] = drift(nn, pred)
        summary["projections"][PHYSICS] = phys
        curves[PHYSICS], sums[PHYSICS], preds[PHYSICS] = (xy_error_curves(moves, pred),
                                                          element_sums(moves, pred), pred)
        log.info("physics: final (x,y) error %s m", res.get("final_xy_error_m"))

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

    phys_curve = curves.get(PHYSICS)
    _plot_by_method(plt, t, mean_curves, phys_curve, len(moves), out / "fig5_6_mean_by_method.png")
    _plot_final_by_method(plt, by_method, summary["projections"].get(PHYSICS),
                          out / "fig_projection_by_method.png")
    atomic_write_text(out / "rollouts.md", rollouts_report(summary))
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


def _plot_by_method(plt, t, mean_curves, phys_curve, n_moves, path: Path) -> None:
    n = len(mean_curves)
    fig, axes = plt.subplots(1, n, figsize=(3.6 * n, 3.6), sharey=True, squeeze=False)
    for ax, (m, cur) in zip(axes[0], mean_curves.items()):
        show = dict(cur)
        if phys_curve is not None:
            show[PHYSICS] = phys_curve
        _plot_curves(ax, t, {k: np.nanmean(v, axis=0) for k, v in show.items()}, band=False)
        ax.set_yscale("log")
        ax.set_title(m.upper())
        if ax is not axes[0][0]:
            ax.set_ylabel("")
            ax.get_legend().remove()
    fig.suptitle(f"Mean cumulative (x, y) error over {n_moves} TestPool moves, every model")
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


def _plot_final_by_method(plt, by_method, phys, path: Path) -> None:
    methods = list(by_method)
    labels = list(next(iter(by_method.values())))
    width = 0.8 / len(labels)
    x = np.arange(len(methods))
    fig, ax = plt.subplots(figsize=(9.5, 4))
    for i, lab in enumerate(labels):
        v = [by_method[m][lab]["final_xy_error_m"] for m in methods]
        ax.bar(x + (i - (len(labels) - 1) / 2) * width,
               [np.nan if e is None else e for e in v], width, label=lab)
    if phys is not None and phys.get("final_xy_error_m") is not None:
        ax.axhline(phys["final_xy_error_m"], color="k", ls="--", lw=1, label=PHYSICS)
    ax.set_yscale("log")
    ax.set_xticks(x, [m.upper() for m in methods])
    ax.set_ylabel("mean final (4 s) (x, y) error [m]")
    ax.set_title("Projections per learned model (TestPool mean)")
    ax.legend(fontsize=7, loc="upper left", bbox_to_anchor=(1.01, 1.0))
    ax.grid(True, axis="y", alpha=0.3)
    fig.tight_layout()
    fig.savefig(path, dpi=120)
    plt.close(fig)


def _m(v: float | None, nd: int = 4) -> str:
    return "NaN" if v is None else f"{v:.{nd}f}"


def rollouts_report(summary: dict[str, Any]) -> str:
    """Markdown: every model x projection, mean final (x, y) error; alpha 0.5 against none and
    BOUND; drift of the fed-back state from the TrainPool; the physics baseline."""
    by_method = summary["by_method"]
    labels = list(next(iter(by_method.values())))
    phys = summary["projections"].get(PHYSICS)
    a5 = "alpha-PROJ 0.5"
    lines = [f"# Rollouts per learned model ({summary['n_moves']} TestPool moves)", "",
             "Mean final (4 s) cumulative (x, y) error [m] over the TestPool moves. `a0.5 / none`: "
             "alpha-PROJ 0.5 over no projection (target: at most 0.5); `a0.5 <= BOUND`: whether "
             "alpha-PROJ 0.5 is at least as good as BOUND. `drift`: median over the moves of the "
             "normalised distance of the last fed-back state to its nearest TrainPool state; "
             "the measured TestPool states' own is "
             f"{_m(summary['drift_measured'][f'step{DRIFT_STEPS[-1]}'], 2)}. A model whose "
             "unprojected rollout drifts far beyond that leaves the feasible data region, which "
             "is what alpha-PROJ is for.", "",
             "| model | " + " | ".join(labels) + " | a0.5 / none | a0.5 <= BOUND | "
             "drift none | drift a0.5 |",
             "|---|" + "---|" * (len(labels) + 4)]
    for m, summ in by_method.items():
        e = {lab: summ[lab]["final_xy_error_m"] for lab in labels}
        ratio = (e[a5] / e["none"] if None not in (e[a5], e["none"]) and e["none"] > 0 else None)
        better = ("" if None in (e[a5], e["BOUND"]) else "yes" if e[a5] <= e["BOUND"] else "no")
        dn = summ["none"].get("drift_nn_distance_median", {}).get(f"step{DRIFT_STEPS[-1]}")
        da = summ[a5].get("drift_nn_distance_median", {}).get(f"step{DRIFT_STEPS[-1]}")
        lines.append(f"| {m.upper()} | " + " | ".join(_m(e[lab]) for lab in labels)
                     + f" | {_m(ratio, 2)} | {better} | {_m(dn, 2)} | {_m(da, 2)} |")
    if phys is not None:
        dp = phys.get("drift_nn_distance_median", {}).get(f"step{DRIFT_STEPS[-1]}")
        lines += ["", f"Physics baseline (nominal pybullet, tuned on TrainPool): "
                  f"{_m(phys['final_xy_error_m'])} m (drift {_m(dp, 2)}).", ""]
        best = min(((summ[lab]["final_xy_error_m"], m, lab) for m, summ in by_method.items()
                    for lab in labels if summ[lab]["final_xy_error_m"] is not None), default=None)
        if best is not None:
            lines.append(f"Best learned rollout: {best[1].upper()} with {best[2]}, "
                         f"{_m(best[0])} m ({best[0] / phys['final_xy_error_m']:.2f} x physics).")
    return "\n".join(lines) + "\n"
