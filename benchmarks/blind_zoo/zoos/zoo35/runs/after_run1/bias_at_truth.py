"""zoo35, not blind: the fit's bias at the gap robot itself, against the bias the bootstrap
measured at the twin.

run1's bootstrap refitted recordings of the fitted twin and found the hip pitch's torque limit
8 % low there (two noise seeds, sd 0.8 %); it added that back, and the limit ended 7.5 % above
the truth, where the fit before the bootstrap was 0.8 % below it. Here the gap robot records the
22 TrainPool moves run1 fitted (their commands and starts, ``twin_bias.synthetic_recordings``),
with R noise seeds, and each is fitted as run1's bootstrap refits were (the 16 parameters, from
the fit before the bootstrap, no score test, weighed at the gap robot's own mass): per
parameter, the mean fit against the truth (the estimator's bias at the truth) next to the bias
the bootstrap measured at the twin.

    OPENBLAS_NUM_THREADS=1 .venv/bin/python benchmarks/blind_zoo/zoos/zoo35/runs/after_run1/bias_at_truth.py \
        REFERENCE [R] [OUT_JSON]

REFERENCE: the reference dataset run1 calibrated on (the harness's WORK/reference; seed 267).
Another zoo's run: ``bias_at_truth.py REFERENCE R OUT_JSON RUN_DIR GAP_ROBOT``; other horizons
than the calibration's (1, 10): ``BIAS_HORIZONS=10,25``.
"""
from __future__ import annotations

import json
import sys
import time
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
ZOO = HERE.parents[1]


def main(ref: str, reps: int = 2, out_json: str | None = None, run: str | None = None,
         gap_file: str | None = None) -> int:
    from littledog_mlsim.robot import twin_fit as tf
    from littledog_mlsim.robot.parameters import total_mass
    from littledog_mlsim.robot.twin_bias import synthetic_recordings
    from run4 import run4_case       # zoo32's secant_check: a run's fit before its bootstrap

    case = run4_case(ref, run or HERE.parent / "run1", gap_file or ZOO / "gap_robot.json")
    boot, params, fit, gap, train = case.boot, case.params, case.fit, case.gap, case.train
    import os
    horizons = tuple(int(h) for h in os.environ.get("BIAS_HORIZONS", "1,10").split(","))
    opts = tf.CalibrationOptions(params=tuple(boot), servo="keep", test_missing=False,
                                 horizons=horizons,
                                 initial_state="smoothed", moves_per_type=None,
                                 max_evals=tf.ROUND_EVALS_PER_COLUMN * (2 * len(params) + 1),
                                 weighed_mass=total_mass(gap), weighed_mass_sd=0.01)
    fits, walls = [], []
    for rep in range(reps):
        t0 = time.perf_counter()
        synth = synthetic_recordings(train, gap, 300 + rep)
        rc = tf.calibrate_twin(synth, [], fit, opts, lambda s: None)
        fits.append([p.to_x(p.get(rc.config)) for p in params])
        walls.append(round(time.perf_counter() - t0, 1))
        print(f"refit {rep + 1}: {walls[-1]} s, {rc.report.get('stop')}", flush=True)
    fits = np.array(fits)
    truth = np.array([p.to_x(p.get(gap)) for p in params])
    rows = {}
    for k, p in enumerate(params):
        b = boot[p.name]
        rows[p.name] = {"truth": p.get(gap), "fit_before_bootstrap": b["fitted"],
                        "bias_at_truth_coordinate": float(fits[:, k].mean() - truth[k]),
                        "spread_at_truth_coordinate": (float(fits[:, k].std(ddof=1))
                                                       if reps > 1 else None),
                        "bias_at_twin_coordinate": b["bias_coordinate"][-1],
                        "log": p.log}
        print(f"{p.name:24s} bias at the truth {rows[p.name]['bias_at_truth_coordinate']:+.4f}"
              f"  at the twin {b['bias_coordinate'][-1]:+.4f}"
              + ("  (e-folds)" if p.log else ""))
    doc = {"command": " ".join(sys.argv), "horizons": list(horizons), "reference": str(ref),
           "replicates": reps,
           "walls_s": walls, "params": rows}
    if out_json:
        Path(out_json).write_text(json.dumps(doc, indent=1) + "\n")
    return 0


if __name__ == "__main__":
    sys.path.insert(0, str(HERE.parents[4]))
    sys.path.insert(0, str(ZOO.parent / "zoo32" / "runs" / "secant_check"))
    sys.exit(main(sys.argv[1], int(sys.argv[2]) if len(sys.argv) > 2 else 2,
                  sys.argv[3] if len(sys.argv) > 3 else None,
                  sys.argv[4] if len(sys.argv) > 4 else None,
                  sys.argv[5] if len(sys.argv) > 5 else None))
