"""``report.json`` and ``report.md`` (with figures) of a diagnosis.

Both routes write one document, format ``littledog_mlsim.diagnosis``, version 1: the learned
route's through :func:`build_report`, the physical route's through
:func:`build_physical_report`. Its schema, every key with the route that writes it, is
``docs/report.md`` (the one place it is written; ``test/diagnose`` checks that every key the
builders write is there). All numbers are plain JSON (no NaN: undefined values are null).
"""
from __future__ import annotations

import json
import math
import os
from pathlib import Path
from typing import Any, Mapping, Sequence

import numpy as np

from ..fileio import atomic_write_text
from ..layout import STATE_NAMES
from .selection import CandidateScore, Round, SelectionResult

REPORT_FORMAT = "littledog_mlsim.diagnosis"
REPORT_FORMAT_VERSION = 1

__all__ = ["write_report", "build_report", "REPORT_FORMAT", "REPORT_FORMAT_VERSION"]


def _f(x: Any) -> float | None:
    try:
        x = float(x)
    except (TypeError, ValueError):
        return None
    return x if math.isfinite(x) else None


def _named(v: np.ndarray) -> dict[str, float | None]:
    return {n: _f(x) for n, x in zip(STATE_NAMES, v)}


def _clean(obj: Any) -> Any:
    if isinstance(obj, dict):
        return {str(k): _clean(v) for k, v in obj.items()}
    if isinstance(obj, (list, tuple)):
        return [_clean(v) for v in obj]
    if isinstance(obj, (np.floating, float)):
        return _f(obj)
    if isinstance(obj, np.integer):
        return int(obj)
    if isinstance(obj, np.bool_):
        return bool(obj)
    if isinstance(obj, np.ndarray):
        return _clean(obj.tolist())
    return obj


def _outputs(s: CandidateScore, alpha: float, min_gain: float) -> list[str]:
    mask = (s.p_element < alpha) & (s.gain >= 0.5 * min_gain)
    return [STATE_NAMES[j] for j in np.flatnonzero(mask)]


def _effect(k: int, r: Round, sel: SelectionResult, before: dict, after: dict,
            floor: Mapping[str, Any] | None = None) -> dict:
    s = r.picked
    assert s is not None
    fam = [c for c in r.scores if c.augmentation.family == s.augmentation.family]
    outputs = _outputs(s, sel.alpha, sel.min_gain) or s.outputs
    cut = {}
    for name in outputs:
        b, a = before["nmse"].get(name), after["nmse"].get(name)
        cut[name] = _f(1.0 - a / b) if (a is not None and b) else None
    order = np.argsort(-s.gain)
    return {
        "round": k + 1, "name": s.augmentation.name, "label": s.label,
        "family": s.augmentation.family, "params": s.augmentation.params(),
        "columns": list(s.augmentation.columns()), "outputs": outputs,
        "p_value": min(c.p_value for c in fam),
        "evidence": {
            "held_out_gain": _named(s.gain), "total_gain": s.total_gain,
            "max_gain": s.max_gain, "p_pooled": s.p_pooled, "p_member": s.p_value,
            "n_moves": len(sel.move_types),
            "moves_improved": {STATE_NAMES[j]: int(s.n_moves_better[j]) for j in order[:8]},
            "parameter_profile": [{"candidate": c.label, "params": c.augmentation.params(),
                                   "total_gain": c.total_gain, "max_gain": c.max_gain,
                                   "p_value": c.p_value} for c in fam],
            "search_nmse_before": _named(r.search_nmse),
            "residual_input_ccf": r.ccf,
            "delay_scan": (None if r.delay_profile is None else
                           [{"delay": d["delay"], "total_gain": d["total_gain"],
                             "gain": _named(np.asarray(d["gain"]))} for d in r.delay_profile]),
        },
        "before": before, "after": after, "nmse_cut": cut,
        "physical": learned_physical(s.augmentation, floor),
    }


def learned_physical(aug: Any, floor: Mapping[str, Any] | None = None) -> dict[str, Any]:
    """The vocabulary's family/scope of a feature the learned loop added (docs/diagnosis.md);
    the learned loop measures no physical magnitude, so the primary parameter is null except a
    command delay's (lag x 10 ms), a command filter's, and a position effect's where the floor
    is a plane (``floor``: report.json's ``floor_plane``; :mod:`.families.learned`)."""
    from .families.learned import physical_reading
    return physical_reading(aug, floor)


