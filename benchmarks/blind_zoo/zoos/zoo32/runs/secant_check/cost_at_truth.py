"""zoo32, not blind: is run4's fit (before its bootstrap) at a lower k-step cost than the gap
robot itself, on the same 22 TrainPool moves and weights? (And does it matter how the contact's
friction product is split between the foot and the floor?)

If the gap robot's own parameters (read from gap_robot.json after the truth was read) cost more
than the fit, the 2-4 % left is the estimator's (what the twin's cost prefers on this
recording); if they cost less, the fit stopped short of the optimum.

    OPENBLAS_NUM_THREADS=1 .venv/bin/python benchmarks/blind_zoo/zoos/zoo32/runs/secant_check/cost_at_truth.py REFERENCE
"""
from __future__ import annotations

import json
import sys
from dataclasses import replace
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
ZOO = HERE.parents[1]


def main(ref: str) -> None:
    from littledog_mlsim.data.dataset import load_moves
    from littledog_mlsim.robot import baseline as bl
    from littledog_mlsim.robot import twin_fit as tf
    from littledog_mlsim.robot.parameters import twin_parameters
    from littledog_mlsim.robot.twin import load_twin

    twin = load_twin(HERE.parent / "run4_bootstrap2" / "calibrated_twin.json")
    cal = twin.provenance["calibration"]
    boot = cal["bootstrap"]["params"]
    fit = replace(twin.robot, sensor_noise=False)
    params = twin_parameters(list(boot), fit)
    for p in params:
        fit = p.set(fit, boot[p.name]["fitted"])
    corrected = replace(twin.robot, sensor_noise=False)
    gap = replace(load_twin(ZOO / "gap_robot.json").robot, sensor_noise=False)
    train = [r for r in load_moves(ref, "train") if r.name in set(cal["train_moves"])]
    opts = tf.CalibrationOptions(initial_state="smoothed")
    out = {}
    with bl.move_pool(train, 2) as pool:
        def raw(c):
            return tf.twin_residuals(pool, c, opts.stride, opts.horizons, opts.initial_state)
        r_fit = raw(fit)
        scale = tf._rms_scale(r_fit)
        split = replace(gap, foot_friction=fit.foot_friction,
                        ground_friction=gap.foot_friction * gap.ground_friction / fit.foot_friction)
        for name, c in (("fit (before the bootstrap)", fit), ("bootstrap-corrected", corrected),
                        ("the gap robot", gap),
                        ("the gap robot, its friction product split as the twin's", split)):
            w = tf._weighted(raw(c), scale)
            out[name] = 0.5 * float(w @ w)
            print(f"{name}: k-step cost {out[name]:.2f}", flush=True)
    (HERE / "cost_at_truth.json").write_text(json.dumps(out, indent=1))


if __name__ == "__main__":
    main(sys.argv[1])
