#!/bin/sh
# The float32 std from packed factors (559a6da) against square ones (BEFORE: a checkout of the
# commit before it), three alternating pairs, the float32 configuration of std_tail.py only.
#   MODEL=... DATA=... BEFORE=/path/to/checkout OUT=dir sh benchmarks/sim_node_20x/std_tail/packed_ab.sh
set -e
mkdir -p "$OUT"
for i in 1 2 3; do
  for side in before after; do
    root=$PWD; [ "$side" = before ] && root=$BEFORE
    OPENBLAS_NUM_THREADS=1 .venv/bin/python benchmarks/sim_node_20x/std_tail/std_tail.py \
      --model "$MODEL" --data "$DATA" --only float32 --code-root "$root" --out "$OUT/${side}_$i" > /dev/null
    uptime >> "$OUT/${side}_$i.load"
  done
done
.venv/bin/python - "$OUT" <<'PY'
import json, sys, pathlib
out = pathlib.Path(sys.argv[1])
rows = ["| pair | side | code | step p50 [ms] | p99 | mean | load after |", "|---|---|---|---|---|---|---|"]
for i in (1, 2, 3):
    for side in ("before", "after"):
        d = json.loads((out / f"{side}_{i}.json").read_text())
        s = d["step_cpu_ms"]
        rows.append(f"| {i} | {side} | {d['code']} | {s['p50']:.3f} | {s['p99']:.3f} | {s['mean']:.3f} | "
                    f"{(out / f'{side}_{i}.load').read_text().strip().split('load average: ')[1]} |")
(out / "packed_ab.md").write_text("\n".join(rows) + "\n")
print("\n".join(rows))
PY
