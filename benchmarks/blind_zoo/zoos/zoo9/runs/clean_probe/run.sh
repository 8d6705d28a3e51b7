#!/bin/sh
# zoo9's clean seeds 41 and 42, recorded with the gap robot as sealed and with the same robot
# without its 6 ms set-point delay (gap_no_delay.json), each diagnosed in the learned arm as run1
# diagnosed it. Usage: run.sh WORK CHECKOUT (WORK: a scratch directory; CHECKOUT: a clone of the
# code; run from the repository root).
WORK=$1; CHECKOUT=$2
ZOO=benchmarks/blind_zoo/zoos/zoo9
HERE=$ZOO/runs/clean_probe
for seed in 41 42; do
  for robot in gap no_delay; do
    case $robot in gap) R=$ZOO/gap_robot.json;; no_delay) R=$HERE/gap_no_delay.json;; esac
    n=${robot}_s$seed
    s=$(date +%s)
    OPENBLAS_NUM_THREADS=1 PYTHONPATH="$CHECKOUT" .venv/bin/python -m littledog_mlsim.cli record \
      --out "$WORK/$n" --moves-per-type 10 --seed $seed --robot "$R" --jobs 2 --quiet || exit 1
    echo "record $n $(( $(date +%s) - s )) s $(uptime)"
    s=$(date +%s)
    OPENBLAS_NUM_THREADS=1 PYTHONPATH="$CHECKOUT" .venv/bin/python -m littledog_mlsim.cli diagnose \
      --data "$WORK/$n" --out "$WORK/diag_$n" --no-figures \
      --jobs 2 --physics off --rollout-route > "$WORK/diag_$n.log" 2>&1
    echo "diagnose $n rc=$? $(( $(date +%s) - s )) s $(uptime)"
  done
done
