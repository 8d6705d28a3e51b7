#!/bin/bash
# diagnose zoo46 datasets again with the working tree's code (not blind), one at a time:
#   REPO=. WORK=<zoo46 work directory> bash diag.sh z07 z05 ...
cd "${REPO:?set REPO to the repository root}"
export OPENBLAS_NUM_THREADS=1
W="${WORK:?set WORK to the work directory}"
T=$W/calibrated_twin_servo_auto_add_asked_2_bootstrap_1_bootstrap_replicates_2_weighed_mass_2_97_weighed_mass_sd_0_01.json
mkdir -p $W/diag051
for id in "$@"; do
  case $id in clean*) D=$W/clean/${id#clean_};; *) D=$W/effects/$id;; esac
  start=$(date +%s)
  .venv/bin/python -P -m littledog_mlsim.cli diagnose --data $D --out $W/diag051/$id --no-figures --jobs 2 --twin $T --reference $W/reference > $W/diag051/diag_$id.log 2>&1
  rc=$?
  echo "$id $(( $(date +%s) - start )) s rc=$rc load $(cut -d' ' -f1-3 /proc/loadavg)" >> $W/diag051/diag_times.txt
done
