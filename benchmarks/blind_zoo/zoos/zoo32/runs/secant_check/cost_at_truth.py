"""zoo32, not blind: is run4's fit (before its bootstrap) at a lower k-step cost than the gap
robot itself, on the same 22 TrainPool moves and weights? (And does it matter how the contact's
friction product is split between the foot and the floor?)

If the gap robot's own parameters (read from gap_robot.json after the truth was read) cost more
than the fit, the 2-4 % left is the estimator's (what the twin's cost prefers on this
recording); if they cost less, the fit stopped short of the optimum.

    OPENBLAS_NUM_THREADS=1 .venv/bin/python benchmarks/blind_zoo/zoos/zoo32/runs/secant_check/cost_at_truth.py REFERENCE

Another zoo's run: ``cost_at_truth.py REFERENCE RUN_DIR GAP_ROBOT OUT_JSON``.
"""
from __future__ import annotations

import json
import sys
from dataclasses import replace
from pathlib import Path


HERE = Path(__file__).resolve().parent


def main(ref: str, run: str | None = None, gap_file: str | None = None,
         out_json: str | None = None) -> None:
    from littledog_mlsim.robot import baseline as bl
    from littledog_mlsim.robot import twin_fit as tf
    from run4 import run4_case

    case = run4_case(ref, run, gap_file)
    train = case.train
    fit = replace(case.fit, sensor_noise=False)
    corrected = replace(case.twin.robot, sensor_noise=False)
    gap = replace(case.gap, sensor_noise=False)
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
    Path(out_json or HERE / "cost_at_truth.json").write_text(json.dumps(out, indent=1))


if __name__ == "__main__":
    main(*sys.argv[1:5])
