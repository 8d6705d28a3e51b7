"""Are calibrate's move-clustered intervals too narrow because there are few moves?

    OPENBLAS_NUM_THREADS=1 .venv/bin/python benchmarks/calibrate/interval_honesty/jackknife.py \
        --data REFERENCE --twin TWIN.json --truth GAP_ROBOT.json [--out OUT]

``calibrate``'s intervals take the widest of three covariances at the optimum: the plain
s^2 (J^T J)^-1 and two sandwiches, clustered by sampled state and by move (module doc 4 of
``robot/twin_fit.py``). The move-clustered sandwich (CR1: the clusters' scores, times
G / (G - 1)) is known to be too narrow when the clusters are few against the parameters and
when one cluster carries much of a parameter's information (its leverage): here 22 moves and
15-16 parameters, and a rotor inertia or the delay may be pinned by a few moves. The
leave-one-move-out jackknife (CR3) does not have that bias to first order: with each move g
left out in turn, the Gauss-Newton step delta_g = (J^T J - J_g^T J_g)^-1 J_g^T r_g is how far
the optimum moves, and V3 = (G - 1) / G sum_g (delta_g - mean)(delta_g - mean)^T.

From the calibrated twin (its fitted parameters, its values) the fitted TrainPool moves of the
reference are re-simulated as ``calibrate`` did (the stride, horizons and starting states of
the twin's report), weighted by their RMS at the twin, and the central-difference Jacobian taken there
(2p + 1 re-simulations). Printed per parameter: the data sd the twin reports, CR1 and CR3 by
move recomputed at the twin, their ratio, and whether the truth is inside the reported
interval and inside it widened to the CR3 sd (each half-width h becomes
sqrt(h^2 + 1.96^2 (max(sd_data, sd_CR3)^2 - sd_data^2)) in the fit's coordinate).
"""
from __future__ import annotations

import argparse
import json
import math
import os
import sys
from dataclasses import replace
from pathlib import Path

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
ROOT = Path(__file__).resolve().parents[3]
sys.path.insert(0, str(ROOT))

import numpy as np  # noqa: E402

Z95 = 1.959964


def cluster_covariances(J: np.ndarray, r: np.ndarray, sizes: list[int]
                        ) -> tuple[np.ndarray, np.ndarray]:
    """(CR1, CR3) covariances of the fit coordinates clustered by ``sizes`` consecutive
    residuals: ``calibrate``'s own per-move sandwich and jackknife (module doc)."""
    from littledog_mlsim.robot import twin_fit as tf
    return tf._sandwich(J, r, np.linalg.pinv(J.T @ J), sizes), tf._jackknife(J, r, sizes)


