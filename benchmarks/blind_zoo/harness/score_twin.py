"""Score a calibrated twin file against a gap robot, as the harness's ``calibration`` score
does, and print one line per parameter, the score and the intervals' median width.

    .venv/bin/python benchmarks/blind_zoo/harness/score_twin.py TWIN.json GAP_ROBOT.json [--json OUT]

Width: the interval's upper end over its lower end (a scale; none for an interval through 0).
"""
from __future__ import annotations

import argparse
import json
import statistics
import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[3]))

from benchmarks.blind_zoo.harness.run import calibration_score  # noqa: E402


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("twin", type=Path)
    ap.add_argument("robot", type=Path, help="the gap robot's twin file (the truth)")
    ap.add_argument("--json", type=Path, default=None, help="also write the score here")
    a = ap.parse_args(argv)
    doc = calibration_score({"twin": str(a.twin), "seconds": None}, a.robot)
    widths = []
    for r in doc["rows"]:
        lo, hi = r["ci95"]
        w = hi / lo if lo is not None and hi is not None and lo > 0 else None
        r["width"] = w
        if w is not None:
            widths.append(w)
        print(f"{r['name']:<18} as {r['scored_as']:<17} value {r['value']:<9.4g} "
              f"95 % [{'-' if lo is None else f'{lo:.4g}'}, {'-' if hi is None else f'{hi:.4g}'}]"
              f"  truth {'-' if r['truth'] is None else format(r['truth'], '.4g')}"
              f"  inside {r['inside']}  identifiable {r['identifiable']}"
              f"  width {'-' if w is None else f'{w:.3f}'}")
    doc["median_width"] = statistics.median(widths) if widths else None
    print(f"inside their intervals: {doc['summary']} identifiable; median width "
          f"{doc['median_width'] if doc['median_width'] is None else round(doc['median_width'], 3)}")
    if a.json is not None:
        a.json.write_text(json.dumps(doc, indent=1, default=str) + "\n")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
