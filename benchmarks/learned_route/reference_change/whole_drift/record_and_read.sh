#!/bin/bash
# Decision 068's evidence (README.md): records open zoos with each zoo's own harness seeds and
# reads both drift rules on them with whole_drift.py (or STUDY's script). From the repository root:
#   bash benchmarks/learned_route/reference_change/whole_drift/record_and_read.sh SCRATCH [PART [STUDY]]
# SCRATCH: a scratch directory for the recordings (SCRATCH/zooNN); a zoo already recorded there
# (SCRATCH/zooNN.recorded) is not recorded again: the recorder is deterministic on one machine.
# PART: full (every recording of zoo20, zoo22, zoo65-67), drifts (every other time drift of a
# zoo with a gap robot, beside its effect seed's clean recording), or both (default). Each
# part records first, then reads in two processes. Rows are appended to result.json and
# result.md here; a recording that already has a row there is not read again. Run it on a free
# machine. STUDY: the study that reads the recordings (default this one): its folder's script
# (STUDY/NAME.py, NAME the folder's name) reads, and its result.json and result.md get the rows.
# ONLY_ZOOS (environment, optional): space-separated zoos; only their recordings are recorded
# and read (a run in parts: the rows already read are not read again).
set -u
S=${1:?scratch directory}
PART=${2:-both}
mkdir -p "$S" || exit 1
D=${3:-benchmarks/learned_route/reference_change/whole_drift}
N=$(basename "$D")
export OPENBLAS_NUM_THREADS=1
skipped() {  # zoo: true where ONLY_ZOOS is set and does not name it
  [ -n "${ONLY_ZOOS:-}" ] && [[ " $ONLY_ZOOS " != *" $1 "* ]]
}
record() {   # zoo seed reference-seed clean-seeds [extra harness arguments]
  w=$S/$1
  [ -f $w.recorded ] && return 0
  .venv/bin/python benchmarks/blind_zoo/harness/run.py --zoo benchmarks/blind_zoo/zoos/$1 \
    --robot gap_robot.json --work $w --out $w/out --seed $2 --clean-seeds $4 \
    --reference-seed $3 ${5:-} --moves-per-type 10 --no-follow-up --jobs 1 --record-only \
    > $w.record.log 2>&1 && touch $w.recorded
}
reads=()     # one whole_drift.py argument line per zoo: zoo [options]
if [ "$PART" != drifts ]; then
  # every recording of five zoos: their drifts (zoo65 z04, zoo66 z06, zoo67 z12: supply sags;
  # zoo20 z06, zoo22 z07: servo gains that drift) and every other effect and clean seed
  for c in zoo67:581:587:0.05 zoo66:571:577:0.05 zoo65:561:567:0.05 zoo20:111:117: \
           zoo22:131:137:; do
    IFS=: read z s r x <<< "$c"
    skipped $z && continue
    extra="--clean-seeds-excited $s"
    [ -n "$x" ] && extra="$extra --clean-excitation $x"
    record $z $s $r $s,$((s + 1)),$((s + 2)) "$extra" || { echo "record failed: $z" >&2; continue; }
    reads+=("$z")
  done
fi
if [ "$PART" != full ]; then
  # every other time drift of a zoo with a gap robot (zoo8 on); the whole output's: zoo11 z05,
  # zoo30 z01, zoo31 z05, zoo45 z12 (excited), zoo46 z05, zoo47 z02, zoo64 z05; zoo12 z08
  # scales the P gain and the torque limit
  for c in zoo8:g06:31:80 zoo9:g11:41:90 zoo10:z01:51:95 zoo11:z05:61:96 zoo12:z08:71:97 \
           zoo13:z06:81:98 zoo45:z12:361:367 zoo46:z05:371:377 zoo47:z02:381:387 \
           zoo48:z04:391:397 \
           zoo14:z08:91:97 zoo15:z06:101:107 zoo16:z07:101:107 zoo17:z06:101:107 \
           zoo18:z03:101:107 zoo19:z02:101:107 zoo21:z05:121:127 zoo23:z04:141:147 \
           zoo24:z07:151:157 zoo25:z06:161:167 zoo26:z07:171:177 zoo27:z08:181:187 \
           zoo28:z02:191:197 zoo29:z08:201:207 zoo30:z01:211:217 zoo31:z05:221:227 \
           zoo50:z11:411:417 zoo62:z10:531:537 zoo63:z07:541:547 zoo64:z05:551:557; do
    IFS=: read z id s r <<< "$c"
    skipped $z && continue
    record $z $s $r $s "--only $id" || { echo "record failed: $z" >&2; continue; }
    reads+=("$z --only $id,s${s}_e0")
  done
fi
# the reads, two processes at a time
printf '%s\n' "${reads[@]}" | xargs -P 2 -I{} bash -c 'set -- {}; z=$1; shift; \
  .venv/bin/python '"$D/$N"'.py --zoo-dir '"$S"'/$z \
    --truth benchmarks/blind_zoo/zoos/$z/truth.yaml --label $z --out '"$D"'/result "$@" \
    > '"$S"'/$z.'"$N"'.log 2>&1 || echo "read failed: $z" >&2'
