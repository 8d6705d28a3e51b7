"""zoo32, not blind: the estimator's own spread and bias at the gap robot itself.

The gap robot (read from gap_robot.json, after its truth was read) records the 22 TrainPool
moves run4 fitted again, with their commands and starts (``twin_bias.synthetic_recordings``),
with R other noise seeds; each is fitted as run4's last round was (the 15 parameters, from
run4's fit before its bootstrap, no score test). Per parameter: the mean fit against the truth
(the estimator's bias at the truth), the spread of the R fits, and the data sd the calibration
reports (run4's ``sd_coordinate_data``).

    OPENBLAS_NUM_THREADS=1 .venv/bin/python benchmarks/blind_zoo/zoos/zoo32/runs/secant_check/spread.py REFERENCE [R]

Another zoo's run: ``spread.py REFERENCE R RUN_DIR GAP_ROBOT OUT_JSON``.
"""
from __future__ import annotations

import json
import sys
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent


def main(ref: str, reps: int, run: str | None = None, gap_file: str | None = None,
         out_json: str | None = None) -> None:
    from littledog_mlsim.robot import twin_fit as tf
    from littledog_mlsim.robot.twin_bias import synthetic_recordings
    from run4 import run4_case

    case = run4_case(ref, run, gap_file)
    cal, boot, params, gap, train = case.cal, case.boot, case.params, case.gap, case.train
    start = case.fit
    opts = tf.CalibrationOptions(params=tuple(boot), servo="keep", test_missing=False,
                                 initial_state="smoothed", moves_per_type=None,
                                 max_evals=tf.ROUND_EVALS_PER_COLUMN * (2 * len(params) + 1))
    fits = []
    for rep in range(reps):
        synth = synthetic_recordings(train, gap, 100 + rep)
        rc = tf.calibrate_twin(synth, [], start, opts, lambda s: None)
        fits.append({p.name: p.get(rc.config) for p in params})
        print(f"replicate {rep}: {rc.report.get('stop')}", flush=True)
    out = {"replicates": fits, "rows": []}
    print("| parameter | truth | mean fit vs truth | spread of the fits (sd) | reported data sd | "
          "the recording's fit vs truth |")
    print("|---|---|---|---|---|---|")
    for p in params:
        truth = (gap.ground_friction * gap.foot_friction / start.foot_friction
                 if p.name == "ground_friction" else p.get(gap))
        xs = np.array([p.to_x(f[p.name]) for f in fits])
        xt = p.to_x(truth)
        unit = "%" if p.log else "coord"
        k = 100 if p.log else 1
        row = {"name": p.name, "truth": truth, "mean_minus_truth": float(xs.mean() - xt),
               "sd_fits": float(xs.std(ddof=1)) if reps > 1 else None,
               "sd_data": cal["sd_coordinate_data"][p.name],
               "recording_minus_truth": float(p.to_x(boot[p.name]["fitted"]) - xt)}
        out["rows"].append(row)
        sdf = "" if row["sd_fits"] is None else f"{k * row['sd_fits']:.2f}"
        print(f"| {p.name} | {truth:.4g} | {k * row['mean_minus_truth']:+.2f} {unit} | {sdf} | "
              f"{k * row['sd_data']:.2f} | {k * row['recording_minus_truth']:+.2f} |", flush=True)
    Path(out_json or HERE / "spread.json").write_text(json.dumps(out, indent=1))


if __name__ == "__main__":
    main(sys.argv[1], int(sys.argv[2]) if len(sys.argv) > 2 else 4, *sys.argv[3:6])
