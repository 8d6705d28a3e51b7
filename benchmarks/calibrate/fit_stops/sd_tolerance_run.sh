#!/bin/bash
# zoo54 run1's calibrate command with --sd-tolerance 0.1 (not blind)
export OPENBLAS_NUM_THREADS=1 PYTHONPATH=CLONE_WITH_PATCH
cd WORK
start=$(date +%s)
.venv/bin/python -P -m littledog_mlsim.cli calibrate --data REFERENCE --robot nominal --out WORK/twin.json --servo auto --add-asked 2 --bootstrap 1 --bootstrap-replicates 2 --split-starts 0.15 --weighed-mass 3.33 --weighed-mass-sd 0.01 --sd-tolerance 0.1 > out.txt 2> calibrate.log
echo $? > rc; echo $(( $(date +%s) - start )) > seconds
