#!/usr/bin/env bash
# `train --method lgpr --jobs 2` on one dataset by two checkouts, alternating (before, after,
# before, after): the whole command's wall time and the LGPR fit's own time (its log line).
# Usage: BEFORE=OLD_CHECKOUT DATA=DATASET WORK=SCRATCH benchmarks/diagnose_speed/zoo_diagnosis/ab_train.sh
set -u
AFTER=$(cd "$(dirname "$0")/../../.." && pwd)
for i in 1 2; do
  for side in before after; do
    if [ "$side" = before ]; then T=$BEFORE; else T=$AFTER; fi
    out="$WORK/ab_$side$i"
    rm -rf "$out"
    s=$(date +%s.%N)
    PYTHONPATH=$T OPENBLAS_NUM_THREADS=1 "$T/.venv/bin/python" -P -m littledog_mlsim.cli train \
      --data "$DATA" --method lgpr --out "$out" --jobs 2 > "$out.log" 2>&1
    e=$(date +%s.%N)
    echo "$side $i $(echo "$e - $s" | bc) s; $(grep -o 'fitted lgpr in [0-9.]* s' "$out.log"); $(uptime | sed 's/.*load/load/')"
  done
done
