#!/bin/sh
# Diagnose zoo50's datasets one after another with record.py (the blind run's arguments of the
# arm calibrated+reference) and write OUT/<name>.json, OUT/<name>.log and OUT/<name>/ (the
# reports). WORK50: zoo50's recordings (benchmarks/blind_zoo/zoos/zoo50/README.md, the
# harness's --record-only command); NAMES: effects/zNN or clean/sNNN_eE, space-separated.
#
#   WORK50=DIR OUT=DIR NAMES="effects/z05 clean/s413_e0" \
#       sh benchmarks/diagnose_speed/contention/run_set.sh
set -e
: "${WORK50:?}" "${OUT:?}" "${NAMES:?}"
ROOT=$(cd "$(dirname "$0")/../../.." && pwd)
cd "$ROOT"
mkdir -p "$OUT"
for n in $NAMES; do
    b=$(basename "$n")
    echo "$(date -u +%H:%M:%S) $b start (load $(cut -d' ' -f1-3 /proc/loadavg))"
    OPENBLAS_NUM_THREADS=1 .venv/bin/python -P benchmarks/diagnose_speed/contention/record.py \
        "$OUT/$b.json" -- diagnose --data "$WORK50/$n" --out "$OUT/$b" --no-figures --jobs 2 \
        --twin benchmarks/blind_zoo/zoos/zoo50/runs/run1/calibrated_twin.json \
        --reference "$WORK50/reference" > "$OUT/$b.log" 2>&1
    echo "$(date -u +%H:%M:%S) $b done: $(grep -o 'wrote .* in [0-9.]* s' "$OUT/$b.log" | tail -1)"
done
