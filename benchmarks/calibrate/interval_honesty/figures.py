"""Two figures the README quotes, read from committed files.

    .venv/bin/python benchmarks/calibrate/interval_honesty/figures.py

1. The contact friction's error (the calibrated product of the foot's and the ground's
   friction against the gap robot's) over the blind zoos zoo40-zoo57 whose run1 has a
   ``score.json``, and its median.
2. zoo56 run1's bootstrap: per parameter, the data sd in the fit's coordinate over the refits'
   spread (``sd_coordinate_data`` / ``bootstrap.params[name].sd_refits_coordinate``).
"""
from __future__ import annotations

import json
import statistics
from pathlib import Path

ZOOS = Path(__file__).resolve().parents[2] / "blind_zoo" / "zoos"


def main() -> int:
    errors = {}
    for z in range(40, 58):
        score = ZOOS / f"zoo{z}" / "runs" / "run1" / "score.json"
        if not score.is_file():
            continue
        rows = [r for r in json.loads(score.read_text())["rows"]
                if r["scored_as"] == "contact_friction"]
        if rows:
            errors[z] = 100 * (rows[0]["value"] / rows[0]["truth"] - 1)
    print("contact friction error [%] by zoo (run1): "
          + ", ".join(f"zoo{z} {e:+.1f}" for z, e in errors.items()))
    print(f"median over {len(errors)} zoos: {statistics.median(errors.values()):+.1f} %")
    cal = json.loads((ZOOS / "zoo56/runs/run1/calibrated_twin.json").read_text())
    cal = cal["provenance"]["calibration"]
    ratios = {n: cal["sd_coordinate_data"][n] / b["sd_refits_coordinate"]
              for n, b in cal["bootstrap"]["params"].items()
              if b.get("sd_refits_coordinate") and cal["sd_coordinate_data"].get(n)}
    print("zoo56 run1, data sd / refits' spread: "
          + ", ".join(f"{n} {r:.0f}" for n, r in ratios.items()))
    print(f"range {min(ratios.values()):.1f} to {max(ratios.values()):.0f}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
