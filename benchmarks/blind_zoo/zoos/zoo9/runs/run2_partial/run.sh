cd CHECKOUT
for d in clean/s41_e0 effects/g06 effects/g13 clean/s42_e0; do
  n=$(echo $d | tr / _)
  s=$(date +%s)
  OPENBLAS_NUM_THREADS=1 PYTHONPATH=CHECKOUT .venv/bin/python -m littledog_mlsim.cli diagnose --data WORK/$d --out OUT/$n --no-figures --jobs 2 --physics off --rollout-route > OUT/$n.log 2>&1
  echo "$n rc=$? $(( $(date +%s) - s )) s $(uptime)" >> OUT/times
done
