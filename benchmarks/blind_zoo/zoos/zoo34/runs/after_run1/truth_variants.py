"""zoo34, not blind: the k-step cost of run1's recording at the gap robot with one part of it
changed to the twin's, against the fit's (the weights of ``cost_at_truth.py``: the fit's rms,
so that the fit costs half the number of residuals).

    OPENBLAS_NUM_THREADS=1 .venv/bin/python benchmarks/blind_zoo/zoos/zoo34/runs/after_run1/truth_variants.py REFERENCE
"""
from __future__ import annotations

import json
import sys
from dataclasses import replace
from pathlib import Path

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE.parents[2] / "zoo32" / "runs" / "secant_check"))


def main(ref: str) -> None:
    from littledog_mlsim.robot import baseline as bl
    from littledog_mlsim.robot import twin_fit as tf
    from run4 import run4_case

    case = run4_case(ref, HERE.parent / "run1", HERE.parents[1] / "gap_robot.json")
    fit = replace(case.fit, sensor_noise=False)
    gap = replace(case.gap, sensor_noise=False)
    scale = fit.body_mass / gap.body_mass

    def scaled(c, s):
        """Every mass, gain, damping, torque limit and rotor inertia times s."""
        return replace(c, body_mass=c.body_mass * s, leg_mass=c.leg_mass * s,
                       kp=tuple(k * s for k in c.kp), kd=tuple(k * s for k in c.kd),
                       torque_limit=tuple(k * s for k in c.torque_limit),
                       armature=tuple(k * s for k in c.armature))

    variants = {
        "the fit": fit,
        "the gap robot": gap,
        "the gap robot, hip torque limits the twin's (1.7 N m)":
            replace(gap, torque_limit=(1.7, 1.7, gap.torque_limit[2])),
        "the gap robot, every mass and servo torque x the fit's body-mass ratio":
            scaled(gap, scale),
        "the gap robot, its body mass alone x that ratio":
            replace(gap, body_mass=gap.body_mass * scale),
        "the fit, every mass and servo torque / that ratio": scaled(fit, 1 / scale),
    }
    out = {"body_mass_ratio": scale}
    opts = tf.CalibrationOptions(initial_state="smoothed")
    with bl.move_pool(case.train, 2) as pool:
        def raw(c):
            return tf.twin_residuals(pool, c, opts.stride, opts.horizons, opts.initial_state)
        weights = tf._rms_scale(raw(fit))
        r_gap = tf._weighted(raw(gap), weights)
        for name, c in variants.items():
            w = tf._weighted(raw(c), weights)
            out[name] = {"cost": 0.5 * float(w @ w),
                         "max_abs_residual_change_vs_gap": float(abs(w - r_gap).max())}
            print(f"{name}: k-step cost {out[name]['cost']:.3f}, largest weighted residual "
                  f"change against the gap robot's {out[name]['max_abs_residual_change_vs_gap']:.3g}",
                  flush=True)
    (HERE / "truth_variants.json").write_text(json.dumps(out, indent=1))


if __name__ == "__main__":
    main(sys.argv[1])