def main() -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    p.add_argument("--data", required=True)
    p.add_argument("--twin", required=True)
    p.add_argument("--truth", required=True, help="the gap robot's twin file")
    p.add_argument("--jobs", type=int, default=2)
    p.add_argument("--out", default=None, help="write OUT.json and OUT.md")
    a = p.parse_args()
    from littledog_mlsim.data.dataset import load_moves
    from littledog_mlsim.robot import baseline as bl
    from littledog_mlsim.robot import twin_fit as tf
    from littledog_mlsim.robot.parameters import twin_parameters
    from littledog_mlsim.robot.twin import load_twin

    twin = load_twin(a.twin)
    truth = load_twin(a.truth).robot
    cal = twin.provenance["calibration"]
    names = list(cal["sd_coordinate_data"])          # the fitted parameters, in order
    sd_data = cal["sd_coordinate_data"]
    reported = twin.provenance["parameters"]
    st = cal["settings"]
    options = tf.CalibrationOptions(stride=int(st["stride"]), horizons=tuple(st["horizons"]),
                                    jobs=a.jobs, initial_state=st["initial_state"])
    train = bl.first_per_type(load_moves(a.data, "train"), options.moves_per_type)
    base = replace(twin.robot, sensor_noise=False)
    params = twin_parameters(names, base)
    x = np.array([q.to_x(q.get(base)) for q in params])
    with bl.move_pool(train, options.jobs, None) as pool:
        prob = tf._Problem(pool, base, params, replace(options, max_evals=10 ** 6), print)
        prob.scale = tf._rms_scale(prob.raw(x))
        r = prob.fun(x)
        sizes = [m.size for m in prob.raw(x)]
        J = prob.jac(x)
    cr1, cr3 = cluster_covariances(J, r, sizes)
    from benchmarks.blind_zoo.harness.run import calibration_score
    scored = {row["name"]: row for row in
              calibration_score({"twin": str(a.twin), "seconds": None}, Path(a.truth))["rows"]}
    rows = []
    for k, q in enumerate(params):
        s1, s3 = (math.sqrt(max(float(c[k, k]), 0.0)) for c in (cr1, cr3))
        sd = sd_data.get(q.name)
        row = {"name": q.name, "sd_data_reported": sd, "sd_cr1": s1, "sd_cr3": s3,
               "ratio": s3 / s1 if s1 > 0 else None, "moves": len(sizes)}
        sc = scored.get(q.name) or {}
        lo, hi = sc.get("ci95") or (None, None)
        if sc.get("identifiable") and lo is not None and hi is not None and sd:
            # the scored quantity: the parameter, or (a friction) the contact's product
            factor = 1.0 if q.log else sc["value"] / reported[q.name]["value"]
            f = math.log if q.log else (lambda v: v)
            v, tx, lx, hx = f(sc["value"]), f(sc["truth"]), f(lo), f(hi)
            grow = (Z95 * factor) ** 2 * max(0.0, max(sd, s3) ** 2 - sd ** 2)
            lw, hw = v - math.sqrt((v - lx) ** 2 + grow), v + math.sqrt((hx - v) ** 2 + grow)
            half = (hx - v) if tx > v else (v - lx)
            half3 = (hw - v) if tx > v else (v - lw)
            back = math.exp if q.log else (lambda u: u)
            row.update({"scored_as": sc.get("scored_as"), "truth": sc["truth"],
                        "value": sc["value"], "ci95": [lo, hi],
                        "z": Z95 * (tx - v) / half if half > 0 else None,
                        "half_reported": half, "half_cr3": half3,
                        "inside": bool(lx <= tx <= hx), "inside_cr3": bool(lw <= tx <= hw),
                        "width": hi / lo if lo > 0 else None,
                        "width_cr3": back(hw) / back(lw) if back(lw) > 0 else None})
        rows.append(row)
    n_in = sum(1 for r_ in rows if r_.get("inside"))
    n_in3 = sum(1 for r_ in rows if r_.get("inside_cr3"))
    n = sum(1 for r_ in rows if "inside" in r_)
    lines = [f"# Jackknife over moves: `{a.twin}` on `{a.data}`", "",
             f"{len(sizes)} moves, {len(params)} parameters, {r.size} weighted residuals; "
             f"inside the reported intervals {n_in} of {n}, widened to CR3 {n_in3} of {n}", "",
             "| parameter | sd data (reported) | CR1 at the twin | CR3 | CR3 / CR1 | z | inside "
             "| inside with CR3 | width | width with CR3 |", "|---|---|---|---|---|---|---|---|---|---|"]

    def g(v, fmt=".3g"):
        return "-" if v is None else (("yes" if v else "no") if isinstance(v, bool) else
                                      format(v, fmt))
    for row in rows:
        lines.append(f"| {row['name']} | {g(row['sd_data_reported'])} | {g(row['sd_cr1'])} | "
                     f"{g(row['sd_cr3'])} | {g(row['ratio'], '.2f')} | {g(row.get('z'), '+.2f')} "
                     f"| {g(row.get('inside'))} | {g(row.get('inside_cr3'))} | "
                     f"{g(row.get('width'), '.3f')} | {g(row.get('width_cr3'), '.3f')} |")
    text = "\n".join(lines) + "\n"
    print(text)
    if a.out:
        Path(a.out + ".json").write_text(json.dumps({"command": sys.argv, "rows": rows},
                                                     indent=1) + "\n")
        Path(a.out + ".md").write_text(text)
    return 0


if __name__ == "__main__":
    sys.exit(main())
