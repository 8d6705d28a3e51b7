"""Does a round take the robots the fit before it simulated? Run at feca1221 (the reuse, later
reverted): a small calibration (one TrainPool move per type, stride 80, four parameters, one
added round) with the reuse on, then with it off (``Evaluations.get`` returning nothing);
prints the robots reused and whether the two calibrations are the same.

    git worktree add /tmp/reuse feca1221
    OPENBLAS_NUM_THREADS=1 PYTHONPATH=/tmp/reuse .venv/bin/python \\
      benchmarks/calibrate/reuse_probe/reuse_check.py --data REF
"""
from __future__ import annotations

import argparse
import dataclasses
import sys

from littledog_mlsim.data.dataset import load_moves
from littledog_mlsim.robot import baseline as bl
from littledog_mlsim.robot import twin_fit as tf
from littledog_mlsim.robot.config import robot_config


def calibrate(data: str, reuse: bool):
    train = bl.first_per_type(load_moves(data, "train"), 1)
    base = dataclasses.replace(tf.with_servo(robot_config("nominal"), "pd_torque"),
                               rate_filter_hz=100.0)
    opts = tf.CalibrationOptions(params=("body_mass", "leg_mass", "kp_knee", "kd_knee"),
                                 stride=80, max_evals=40, add_asked=1,
                                 initial_state="smoothed")
    real = tf.Evaluations.get
    if not reuse:
        tf.Evaluations.get = lambda self, recs, options, config: None
    try:
        return tf.calibrate_twin(train, [], base, opts)
    finally:
        tf.Evaluations.get = real


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--data", required=True)
    args = ap.parse_args(argv)
    on, off = calibrate(args.data, True), calibrate(args.data, False)
    print("rounds added:", [r["added"] for r in on.report["added"]])
    print("robots reused by the last round:", on.report.get("n_evals_reused"),
          "(of its", on.report["n_evals"], "evaluations)")
    same = ([(e.value, e.ci95) for e in on.estimates] == [(e.value, e.ci95) for e in off.estimates])
    print("the same calibration with the reuse off:", same)
    return 0


if __name__ == "__main__":
    sys.exit(main())