def build_report(sel: SelectionResult, stages: Sequence[dict], **info: Any) -> dict[str, Any]:
    """The report.json document (see module doc)."""
    floor = info.get("floor_plane")
    contrasts = info.pop("one_step_contrasts", None)
    # decisions 043 and 044: a first stage on the data as recorded
    off = 1 if info.get("sensor_correction") or info.get("frame_repair") else 0
    effects = [_effect(k, r, sel, stages[k + off], stages[k + off + 1], floor)
               for k, r in enumerate([r for r in sel.rounds if r.picked is not None])]
    for e, c in zip(effects, contrasts or []):
        if c is not None:
            e["reference"] = c
    rounds = []
    for r in sel.rounds:
        best = sorted(r.scores, key=lambda c: -c.total_gain)[:10]
        rounds.append({"round": r.index + 1, "feature_set": r.feature_set.describe(),
                       "picked": None if r.picked is None else r.picked.label,
                       "n_candidates": len(r.scores),
                       "n_significant": sum(c.significant for c in r.scores),
                       "n_material": sum(c.significant and c.material for c in r.scores),
                       "search_nmse_mean": _f(np.nanmean(r.search_nmse)),
                       "notes": list(r.notes),
                       "seconds": r.seconds, "best": [c.to_dict() for c in best]})
    doc = {
        "format": REPORT_FORMAT, "format_version": REPORT_FORMAT_VERSION,
        "significant": bool(effects), "effects": effects, "suspected": [],
        "before": stages[0], "after": stages[-1], "stages": list(stages), "rounds": rounds,
        "search": {**sel.search_model, "residual": "cross-fitted by move (held-out folds)",
                   "alpha": sel.alpha, "min_gain": sel.min_gain,
                   "library_size": len(sel.library),
                   "test": "one-sided t-test over moves of per-move held-out SSE cuts "
                           "(pooled over elements and per element), Bonferroni"},
        **info,
    }
    doc["suspected"] = _rollout_suspects(info.get("rollout_route"))
    cond = info.get("reference_conditions")
    if cond is not None and not cond["comparable"]:
        _not_comparable(doc, cond)
    if contrasts is not None:
        _shared(doc)
    return _clean(doc)


def _shared(doc: dict[str, Any]) -> None:
    """Decision 041 on the one-step loop's effects: an effect the reference shows as much
    (its ``reference.changed`` false, :mod:`.one_step_contrast`) moves from ``effects`` to
    ``shared`` (the robot's own: the model keeps its columns, ``significant`` does not count
    it)."""
    own = [not (e.get("reference") or {}).get("changed", True) for e in doc["effects"]]
    doc["shared"] = [e for e, o in zip(doc["effects"], own) if o]
    doc["effects"] = [e for e, o in zip(doc["effects"], own) if not o]
    doc["significant"] = bool(doc["effects"])


def _not_comparable(doc: dict[str, Any], cond: Mapping[str, Any]) -> None:
    """Decision 031 on the one-step loop's effects: with a reference recorded under another
    command excitation than the data (``cond``: :meth:`.conditions.Conditions.to_dict`), an
    effect of a family excitation shows moves from ``effects`` to ``not_comparable`` (the model
    keeps its columns) and is listed under ``suspected`` with why and the recording that
    settles it; ``significant`` counts what is left."""
    from .conditions import Conditions
    from .families.learned import learned_family
    c = Conditions(cond["data_excitation_rad"], cond["reference_excitation_rad"])
    moved = [e for e in doc["effects"] if learned_family(e["family"]).excitation_shows]
    doc["effects"] = [e for e in doc["effects"] if e not in moved]
    doc["significant"] = bool(doc["effects"])
    doc["not_comparable"] = [{**e, "why": c.why, "recording": c.recording} for e in moved]
    for e in moved:
        ph = e.get("physical") or {}
        doc["suspected"].append({"family": ph.get("family", "other"),
                                 "scope": ph.get("scope", "body"),
                                 "params": ph.get("params", {}), "why": c.why,
                                 "recording": c.recording, "label": e["label"],
                                 "p_value": e["p_value"]})


def _rollout_suspects(r: Mapping[str, Any] | None) -> list[dict[str, Any]]:
    """The rollout route's suspected families (``--rollout-route``) in the vocabulary, in the
    physical route's ``suspected`` form, with the probe's ``label`` and ``p_value`` (and
    ``settle_moves_per_type`` where the rollout route gives it); none without the rollout
    route."""
    out = []
    for s in (r or {}).get("suspected", []):
        v = s["vocabulary"]
        entry = {"family": v["family"], "scope": v["scope"], "params": v["params"],
                 "why": s["why"], "recording": s["recording"], "label": s["label"],
                 "p_value": s["p_value"]}
        if "settle_moves_per_type" in s:
            entry["settle_moves_per_type"] = s["settle_moves_per_type"]
        out.append(entry)
    return out


# ---------------------------------------------------------------------------------------------
# figures

def _rollout_figure(out: Path, stages: Sequence[dict], step: str, title: str) -> str:
    """rollout_before_after.png: the mean cumulative (x, y) error against time of every stage's
    report model, one panel per projection; returns the file name."""
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    labels = list(stages[0]["rollout"])
    fig, axes = plt.subplots(1, len(labels), figsize=(5 * len(labels), 3.6), squeeze=False)
    for ax, lab in zip(axes[0], labels):
        for i, st in enumerate(stages):
            y = [np.nan if v is None else v for v in st["rollout"][lab]["xy_error_vs_time_mean"]]
            ax.plot(np.arange(1, len(y) + 1) * 0.01, y,
                    label="start" if i == 0 else f"+ {step} {i}")
        ax.set_xlabel("time after s_1 [s]")
        ax.set_ylabel("mean cumulative (x, y) error [m]")
        ax.set_title(f"{title}, projection {lab}")
        ax.legend(fontsize=7)
    fig.tight_layout()
    fig.savefig(out / "rollout_before_after.png", dpi=90)
    plt.close(fig)
    return "rollout_before_after.png"


def _figures(out: Path, sel: SelectionResult, doc: dict) -> dict[str, list[str]]:
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    figs: dict[str, list[str]] = {"effects": [], "summary": []}
    picked_rounds = [r for r in sel.rounds if r.picked is not None]
    by_round = {e["round"]: e for e in doc["effects"]}   # not those moved by decision 031
    for k, r in enumerate(picked_rounds):
        if k + 1 in by_round:
            figs["effects"].append(_effect_figure(out, plt, k, r, by_round[k + 1], sel))
    figs["summary"].append(_nmse_figure(out, plt, doc["stages"]))
    if list(doc["stages"][0]["rollout"]):
        figs["summary"].append(_rollout_figure(out, doc["stages"], "effect", "rollout"))
    figs["summary"].append(_last_round_figure(out, plt, sel))
    return figs


