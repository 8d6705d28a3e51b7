#!/usr/bin/env bash
# Time `make test`'s venv set-up: pip install of the pinned requirements into a new venv, with
# pip's default byte-compiling and with --no-compile, then the first import of the heavy
# packages (which compiles what --no-compile left). Run from the repository root:
#   bash benchmarks/ci_time/install.sh > benchmarks/ci_time/install.txt
set -euo pipefail
cd "$(dirname "$0")/../.."
VENV=$(mktemp -d)/venv
echo "# $(date -u +%FT%TZ) commit $(git rev-parse --short HEAD) nproc $(nproc) load $(cut -d' ' -f1-3 /proc/loadavg)"
echo "mode install_s first_import_s"
for mode in compile no-compile; do
  rm -rf "$VENV"; python3 -m venv "$VENV"
  flag=(); [ "$mode" = no-compile ] && flag=(--no-compile)
  s=$(date +%s.%N)
  "$VENV/bin/python" -m pip install --quiet "${flag[@]}" -r requirements.txt -c constraints.txt 2>/dev/null
  m=$(date +%s.%N)
  "$VENV/bin/python" -c "import numpy, scipy, sklearn, dask, distributed, pybullet, rclpy, matplotlib, rosbags, viser" >/dev/null 2>&1
  e=$(date +%s.%N)
  printf "%s %.1f %.1f\n" "$mode" "$(echo "$m - $s" | bc)" "$(echo "$e - $m" | bc)"
done
echo "# end $(date -u +%FT%TZ) load $(cut -d' ' -f1-3 /proc/loadavg)"
rm -rf "$(dirname "$VENV")"
