#!/bin/bash
# sim_node's lockstep (with the echo floor before it) from several code roots, alternated so that
# the machine's state acts on each alike. Usage (from anywhere; each ROOT a checkout with this
# study's echo_floor.py copied into benchmarks/sim_node_20x/ if it lacks it):
#   benchmarks/sim_node_20x/lockstep_1203/alternate.sh VENV_PYTHON MODEL DATA OUT_DIR ROUNDS ROOT...
set -eu
py=$1 model=$2 data=$3 out=$4 rounds=$5
shift 5
export OPENBLAS_NUM_THREADS=1
mkdir -p "$out"
for r in $(seq 1 "$rounds"); do
  for root in "$@"; do
    tag=$(basename "$root")
    (cd "$root" && "$py" benchmarks/sim_node_20x/echo_floor.py --model "$model" --data "$data" \
       --rounds 1 --lockstep-duration 15 --out "$out/${tag}_r$r") 2>&1 | sed "s/^/$tag r$r: /"
  done
done
