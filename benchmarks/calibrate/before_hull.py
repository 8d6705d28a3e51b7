"""Score a calibrated twin with the intervals it had before the second starts' hull
(`calibrate --split-starts`, decision 059), reconstructed from its own report, against the gap
robot: how much of a run's coverage the widening over tied minima made.

    OPENBLAS_NUM_THREADS=1 .venv/bin/python benchmarks/calibrate/before_hull.py \\
        benchmarks/blind_zoo/zoos/zoo53/runs/run1/calibrated_twin.json \\
        benchmarks/blind_zoo/zoos/zoo53/gap_robot.json

A parameter the bootstrap corrected or widened gets the interval `twin_bias.bias_corrected`
gave it: its corrected value (the fit's, where the bias was held) +- 1.96 of the square root of
the fit's `sd_coordinate` squared plus the bias's `sd_bias_coordinate` squared, in the fit's
coordinate. Any other keeps the kept start's own interval from `split_starts.candidates` (the
fit's, before a bootstrap or continuation), and the printout names it. The scorer is the
harness's (`harness/score_twin.py`), run on a copy of the twin with those intervals.
"""
from __future__ import annotations

import argparse
import json
import math
import sys
import tempfile
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[2]))

from benchmarks.blind_zoo.harness.run import calibration_score  # noqa: E402
from littledog_mlsim.robot import twin_fit  # noqa: E402
from littledog_mlsim.robot.parameters import TWIN_PARAMETERS  # noqa: E402


def before_hull(doc: dict) -> tuple[dict, list[str]]:
    """The twin file's JSON ``doc`` with every parameter's interval as before the hull, and the
    parameters whose interval is the kept start's own (not recomputed by a bootstrap)."""
    cal = doc["provenance"]["calibration"]
    split = cal["split_starts"]
    kept = {p["name"]: p for p in next(c for c in split["candidates"]
                                       if c["start"] == split["chosen"])["params"]}
    boot = (cal.get("bootstrap") or {}).get("params") or {}
    own = []
    for name, p in doc["provenance"]["parameters"].items():
        b = boot.get(name)
        if b and (b["applied"] or b["widened_only"]):
            par = TWIN_PARAMETERS[name]
            sd = math.hypot(cal["sd_coordinate"][name], b["sd_bias_coordinate"])
            x = par.to_x(b["corrected"] if b["applied"] else b["fitted"])
            p["ci95"] = list(twin_fit._interval(par, x, sd))
        else:
            p["ci95"] = list(kept[name]["ci95"])
            own.append(name)
    return doc, own


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("twin", type=Path)
    ap.add_argument("robot", type=Path, help="the gap robot's twin file (the truth)")
    a = ap.parse_args(argv)
    doc, own = before_hull(json.loads(a.twin.read_text()))
    with tempfile.TemporaryDirectory() as tmp:
        path = Path(tmp) / "before_hull.json"
        path.write_text(json.dumps(doc))
        score = calibration_score({"twin": str(path), "seconds": None}, a.robot)
    for r in score["rows"]:
        lo, hi = r["ci95"]
        print(f"{r['name']:<18} as {r['scored_as']:<17} value {r['value']:<9.4g} "
              f"95 % before the hull [{lo:.4g}, {hi:.4g}]  truth {r['truth']:.4g}  "
              f"inside {r['inside']}" + ("  (the kept start's own interval)"
                                         if r["name"] in own else ""))
    print(f"inside their intervals before the hull: {score['summary']} identifiable")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
