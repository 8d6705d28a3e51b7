"""The seconds of each report of a ``run.py`` comparison (the whole run and its rollout route),
and whether the two reports are the same with the durations and the model's path (each run
writes its own) left out.

    python benchmarks/learned_route/speed/extract.py WORK_A WORK_B ...
"""
from __future__ import annotations

import json
import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
from run import differences, strip_durations  # noqa: E402


def main(argv=None) -> int:
    for work in map(Path, argv or sys.argv[1:]):
        reports = {n: json.loads((work / n / "report.json").read_text())
                   for n in ("before", "after")}
        for n, r in reports.items():
            print(f"{work}/{n}: seconds {r['seconds']:.1f}, rollout route "
                  f"{r['rollout_route']['seconds']:.1f}")
        a, b = (strip_durations({k: v for k, v in r.items() if k != "model"})
                for r in reports.values())
        diff = differences(a, b)
        print(f"{work}: the same without durations and the model's path: {not diff}"
              + "".join(f"\n  {d}" for d in diff))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
