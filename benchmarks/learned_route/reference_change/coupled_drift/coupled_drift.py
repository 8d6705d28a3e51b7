"""Decision 069 on read zoos: a drift with time coupled over its scope's joints (``t (u - q)``
and ``t dq`` of every scope joint at each) against the stiffness alone (``t (u - q)``).

    OPENBLAS_NUM_THREADS=1 .venv/bin/python \
        benchmarks/learned_route/reference_change/coupled_drift/coupled_drift.py --zoo-dir WORK \
        --truth benchmarks/blind_zoo/zoos/zooNN/truth.yaml --label zooNN --out OUT [--only IDS]

The rows are ``../whole_drift/whole_drift.py``'s (its module doc), read under two rules:
``before`` (every flag of ``whole_drift.FLAGS`` off) and ``coupled``
(``change.DRIFT_COUPLED`` True).
"""
from __future__ import annotations

import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "whole_drift"))

import whole_drift  # noqa: E402

RULES = {"before": {}, "coupled": {"DRIFT_COUPLED": True}}
TITLE = "Decision 069 on read zoos: a drift with time coupled over its scope's joints"

if __name__ == "__main__":
    whole_drift.main(RULES, TITLE, __doc__)
