"""Exit 0 when two calibration.json files (the harness's --calibrate-only) hold the same twin: every
parameter's value and interval and the TestPool rollout after the fit equal.

    python3 same_twin.py A/calibration.json B/calibration.json
"""
import json, sys
a = json.load(open(sys.argv[1]))["calibration"]
b = json.load(open(sys.argv[2]))["calibration"]
ra = [(r["name"], r["value"], r["ci95"]) for r in a["rows"]]
rb = [(r["name"], r["value"], r["ci95"]) for r in b["rows"]]
same = ra == rb and a["rollout"]["after"]["final_xy_error_m"] == b["rollout"]["after"]["final_xy_error_m"]
for x, y in zip(ra, rb):
    print(x[0], x[1], y[1], "same" if x == y else "DIFFERENT")
print("rollout after", a["rollout"]["after"]["final_xy_error_m"], b["rollout"]["after"]["final_xy_error_m"])
print("SAME TWIN" if same else "NOT THE SAME TWIN")
sys.exit(0 if same else 1)
