"""Shares of a py-spy profile (``py-spy record --format raw``): where the learned route's
time goes, by the functions and callers named below.

    py-spy record --rate 40 --format raw --duration 600 -o PROFILE.txt -- \\
        .venv/bin/python -P -m littledog_mlsim.cli diagnose --data DATA --out OUT \\
        --no-figures --jobs 1 --physics off --rollout-route --reference REF
    python benchmarks/learned_route/speed/profile.py PROFILE.txt
"""
from __future__ import annotations

import sys
from collections import Counter

# (function, a caller within the three frames above it, or None for any caller)
WATCH = [("_Route.probe", None), ("_roll", "_Route.probe"),
         ("_Design.basis", "CrossFitModel.fit"), ("_Design.basis", "_roll"),
         ("_Design.basis", "CrossFitModel.predict"), ("_Design.basis", "CrossFitModel.predictive_std"),
         ("_cho_solve", "CrossFitModel.predictive_std"),
         ("CrossFitModel.fit.<locals>.<listcomp>", "_Route.probe")]


def shares(path: str) -> tuple[int, Counter]:
    total, hits = 0, Counter()
    for line in open(path):
        line = line.rstrip()
        if not line:
            continue
        stack, n = line.rsplit(" ", 1)
        total += int(n)
        frames = [f.split(" (")[0] for f in stack.split(";")]
        for fn, caller in WATCH:
            if fn in frames:
                i = frames.index(fn)
                if caller is None or caller in frames[max(0, i - 3):i]:
                    hits[(fn, caller)] += int(n)
    return total, hits


def main(argv=None) -> int:
    path = (argv or sys.argv[1:])[0]
    total, hits = shares(path)
    print(f"{total} samples in {path}")
    for fn, caller in WATCH:
        where = f" (under {caller})" if caller else ""
        print(f"{hits[(fn, caller)] / total:6.1%}  {fn}{where}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
