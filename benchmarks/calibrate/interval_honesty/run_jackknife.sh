#!/bin/sh
# The jackknife study over the ten split-start runs of zoo52-zoo57 (README "Jackknife"):
# records each zoo's reference again (its seed, 10 moves per type, the gap robot) into
# SCRATCH, then runs jackknife.py on each run's twin; results go to OUT/<zoo>_<run>.{md,json}.
#     sh benchmarks/calibrate/interval_honesty/run_jackknife.sh SCRATCH OUT
set -e
SCRATCH=$1; OUT=$2
PY=.venv/bin/python
Z=benchmarks/blind_zoo/zoos
export OPENBLAS_NUM_THREADS=1
mkdir -p "$SCRATCH" "$OUT"
for zs in zoo52:437 zoo53:447 zoo54:457 zoo55:467 zoo56:477 zoo57:487; do
  zoo=${zs%%:*}; seed=${zs##*:}
  [ -d "$SCRATCH/$zoo" ] || $PY -m littledog_mlsim.cli record --out "$SCRATCH/$zoo" \
      --moves-per-type 10 --seed "$seed" --jobs 2 --quiet --robot "$Z/$zoo/gap_robot.json"
done
for run in zoo52/runs/run2_split zoo53/runs/run1 zoo53/runs/run3_stride40 \
           zoo53/runs/run4_bootstrap_continued zoo54/runs/run1 zoo54/runs/run2_stride40 \
           zoo55/runs/run1 zoo55/runs/run2_bootstrap_continued zoo56/runs/run1 zoo57/runs/run1; do
  zoo=${run%%/*}; name=$(echo "$run" | sed 's#/runs/#_#')
  $PY benchmarks/calibrate/interval_honesty/jackknife.py --data "$SCRATCH/$zoo" \
      --twin "$Z/$run/calibrated_twin.json" --truth "$Z/$zoo/gap_robot.json" \
      --out "$OUT/$name" > "$OUT/$name.log" 2>&1
  grep "inside the reported" "$OUT/$name.md"
done
