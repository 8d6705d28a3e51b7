#!/bin/bash
# zoo62 datasets diagnosed one after the other with the arguments of the harness's arm
# calibrated+reference (run1's twin and reference), from a checkout CLONE of the code to test:
#   WORK=... CLONE=... OUT=... bash benchmarks/blind_zoo/zoos/zoo62/runs/after_decisions060_061/check.sh effects/z12 clean/s531_e0.05
# WORK: zoo62 run1's work directory (the harness's --record-only command, zoo62's README).
set -u
REPO=$(cd "$(dirname "$0")/../../../../../.." && pwd)
export OPENBLAS_NUM_THREADS=1
mkdir -p "$OUT"
for d in "$@"; do
  n=$(echo "$d" | tr / _)
  { date -u; uptime; } > "$OUT/$n.start"
  ( cd "$CLONE" && /usr/bin/time -f "%e s wall, %U user, %S sys" env PYTHONPATH="$CLONE" \
      "$REPO/.venv/bin/python" -P -m littledog_mlsim.cli diagnose --data "$WORK/$d" \
      --out "$OUT/out_$n" --no-figures --jobs 2 \
      --twin "$REPO/benchmarks/blind_zoo/zoos/zoo62/runs/run1/calibrated_twin.json" \
      --reference "$WORK/reference" > "$OUT/$n.log" 2>&1 )
  { date -u; uptime; } > "$OUT/$n.end"
done
