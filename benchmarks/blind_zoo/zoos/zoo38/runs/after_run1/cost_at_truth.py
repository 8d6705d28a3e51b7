"""The calibration's k-step cost at its own optimum against the cost at the gap robot itself.

At the fit's optimum (before the bootstrap correction) the fit's weights are fixed (the
residual RMS there), and the same k-step residual is evaluated on the same fitted moves at:
the optimum; the calibrated twin (after the bootstrap); the gap robot (its own configuration,
without sensor noise); the optimum with the fitted parameters set to the gap robot's values
(the parameters not fitted left at the twin's); and the optimum with each parameter not fitted
set to the gap robot's value alone. A gap robot whose cost is below the optimum's says the fit
stopped in another basin (a search problem); one above it says the objective itself prefers
the wrong robot (a bias no search removes).

    OPENBLAS_NUM_THREADS=1 .venv/bin/python benchmarks/blind_zoo/zoos/zoo38/runs/after_run1/cost_at_truth.py \
        TWIN.json GAP_ROBOT.json DATA OUT.json
"""
from __future__ import annotations

import json
import sys
import time
from pathlib import Path

import numpy as np

from littledog_mlsim.data.dataset import load_moves
from littledog_mlsim.robot import baseline as bl
from littledog_mlsim.robot import twin_fit as tf
from littledog_mlsim.robot.parameters import TWIN_PARAMETERS, twin_parameters

sys.path.insert(0, str(Path(__file__).resolve().parents[4] / "harness"))
from fit_points import fit_points  # noqa: E402


def main() -> None:
    twin_path, gap_path, data, out = sys.argv[1:5]
    pts = fit_points(twin_path, gap_path)
    settings, final, config, gap = pts.settings, pts.final, pts.fit, pts.gap
    params = twin_parameters(pts.names, final)
    opts = tf.CalibrationOptions(params=tuple(p.name for p in params), jobs=1,
                                 horizons=tuple(settings["horizons"]), stride=settings["stride"],
                                 initial_state=settings["initial_state"], max_evals=10_000)
    train = bl.first_per_type(load_moves(data, "train"), 2)
    t0 = time.perf_counter()
    rows = []
    with bl.move_pool(train, 1, None) as pool:
        prob = tf._Problem(pool, config, params, opts, lambda s: None)
        x = np.array([p.to_x(p.get(config)) for p in params])
        prob.scale = tf._rms_scale(prob.raw(x))

        def cost(label: str, robot) -> None:
            raw = tf.twin_residuals(pool, robot, opts.stride, opts.horizons, opts.initial_state)
            w = tf._weighted(raw, prob.scale)
            row = {"at": label, "cost": 0.5 * float(w @ w),
                   "diverged": int(np.sum(w == tf.DIVERGED_RESIDUAL))}
            rows.append(row)
            print(json.dumps(row), flush=True)

        cost("fit optimum", config)
        cost("calibrated twin (after the bootstrap)", final)
        cost("gap robot", gap)
        truth_fitted = config
        for p in params:
            try:
                truth_fitted = p.set(truth_fitted, p.get(gap))
            except ValueError:
                pass
        cost("optimum, fitted parameters at the gap robot's values", truth_fitted)
        fitted_names = {p.name for p in params}
        for par in TWIN_PARAMETERS.values():
            if par.name in fitted_names or (par.servo is not None and par.servo != config.servo):
                continue
            try:
                v_gap, v_now = par.get(gap), par.get(config)
            except ValueError:
                continue
            if abs(v_gap - v_now) <= 1e-9 * max(abs(v_now), 1.0):
                continue
            cost(f"optimum, {par.name} alone at the gap robot's {v_gap:.4g} (twin {v_now:.4g})",
                 par.set(config, v_gap))
    json.dump({"twin": twin_path, "gap_robot": gap_path, "rows": rows,
               "seconds": time.perf_counter() - t0}, open(out, "w"), indent=1)


if __name__ == "__main__":
    main()