def _effect_figure(out: Path, plt: Any, k: int, r: Round, eff: dict, sel: SelectionResult
                   ) -> str:
    """Residual vs candidate for the most affected elements, the delay scan (if any) and the
    family's parameter profile."""
    s = r.picked
    # residual vs candidate: binned held-out residual against the held-out correction
    outs = [STATE_NAMES.index(n) for n in eff["outputs"]] or list(np.argsort(-s.gain)[:3])
    outs = sorted(outs, key=lambda j: -s.gain[j])[:3]
    scan = eff["evidence"].get("delay_scan")
    n_panels = len(outs) + 1 + (scan is not None)
    fig, axes = plt.subplots(1, n_panels, figsize=(4.2 * n_panels, 3.6))
    for ax, j in zip(axes, outs):
        _residual_panel(ax, r, s, j)
    if scan is not None:
        ax = axes[-2]
        ds = [d["delay"] for d in scan]
        tg = [d["total_gain"] for d in scan]
        ax.bar(ds, tg, color=["C3" if d == s.augmentation.params().get("lag") else "C0"
                              for d in ds])
        ax.set_xlabel("d: search model refitted with u_{t-d} in place of u_t")
        ax.set_ylabel("total held-out gain vs d = 0")
        ax.set_title("delay scan (red: estimate)", fontsize=9)
    _profile_panel(axes[-1], eff["evidence"]["parameter_profile"], s, sel)
    fig.tight_layout()
    name = f"effect{k + 1}_{s.augmentation.name}.png"
    fig.savefig(out / name, dpi=90)
    plt.close(fig)
    return name


def _residual_panel(ax: Any, r: Round, s: CandidateScore, j: int) -> None:
    x, y = r.correction[:, j], r.residual[:, j]
    q = np.quantile(x, np.linspace(0, 1, 21))
    q[-1] += 1e-12
    b = np.clip(np.searchsorted(q, x, side="right") - 1, 0, 19)
    cx = np.array([x[b == i].mean() if np.any(b == i) else np.nan for i in range(20)])
    cy = np.array([y[b == i].mean() if np.any(b == i) else np.nan for i in range(20)])
    se = np.array([y[b == i].std() / math.sqrt(max((b == i).sum(), 1))
                   for i in range(20)])
    ax.errorbar(cx, cy, yerr=se, fmt="o", ms=3, label="binned mean")
    lim = np.nanmax(np.abs(np.concatenate([cx, cy])))
    ax.plot([-lim, lim], [-lim, lim], "k--", lw=0.8, label="residual = effect")
    ax.axhline(0, color="0.7", lw=0.5)
    ax.set_xlabel(f"{s.label.split('(')[0]} term (held-out fit)")
    ax.set_ylabel(f"held-out residual {STATE_NAMES[j]}")
    ax.set_title(f"{STATE_NAMES[j]}: cut {s.gain[j]:.1%}", fontsize=9)
    ax.legend(fontsize=7)


def _profile_panel(ax: Any, prof: list[dict], s: CandidateScore, sel: SelectionResult) -> None:
    labels = [p["candidate"].replace(f"{p['candidate'].split('(')[0]}", "")[:22]
              for p in prof]
    tg = [p["total_gain"] for p in prof]
    colors = ["C3" if p["candidate"] == s.label else
              ("C0" if p["p_value"] < sel.alpha else "0.6") for p in prof]
    ax.barh(range(len(prof)), tg, color=colors)
    ax.set_yticks(range(len(prof)))
    ax.set_yticklabels([f"{p['candidate'].split('(')[0]}{lab}" for p, lab in zip(prof, labels)],
                       fontsize=6)
    ax.invert_yaxis()
    ax.set_xlabel("total held-out gain (sum over elements)")
    ax.set_title(f"{s.augmentation.family}: parameter profile\n(red: chosen; blue: p < alpha)",
                 fontsize=8)


def _nmse_figure(out: Path, plt: Any, stages: list[dict]) -> str:
    """Before/after bars of the one-step nMSE (TestPool), every stage."""
    fig, ax = plt.subplots(figsize=(14, 4))
    w = 0.8 / len(stages)
    for i, st in enumerate(stages):
        v = [st["nmse"].get(n) or np.nan for n in STATE_NAMES]
        ax.bar(np.arange(len(STATE_NAMES)) + (i - (len(stages) - 1) / 2) * w, v, w,
               label=("start: " if i == 0 else f"+ effect {i}: ")
               + st["feature_set_description"][-60:])
    ax.set_yscale("log")
    ax.set_xticks(range(len(STATE_NAMES)))
    ax.set_xticklabels(STATE_NAMES, rotation=90, fontsize=7)
    ax.set_ylabel("one-step nMSE (TestPool)")
    ax.legend(fontsize=7)
    fig.tight_layout()
    fig.savefig(out / "nmse_before_after.png", dpi=90)
    plt.close(fig)
    return "nmse_before_after.png"


