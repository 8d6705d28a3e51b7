"""The score test of a torque limit not fitted, read by secants of several lengths.

At a calibration's fitted optimum (before its bootstrap correction: the values the score test
saw), every named threshold is lowered by each step (e-folds) and its secant column tested as
``twin_fit.missing_parameters`` tests the one of 2 x the consider spread: statistic, p-value,
suggested value and cost share. The fitted columns are the Jacobian at that optimum; the
weights the residual RMS there.

    OPENBLAS_NUM_THREADS=1 .venv/bin/python benchmarks/blind_zoo/zoos/zoo37/runs/after_run1/threshold_profile.py \
        TWIN.json DATA OUT.json [torque_limit_hip_pitch,torque_limit_hip_roll] [0.05,0.1,0.15,0.2,0.3]
"""
from __future__ import annotations

import json
import sys
import time
from dataclasses import replace

import numpy as np

from littledog_mlsim.data.dataset import load_moves
from littledog_mlsim.robot import baseline as bl
from littledog_mlsim.robot import twin_fit as tf
from littledog_mlsim.robot.parameters import TWIN_PARAMETERS, twin_parameters
from littledog_mlsim.robot.twin import load_twin


def main() -> None:
    twin_path, data, out = sys.argv[1:4]
    names = (sys.argv[4] if len(sys.argv) > 4 else
             "torque_limit_hip_pitch,torque_limit_hip_roll").split(",")
    steps = [float(s) for s in (sys.argv[5] if len(sys.argv) > 5 else
                                "0.05,0.1,0.15,0.2,0.3").split(",")]
    twin = load_twin(twin_path)
    cal = twin.provenance["calibration"]
    settings = cal["settings"]
    fitted = {n: p["fitted"] for n, p in (cal.get("bootstrap") or {}).get("params", {}).items()}
    config = replace(twin.robot, sensor_noise=False)
    params = twin_parameters(list(twin.provenance["parameters"]), config)
    for p in params:                       # back to the fit's optimum (before the bootstrap)
        if p.name in fitted:
            config = p.set(config, fitted[p.name])
    opts = tf.CalibrationOptions(params=tuple(p.name for p in params), jobs=1,
                                 horizons=tuple(settings["horizons"]), stride=settings["stride"],
                                 initial_state=settings["initial_state"], max_evals=10_000)
    train = bl.first_per_type(load_moves(data, "train"), 2)
    t0 = time.perf_counter()
    with bl.move_pool(train, 1, None) as pool:
        prob = tf._Problem(pool, config, params, opts, lambda s: None)
        x = np.array([p.to_x(p.get(config)) for p in params])
        prob.scale = tf._rms_scale(prob.raw(x))
        r = prob.fun(x)
        J = prob.jac(x)
        rows = []
        for name in names:
            par = TWIN_PARAMETERS[name]
            value = par.get(config)
            xc = par.to_x(value)
            for s in steps:
                raw = tf.twin_residuals(pool, par.set(config, par.from_x(xc - s)), opts.stride,
                                        opts.horizons, opts.initial_state)
                w = tf._weighted(raw, prob.scale)
                col = (w - r) / (-s)
                m = tf.missing_parameters(prob, x, J, r, columns=[(par, value, col)])
                row = {"name": name, "step": -s, "lowered_to": par.from_x(xc - s),
                       "cost_lowered": 0.5 * float(w @ w), "cost_fit": 0.5 * float(r @ r)}
                if m:
                    row.update({k: m[0][k] for k in ("suggested", "statistic", "p", "cost_share")})
                rows.append(row)
                print(json.dumps(row), flush=True)
    json.dump({"twin": twin_path, "steps": steps, "rows": rows,
               "seconds": time.perf_counter() - t0}, open(out, "w"), indent=1)


if __name__ == "__main__":
    main()
