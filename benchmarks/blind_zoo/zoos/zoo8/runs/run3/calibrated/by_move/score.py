"""Score a calibrated twin of zoo8's reference against the gap robot (the harness's
``calibration_score``): score.py TWIN SECONDS, from the repository root."""
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[8]
sys.path.insert(0, str(ROOT / "benchmarks" / "blind_zoo" / "harness"))
sys.path.insert(0, str(ROOT))
import run as harness  # noqa: E402

res = harness.calibration_score({"twin": sys.argv[1], "seconds": float(sys.argv[2])},
                                ROOT / "benchmarks/blind_zoo/zoos/zoo8/gap_robot.json")
print("| parameter | truth (gap robot) | calibrated | 95 % interval | inside | at bound | identifiable |")
print("|---|---|---|---|---|---|---|")
for r in res["rows"]:
    print(f"| {r['name']} | {r['truth']:.4g} | {r['value']:.4g} | [{r['ci95'][0]:.4g}, "
          f"{r['ci95'][1]:.4g}] | {r['inside']} | {r['at_bound'] or '-'} | {r['identifiable']} |")
print(f"\nInside the 95 % interval, of the identifiable parameters with a true value: "
      f"{res['summary']}.")
