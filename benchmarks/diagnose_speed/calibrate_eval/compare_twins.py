"""Two twin files compared: every field of the robot and every fitted parameter's value and
95 % interval, exactly (the count of those that differ and the largest relative difference),
and the TestPool rollout before and after.

    .venv/bin/python benchmarks/diagnose_speed/calibrate_eval/compare_twins.py A.json B.json
"""
from __future__ import annotations

import json
import sys


def flat(x, prefix=""):
    if isinstance(x, dict):
        for k, v in x.items():
            yield from flat(v, f"{prefix}{k}.")
    elif isinstance(x, list):
        for i, v in enumerate(x):
            yield from flat(v, f"{prefix}{i}.")
    else:
        yield prefix[:-1], x


def main() -> None:
    a, b = (json.load(open(p)) for p in sys.argv[1:3])
    ra, rb = dict(flat(a["robot"])), dict(flat(b["robot"]))
    pa, pb = (dict(flat({k: {"value": v["value"], "ci95": v["ci95"]}
                         for k, v in t["provenance"]["parameters"].items()})) for t in (a, b))
    for what, x, y in (("robot fields", ra, rb), ("parameter values and intervals", pa, pb)):
        keys = sorted(set(x) | set(y))
        diff = [k for k in keys if x.get(k) != y.get(k)]
        rel = max((abs(x[k] - y[k]) / max(abs(x[k]), 1e-300) for k in diff
                   if isinstance(x.get(k), float) and isinstance(y.get(k), float)), default=0.0)
        print(f"{what}: {len(keys)}, {len(diff)} differ (largest relative difference {rel:.3g})"
              + (f": {', '.join(diff[:8])}" if diff else ""))
    for t, name in ((a, "A"), (b, "B")):
        ro = t["provenance"].get("calibration", {}).get("rollout") or {}
        print(f"{name}: TestPool rollout final (x, y) error " + " -> ".join(
            f"{ro[k]['final_xy_error_m']:.6g} m" for k in ("before", "after") if k in ro))


if __name__ == "__main__":
    main()
