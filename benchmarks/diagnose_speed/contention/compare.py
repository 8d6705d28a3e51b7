"""Compare diagnoses of the same datasets by two codes: per dataset, each report's time, what
it named (family, scope, physical parameters, p) and its suspected rivals, and the true effect
from the zoo's truth. Writes a Markdown table to stdout.

    python benchmarks/diagnose_speed/contention/compare.py BEFORE_DIR AFTER_DIR NAME [NAME ...] \\
        [--truth benchmarks/blind_zoo/zoos/zoo50/truth.yaml] [--rivals K]

``--rivals K``: after the table, each dataset's K hypotheses with the largest held-out mean
per-move cut in each report (the physical route's alternatives).

BEFORE_DIR and AFTER_DIR hold one directory per dataset NAME with its `report.json`; a NAME
written BEFORE_NAME:AFTER_NAME names the two directories apart.
"""
from __future__ import annotations

import argparse
import json
from pathlib import Path

import yaml


def _num(v) -> str:
    if isinstance(v, float):
        return f"{v:.3g}"
    if isinstance(v, list):
        return "(" + ", ".join(_num(x) for x in v) + ")"
    return str(v)


def named(rep: dict) -> str:
    eff = rep.get("effects") or []
    out = []
    for e in eff:
        phys = e.get("physical") or {}
        params = phys.get("params") or e.get("params") or {}
        keep = {k: v for k, v in params.items() if isinstance(v, (int, float, list))}
        out.append(f"{phys.get('family', e.get('family'))} @ {phys.get('scope', '?')} "
                   f"({', '.join(f'{k}={_num(v)}' for k, v in keep.items())}; "
                   f"p {e.get('p_value', float('nan')):.2g})")
    left = ((rep.get("physics") or {}).get("reference") or {}).get("unexplained") or {}
    voc = left.get("vocabulary")
    if left.get("named") and voc:
        out.append(f"other @ {voc['scope']} (error_ratio={_num(voc['params']['error_ratio'])})")
    return "; ".join(out) or "nothing"


def rivals(rep: dict, k: int) -> str:
    """The ``k`` largest held-out mean per-move cuts among the report's alternatives."""
    best: dict[tuple[str, str], float] = {}

    def walk(d) -> None:
        if isinstance(d, dict):
            if "held_out_move_cut" in d and "searched_family" in d:
                key = (d["searched_family"], d["scope"])
                best[key] = max(best.get(key, -float("inf")), float(d["held_out_move_cut"]))
            for v in d.values():
                walk(v)
        elif isinstance(d, list):
            for v in d:
                walk(v)
    walk(rep.get("effects") or [])
    top = sorted(best.items(), key=lambda kv: -kv[1])[:k]
    return "; ".join(f"{f} @ {s} {c:.3f}" for (f, s), c in top)


def suspected(rep: dict) -> str:
    return ", ".join(f"{s['family']} @ {s.get('scope', '?')}" for s in rep.get("suspected") or [])


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("before")
    ap.add_argument("after")
    ap.add_argument("names", nargs="+")
    ap.add_argument("--truth", default=None)
    ap.add_argument("--rivals", type=int, default=0)
    a = ap.parse_args()
    truth = {}
    if a.truth:
        t = yaml.safe_load(open(a.truth, encoding="utf-8"))
        for e in t.get("effects", []):
            truth[e.get("id") or e.get("name")] = e
    extra: list[str] = []
    print("| dataset | truth | before: named | after: named | before: suspected | "
          "after: suspected | seconds before -> after |")
    print("|---|---|---|---|---|---|---|")
    for name in a.names:
        nb, _, na = name.partition(":")
        n = na or nb
        b = json.load(open(Path(a.before) / nb / "report.json", encoding="utf-8"))
        f = json.load(open(Path(a.after) / n / "report.json", encoding="utf-8"))
        tr = truth.get(n)
        tt = (f"{tr.get('family')} @ {tr.get('scope')}: "
              + ", ".join(f"{k}={_num(v)}" for k, v in (tr.get("params") or {}).items())
              if tr else "clean")
        print(f"| {n} | {tt} | {named(b)} | {named(f)} | {suspected(b)} | {suspected(f)} | "
              f"{b['seconds']:.1f} -> {f['seconds']:.1f} |")
        if a.rivals:
            extra.append(f"- {n}: before {rivals(b, a.rivals)}; after {rivals(f, a.rivals)}")
    if extra:
        print("\nHeld-out mean per-move cuts, the largest (family @ scope, cut):\n")
        print("\n".join(extra))


if __name__ == "__main__":
    main()
