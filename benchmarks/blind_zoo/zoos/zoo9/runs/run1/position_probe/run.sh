#!/bin/sh
# zoo9's clean seed 41, recorded again with every move started from its own place and heading
# (random_start.yaml), then diagnosed in the learned arm as run1 diagnosed it. Usage:
# run.sh WORK CHECKOUT (WORK: a scratch directory; CHECKOUT: a clone of the code; run from the
# repository root).
WORK=$1; CHECKOUT=$2
HERE=benchmarks/blind_zoo/zoos/zoo9/runs/run1/position_probe
OPENBLAS_NUM_THREADS=1 PYTHONPATH="$CHECKOUT" .venv/bin/python -m littledog_mlsim.cli record \
  --out "$WORK/clean_s41_random_start" --moves-per-type 10 --seed 41 \
  --robot benchmarks/blind_zoo/zoos/zoo9/gap_robot.json --effects "$HERE/random_start.yaml" \
  --jobs 2 --quiet || exit 1
s=$(date +%s)
OPENBLAS_NUM_THREADS=1 PYTHONPATH="$CHECKOUT" .venv/bin/python -m littledog_mlsim.cli diagnose \
  --data "$WORK/clean_s41_random_start" --out "$WORK/diag_clean_s41_random_start" --no-figures \
  --jobs 2 --physics off --rollout-route > "$WORK/diag_clean_s41_random_start.log" 2>&1
echo "diagnose rc=$? $(( $(date +%s) - s )) s $(uptime)"
