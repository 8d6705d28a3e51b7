#!/usr/bin/env bash
# What CI does, timed: clone this repository's HEAD into a new temporary directory (no .venv,
# nothing from the working tree), run `make test` there under /usr/bin/time, with the date and
# load before and after. From the repository root:
#   bash benchmarks/ci_time/fresh_make_test.sh > benchmarks/ci_time/suite_$(git rev-parse --short HEAD)_make_test.txt
set -u
REPO=$(cd "$(dirname "$0")/../.." && pwd)
D=$(mktemp -d /tmp/fresh_XXXX)
git clone -q "$REPO" "$D/FRESH"
cd "$D/FRESH"
date; uptime
/usr/bin/time -f "%e s wall, %U user, %S sys" make test
echo "exit $?"
date; uptime
