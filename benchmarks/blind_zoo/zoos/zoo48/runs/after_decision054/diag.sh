#!/bin/bash
# zoo48's z08 (every motor's torque falling with joint speed) diagnosed again with the family
# torque_speed (decision 054; not blind: built after reading zoo48's truth), run1's twin
# and reference. WORK: the run's work directory (the harness's --work); from the repository root:
#   WORK=... [TAG=name] bash benchmarks/blind_zoo/zoos/zoo48/runs/after_decision054/diag.sh
# TAG (optional) names a later run's log and report beside the first's: z08_TAG.
set -u
HERE=benchmarks/blind_zoo/zoos/zoo48/runs/after_decision054
TWIN=$(ls "$WORK"/calibrated_twin_*.json)
for pair in "z08 effects/z08"; do
  set -- $pair
  ID=$1${TAG:+_$TAG}; DATA=$WORK/$2
  mkdir -p "$HERE/logs" "$HERE/reports/$ID"
  start=$(date +%s)
  OPENBLAS_NUM_THREADS=1 .venv/bin/python -m littledog_mlsim.cli diagnose --data "$DATA" \
    --out "$WORK/after_decision054/$ID" --no-figures --jobs 2 --twin "$TWIN" \
    --reference "$WORK/reference" > "$HERE/logs/diagnose_$ID.log" 2>&1
  rc=$?
  echo "$ID $(( $(date +%s) - start )) s rc=$rc code $(git rev-parse --short=8 HEAD) load $(cut -d' ' -f1-3 /proc/loadavg)" >> "$HERE/seconds.txt"
  cp "$WORK/after_decision054/$ID/report.json" "$WORK/after_decision054/$ID/report.md" "$HERE/reports/$ID/"
  sed -i -e "s#$WORK#WORK#g" "$HERE/logs/diagnose_$ID.log" "$HERE/reports/$ID/report.json" "$HERE/reports/$ID/report.md"
done
