#!/usr/bin/env bash
# One zoo diagnosis with two checkouts, one after the other, nothing else running: the wall and
# CPU seconds of each (/usr/bin/time), the load before and after, and the two reports compared.
#   bash benchmarks/diagnose_speed/step_python/ab_diagnosis.sh BEFORE AFTER DATA REFERENCE TWIN OUT
# BEFORE and AFTER are checkouts (their package is imported via PYTHONPATH); the venv is this
# repository's. The diagnosis's arguments are those of the blind harness's arm
# calibrated+reference.
set -u
REPO=$(cd "$(dirname "$0")/../../.." && pwd)
BEFORE=$1; AFTER=$2; DATA=$3; REF=$4; TWIN=$5; OUT=$6
mkdir -p "$OUT"
export OPENBLAS_NUM_THREADS=1
for side in before after; do
  CO=$BEFORE; [ "$side" = after ] && CO=$AFTER
  echo "== $side: $(git -C "$CO" rev-parse --short=8 HEAD)"
  date -u; uptime
  ( cd "$CO" && /usr/bin/time -f "%e s wall, %U user, %S sys" env PYTHONPATH="$CO" \
      "$REPO/.venv/bin/python" -P -m littledog_mlsim.cli diagnose --data "$DATA" \
      --out "$OUT/$side" --no-figures --jobs 2 --twin "$TWIN" --reference "$REF" \
      > "$OUT/$side.log" 2>&1 )
  tail -1 "$OUT/$side.log"
  date -u; uptime
done
"$REPO/.venv/bin/python" "$REPO/benchmarks/diagnose_speed/memo/compare_reports.py" \
  "$OUT/before/report.json" "$OUT/after/report.json"
