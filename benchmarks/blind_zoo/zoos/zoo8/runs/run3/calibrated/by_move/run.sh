#!/bin/bash
# run3's calibration again with the per-move sandwich in the intervals (code of b35cee4 on).
# From the repository root: run.sh WORK OUT
#   WORK: the harness's work directory (its reference/); OUT: the twin file to write.
# Then: .venv/bin/python benchmarks/blind_zoo/zoos/zoo8/runs/run3/calibrated/by_move/score.py OUT SECONDS
set -u
WORK=$1 OUT=$2
export OPENBLAS_NUM_THREADS=1
t0=$(date +%s)
.venv/bin/python -m littledog_mlsim.cli calibrate --data "$WORK/reference" --robot nominal \
  --out "$OUT" --servo pd_torque --params body_mass,leg_mass,kp_hip_roll,kp_hip_pitch,kp_knee,kd_knee,torque_limit_knee,ground_friction,command_delay_ms,rate_filter_hz
echo "rc=$? $(( $(date +%s) - t0 )) s $(uptime)"
