"""Decision 027's screen forced at narrower scopes than the one it located (an exploration on
read zoos; nothing of the package changes).

    OPENBLAS_NUM_THREADS=1 .venv/bin/python \
        benchmarks/learned_route/reference_change/drift_scope/drift_scope.py --zoo-dir WORK24 \
        --truth benchmarks/blind_zoo/zoos/zoo24/truth.yaml --label zoo24 --only z07 --out OUT

For each effect of ``--only``: the change read through the reference's model
(:func:`littledog_mlsim.diagnose.change.reference_change`, at the route's start features, as
a diagnosis whose search accepted nothing would read it), then decision 027's screen
(``change._screen``) run at ``all``, each joint type, each side and each leg, whatever scope
the reading located. Each row gives, per scope, the hypothesis kept, the share of that
scope's excess over the data's own model it removes (75 % names it) and its size. Writes
OUT.md and OUT.json (appending rows where OUT.json exists).
"""
from __future__ import annotations

import os
import sys
from pathlib import Path

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
sys.path[:0] = [str(Path(__file__).resolve().parents[4]), str(Path(__file__).resolve().parents[3])]

from _common import (named_change, save_study, study_commands,  # noqa: E402
                     truth_with_params, zoo_effect_study)

from littledog_mlsim.diagnose import change   # noqa: E402
from littledog_mlsim.layout import N_STATE   # noqa: E402

SCOPES = ("all", "type:hip_rolls", "type:hip_pitches", "type:knees", "side:left", "side:right",
          "leg:front_left", "leg:front_right", "leg:back_left", "leg:back_right")


def write_md(doc: dict, path: Path) -> None:
    lines = ["# Decision 027's screen forced at narrower scopes", ""]
    lines += study_commands(doc)
    lines += ["", "| zoo | effect | truth | located (ratio) | named by the reading | "
              "scope forced | kept | explained | size |", "|---|---|---|---|---|---|---|---|---|"]
    for r in doc["rows"]:
        for s in r["scopes"]:
            size = ", ".join(f"{k} {v}" for k, v in s["size"].items()) or "-"
            lines.append(f"| {r['zoo']} | {r['data']} | {r['truth']} | {r['scope']} "
                         f"({r['ratio']:.2f}) | {r['named'] or 'nothing'} | {s['scope']} | "
                         f"{s['label'] or '-'} | "
                         f"{'-' if s['explained'] is None else format(s['explained'], '.0%')} "
                         f"| {size} |")
    path.write_text("\n".join(lines) + "\n")


def main() -> None:
    a, start, ref, ref_fit, effects, doc = zoo_effect_study(__doc__.splitlines()[0])
    ref_model, ev_ref = ref_fit
    Xr, Yr, mir = start.features_responses(ref.train)
    for name, e, r, seconds in effects:
        c = change.reference_change(r, ref, start, None, None, ref_fit)
        X, Y, mi = start.features_responses(r.train)
        data, refs = change._sides(r, ref, ref_model, ev_ref, start, (X, Y, mi), (Xr, Yr, mir))
        _, ev_own = r.fit(start, one_step=True)
        D, Dr = Y - X[:, :N_STATE], Yr - Xr[:, :N_STATE]
        scopes = []
        for scope in SCOPES:
            s = change._screen(data, refs, start, scope, ev_own.one_step, X, D, mi, Xr, Dr,
                               r.opts, [], mir)
            scopes.append({"scope": scope, "label": s.get("label"), "family": s.get("family"),
                           "explained": s.get("explained"), "named": s.get("named"),
                           "size": {k: v for k, v in (s.get("size") or {}).items()
                                    if k != "per_joint"}})
            print(name, scopes[-1], flush=True)
        doc["rows"].append({
            "zoo": a.label, "data": name,
            "truth": truth_with_params(e),
            "scope": c["scope"], "ratio": c["ratio"],
            "named": named_change(c),
            "scopes": scopes, "seconds": seconds()})
    save_study(doc, a.out, write_md)


if __name__ == "__main__":
    main()
