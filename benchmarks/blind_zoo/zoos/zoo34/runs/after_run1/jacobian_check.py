"""zoo34, not blind: does the fit's Jacobian see the common scale as flat?

At run1's fit (before its bootstrap), the central-difference Jacobian of the 15 fitted
parameters (the calibration's own ``_Problem.jac``), and its product with the direction that
scales every mass, gain, damping, the knee's torque limit and every rotor inertia together
(the residuals do not change along it: ``truth_variants.py``), against its columns' norms;
also the finite difference along that direction itself.

    OPENBLAS_NUM_THREADS=1 .venv/bin/python benchmarks/blind_zoo/zoos/zoo34/runs/after_run1/jacobian_check.py REFERENCE
"""
from __future__ import annotations

import json
import sys
from dataclasses import replace
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE.parents[2] / "zoo32" / "runs" / "secant_check"))

SCALED = ("body_mass", "leg_mass", "kp_hip_roll", "kp_hip_pitch", "kp_knee", "kd_hip_roll",
          "kd_hip_pitch", "kd_knee", "torque_limit_knee", "armature_hip_roll",
          "armature_hip_pitch", "armature_knee")


def main(ref: str) -> None:
    from littledog_mlsim.robot import baseline as bl
    from littledog_mlsim.robot import twin_fit as tf
    from run4 import run4_case

    case = run4_case(ref, HERE.parent / "run1", HERE.parents[1] / "gap_robot.json")
    fit = replace(case.fit, sensor_noise=False)
    params = case.params
    opts = tf.CalibrationOptions(initial_state="smoothed", max_evals=10_000)
    x = np.array([p.to_x(p.get(fit)) for p in params])
    # the direction: d(coordinate)/d(log s) per parameter
    v = np.array([(1.0 if p.log else p.get(fit)) if p.name in SCALED else 0.0 for p in params])
    scale = np.array([p.x_scale for p in params])
    out = {"direction": {p.name: float(c) for p, c in zip(params, v)}, "by_diff_step": {}}
    with bl.move_pool(case.train, 2) as pool:
        for step in (0.05, 0.01):
            prob = tf._Problem(pool, fit, params, replace(opts, diff_step=step), lambda s: None)
            prob.scale = tf._rms_scale(prob.raw(x))
            J = prob.jac(x)
            h = step
            along = (prob.fun(x + h * v) - prob.fun(x - h * v)) / (2 * h)
            sv = np.linalg.svd(J * scale[None, :], compute_uv=False)
            per = {p.name: float(np.linalg.norm(J[:, k] * v[k])) for k, p in enumerate(params)}
            row = {"J_times_direction_norm": float(np.linalg.norm(J @ v)),
                   "difference_along_direction_norm": float(np.linalg.norm(along)),
                   "column_times_direction_norms": per,
                   "singular_values_scaled": [float(s) for s in sv]}
            out["by_diff_step"][str(step)] = row
            print(f"diff_step {step}: |J v| {row['J_times_direction_norm']:.1f}, |difference "
                  f"along v| {row['difference_along_direction_norm']:.2f}, smallest scaled "
                  f"singular values {[round(s, 1) for s in sv[-3:]]}", flush=True)
            print("  |J_k v_k|:", {k: round(c, 1) for k, c in per.items()}, flush=True)
    (HERE / "jacobian_check.json").write_text(json.dumps(out, indent=1))


if __name__ == "__main__":
    main(sys.argv[1])
