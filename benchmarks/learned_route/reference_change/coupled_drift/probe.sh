#!/bin/bash
# The probe's recordings (README.md, "What led here"), two processes; from the repository root:
#   bash benchmarks/learned_route/reference_change/coupled_drift/probe.sh SCRATCH > probe.txt
# SCRATCH holds the recordings ../whole_drift/record_and_read.sh makes.
W=${1:?scratch directory}
P=benchmarks/learned_route/reference_change/coupled_drift/probe.py
export OPENBLAS_NUM_THREADS=1
printf '%s\n' "zoo67 z12" "zoo65 z04" "zoo66 z06:type:knees,s571_e0" "zoo11 z05" "zoo46 z05" \
  "zoo48 z04:leg:front_left,z04" "zoo17 z06:type:knees" "zoo47 z02:type:hip_pitches" \
  "zoo21 z05:side:right" "zoo30 z01" "zoo31 z05" "zoo64 z05" "zoo20 z06" "zoo8 g06" |
  xargs -P 2 -L 1 bash -c '.venv/bin/python '"$P"' "$0" "$1" --work '"$W"
