#!/bin/bash
# run3's twin with the clean reference, on the three clean seeds of the gap robot
export OPENBLAS_NUM_THREADS=1 PYTHONPATH=/tmp/frozen_ref
for s in 31 32 33; do
  t0=$(date +%s)
  /work/main/.venv/bin/python -m littledog_mlsim.cli diagnose --data /tmp/zoo8work/clean/s${s}_e0 --out /tmp/zoo8work/diag_calref/clean_s${s}_e0 --no-figures --jobs 2 --twin /tmp/zoo8work/calibrated_twin_servo_pd_torque_params_body_mass_leg_mass_kp_hip_roll_kp_hip_pitch_kp_knee_kd_knee_torque_limit_knee_ground_friction_command_delay_ms_rate_filter_hz.json --reference /tmp/zoo8work/reference > /tmp/zoo8work/diag_calref_s${s}.log 2>&1
  echo "s$s rc=$? $(( $(date +%s) - t0 )) s $(uptime)" >> /tmp/zoo8work/diag_calref.times
done