def _last_round_figure(out: Path, plt: Any, sel: SelectionResult) -> str:
    last = sel.rounds[-1]
    best = sorted(last.scores, key=lambda c: -c.max_gain)[:15]
    fig, ax = plt.subplots(figsize=(7, 4.5))
    ax.barh(range(len(best)), [c.max_gain for c in best],
            color=["C0" if c.significant else "0.6" for c in best])
    ax.axvline(sel.min_gain, color="C3", ls="--", label=f"min_gain {sel.min_gain:.0%}")
    ax.set_yticks(range(len(best)))
    ax.set_yticklabels([f"{c.label[:40]}  p={c.p_value:.1g}" for c in best], fontsize=7)
    ax.invert_yaxis()
    ax.set_xlabel("largest held-out nMSE cut of one element (TrainPool cross-fit)")
    ax.set_title(f"round {last.index + 1}: what is left (blue: significant)", fontsize=9)
    ax.legend(fontsize=7)
    fig.tight_layout()
    fig.savefig(out / "last_round.png", dpi=90)
    plt.close(fig)
    return "last_round.png"


# ---------------------------------------------------------------------------------------------
# markdown

def _num(x: Any, fmt: str = ".4g") -> str:
    return "n/a" if x is None else format(x, fmt)


def _markdown(doc: dict, figs: Mapping[str, list[str]]) -> str:
    L: list[str] = _md_head(doc)
    add = L.append
    for e, fig in zip(doc["effects"], figs.get("effects", [])):
        L += _md_effect(e, fig)
    L += _md_before_after(doc, figs)
    L += _md_rounds(doc)
    L += _md_rollout_route(doc.get("rollout_route"))
    L += _md_timing(doc.get("timing"))
    L += _md_held_frames(doc.get("held_frames"), doc.get("frame_repair"))
    add(f"Final model: `{doc.get('model')}`. Schema of report.json: "
        f"`littledog_mlsim/diagnose/report.py`.")
    return "\n".join(L) + "\n"


def _md_timing(t: Mapping[str, Any] | None) -> list[str]:
    """The sensor-timing check's section (:mod:`.timing`), either route."""
    if not t:
        return []
    L = ["## Sensor timing (joint states against the pose)\n"]
    if "error" in t:
        return L + [f"Not checked: {t['error']}\n"]
    ref = (f"; the reference {t['reference_median_ms']:+.1f} ms over "
           f"{t['reference_n_moves']} moves" if "reference_median_ms" in t else "")
    L.append(f"The joint angles fit the feet's height on the floor best read "
             f"{t['median_ms']:+.1f} ms from the pose (median over {t['n_moves']} moves, "
             f"quartiles {t['iqr_ms'][0]:+.1f} to {t['iqr_ms'][1]:+.1f}){ref}. Shift "
             f"{t['shift_ms']:+.1f} ms, p = {t['p_value']:.2g} ({t['test']}).\n")
    legs = (t.get("legs") or {}).get("per_leg") or []
    if legs:
        L.append("Per leg (its own angles, over the rows its foot stands): " + "; ".join(
            f"{r['leg'].replace('_', '-')} "
            + ("not read" if r["shift_ms"] is None
               else f"{r['shift_ms']:+.1f} ms (p = {r['p_value']:.2g})") for r in legs)
            + ".\n")
    if t.get("significant"):
        L.append(f"**Found:** {t['statement']}. What to do: {t['recording']}.\n")
    else:
        L.append(f"No shift of at least {t['min_shift_ms']:g} ms at p < {t['alpha']:g}.\n")
    return L


def _md_held_frames(h: Mapping[str, Any] | None, fix: Mapping[str, Any] | None) -> list[str]:
    """The held-frame check's section (:mod:`.held_frames`), either route."""
    if not h:
        return []
    L = ["## Held frames (a sensor stream repeating its last frame)\n"]
    for r in h.get("streams", []):
        ref = (f", the reference {100 * r['reference_held_fraction']:.2f} %"
               if "reference_held_fraction" in r else "")
        L.append(f"- {r['stream']}: held on {100 * r['held_fraction']:.2f} % of the rows where "
                 f"the other stream moves{ref} (p = {r['p_value']:.2g}, {r['test']}).")
    L.append("")
    if h.get("significant"):
        L.append(f"**Found:** {h['statement']}. What to do: {h['recording']}.\n")
    else:
        L.append(f"No stream held on {100 * h['min_held_fraction']:g} % of its rows or more at "
                 f"p < {h['alpha']:g}.\n")
    if fix:
        L.append(f"Repair: {fix['statement']}.\n")
    return L


def _md_rollout_route(r: Mapping[str, Any] | None) -> list[str]:
    """The rollout route's section (``diagnose --rollout-route``), if it ran."""
    if not r:
        return []
    L = ["## Rollout route (held-out k-step rollouts)\n", f"{r.get('verdict', '')}\n"]
    for e in r.get("effects", []):
        L.append(f"- `{e['label']}` (p = {e.get('p_value', float('nan')):.2g}): "
                 f"{e.get('statement', '')}")
    for e in (r.get("reference") or {}).get("shared", []):
        c = e.get("reference", {})
        L.append(f"- in the reference as well: `{e['label']}` (gain {e.get('gain', 0):.2f} here, "
                 f"{c.get('reference_total_gain', float('nan')):.2f} on the reference; p of a "
                 f"change {c.get('p_change', float('nan')):.2g}): {e.get('statement', '')}")
    for e in (r.get("reference") or {}).get("not_comparable", []):
        L.append(f"- the reference cannot tell: `{e['label']}` (the model keeps it): "
                 f"{e.get('statement', '')}")
    for s in r.get("suspected", []):
        L.append(f"- suspected: {s.get('label', s)}")
    res = r.get("residual") or {}
    if res.get("verdict"):
        L.append(f"\nResidual: {res['verdict']}")
    change = r.get("unexplained_change")
    if change:
        L.append(f"\nAgainst the reference: {change['statement']}"
                 + (f"; {change['recording']}" if change["significant"]
                    or change.get("comparable") is False else ""))
    carried = r.get("reference_change")
    if carried:
        L.append(f"\nThe reference's model on this data: {carried['statement']}")
    pushed = r.get("drift_change")
    if pushed and pushed.get("tested"):
        L.append(f"\nThe drift against the reference: {pushed['statement']}")
    return L + [""]


