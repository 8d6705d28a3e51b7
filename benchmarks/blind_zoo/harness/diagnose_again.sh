#!/bin/bash
# A zoo's datasets diagnosed one after the other with the arguments of the harness's arm
# calibrated+reference, from a checkout CLONE of the code to test, with the twin TWIN and the
# reference WORK/reference (WORK: the zoo run's work directory, from the harness's
# --record-only command):
#   WORK=... CLONE=... OUT=... TWIN=... bash benchmarks/blind_zoo/harness/diagnose_again.sh effects/z08 clean/s411_e0.05
# Per dataset: OUT/NAME.log (the diagnosis's output and its wall time), OUT/NAME.start and
# OUT/NAME.end (the UTC time and the load), OUT/out_NAME (report and model).
set -u
REPO=$(cd "$(dirname "$0")/../../.." && pwd)
export OPENBLAS_NUM_THREADS=1
mkdir -p "$OUT"
for d in "$@"; do
  n=$(echo "$d" | tr / _)
  { date -u; uptime; } > "$OUT/$n.start"
  ( cd "$CLONE" && /usr/bin/time -f "%e s wall, %U user, %S sys" env PYTHONPATH="$CLONE" \
      "$REPO/.venv/bin/python" -P -m littledog_mlsim.cli diagnose --data "$WORK/$d" \
      --out "$OUT/out_$n" --no-figures --jobs 2 --twin "$TWIN" \
      --reference "$WORK/reference" > "$OUT/$n.log" 2>&1 )
  { date -u; uptime; } > "$OUT/$n.end"
done
