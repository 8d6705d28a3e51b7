"""Where the calibration's k-step cost is low around zoo38's fit: three probes.

All costs use the residuals of the fit (the calibration's own moves, horizons, stride and
starting states) weighted by their RMS at the fit's optimum (before the bootstrap), so that
the optimum's cost is half the number of residuals and every row compares with it.

- ``each``: the optimum with each fitted parameter alone moved to the calibrated twin's value
  (the bootstrap's correction, one parameter at a time).
- ``line``: the cost along the straight line, in the fit's coordinates, from the optimum
  (t = 0) to the gap robot's values of the fitted parameters (t = 1; the parameters not fitted
  stay at the twin's).
- ``starts``: a least-squares fit of the same parameters, with those weights held, from the
  starting robot (``nominal`` in the torque-mode PD structure) and from ``K`` draws around it
  (each coordinate with the consider analysis's a-priori sd at ``SPREAD``; seed 0), ``ITERS``
  Jacobians each; the cost reached and every parameter's error against the gap robot.
- ``limit``: the same fit with one parameter not fitted (``NAME``) added, from the optimum
  with that parameter lowered to each ``FACTOR`` of its value.

    OPENBLAS_NUM_THREADS=1 .venv/bin/python benchmarks/blind_zoo/zoos/zoo38/runs/after_run1/basin.py \
        TWIN.json GAP_ROBOT.json DATA OUT.json line 0,0.2,0.4,0.6,0.8,1
    ... each
    ... starts K SPREAD ITERS
    ... limit NAME FACTOR[,FACTOR...] ITERS
"""
from __future__ import annotations

import json
import sys
import time
from dataclasses import replace
from pathlib import Path

import numpy as np

from littledog_mlsim.data.dataset import load_moves
from littledog_mlsim.robot import baseline as bl
from littledog_mlsim.robot import twin_fit as tf
from littledog_mlsim.robot.config import robot_config
from littledog_mlsim.robot.parameters import twin_parameters

sys.path.insert(0, str(Path(__file__).resolve().parents[4] / "harness"))
from fit_points import fit_points  # noqa: E402


def _errors(params, x, gap) -> dict[str, float]:
    out = {}
    for p, xi in zip(params, x):
        v, g = p.from_x(float(xi)), p.get(gap)
        out[p.name] = round(v / g - 1.0, 4)
    return out


def main() -> None:
    twin_path, gap_path, data, out, mode, *args = sys.argv[1:]
    pts = fit_points(twin_path, gap_path)
    settings, final, config, gap = pts.settings, pts.final, pts.fit, pts.gap
    names = list(pts.names)
    if mode == "limit":
        names = names + [args[0]]
    params = twin_parameters(names, config)
    opts = tf.CalibrationOptions(params=tuple(names), jobs=2,
                                 horizons=tuple(settings["horizons"]), stride=settings["stride"],
                                 initial_state=settings["initial_state"], max_evals=100_000)
    train = bl.first_per_type(load_moves(data, "train"), 2)
    rows: list[dict] = []

    def row(d: dict) -> None:
        rows.append(d)
        print(json.dumps(d), flush=True)

    t0 = time.perf_counter()
    with bl.move_pool(train, 2, None) as pool:
        prob = tf._Problem(pool, config, params, opts, lambda s: None)
        x_fit = np.array([p.to_x(p.get(config)) for p in params])
        prob.scale = tf._rms_scale(prob.raw(x_fit))

        def cost(x: np.ndarray) -> float:
            return 0.5 * float(np.sum(prob.fun(np.clip(x, prob.lo, prob.hi)) ** 2))

        row({"at": "fit optimum", "cost": cost(x_fit)})
        if mode == "each":
            for k, p in enumerate(params):
                x = x_fit.copy()
                x[k] = p.to_x(p.get(final))
                if x[k] != x_fit[k]:
                    row({"param": p.name, "fit": p.get(config), "corrected": p.get(final),
                         "cost": cost(x)})
        elif mode == "line":
            x_gap = np.array([p.to_x(p.get(gap)) for p in params])
            for t in (float(s) for s in args[0].split(",")):
                row({"t": t, "cost": cost(x_fit + t * (x_gap - x_fit))})
        elif mode == "starts":
            k, spread, iters = int(args[0]), float(args[1]), int(args[2])
            nominal = replace(tf.with_servo(robot_config("nominal"), "pd_torque"),
                              sensor_noise=False)
            x_nom = np.array([p.to_x(min(max(p.get(nominal), p.bounds[0]), p.bounds[1]))
                              for p in params])
            sd = np.array([tf.consider_sd(p, p.get(nominal), spread) for p in params])
            rng = np.random.default_rng(0)
            starts = [("nominal", x_nom)] + [
                (f"draw {j}", x_nom + sd * rng.standard_normal(len(params))) for j in range(k)]
            for label, x0 in starts:
                x0 = np.clip(x0, prob.lo, prob.hi)
                c0, t1 = cost(x0), time.perf_counter()
                x, stop = tf._least_squares(prob, x0, max_nfev=iters)
                row({"start": label, "cost_start": c0, "cost_end": cost(x), "stop": stop,
                     "seconds": round(time.perf_counter() - t1, 1),
                     "error_against_gap_robot": _errors(params, x, gap)})
        elif mode == "limit":
            factors, iters = [float(f) for f in args[1].split(",")], int(args[2])
            lim = params[-1]
            for f in factors:
                x0 = x_fit.copy()
                x0[-1] = lim.to_x(lim.get(config) * f)
                c0, t1 = cost(x0), time.perf_counter()
                x, stop = tf._least_squares(prob, x0, max_nfev=iters)
                row({"factor": f, "lowered_to": lim.get(config) * f, "cost_start": c0,
                     "cost_end": cost(x), "limit_end": lim.from_x(float(x[-1])), "stop": stop,
                     "seconds": round(time.perf_counter() - t1, 1),
                     "error_against_gap_robot": _errors(params, x, gap)})
        else:
            raise SystemExit(f"unknown mode {mode!r}: each, line, starts or limit")
    json.dump({"command": sys.argv, "rows": rows, "seconds": time.perf_counter() - t0},
              open(out, "w"), indent=1)


if __name__ == "__main__":
    main()
