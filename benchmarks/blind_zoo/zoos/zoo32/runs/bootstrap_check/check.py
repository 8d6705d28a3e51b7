"""zoo32, not blind: does the fit's bias show on the fitted twin's own recordings?

``make``: the after_all17 twin with the gap robot's sensing (its motion-capture noise and
encoder counts, read from gap_robot.json: this is a diagnostic made after reading the truth)
-> ``synthetic_twin.json``. ``score``: per parameter, the fit against the truth, the refit on
the synthetic recording against the twin, and the fit with the refit's shift subtracted, as
z-scores (the after_all17 fit's data sd; the corrected one's sd times sqrt 2, for the shift's
own noise).

    .venv/bin/python benchmarks/blind_zoo/zoos/zoo32/runs/bootstrap_check/check.py make
    littledog-mlsim record --out SYNTH --moves-per-type 10 --seed 237 --robot .../synthetic_twin.json --jobs 2
    littledog-mlsim calibrate --data SYNTH --robot .../synthetic_twin.json --servo pd_torque \\
        --params <the 17 of after_all17> --max-evals 400 --out .../refit_twin.json
    .venv/bin/python benchmarks/blind_zoo/zoos/zoo32/runs/bootstrap_check/check.py score
"""
from __future__ import annotations

import json
import math
import sys
from pathlib import Path

HERE = Path(__file__).resolve().parent
ZOO = HERE.parents[1]


def make() -> None:
    t = json.loads((HERE.parent / "after_all17" / "calibrated_twin.json").read_text())
    g = json.loads((ZOO / "gap_robot.json").read_text())
    for k in ("sensor_noise", "mocap_position_std", "mocap_orientation_std", "encoder_resolution"):
        t["robot"][k] = g["robot"][k]
    t["robot"]["name"] = "synthetic-from-all17"
    t["provenance"] = {"note": "diagnostic: after_all17 twin with the gap robot sensing"}
    (HERE / "synthetic_twin.json").write_text(json.dumps(t, indent=1))


def score() -> None:
    from littledog_mlsim.robot.parameters import twin_parameters
    from littledog_mlsim.robot.twin import load_twin

    t = load_twin(HERE / "synthetic_twin.json").robot
    f = load_twin(HERE / "refit_twin.json").robot
    g = load_twin(ZOO / "gap_robot.json").robot
    cal = json.loads((HERE.parent / "after_all17" / "calibrated_twin.json").read_text())
    sd = cal["provenance"]["calibration"]["sd_coordinate_data"]
    ps = {p.name: p for p in twin_parameters(list(sd), t)}
    n = raw_in = cor_in = 0
    print("| parameter | truth | fit | fit / truth | refit / fit | corrected / truth | z fit | z corrected |")
    print("|---|---|---|---|---|---|---|---|")
    for name, s in sd.items():
        p = ps[name]
        xt, xf = p.to_x(p.get(t)), p.to_x(p.get(f))
        truth = (g.ground_friction * g.foot_friction / t.foot_friction
                 if name == "ground_friction" else p.get(g))   # the contact's product
        xg = p.to_x(truth)
        xc = 2 * xt - xf
        if s <= 1e-12:      # a direction the data does not bound (the fit reports it weak)
            print(f"| {name} | {truth:.4g} | {p.get(t):.4g} | | | | unbounded (weak) | |")
            continue
        z1, z2 = (xt - xg) / s, (xc - xg) / (s * math.sqrt(2))
        n += 1
        raw_in += abs(z1) < 1.96
        cor_in += abs(z2) < 1.96
        ratio = (lambda a, b: f"{a / b:.4f}") if p.log else (lambda a, b: f"{a - b:+.4g}")
        print(f"| {name} | {truth:.4g} | {p.get(t):.4g} | {ratio(p.get(t), truth)} | "
              f"{ratio(p.get(f), p.get(t))} | {ratio(p.from_x(xc), truth)} | {z1:.2f} | {z2:.2f} |")
    print(f"\ninside 95 % (|z| < 1.96): the fit {raw_in} of {n}, corrected {cor_in} of {n}")


if __name__ == "__main__":
    {"make": make, "score": score}[sys.argv[1]]()
