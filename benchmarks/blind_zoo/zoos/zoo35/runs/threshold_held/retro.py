"""What the committed one-iteration bootstrap runs would have reported for their torque limits
had a threshold's bias been held (not applied, its square added to the interval's variance;
``littledog_mlsim/robot/twin_bias.py``, step 3), computed from their committed twin files
and scores (not blind: the truths are read). With one iteration the other parameters'
corrections do not depend on the limit's, so the figures are exact for these runs.

    python3 benchmarks/blind_zoo/zoos/zoo35/runs/threshold_held/retro.py > .../retro.md
"""
import json
import math
from pathlib import Path

ZOOS = Path(__file__).resolve().parents[3]
RUNS = ["zoo32/runs/run5_replicates2", "zoo33/runs/run2_replicates2", "zoo33/runs/run4_weighed",
        "zoo34/runs/run3_weighed", "zoo35/runs/run1"]
Z = 1.959964

print("| run | parameter | truth | fit (before the bootstrap) | corrected: inside, width | "
      "held: 95 % interval, inside, width |")
print("|---|---|---|---|---|---|")
for run in RUNS:
    d = ZOOS / run
    twin = json.loads((d / "calibrated_twin.json").read_text())["provenance"]
    rows = {r["name"]: r for r in json.loads((d / "score.json").read_text())["rows"]}
    for name, b in twin["calibration"]["bootstrap"]["params"].items():
        if not name.startswith("torque_limit"):
            continue
        lo, hi = twin["parameters"][name]["ci95"]
        sd = math.sqrt((math.log(hi / lo) / (2 * Z)) ** 2 + b["bias_coordinate"][-1] ** 2)
        fit, truth = b["fitted"], rows[name]["truth"]
        nlo, nhi = fit * math.exp(-Z * sd), fit * math.exp(Z * sd)
        print(f"| {run} | {name} | {truth:.4g} | {fit:.4g} ({100 * (fit / truth - 1):+.1f} %) | "
              f"{rows[name]['inside']}, {hi / lo:.3f} | [{nlo:.4g}, {nhi:.4g}], "
              f"{nlo <= truth <= nhi}, {nhi / nlo:.3f} |")
