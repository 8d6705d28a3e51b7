#!/bin/bash
# Decision 067's evidence (README.md): records open zoos' datasets with each zoo's own harness
# seeds and reads decisions 029/034/067 on them with swing_location.py. From the repository root:
#   bash benchmarks/learned_route/swing_apart/record_and_read.sh SCRATCH
# SCRATCH: a scratch directory for the recordings (WORKnn = SCRATCH/zoonn; the full zoos SCRATCH/full_zoonn). Rows are appended to
# result.json / result.md here (the swing drags) and to SCRATCH/full.json / full.md (every
# recording of zoo20 and zoo22). zoo65's rows were read from its blind run's WORK (WORK65) with
#   swing_location.py --zoo-dir WORK65 --truth benchmarks/blind_zoo/zoos/zoo65/truth.yaml \
#     --label zoo65 --out benchmarks/learned_route/swing_apart/result
set -u
S=${1:?scratch directory}
OUT=benchmarks/learned_route/swing_apart/result
export OPENBLAS_NUM_THREADS=1
record() {   # work zoo seed reference-seed clean-seeds [--only ID]
  .venv/bin/python benchmarks/blind_zoo/harness/run.py --zoo benchmarks/blind_zoo/zoos/$2 \
    --robot gap_robot.json --work $1 --out $1/out --seed $3 --clean-seeds $5 \
    --clean-seeds-excited $3 --reference-seed $4 ${6:-} --moves-per-type 10 \
    --no-follow-up --jobs 1 --record-only > $1.record.log 2>&1
}
read_swing() {   # work zoo out [swing_location options]
  w=$1; z=$2; o=$3; shift 3
  .venv/bin/python benchmarks/learned_route/reference_change/swing_location.py --zoo-dir $w \
    --truth benchmarks/blind_zoo/zoos/$z/truth.yaml --label $z --out $o "$@"
}
# each swing drag of a zoo with a gap robot and a reference, beside the effect seed's clean dataset
for c in zoo19:z09:101:107 zoo24:z03:151:157 zoo27:z01:181:187 zoo25:z09:161:167 \
         zoo30:z09:211:217 zoo16:z08:101:107 zoo20:z07:111:117 zoo17:z01:101:107 \
         zoo18:z02:101:107 zoo22:z08:131:137 zoo28:z05:191:197 zoo29:z07:201:207 \
         zoo12:z01:71:97 zoo13:z07:81:98 zoo14:z07:91:97 zoo15:z10:101:107 \
         zoo8:g10:31:80 zoo9:g08:41:90 zoo10:z09:51:95 zoo11:z13:61:96 zoo31:z10:221:227 \
         zoo43:z08:341:347 zoo51:z01:421:427 zoo62:z11:531:537 zoo63:z12:541:547; do
  IFS=: read z id s r <<< "$c"
  record $S/$z $z $s $r $s "--only $id" || { echo "record failed: $z" >&2; continue; }
  read_swing $S/$z $z $OUT --only $id,s${s}_e0
done
# every recording of zoo20 and zoo22 (the run of the README's log was stopped after zoo22 z02)
for c in zoo20:111:117 zoo22:131:137; do
  IFS=: read z s r <<< "$c"
  record $S/full_$z $z $s $r $s,$((s + 1)),$((s + 2)) && read_swing $S/full_$z $z $S/full
done
# zoo20 z05 under the rule before decision 067
read_swing $S/full_zoo20 zoo20 benchmarks/learned_route/swing_apart/result_before --only z05 \
  --no-swing-apart
