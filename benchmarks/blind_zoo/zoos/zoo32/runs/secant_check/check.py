"""zoo32, not blind: do the torque limits the calibration leaves out explain the fit's bias?

run4's fit (before its bootstrap) leaves the hip roll's and hip pitch's torque limits at the
nominal 1.7 N m. The score test's column for each is a 5 % step up, where a limit the gait never
reaches does nothing, so the consider analysis gave them no weight (run4: 1e-11). This script
linearises the fit at run4's fitted point (the 15 parameters, the same 22 TrainPool moves, the
same weights as far as the refit's start allows) and gives the optimum's shift S dr that a
finite change of each limit implies, s = -(J^T J)^-1 J^T (r(limit changed) - r): a secant at
+-0.10 and +-0.15 e-folds, and at the gap robot's true limits (read from gap_robot.json: this is
a diagnostic made after reading zoo32's truth). Compared with the fit's error against the truth.

    OPENBLAS_NUM_THREADS=1 .venv/bin/python benchmarks/blind_zoo/zoos/zoo32/runs/secant_check/check.py REFERENCE

REFERENCE: zoo32's reference recording (the harness records it: seed 237, 10 moves per type).
Another zoo's run: ``check.py REFERENCE RUN_DIR GAP_ROBOT OUT_JSON`` (the run's twin must have
a bootstrap; its hip limits are changed the same way).
"""
from __future__ import annotations

import json
import math
import sys
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent


def main(ref: str, run: str | None = None, gap_file: str | None = None,
         out_json: str | None = None) -> None:
    from littledog_mlsim.robot import baseline as bl
    from littledog_mlsim.robot import twin_fit as tf
    from littledog_mlsim.robot.parameters import TWIN_PARAMETERS
    from dataclasses import replace
    from run4 import run4_case

    case = run4_case(ref, run, gap_file)
    cal, boot, params, gap, train = case.cal, case.boot, case.params, case.gap, case.train
    cfg = replace(case.fit, sensor_noise=False)
    opts = tf.CalibrationOptions(initial_state="smoothed", max_evals=10_000)
    out: dict = {"train_moves": len(train), "secants": {}}
    with bl.move_pool(train, 2) as pool:
        prob = tf._Problem(pool, cfg, params, opts, lambda s: None)
        x = np.array([p.to_x(p.get(cfg)) for p in params])
        prob.scale = tf._rms_scale(prob.raw(x))
        r = prob.fun(x)
        J = prob.jac(x)
        P = np.linalg.pinv(J.T @ J) @ J.T
        sd = np.sqrt(np.diag(np.linalg.pinv(J.T @ J)) * float(r @ r) / max(r.size - len(x), 1))

        def shift(c) -> dict:
            raw = tf.twin_residuals(pool, c, opts.stride, opts.horizons, opts.initial_state)
            w = tf._weighted(raw, prob.scale)
            s = -P @ (w - r)
            return {"d_cost": 0.5 * float(w @ w - r @ r),
                    "shift_pct": {p.name: 100 * float(si) for p, si in zip(params, s)}}

        lim = TWIN_PARAMETERS["torque_limit_hip_roll"], TWIN_PARAMETERS["torque_limit_hip_pitch"]
        for par in lim:
            xc = par.to_x(par.get(cfg))
            for d in (-0.15, -0.10, 0.10, 0.15):
                key = f"{par.name} {d:+.2f}"
                out["secants"][key] = shift(par.set(cfg, par.from_x(xc + d)))
                print(key, "d_cost", round(out["secants"][key]["d_cost"], 3), flush=True)
        c = cfg
        for par in lim:
            c = par.set(c, par.get(gap))
        out["secants"]["both at the truth"] = shift(c)
        out["fit_error_pct"] = {}
        for p in params:
            truth = (gap.ground_friction * gap.foot_friction / cfg.foot_friction
                     if p.name == "ground_friction" else p.get(gap))
            if truth > 0 and p.get(cfg) > 0:
                out["fit_error_pct"][p.name] = 100 * math.log(p.get(cfg) / truth)
        out["sd_data_pct_plain"] = {p.name: 100 * float(s) for p, s in zip(params, sd)}
    Path(out_json or HERE / "secants.json").write_text(json.dumps(out, indent=1))
    keys = list(out["secants"])
    print("| parameter | fit - truth [%] | " + " | ".join(keys) + " |")
    print("|---|---|" + "---|" * len(keys))
    for p in params:
        row = [f"{out['secants'][k]['shift_pct'][p.name]:+.2f}" for k in keys]
        fe = out["fit_error_pct"].get(p.name)
        print(f"| {p.name} | {'' if fe is None else f'{fe:+.2f}'} | " + " | ".join(row) + " |")
    print("| cost change | | " + " | ".join(f"{out['secants'][k]['d_cost']:+.2f}" for k in keys)
          + " |")


if __name__ == "__main__":
    main(*sys.argv[1:5])