def _params_text(params: Mapping[str, Any]) -> str:
    """``name value, ...`` of the parameters that have a value."""
    return ", ".join(f"{k} {v:.3g}" if isinstance(v, float) else f"{k} {v}"
                     for k, v in params.items() if v is not None)


def _md_head(doc: dict) -> list[str]:
    L: list[str] = []
    add = L.append
    add("# Residual diagnosis\n")
    add(f"Data: `{doc.get('data')}` ({doc.get('n_train_moves')} TrainPool moves pick the "
        f"effects; {doc.get('n_test_moves')} TestPool moves, which took no part in choosing, "
        f"score them). Start: {doc.get('baseline')} "
        f"({doc['before']['feature_set_description']}); report model `{doc.get('method')}` "
        f"{doc.get('options') or ''}.\n")
    srch = doc["search"]
    add(f"**Significant: {'yes' if doc['significant'] else 'no'}.** "
        + ("Effects found, in order: " + "; ".join(
            f"{e['family']} `{e['label']}` (p = {e['p_value']:.2g})" for e in doc["effects"])
           + "." if doc["effects"] else
           f"No candidate of the {srch['library_size']}-candidate library explains significantly "
           f"(adjusted p < {srch['alpha']}) and materially (>= {srch['min_gain']:.0%} held-out "
           f"nMSE cut of one element) more residual variance than chance; nothing was added.")
        + "\n")
    readings = [f"- `{e['label']}` reads as {ph['family']} at {ph['scope']} "
                f"({_params_text(ph['params'])}): {ph['statement']}"
                for e in doc["effects"] for ph in [e.get("physical") or {}]
                if any(v is not None for v in (ph.get("params") or {}).values())]
    if readings:                         # the effects the vocabulary gives a magnitude
        L += readings + [""]
    cond = doc.get("reference_conditions") or {}
    if not cond.get("comparable", True):
        add(f"Against the reference: {cond['statement']}; {cond['recording']}.\n")
    for e in doc.get("not_comparable", []):
        add(f"- the reference cannot tell: {e['family']} `{e['label']}` (p = "
            f"{e['p_value']:.2g}; the model keeps it): {e['why']}")
    if doc.get("not_comparable"):
        add("")
    for e in doc.get("shared", []):
        c = e["reference"]
        add(f"- in the reference as well (the robot's own; the model keeps it): {e['family']} "
            f"`{e['label']}` (gain {c['total_gain']:.3f} on the data, "
            f"{c['reference_total_gain']:.3f} on the reference; p = {c['p_change']:.2g} that "
            "it gains more on the data)")
    if doc.get("shared"):
        add("")
    add(f"Method: residuals of a {srch.get('kind')} search model (M = "
        f"{srch.get('n_random_features')} random features, ARD length scales from a GP) "
        f"cross-fitted over {srch.get('n_folds')} folds of moves; each candidate is added as a "
        f"linear term and scored by the held-out MSE cut per element; {srch['test']}. "
        f"See `littledog_mlsim/diagnose/selection.py`.\n")
    return L


def _md_effect(e: dict, fig: str) -> list[str]:
    L: list[str] = []
    add = L.append
    add(f"## Effect {e['round']}: {e['family']} — `{e['label']}`\n")
    ev = e["evidence"]
    add(f"- parameters: `{json.dumps(e['params'])}`; adds {len(e['columns'])} columns "
        f"(`{e['columns'][0]}` ...)")
    add(f"- affects: {', '.join(e['outputs']) or '(no single element on its own)'}")
    add(f"- p = {e['p_value']:.2g} (family, adjusted); pooled p (unadjusted) = "
        f"{ev['p_pooled']:.2g}; held-out TrainPool cut: max {ev['max_gain']:.1%}, "
        f"total {ev['total_gain']:.2f} over {ev['n_moves']} moves\n")
    if ev.get("residual_input_ccf"):
        c = ev["residual_input_ccf"]
        add("- residual-input cross-correlation (held-out residual vs the joint's command "
            "increment u_{t-k} - u_{t-k-1}; evidence only):\n")
        add("| element | " + " | ".join(f"k={k}" for k in c["lags"]) + " |")
        add("|---|" + "---|" * len(c["lags"]))
        for n, v in c["ccf"].items():
            add(f"| {n} | " + " | ".join(f"{x:+.2f}" for x in v) + " |")
        add(f"\n(rough 95 % band +-{c['band_95']:.2f})\n")
    if ev.get("delay_scan"):
        add("- delay scan (search model refitted with u_{t-d} in place of u_t; total held-out "
            "gain over the 33 elements): " + ", ".join(
                f"d = {d['delay']}: {d['total_gain']:+.3f}" for d in ev["delay_scan"]) + "\n")
    add(f"![effect {e['round']}]({fig})\n")
    add("Left: held-out residual of the most affected elements against the candidate's "
        "held-out fitted term (binned means; on the dashed line the term explains the "
        "residual). Right: total held-out gain of each member of the family (the "
        "parameter estimate).\n")
    add("TestPool, report model, before -> after:\n")
    add("| element | nMSE before | nMSE after | cut |")
    add("|---|---|---|---|")
    for n in e["outputs"]:
        add(f"| {n} | {_num(e['before']['nmse'].get(n))} | {_num(e['after']['nmse'].get(n))} "
            f"| {_num(e['nmse_cut'].get(n), '.1%')} |")
    for lab in e["before"]["rollout"]:
        b, a = e["before"]["rollout"][lab], e["after"]["rollout"][lab]
        add(f"| rollout {lab}: final (x, y) error [m] | {_num(b['final_xy_error_m'])} | "
            f"{_num(a['final_xy_error_m'])} | |")
    add("")
    return L


