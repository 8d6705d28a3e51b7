#!/bin/bash
# sim_node in timer mode, the code before and after the compiled search, alternating three times
# (catch_up.py, one run of each controller per call). BEFORE: a clone of 6bb8354 with the
# repository's .venv linked in; MODEL, DATA, OUT as in ../README.md.
export OPENBLAS_NUM_THREADS=1
M=$MODEL; D=$DATA; O=$OUT
B=benchmarks/sim_node_20x
for r in 1 2 3; do
  (cd "$BEFORE" && PYTHONPATH="$BEFORE" .venv/bin/python $B/catch_up.py --model $M --data $D --steps-per-tick 2 --repeats 1 --executor single --out $O/alt_before_$r)
  (cd "$(dirname "$0")/../../.." && .venv/bin/python $B/catch_up.py --model $M --data $D --steps-per-tick 2 --repeats 1 --executor single --out $O/alt_after_$r)
done
date -u
