"""The seconds of every row of a `compare.py` table (`table.md`): how many, their range and
median before and after, each row's after / before ratio (range and median), and how many were
over a limit before and after.

    python benchmarks/diagnose_speed/contention/summarize.py \\
        benchmarks/diagnose_speed/contention/table.md [--limit 600]
"""
from __future__ import annotations

import argparse
import re
import statistics


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("table")
    ap.add_argument("--limit", type=float, default=600.0)
    a = ap.parse_args()
    pairs = [(float(b), float(f)) for b, f in re.findall(
        r"\| ([0-9.]+) -> ([0-9.]+) \|\s*$", open(a.table, encoding="utf-8").read(), re.M)]
    before, after = [b for b, _ in pairs], [f for _, f in pairs]
    ratio = [f / b for b, f in pairs]
    print(f"{len(pairs)} diagnoses; before {min(before):.1f}-{max(before):.1f} s (median "
          f"{statistics.median(before):.1f}), after {min(after):.1f}-{max(after):.1f} s (median "
          f"{statistics.median(after):.1f}); after / before {min(ratio):.3f}-{max(ratio):.3f} "
          f"(median {statistics.median(ratio):.3f}); over {a.limit:g} s: "
          f"{sum(b > a.limit for b in before)} before, {sum(f > a.limit for f in after)} after")


if __name__ == "__main__":
    main()
