#!/bin/bash
# Decision 067's evidence: records open zoos' swing-drag effects (the effect, the effect seed's
# clean dataset, the zoo's reference, with each zoo's own harness seeds) and reads decisions
# 029/034/067 on them with swing_location.py. Usage, from the repository root:
#   bash benchmarks/learned_route/swing_apart/record_and_read.sh SCRATCH OUT
# SCRATCH: a scratch directory for the recordings; OUT: the result's path stem (OUT.md, OUT.json;
# rows are appended where OUT.json exists). zoo65's row set was read from its blind run's WORK
# (all 16 datasets) with swing_location.py --zoo-dir WORK65 first.
set -u
S=${1:?scratch directory}; OUT=${2:?output stem}
export OPENBLAS_NUM_THREADS=1
for c in zoo19:z09:101:107 zoo24:z03:151:157 zoo27:z01:181:187 zoo25:z09:161:167 zoo30:z09:211:217 zoo16:z08:101:107 zoo20:z07:111:117 zoo17:z01:101:107 zoo18:z02:101:107 zoo22:z08:131:137 zoo28:z05:191:197 zoo29:z07:201:207 zoo12:z01:71:97 zoo13:z07:81:98 zoo14:z07:91:97 zoo15:z10:101:107; do
  IFS=: read z id s r <<< "$c"
  W=$S/$z
  .venv/bin/python benchmarks/blind_zoo/harness/run.py --zoo benchmarks/blind_zoo/zoos/$z \
    --robot gap_robot.json --work $W --out $W/out --seed $s --clean-seeds $s \
    --clean-seeds-excited $s --reference-seed $r --only $id --moves-per-type 10 \
    --no-follow-up --jobs 1 --record-only > $W.record.log 2>&1 || { echo "record failed: $z" >&2; continue; }
  .venv/bin/python benchmarks/learned_route/reference_change/swing_location.py --zoo-dir $W \
    --truth benchmarks/blind_zoo/zoos/$z/truth.yaml --label $z --only $id,s${s}_e0 --out $OUT
done
