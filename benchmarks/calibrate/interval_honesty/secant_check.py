"""Does the Jacobian's curvature hold out to a calibrated twin's interval ends?

    OPENBLAS_NUM_THREADS=1 .venv/bin/python benchmarks/calibrate/interval_honesty/secant_check.py \
        --data REFERENCE --twin TWIN.json [--stride 40] [--out OUT]

From the calibrated twin (its fitted parameters and their data sd, ``sd_coordinate_data``) the
fitted TrainPool moves of the reference are re-simulated as ``calibrate`` does (the same
stride, horizons and starting states), weighted by their RMS at the twin. The central-difference
Jacobian J (calibrate's) is taken at the twin; then each parameter alone is moved to the ends
of its data interval, x +- 1.96 sd, and the cost 0.5 |r|^2 re-simulated there. The quadratic
model of J predicts a rise of 0.5 |J_k h|^2 at each end (h = 1.96 sd; the linear term, J_k . r
h, is given too); the ratio of the measured mean rise over the two ends to that prediction is
1 where the linearisation holds at the scale of the interval, and below 1 where the cost is
flatter there than J says (the interval is then too narrow by about 1 / sqrt(ratio)).
Costs 2p + 1 re-simulations for J and 2p for the ends.
"""
from __future__ import annotations

import argparse
import json
import os
import sys
from dataclasses import replace
from pathlib import Path

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
ROOT = Path(__file__).resolve().parents[3]
sys.path.insert(0, str(ROOT))

import numpy as np  # noqa: E402


def main() -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    p.add_argument("--data", required=True)
    p.add_argument("--twin", required=True)
    p.add_argument("--stride", type=int, default=40)
    p.add_argument("--jobs", type=int, default=2)
    p.add_argument("--out", default=None, help="write OUT.json and OUT.md")
    a = p.parse_args()
    from littledog_mlsim.data.dataset import load_moves
    from littledog_mlsim.robot import baseline as bl
    from littledog_mlsim.robot import twin_fit as tf
    from littledog_mlsim.robot.parameters import twin_parameters
    from littledog_mlsim.robot.twin import load_twin

    twin = load_twin(a.twin)
    cal = twin.provenance["calibration"]
    names = list(cal["sd_coordinate_data"])          # the fitted parameters, in order
    sd = cal["sd_coordinate_data"]
    options = tf.CalibrationOptions(stride=a.stride, jobs=a.jobs,
                                    initial_state=cal["settings"]["initial_state"])
    train = bl.first_per_type(load_moves(a.data, "train"), options.moves_per_type)
    base = replace(twin.robot, sensor_noise=False)
    params = twin_parameters(names, base)
    x = np.array([q.to_x(q.get(base)) for q in params])
    rows = []
    with bl.move_pool(train, options.jobs, None) as pool:
        prob = tf._Problem(pool, base, params, replace(options, max_evals=10 ** 6), print)
        prob.scale = tf._rms_scale(prob.raw(x))
        r = prob.fun(x)
        c0 = 0.5 * float(r @ r)
        J = prob.jac(x)
        ends = []
        for k, q in enumerate(params):
            s = sd.get(q.name)
            if s is None or not np.isfinite(s) or s <= 0:
                continue
            h = 1.959964 * s
            up, down = x.copy(), x.copy()
            up[k], down[k] = min(x[k] + h, prob.hi[k]), max(x[k] - h, prob.lo[k])
            ends.append((k, q, h, up, down))
        prob.raw_many([v for e in ends for v in e[3:]])
        for k, q, h, up, down in ends:
            rise = [0.5 * float(prob.fun(v) @ prob.fun(v)) - c0 for v in (up, down)]
            quad = 0.5 * float((J[:, k] * h) @ (J[:, k] * h))
            lin = float(J[:, k] @ r) * h
            ratio = float(np.mean(rise)) / quad if quad > 0 else float("nan")
            rows.append({"name": q.name, "sd_coordinate_data": s, "h": h,
                         "rise_up": rise[0], "rise_down": rise[1], "predicted_quadratic": quad,
                         "linear_term": lin, "ratio": ratio,
                         "sd_factor": (1 / np.sqrt(ratio)) if ratio > 0 else None})
    lines = [f"# Secant check of the intervals: `{a.twin}` on `{a.data}`", "",
             f"k-step cost at the twin {c0:.1f} (0.5 |r|^2, {r.size} weighted residuals)", "",
             "| parameter | h (1.96 sd) | rise at +h | rise at -h | J's quadratic | J's linear "
             "term | ratio | 1 / sqrt(ratio) |", "|---|---|---|---|---|---|---|---|"]
    for row in rows:
        f = row["sd_factor"]
        lines.append(f"| {row['name']} | {row['h']:.4g} | {row['rise_up']:.1f} | "
                     f"{row['rise_down']:.1f} | {row['predicted_quadratic']:.1f} | "
                     f"{row['linear_term']:+.1f} | {row['ratio']:.2f} | "
                     + ("-" if f is None else f"{f:.2f}") + " |")
    text = "\n".join(lines) + "\n"
    print(text)
    if a.out:
        Path(a.out + ".json").write_text(json.dumps({"command": sys.argv, "cost": c0,
                                                      "rows": rows}, indent=1) + "\n")
        Path(a.out + ".md").write_text(text)
    return 0


if __name__ == "__main__":
    sys.exit(main())