def _md_before_after(doc: dict, figs: Mapping[str, list[str]]) -> list[str]:
    L: list[str] = []
    add = L.append
    add("## Before and after (TestPool)\n")
    stages = doc["stages"]
    for i, st in enumerate(stages):
        if st.get("error") or st.get("note"):
            add(f"Stage {i} ({st['feature_set_description']}): "
                f"{st.get('error') or st.get('note')}.\n")
    for f in figs.get("summary", []):
        add(f"![{f}]({f})\n")
    stages = doc["stages"]
    add("| element | " + " | ".join("start" if i == 0 else f"+{i}" for i in range(len(stages)))
        + " |")
    add("|---|" + "---|" * len(stages))
    for n in STATE_NAMES:
        add(f"| {n} | " + " | ".join(_num(st["nmse"].get(n)) for st in stages) + " |")
    add("| **mean** | " + " | ".join(_num(st["nmse_mean"]) for st in stages) + " |")
    for lab in stages[0]["rollout"]:
        add(f"| rollout {lab} final (x, y) error [m] | "
            + " | ".join(_num(st["rollout"][lab]["final_xy_error_m"]) for st in stages) + " |")
        for h in ("0.5", "1"):
            add(f"| rollout {lab} nMSE mean at {h} s | " + " | ".join(
                _num(_mean_or_none(st["rollout"][lab]["nmse_at_horizon"].get(h, {}).get("nmse")))
                for st in stages) + " |")
    add("")
    return L


def _md_rounds(doc: dict) -> list[str]:
    L: list[str] = []
    add = L.append
    add("## Rounds\n")
    for r in doc["rounds"]:
        add(f"Round {r['round']} ({r['feature_set']}): {r['n_significant']} significant, "
            f"{r['n_material']} significant and material; picked "
            f"{'`' + r['picked'] + '`' if r['picked'] else 'nothing'} "
            f"({r['seconds']:.0f} s).\n")
        for note in r.get("notes", []):
            add(f"Note: {note}.\n")
        add("| candidate | family | max cut | total | p (adjusted) |")
        add("|---|---|---|---|---|")
        for c in r["best"][:6]:
            add(f"| `{c['candidate']}` | {c['family']} | {c['max_gain']:.1%} | "
                f"{c['total_gain']:.2f} | {c['p_value']:.2g} |")
        add("")
    return L


def _mean_or_none(d: Mapping[str, Any] | None) -> float | None:
    if not d:
        return None
    v = [x for x in d.values() if x is not None]
    return float(np.mean(v)) if v else None


def write_report(out: str | os.PathLike, sel: SelectionResult, stages: Sequence[dict], *,
                 figures: bool = True, **info: Any) -> dict[str, Any]:
    """Write ``out/report.json``, ``out/report.md`` and the figures; return the JSON document."""
    return _write(out, info, lambda i: build_report(sel, stages, **i),
                  lambda doc: _figures(Path(out), sel, doc) if figures else {}, _markdown)


def _write(out: str | os.PathLike, info: dict[str, Any], build: Any, figs: Any,
           markdown: Any) -> dict[str, Any]:
    """The report files of either mode: the document from ``info`` (its run keys renamed as
    report.json has them), the figures, then report.json and report.md, each atomically."""
    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    info = dict(info)
    info["n_train_moves"] = info.pop("n_train", None)
    info["n_test_moves"] = info.pop("n_test", None)
    info["model"] = info.pop("model_path", None)
    doc = build(info)
    f = figs(doc)
    atomic_write_text(out / "report.json", json.dumps(doc, indent=1, allow_nan=False) + "\n")
    atomic_write_text(out / "report.md", markdown(doc, f))
    return doc


# ---------------------------------------------------------------------------------------------
# the physical identification's report (``diagnose`` with physics on; docs/diagnosis.md)

