#!/bin/sh
# zoo8 run6 (not blind): the physical route with measured and smoothed starting states, on the
# two effects run3's calibrated+reference arm found with their size off (g07 payload, g09
# back-left foot friction). Usage: run.sh WORK TWIN CHECKOUT OUT (WORK: zoo8's work directory;
# TWIN: run3's calibrated twin; CHECKOUT: a clone of the code; OUT: where the reports go).
WORK=$1; TWIN=$2; CHECKOUT=$3; OUT=$4
mkdir -p "$OUT"
cd "$CHECKOUT" || exit 1
for g in g07 g09; do for st in measured smoothed; do
  s=$(date +%s)
  OPENBLAS_NUM_THREADS=1 PYTHONPATH="$CHECKOUT" nice -n 10 .venv/bin/python -m littledog_mlsim.cli \
    diagnose --data "$WORK/effects/$g" --out "$OUT/${g}_$st" --no-figures --jobs 2 \
    --twin "$TWIN" --reference "$WORK/reference" --initial-state $st > "$OUT/${g}_$st.log" 2>&1
  echo "$g $st rc=$? $(( $(date +%s) - s )) s $(uptime)" >> "$OUT/times"
done; done
