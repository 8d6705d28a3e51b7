"""Decision 040 on read zoos: a spread change whose family is not named over all joints,
screened again at the joint types, sides and legs.

    OPENBLAS_NUM_THREADS=1 .venv/bin/python \
        benchmarks/learned_route/reference_change/narrower/narrower.py --zoo-dir WORK_zooNN \
        --truth benchmarks/blind_zoo/zoos/zooNN/truth.yaml --label zooNN --only z05,z07 \
        --out OUT

For each effect of ``--only`` (or clean seed, read from the harness's ``clean/``): the change
read through the reference's model (:func:`littledog_mlsim.diagnose.change.reference_change`,
at the route's start features, as a diagnosis whose search accepted nothing would read it),
with decision 040 (``change.SCREEN_NARROWER``). Each row gives the located scope and ratio,
what decision 027 kept over all joints and the share it explains, each narrower scope decision
040 screened (its ratio, the family the screen keeps there and its share), and what is named
in the end. Writes OUT.md and OUT.json (appending rows where OUT.json exists).
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


def _pct(x) -> str:
    return "-" if x is None else format(x, ".0%")


def write_md(doc: dict, path: Path) -> None:
    lines = ["# Decision 040 on read zoos: a spread change screened at narrower scopes", ""]
    lines += study_commands(doc)
    lines += ["", "| zoo | data | truth | located (ratio) | kept over all joints | narrower "
              "scopes screened: family kept, share | named | size | s |",
              "|---|---|---|---|---|---|---|---|---|"]
    for r in doc["rows"]:
        nr = r["narrower"]
        if nr is None:
            screened = "not screened"
        else:
            screened = "; ".join(f"{s['scope']} {s['ratio']:.2f}: {s['family']} "
                                 f"{_pct(s['explained'])}" for s in nr["scopes"]
                                 if s["family"] is not None) or "none kept a family"
        size = ", ".join(f"{k} {v}" for k, v in (r["size"] or {}).items()) or "-"
        lines.append(f"| {r['zoo']} | {r['data']} | {r['truth']} | {r['scope']} "
                     f"({r['ratio']:.2f}){'' if r['significant'] else ', not significant'} | "
                     f"{r['all_label'] or '-'} {_pct(r['all_explained'])} | {screened} | "
                     f"{r['named'] or 'nothing'} | {size} | {r['seconds']} |")
    path.write_text("\n".join(lines) + "\n")


def main() -> None:
    a, start, ref, ref_fit, effects, doc = zoo_effect_study(__doc__.splitlines()[0])
    for name, e, r, seconds in effects:
        c = change.reference_change(r, ref, start, None, None, ref_fit)
        nr = c.get("narrower")
        row = {
            "zoo": a.label, "data": name,
            "truth": truth_with_params(e),
            "scope": c["scope"], "ratio": c["ratio"], "significant": c["significant"],
            "all_label": (nr["all"]["label"] if nr else c.get("label")),
            "all_explained": (nr["all"]["explained"] if nr else c.get("explained")),
            "narrower": nr,
            "named": named_change(c),
            "size": ({k: v for k, v in c["size"].items() if k != "per_joint"}
                     if c.get("named") else None),
            "statement": c["statement"], "seconds": seconds()}
        doc["rows"].append(row)
        print(name, {k: row[k] for k in ("scope", "all_label", "all_explained", "named")},
              row["seconds"], flush=True)
        save_study(doc, a.out, write_md)


if __name__ == "__main__":
    main()
