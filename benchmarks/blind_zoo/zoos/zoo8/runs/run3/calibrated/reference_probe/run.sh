#!/bin/bash
# run3's twin with the clean reference, on the three clean seeds of the gap robot.
# From the repository root: run.sh WORK TWIN [CODE]
#   WORK: the harness's work directory (clean/, reference/); TWIN: run3's calibrated twin file;
#   CODE: a checkout of the frozen code (a674e3f) put first on PYTHONPATH (default: this tree).
set -u
WORK=$1 TWIN=$2 CODE=${3:-$PWD}
export OPENBLAS_NUM_THREADS=1 PYTHONPATH=$CODE
for s in 31 32 33; do
  t0=$(date +%s)
  .venv/bin/python -m littledog_mlsim.cli diagnose --data "$WORK/clean/s${s}_e0" \
    --out "$WORK/diag_calref/clean_s${s}_e0" --no-figures --jobs 2 --twin "$TWIN" \
    --reference "$WORK/reference" > "$WORK/diag_calref_s${s}.log" 2>&1
  echo "s$s rc=$? $(( $(date +%s) - t0 )) s $(uptime)" >> "$WORK/diag_calref.times"
done
