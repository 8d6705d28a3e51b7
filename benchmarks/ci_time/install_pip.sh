#!/usr/bin/env bash
# Time `make test`'s venv set-up with the pip that Python's venv brings and with a newer pip
# (PIN, default 26.2.1), alternating, two of each: a new venv each, then pip install of the
# pinned requirements (byte-compiling, as make does). The newer pip's own install is timed
# apart. Run from the repository root:
#   bash benchmarks/ci_time/install_pip.sh [PIN] > benchmarks/ci_time/install_pip.txt
set -euo pipefail
cd "$(dirname "$0")/../.."
PIN=${1:-26.2.1}
WORK=$(mktemp -d)
VENV=$WORK/venv
echo "# $(date -u +%FT%TZ) commit $(git rev-parse --short HEAD) nproc $(nproc) load $(cut -d' ' -f1-3 /proc/loadavg)"
echo "pip pip_install_s requirements_install_s"
for mode in venv pinned venv pinned; do
  rm -rf "$VENV"; python3 -m venv "$VENV"
  s=$(date +%s.%N)
  [ "$mode" = pinned ] && "$VENV/bin/python" -m pip install --quiet "pip==$PIN" 2>/dev/null
  m=$(date +%s.%N)
  "$VENV/bin/python" -m pip install --quiet -r requirements.txt -c constraints.txt 2>/dev/null
  e=$(date +%s.%N)
  printf "%s %.1f %.1f\n" "$("$VENV/bin/python" -m pip --version | cut -d' ' -f2)" \
    "$(echo "$m - $s" | bc)" "$(echo "$e - $m" | bc)"
done
echo "# end $(date -u +%FT%TZ) load $(cut -d' ' -f1-3 /proc/loadavg)"
rm -rf "$WORK"
