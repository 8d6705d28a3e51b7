"""Decision 070 on read zoos: a coupled drift (decision 069) checked against a coupled servo
response and named at a narrower scope that explains nearly as much, against the screen as
committed.

    OPENBLAS_NUM_THREADS=1 .venv/bin/python \
        benchmarks/learned_route/reference_change/checked_drift/checked_drift.py --zoo-dir WORK \
        --truth benchmarks/blind_zoo/zoos/zooNN/truth.yaml --label zooNN --out OUT [--only IDS]

The rows are ``../whole_drift/whole_drift.py``'s (its module doc), read under two rules:
``before`` (every flag of ``whole_drift.FLAGS`` off) and ``checked``
(``change.DRIFT_COUPLED`` and ``change.COUPLED_CHECKED`` True).
"""
from __future__ import annotations

import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "whole_drift"))

import whole_drift  # noqa: E402

RULES = {"before": {}, "checked": {"DRIFT_COUPLED": True, "COUPLED_CHECKED": True}}
TITLE = "Decision 070 on read zoos: a coupled drift, checked"

if __name__ == "__main__":
    whole_drift.main(RULES, TITLE, __doc__)