def _physical_effect(k: int, f: Any, aug: Any, before: dict, after: dict) -> dict[str, Any]:
    from .physical import CHANNELS
    from .families import vocabulary_family
    ev = f.evidence()
    outputs = [CHANNELS[j] for j in np.flatnonzero((f.p_channel < 0.01) & (f.gain >= 0.025))]
    cut = {}
    for name in STATE_NAMES:
        b, a = before["nmse"].get(name), after["nmse"].get(name)
        cut[name] = _f(1.0 - a / b) if (a is not None and b) else None
    rem = f.remainder
    statement = f.statement if rem is None else f.statement + "; " + remainder_words(rem)
    extra = {} if rem is None else {"remainder": {k: (_f(v) if isinstance(v, float) else v)
                                                  for k, v in rem.items()},
                                    "stand_in": rem["reading"] == "stand-in"}
    return {
        "round": k + 1,
        "name": None if aug is None else aug.name,
        "label": (aug.label() if aug is not None else f"{f.family}({f.scope})"),
        "family": f.family, "params": dict(f.params),
        "columns": [] if aug is None else list(aug.columns()),
        "outputs": outputs, "p_value": f.p_value,
        "physical": {"family": vocabulary_family(f.family), "scope": f.scope,
                     "params": dict(f.params),
                     "statement": statement},
        "augmentation": None if aug is None else aug.to_dict(),
        "augmentation_note": (
            "added to the learned model (computed online by sim_node, rollout, evaluate)"
            if aug is not None else
            "no feature added: a constant change of the robot is a function of the learned "
            "model's inputs, so the model trained on these data already carries it "
            "(before = after)"),
        "evidence": ev, "before": before, "after": after, "nmse_cut": cut, **extra,
    }


def remainder_words(rem: dict[str, Any]) -> str:
    """The clause a physical finding's statement gets where, with a reference, it leaves a
    significant and material excess (``physical.driver.remainder``, decision 045; decisions
    062 and 063: pooled, or in its lead channel, ``rem["channel"]``)."""
    from .physical.driver import p_words
    share = rem["share_of_excess_removed"]
    took = ("" if share is None else
            f"; it removed {100 * min(max(share, 0.0), 1.0):.0f} % of the excess over the "
            "reference")
    where = ", ".join(rem["channels"][:3])
    on = f" in the channel {rem['channel']}" if rem.get("channel") else ""
    if rem["reading"] == "stand-in":
        return (f"a stand-in: the data's error{on} stays {rem['ratio_after']:.2f}x the "
                f"reference's ({p_words(rem)}, most on {where}){took}, so the change is mostly "
                "something the library does not hold")
    return (f"only part of the change: the data's error{on} stays {rem['ratio_after']:.2f}x the "
            f"reference's ({p_words(rem)}, most on {where}){took}; its size, or a "
            "second effect, is not settled")


def build_physical_report(pid: Any, effect_augs: Sequence[Any], effect_stage: Sequence[int],
                          stages: Sequence[dict], **info: Any) -> dict[str, Any]:
    """report.json of a diagnosis by physical identification (see module doc's additions)."""
    effects = []
    for k, (f, aug, si) in enumerate(zip(pid.findings, effect_augs, effect_stage)):
        before = stages[si - 1] if aug is not None else stages[si]
        effects.append(_physical_effect(k, f, aug, before, stages[si]))
    doc = {
        "format": REPORT_FORMAT, "format_version": REPORT_FORMAT_VERSION,
        "significant": bool(effects) or _left_named(pid), "effects": effects,
        "suspected": list(pid.suspected),
        "before": stages[0], "after": stages[-1], "stages": list(stages), "rounds": [],
        "search": {"kind": "physical identification", "alpha": pid.alpha,
                   "min_gain": pid.min_gain, "library_size": pid.library_size,
                   "test": "one-sided tests over held-out moves of per-move output-error SSE "
                           "cuts: pooled over channels, t-test and signed-rank of bounded cuts "
                           "(max over the hypotheses compared, common sign flips); per channel, "
                           "t-test; Bonferroni over channels, hypotheses and the three tests"},
        "physics": pid.describe(),
        **info,
    }
    return _clean(doc)


def _left_named(pid: Any) -> bool:
    """Whether, with a reference, what the findings leave is named ``other`` (decision 047):
    the report is then significant without a finding."""
    return bool(((getattr(pid, "reference", None) or {}).get("unexplained") or {}).get("named"))


def _physical_figures(out: Path, doc: dict) -> dict[str, list[str]]:
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    figs: dict[str, list[str]] = {"effects": [], "summary": []}
    for e in doc["effects"]:
        ev = e["evidence"]
        fig, axes = plt.subplots(1, 3, figsize=(13, 3.6))
        hb, ha = ev["horizon_errors_before"], ev["horizon_errors_after"]
        hs = list(hb)
        for ax, key, lab in ((axes[0], "q_rms_rad", "joint-angle RMS error [rad]"),
                             (axes[1], None, "body (x, y) error [m]")):
            vb = [hb[h].get(key) if key else hb[h].get("xy_body_m", hb[h].get("xy_odom_m"))
                  for h in hs]
            va = [ha[h].get(key) if key else ha[h].get("xy_body_m", ha[h].get("xy_odom_m"))
                  for h in hs]
            x = np.arange(len(hs))
            ax.bar(x - 0.2, [np.nan if v is None else v for v in vb], 0.4, label="without")
            ax.bar(x + 0.2, [np.nan if v is None else v for v in va], 0.4, label="with effect")
            ax.set_xticks(x)
            ax.set_xticklabels([f"{h} ahead" for h in hs], fontsize=8)
            ax.set_ylabel(lab)
            ax.set_yscale("log")
            ax.legend(fontsize=7)
        axes[0].set_title("physics re-simulation, TestPool", fontsize=9)
        prof = ev.get("magnitude_profile") or []
        ax = axes[2]
        mag = [p for p in prof if "along" not in p]
        ridge = [p for p in prof if p.get("along") == "ridge"]
        if mag:
            ax.plot([p["magnitude"] for p in mag], [p["J_relative"] for p in mag], "o-",
                    label="at the fitted position")
        if ridge:   # decision 060: a payload's mass along its ridge of constant moment
            ax.plot([p["magnitude"] for p in ridge], [p["J_relative"] for p in ridge], "s--",
                    label="along the ridge of constant moment")
            ax.legend(fontsize=7)
        ax.set_xlabel(f"{e['physical']['family']} magnitude")
        ax.set_ylabel("weighted output SSE / without")
        ax.set_title("magnitude fit (fit moves)", fontsize=9)
        fig.suptitle(e["physical"]["statement"][:110], fontsize=9)
        fig.tight_layout()
        name = f"effect{e['round']}_{e['physical']['family']}.png"
        fig.savefig(out / name, dpi=90)
        plt.close(fig)
        figs["effects"].append(name)
    stages = doc["stages"]
    if list(stages[0]["rollout"]) and len(stages) > 1:
        figs["summary"].append(_rollout_figure(out, stages, "feature", "learned rollout"))
    return figs


