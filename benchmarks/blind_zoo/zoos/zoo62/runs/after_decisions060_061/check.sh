#!/bin/bash
# zoo62 datasets diagnosed again with run1's calibrated twin and reference, from a checkout CLONE
# of the code to test (WORK: zoo62 run1's work directory; see harness/diagnose_again.sh):
#   WORK=... CLONE=... OUT=... bash benchmarks/blind_zoo/zoos/zoo62/runs/after_decisions060_061/check.sh effects/z08 ...
HERE=$(cd "$(dirname "$0")" && pwd)
TWIN="$HERE/../run1/calibrated_twin.json" exec bash "$HERE/../../../../harness/diagnose_again.sh" "$@"
