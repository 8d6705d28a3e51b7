"""Tables of ``jackknife.py``'s results over runs: per run the true values inside the reported
intervals and inside them widened to the jackknife's sd, and per parameter the median ratio of
the jackknife's sd to the per-move sandwich's, the RMS z of the reported intervals and how
many of the parameter's misses the widening brings inside.

    .venv/bin/python benchmarks/calibrate/interval_honesty/jackknife_table.py OUT/*.json
"""
from __future__ import annotations

import json
import math
import statistics
import sys
from pathlib import Path


def main(paths: list[str]) -> int:
    per: dict[str, list[dict]] = {}
    print("| run | inside (reported) | inside (CR3) | median width (reported) | (CR3) |")
    print("|---|---|---|---|---|")
    tot = [0, 0, 0]
    for p in paths:
        rows = [r for r in json.loads(Path(p).read_text())["rows"] if "inside" in r]
        n, a, b = len(rows), sum(r["inside"] for r in rows), sum(r["inside_cr3"] for r in rows)
        tot = [tot[0] + n, tot[1] + a, tot[2] + b]
        w = statistics.median(r["width"] for r in rows)
        w3 = statistics.median(r["width_cr3"] for r in rows)
        print(f"| {Path(p).stem} | {a} of {n} | {b} of {n} | {w:.3f} | {w3:.3f} |")
        for r in rows:
            per.setdefault(r["name"], []).append(r)
    print(f"| all | {tot[1]} of {tot[0]} | {tot[2]} of {tot[0]} | | |")
    print()
    print("| parameter | runs | CR3 / CR1, median (range) | RMS z (reported) | misses | "
          "brought inside by CR3 |")
    print("|---|---|---|---|---|---|")
    for name, rows in per.items():
        ratios = [r["ratio"] for r in rows if r["ratio"] is not None]
        z = [r["z"] for r in rows if r["z"] is not None]
        rms = math.sqrt(sum(x * x for x in z) / len(z)) if z else float("nan")
        miss = sum(not r["inside"] for r in rows)
        fixed = sum(r["inside_cr3"] and not r["inside"] for r in rows)
        print(f"| {name} | {len(rows)} | {statistics.median(ratios):.2f} "
              f"({min(ratios):.2f}-{max(ratios):.2f}) | {rms:.2f} | {miss} | {fixed} |")
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
