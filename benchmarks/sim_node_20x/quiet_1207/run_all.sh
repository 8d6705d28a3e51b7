#!/bin/bash
# Every issue-27 target of sim_node and the batched simulator in one sitting, on one model and
# dataset made on the machine that day, run in this order with nothing else running. From the
# repository root:
#   MODEL=... DATA=... OUT=benchmarks/sim_node_20x/quiet_1207 bash benchmarks/sim_node_20x/quiet_1207/run_all.sh
# MODEL: littledog-mlsim train --data DATA --method lgpr --out MODEL; DATA: littledog-mlsim
# record --out DATA. Each result file holds its command and the load before and after.
set -eu
: "${MODEL:?}" "${DATA:?}" "${OUT:?}"
export OPENBLAS_NUM_THREADS=1
B=benchmarks/sim_node_20x
PY=.venv/bin/python
R="$PY $B/run.py --model $MODEL --data $DATA"
T="--phases timer --executor events --controller reactive --duration 60"
$R $T --out $OUT/default
$R $T --node-param covariance_every=8 --out $OUT/every8
$R $T --hogs 2 --out $OUT/default_hogs
$R $T --node-param covariance_every=8 --hogs 2 --out $OUT/every8_hogs
$R --phases lockstep --executor events --out $OUT/lockstep_default
$R --phases lockstep --executor events --node-param covariance_every=8 --out $OUT/lockstep_every8
$PY $B/std_tail/std_tail.py --model $MODEL --data $DATA --every "" --held 8 --local-m "" \
  --out $OUT/held
$R --phases profile,batch --batch-n 1,8,64,256 --out $OUT/probe
$PY $B/batch_bound.py --model $MODEL --data $DATA --out $OUT/batch_bound
$PY $B/batch_mean_1206/parts.py --model $MODEL --data $DATA --n 64 > $OUT/parts.txt
