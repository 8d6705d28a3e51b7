#!/bin/bash
# zoo47's excited clean seed diagnosed again with decision 052 (not blind), run1's twin and
# reference. WORK: the run's work directory (the harness's --work); run from the repository root:
#   WORK=... bash benchmarks/blind_zoo/zoos/zoo47/runs/after_decision052/diag.sh
set -eu
HERE=benchmarks/blind_zoo/zoos/zoo47/runs/after_decision052
TWIN=$(ls "$WORK"/calibrated_twin_*.json)
ID=clean_s381_e0.05
mkdir -p "$HERE/logs" "$HERE/reports/$ID"
start=$(date +%s)
OPENBLAS_NUM_THREADS=1 .venv/bin/python -m littledog_mlsim.cli diagnose --data "$WORK/clean/s381_e0.05" \
  --out "$WORK/after052/$ID" --no-figures --jobs 2 --twin "$TWIN" --reference "$WORK/reference" \
  > "$HERE/logs/diagnose_$ID.log" 2>&1
echo "$ID $(( $(date +%s) - start )) s rc=$? code $(git rev-parse --short=8 HEAD) load $(cut -d' ' -f1-3 /proc/loadavg)" >> "$HERE/seconds.txt"
cp "$WORK/after052/$ID/report.json" "$WORK/after052/$ID/report.md" "$HERE/reports/$ID/"
sed -i -e "s#$WORK#WORK#g" "$HERE/logs/diagnose_$ID.log" "$HERE/reports/$ID/report.json" "$HERE/reports/$ID/report.md"
