"""Decision 071 on read zoos: a coupled, checked drift screened only where no screen names the
change, against the screen before it.

    OPENBLAS_NUM_THREADS=1 .venv/bin/python \
        benchmarks/learned_route/reference_change/coupled_fallback/coupled_fallback.py \
        --zoo-dir WORK --truth benchmarks/blind_zoo/zoos/zooNN/truth.yaml --label zooNN \
        --out OUT [--only IDS]

The rows are ``../whole_drift/whole_drift.py``'s (its module doc), read under two rules:
``before`` (every flag of ``whole_drift.FLAGS`` off) and ``fallback``
(``change.COUPLED_FALLBACK`` True).
"""
from __future__ import annotations

import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "whole_drift"))

import whole_drift  # noqa: E402

RULES = {"before": {}, "fallback": {"COUPLED_FALLBACK": True}}
TITLE = "Decision 071 on read zoos: a coupled, checked drift where nothing is named"

if __name__ == "__main__":
    whole_drift.main(RULES, TITLE, __doc__)
