#!/usr/bin/env bash
# Time `make test`'s venv set-up two ways, alternating, two of each: a new venv each, then the
# pinned requirements installed byte-compiled (as make does), (a) by the venv's own pip, (b) by
# uv (pinned in constraints.txt; installed into the venv by pip first, timed apart) with a new,
# empty uv cache each time, as on a fresh CI machine. Each run's installed packages (pip
# freeze, uv itself left out) are compared with the first pip run's. From the repository root:
#   bash benchmarks/ci_time/install_uv.sh > benchmarks/ci_time/install_uv.txt
set -euo pipefail
cd "$(dirname "$0")/../.."
WORK=$(mktemp -d)
VENV=$WORK/venv
echo "# $(date -u +%FT%TZ) commit $(git rev-parse --short HEAD) nproc $(nproc) load $(cut -d' ' -f1-3 /proc/loadavg)"
echo "installer tool_install_s requirements_install_s same_packages_as_pip"
for mode in pip uv pip uv; do
  rm -rf "$VENV" "$WORK/uvcache"; python3 -m venv "$VENV"
  s=$(date +%s.%N)
  if [ "$mode" = uv ]; then
    "$VENV/bin/python" -m pip install --quiet uv -c constraints.txt 2>/dev/null
  fi
  m=$(date +%s.%N)
  if [ "$mode" = uv ]; then
    UV_CACHE_DIR="$WORK/uvcache" "$VENV/bin/uv" pip install --quiet --python "$VENV/bin/python" \
      --compile-bytecode -r requirements.txt -c constraints.txt
  else
    "$VENV/bin/python" -m pip install --quiet -r requirements.txt -c constraints.txt 2>/dev/null
  fi
  e=$(date +%s.%N)
  "$VENV/bin/python" -m pip freeze 2>/dev/null | grep -v '^uv==' | sort > "$WORK/freeze_$mode"
  [ -f "$WORK/freeze_first" ] || cp "$WORK/freeze_$mode" "$WORK/freeze_first"
  same=$(cmp -s "$WORK/freeze_first" "$WORK/freeze_$mode" && echo yes || echo no)
  printf "%s %.1f %.1f %s\n" "$mode" "$(echo "$m - $s" | bc)" "$(echo "$e - $m" | bc)" "$same"
done
echo "# packages: $(wc -l < "$WORK/freeze_first")"
echo "# end $(date -u +%FT%TZ) load $(cut -d' ' -f1-3 /proc/loadavg)"
rm -rf "$WORK"
