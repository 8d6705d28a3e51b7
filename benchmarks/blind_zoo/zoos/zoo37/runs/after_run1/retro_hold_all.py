"""What the committed one-iteration bootstrap runs would have reported had every parameter's
one-point bias been held, as a torque limit's is (``littledog_mlsim/robot/twin_bias.py``,
step 3): the fit's value stands and the measured bias's square joins the interval's variance.
Computed from the committed twin files and scores (not blind: the truths are read).

The as-run interval (after the bootstrap) gives the sd in the fit's coordinate (a log
parameter's interval is a factor; the half-width on the side away from a bound); the held
interval is the fit before the bootstrap +- 1.96 sqrt(sd^2 + bias^2), cut to the parameter's
bounds. A threshold, already held as run, keeps its interval. With one iteration the
corrections do not depend on each other, so the figures are what the code would report.

    .venv/bin/python benchmarks/blind_zoo/zoos/zoo37/runs/after_run1/retro_hold_all.py \
        > benchmarks/blind_zoo/zoos/zoo37/runs/after_run1/retro_hold_all.md
"""
import json
import math
import statistics
from pathlib import Path

from littledog_mlsim.robot.parameters import TWIN_PARAMETERS

ZOOS = Path(__file__).resolve().parents[3]
BLIND = {"zoo34/runs/run1", "zoo35/runs/run1", "zoo36/runs/run1", "zoo37/runs/run1"}
Z = 1.959964


def runs():
    for d in sorted(ZOOS.glob("zoo*/runs/*")):
        twin, score = d / "calibrated_twin.json", d / "score.json"
        if not (twin.exists() and score.exists()):
            continue
        cal = json.loads(twin.read_text())["provenance"]["calibration"]
        b = cal.get("bootstrap") or {}
        if b.get("iterations") == 1:
            yield d.relative_to(ZOOS).as_posix(), b, json.loads(score.read_text())["rows"]


def held(name, b, row):
    """(lo, hi) held, in the score's units, or None where the run did not apply the bias."""
    if not b.get("applied") or row["ci95"] is None or None in row["ci95"]:
        return None
    par = TWIN_PARAMETERS[name]
    k = row["value"] / b["corrected"]           # the score's units (a friction's product)
    lo, hi = (c / k for c in row["ci95"])
    v, fit, bias = b["corrected"], b["fitted"], b["bias_coordinate"][-1]
    plo, phi = par.bounds
    if par.log:
        half = max(math.log(hi / v) if hi < phi else 0.0, math.log(v / lo) if lo > plo else 0.0)
        sd = math.sqrt((half / Z) ** 2 + bias ** 2)
        nlo, nhi = fit * math.exp(-Z * sd), fit * math.exp(Z * sd)
    else:
        half = max(hi - v if hi < phi else 0.0, v - lo if lo > plo else 0.0)
        sd = math.sqrt((half / Z) ** 2 + bias ** 2)
        nlo, nhi = fit - Z * sd, fit + Z * sd
    return max(nlo, plo) * k, min(nhi, phi) * k


def main():
    print("| run | blind | as run: inside, median width | every bias held: inside, median width | "
          "moved in / out |")
    print("|---|---|---|---|---|")
    total = [0, 0, 0]
    detail = []
    for run, b, rows in runs():
        ins_run = ins_held = n = 0
        w_run, w_held, moved = [], [], []
        for row in rows:
            if not row.get("identifiable") or row.get("at_bound") or row["ci95"] is None:
                continue
            n += 1
            ins_run += bool(row["inside"])
            lo, hi = row["ci95"]
            w_run.append(hi / lo if lo > 0 else math.inf)
            h = held(row["name"], b["params"].get(row["name"], {}), row)
            if h is None:
                ins, w = bool(row["inside"]), w_run[-1]
            else:
                ins = h[0] <= row["truth"] <= h[1]
                w = h[1] / h[0] if h[0] > 0 else math.inf
                if ins != bool(row["inside"]):
                    moved.append(f"{row['name']} {'in' if ins else 'out'}")
                detail.append((run, row["name"], row["truth"], b["params"][row["name"]]["fitted"],
                               row["inside"], h, ins))
            ins_held += ins
            w_held.append(w)
        total[0] += n
        total[1] += ins_run
        total[2] += ins_held
        print(f"| {run} | {'yes' if run in BLIND else 'no'} | {ins_run} of {n}, "
              f"{statistics.median(w_run):.3f} | {ins_held} of {n}, {statistics.median(w_held):.3f} | "
              f"{', '.join(moved) or '-'} |")
    print(f"\nIn all: {total[1]} of {total[0]} inside as run, {total[2]} of {total[0]} with every "
          "bias held.\n")
    print("| run | parameter | truth | fit | inside as run | held interval | inside held |")
    print("|---|---|---|---|---|---|---|")
    for run, name, truth, fit, ins, h, ins_h in detail:
        print(f"| {run} | {name} | {truth:.4g} | {fit:.4g} | {ins} | [{h[0]:.4g}, {h[1]:.4g}] | {ins_h} |")


if __name__ == "__main__":
    main()
