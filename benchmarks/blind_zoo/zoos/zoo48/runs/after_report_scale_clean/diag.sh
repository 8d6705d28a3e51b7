#!/bin/bash
# zoo48's clean seeds diagnosed again with encoder_scale's report-only form (`report_scale`,
# built after reading zoo48's truth): does the new form bring false alarms? run1's twin and
# reference. WORK: the run's work directory (the harness's --work); from the repository root:
#   WORK=... bash benchmarks/blind_zoo/zoos/zoo48/runs/after_report_scale_clean/diag.sh [IDS...]
# IDS default: the excited seed 391 first, then 392, 391, 393.
set -u
HERE=benchmarks/blind_zoo/zoos/zoo48/runs/after_report_scale_clean
TWIN=$(ls "$WORK"/calibrated_twin_*.json)
IDS=${*:-"s391_e0.05 s392_e0 s391_e0 s393_e0"}
for ID in $IDS; do
  DATA=$WORK/clean/$ID
  mkdir -p "$HERE/logs" "$HERE/reports/$ID"
  start=$(date +%s)
  OPENBLAS_NUM_THREADS=1 .venv/bin/python -m littledog_mlsim.cli diagnose --data "$DATA" \
    --out "$WORK/after_report_scale_clean/$ID" --no-figures --jobs 2 --twin "$TWIN" \
    --reference "$WORK/reference" > "$HERE/logs/diagnose_$ID.log" 2>&1
  rc=$?
  echo "$ID $(( $(date +%s) - start )) s rc=$rc code $(git rev-parse --short=8 HEAD) load $(cut -d' ' -f1-3 /proc/loadavg)" >> "$HERE/seconds.txt"
  cp "$WORK/after_report_scale_clean/$ID/report.json" "$WORK/after_report_scale_clean/$ID/report.md" "$HERE/reports/$ID/"
  sed -i -e "s#$WORK#WORK#g" "$HERE/logs/diagnose_$ID.log" "$HERE/reports/$ID/report.json" "$HERE/reports/$ID/report.md"
done
