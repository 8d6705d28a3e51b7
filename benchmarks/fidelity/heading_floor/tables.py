"""Figures the README derives from ``heading_floor.py``'s committed results.

For each result file and each kind of data and size in it: the median absolute d_yaw bias
over the trot's first 4 s and after them, their RMS, and the median (worst) gap over the path
without the seeds of ``--without``; and, per seed, the range of the bias over the replicates.

    .venv/bin/python benchmarks/fidelity/heading_floor/tables.py \\
        benchmarks/fidelity/heading_floor/heading_floor*.json --without 5 7
"""
from __future__ import annotations

import argparse
import json
import math
from pathlib import Path

import numpy as np


def _rms(x) -> float:
    return math.sqrt(float(np.mean(np.square(x))))


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("results", nargs="+", type=Path)
    ap.add_argument("--without", nargs="*", type=int, default=[5, 7])
    a = ap.parse_args(argv)
    for path in a.results:
        fits = json.loads(path.read_text())["fits"]
        print(f"## {path.name}\n")
        print("| data | moves | abs bias median, first 4 s / after [mrad/s] | RMS first / after | "
              f"gap / path without seeds {a.without}, median (worst) |")
        print("|---|---|---|---|---|")
        for kind, k in sorted({(f.get("kind", "4 s moves"), f["moves"]) for f in fits}):
            runs = [r for f in fits if f.get("kind", "4 s moves") == kind and f["moves"] == k
                    for r in f["runs"]]
            if "dyaw_bias_first_per_s" in runs[0]:
                first = 1e3 * np.array([r["dyaw_bias_first_per_s"] for r in runs])
                after = 1e3 * np.array([r["dyaw_bias_after_per_s"] for r in runs])
                split = (f"{np.median(np.abs(first)):.2f} / {np.median(np.abs(after)):.2f} | "
                         f"{_rms(first):.2f} / {_rms(after):.2f}")
            else:
                split = "- | -"
            gap = 100 * np.array([r["err_per_m"] for r in runs if r["seed"] not in a.without])
            print(f"| {kind} | {k} | {split} | {np.median(gap):.1f} % ({gap.max():.1f} %) |")
        print("\nPer seed, the d_yaw bias over the replicates, min to max [mrad/s]:\n")
        for kind, k in sorted({(f.get("kind", "4 s moves"), f["moves"]) for f in fits}):
            runs = [r for f in fits if f.get("kind", "4 s moves") == kind and f["moves"] == k
                    for r in f["runs"]]
            seeds = sorted({r["seed"] for r in runs})
            cells = []
            for s in seeds:
                b = [1e3 * r["dyaw_bias_per_s"] for r in runs if r["seed"] == s]
                cells.append(f"{s}: {min(b):.1f} to {max(b):.1f}")
            print(f"- {kind}, {k}: " + "; ".join(cells))
        print()
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
