"""Summarise diagnose report.json files (physical identification) as a markdown table.

Usage: python benchmarks/diagnose_physical/diagnose_physical_table.py OUT1 [OUT2 ...] > table.md
Each OUT is a `littledog-mlsim diagnose --out` directory. Columns: what was found (family,
scope, primary parameter), p, learned model's TestPool one-step nMSE mean and rollout final
(x, y) error before/after, suspected entries, runtime.
"""
from __future__ import annotations

import json
import sys
from pathlib import Path


def _fmt(v, f=".4g"):
    return "n/a" if v is None else format(v, f)


def main(argv: list[str]) -> int:
    print("| run | significant | family | scope | primary parameter | p | nMSE mean before -> after "
          "| rollout final xy [m] before -> after | suspected | seconds |")
    print("|---|---|---|---|---|---|---|---|---|---|")
    for d in argv:
        doc = json.loads((Path(d) / "report.json").read_text())
        sus = "; ".join(f"{s['family']} {s['scope']}" for s in doc.get("suspected", [])) or "-"
        lab = next(iter(doc["before"]["rollout"]), None)
        if not doc["effects"]:
            b = doc["before"]
            xy = b["rollout"][lab]["final_xy_error_m"] if lab else None
            print(f"| {Path(d).name} | no | - | - | - | - | {_fmt(b['nmse_mean'])} | {_fmt(xy)} "
                  f"| {sus} | {doc['seconds']:.0f} |")
        for e in doc["effects"]:
            ph = e["physical"]
            k, v = next(iter(ph["params"].items()))
            bx = e["before"]["rollout"][lab]["final_xy_error_m"] if lab else None
            ax = e["after"]["rollout"][lab]["final_xy_error_m"] if lab else None
            print(f"| {Path(d).name} | yes | {ph['family']} | {ph['scope']} | {k} = {_fmt(v)} | "
                  f"{e['p_value']:.2g} | {_fmt(e['before']['nmse_mean'])} -> "
                  f"{_fmt(e['after']['nmse_mean'])} | {_fmt(bx)} -> {_fmt(ax)} | {sus} | "
                  f"{doc['seconds']:.0f} |")
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