def _physical_markdown(doc: dict, figs: Mapping[str, list[str]]) -> str:
    L: list[str] = []
    add = L.append
    ph = doc["physics"]
    add("# Diagnosis (physical identification)\n")
    add(f"Data: `{doc.get('data')}` ({doc.get('n_train_moves')} TrainPool moves, of which "
        f"{ph['n_fit_moves']} choose and fit, {ph['n_validation_moves']} others decide; "
        f"{doc.get('n_test_moves')} TestPool moves score). Transducer: {ph['transducer']}. "
        f"Library: {ph['library_size']} family x scope hypotheses "
        f"({', '.join(ph['families'])}); {ph['n_simulations']} re-simulations in "
        f"{ph['seconds']:.0f} s.\n")
    add(f"**Significant: {'yes' if doc['significant'] else 'no'}.**\n")
    left = (ph.get("reference") or {}).get("unexplained") or {}
    if left.get("named"):
        add(f"**Unexplained against the reference** (`other` on `{left['scope']}`): "
            f"{left['statement']}.\n")
    for e, fig in zip(doc["effects"], figs.get("effects", [])):
        p = e["physical"]
        ev = e["evidence"]
        add(f"## Effect {e['round']}: {p['statement']}\n")
        add(f"- family `{p['family']}`, scope `{p['scope']}`, parameters "
            f"`{json.dumps(p['params'])}`")
        add(f"- held-out moves: p = {e['p_value']:.2g} (adjusted); largest output-error cuts: "
            + ", ".join(f"{k} {v:.0%}" for k, v in list(ev["held_out_sse_cut"].items())[:4]
                        if v is not None))
        add(f"- learned model: {e['augmentation_note']}"
            + (f" (`{e['label']}`)" if e["augmentation"] else ""))
        add("")
        add("| horizon | joint RMS before [rad] | after | (x, y) before [m] | after |")
        add("|---|---|---|---|---|")
        for h, b in ev["horizon_errors_before"].items():
            a = ev["horizon_errors_after"][h]
            xyb = b.get("xy_body_m", b.get("xy_odom_m"))
            xya = a.get("xy_body_m", a.get("xy_odom_m"))
            add(f"| {h} | {_num(b['q_rms_rad'])} | {_num(a['q_rms_rad'])} | {_num(xyb)} | "
                f"{_num(xya)} |")
        add("")
        add(f"![effect {e['round']}]({fig})\n")
        add("TestPool, learned report model, before -> after: one-step nMSE mean "
            f"{_num(e['before']['nmse_mean'])} -> {_num(e['after']['nmse_mean'])}; " + "; ".join(
                f"rollout {lab} final (x, y) error {_num(e['before']['rollout'][lab]['final_xy_error_m'])}"
                f" -> {_num(e['after']['rollout'][lab]['final_xy_error_m'])} m"
                for lab in e["before"]["rollout"]) + "\n")
    if doc.get("suspected"):
        add("## Suspected, not established on this data\n")
        for s in doc["suspected"]:
            add(f"- `{s['family']}` on `{s['scope']}`: {s['why']}. Settle it with: "
                f"`{s['recording']}`")
        add("")
    if not doc["effects"]:
        for r in ph.get("rejected", []):
            add(f"Best candidate, not accepted: {r['statement']} (held-out p = "
                f"{_num(r['p_value'], '.2g')}, significant {r['significant']}, material "
                f"{r['material']}).\n")
    for f in figs.get("summary", []):
        add(f"![{f}]({f})\n")
    L += _md_timing(doc.get("timing"))
    L += _md_held_frames(doc.get("held_frames"), doc.get("frame_repair"))
    add(f"Final model: `{doc.get('model')}`. Schema of report.json: docs/diagnosis.md.")
    return "\n".join(L) + "\n"


def write_physical_report(out: str | os.PathLike, pid: Any, effect_augs: Sequence[Any],
                          effect_stage: Sequence[int], stages: Sequence[dict], *,
                          figures: bool = True, **info: Any) -> dict[str, Any]:
    """Write report.json / report.md / figures of a physical identification."""
    return _write(out, info,
                  lambda i: build_physical_report(pid, effect_augs, effect_stage, stages, **i),
                  lambda doc: _physical_figures(Path(out), doc) if figures else {},
                  _physical_markdown)
