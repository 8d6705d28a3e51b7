"""zoo31 run1, not blind (the truth read): does the calibration land inside its intervals when
the robot's masses are not fitted but weighed?

`start` writes the starting twin: run1's calibrated twin with the body and leg masses set to
the gap robot's (what a lab weighing the body and a leg would measure). `calibrate` then fits
run1's other ten parameters from it, with run1's servo structure kept. `score` scores the
result with the blind harness's own `calibration_score` against the gap robot. From the
repository root:

    OPENBLAS_NUM_THREADS=1 .venv/bin/python benchmarks/blind_zoo/zoos/zoo31/runs/run1/weighed/weighed.py start OUT/start.json
    OPENBLAS_NUM_THREADS=1 .venv/bin/python -m littledog_mlsim.cli calibrate --data WORK/reference \
        --robot OUT/start.json --out OUT/weighed_twin.json --servo keep \
        --params kp_hip_roll,kp_hip_pitch,kp_knee,kd_knee,torque_limit_knee,ground_friction,rate_filter_hz,kd_hip_roll,command_delay_ms,armature_knee
    .venv/bin/python benchmarks/blind_zoo/zoos/zoo31/runs/run1/weighed/weighed.py score OUT/weighed_twin.json SECONDS > result.json
"""
from __future__ import annotations

import dataclasses
import json
import sys
from pathlib import Path

HERE = Path(__file__).resolve().parent
ROOT = HERE.parents[6]
sys.path.insert(0, str(ROOT))
sys.path.insert(0, str(ROOT / "benchmarks" / "blind_zoo" / "harness"))

from littledog_mlsim.robot.twin import Twin, load_twin, save_twin  # noqa: E402

GAP = HERE.parents[2] / "gap_robot.json"
RUN1_TWIN = HERE.parent / "calibrated_twin.json"


def start(out: str) -> None:
    run1, gap = load_twin(RUN1_TWIN), load_twin(GAP).robot
    robot = dataclasses.replace(run1.robot, body_mass=gap.body_mass, leg_mass=gap.leg_mass)
    save_twin(Twin(robot, {"created_by": "zoo31 run1 weighed.py start",
                           "note": "run1's calibrated twin with the gap robot's masses"}), out)
    print(out)


def score(twin: str, seconds: str) -> None:
    from run import calibration_score
    print(json.dumps(calibration_score({"twin": twin, "seconds": float(seconds)}, GAP),
                     indent=1))


if __name__ == "__main__":
    {"start": start, "score": score}[sys.argv[1]](*sys.argv[2:])
