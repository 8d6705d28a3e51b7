#!/bin/bash
# The cost of importing the package in a new Python process, with and without its modules
# byte-compiled (README.md). Clones HEAD into a temporary directory (no __pycache__), and times
# N new processes that import what the CLI, the nodes and the diagnosis import: first without
# bytecode (PYTHONDONTWRITEBYTECODE=1, as on this machine: nothing is written), then after
# `python -m compileall -q littledog_mlsim` (what `make test` runs first). Alternating rounds.
# Usage: bash benchmarks/ci_time/pyc/import_cost.sh [N] > benchmarks/ci_time/pyc/import_cost.txt
set -euo pipefail
N=${1:-8}
REPO=$(git rev-parse --show-toplevel)
PY=$REPO/.venv/bin/python
TMP=$(mktemp -d)
trap 'rm -rf "$TMP"' EXIT
git clone -q "$REPO" "$TMP/a"
git clone -q "$REPO" "$TMP/b"
(cd "$TMP/b" && "$PY" -m compileall -q littledog_mlsim > /dev/null)
echo "# commit $(git -C "$REPO" rev-parse --short HEAD), $(date -u '+%Y-%m-%d %H:%M UTC'), load $(cut -d' ' -f1-3 /proc/loadavg), $(nproc) cores"
echo "# N=$N processes each, alternating; PYTHONDONTWRITEBYTECODE=1; user+sys CPU seconds per process"
export PYTHONDONTWRITEBYTECODE=1 OPENBLAS_NUM_THREADS=1
IMPORT="import littledog_mlsim.cli, littledog_mlsim.diagnose, littledog_mlsim.robot.sim, littledog_mlsim.nodes"
for i in $(seq "$N"); do
  for v in a b; do
    t=$( { cd "$TMP/$v" && PYTHONPATH="$TMP/$v" /usr/bin/time -f "%U %S" "$PY" -P -c "$IMPORT" 2>&1 >/dev/null | tail -1; } )
    echo "$v $t"
  done
done | "$PY" -c '
import statistics, sys
rows = [l.split() for l in sys.stdin if l.strip()]
for r in rows:
    print(" ".join(r))
for v, label in (("a", "without bytecode"), ("b", "byte-compiled")):
    cpu = [float(r[1]) + float(r[2]) for r in rows if r[0] == v]
    print(f"# median {label} ({v}): {statistics.median(cpu):.2f} s CPU per process")
'
echo "# load after: $(cut -d' ' -f1-3 /proc/loadavg)"
