"""Decision 072 on read zoos: a drift decision 071 names at all joints, named at the narrower
scope whose joints' coupled drift, acting on every joint, explains as much.

    OPENBLAS_NUM_THREADS=1 .venv/bin/python \
        benchmarks/learned_route/reference_change/narrow_fallback/narrow_fallback.py \
        --zoo-dir WORK --truth benchmarks/blind_zoo/zoos/zooNN/truth.yaml --label zooNN \
        --out OUT [--only IDS]

The rows are ``../whole_drift/whole_drift.py``'s (its module doc), read under two rules:
``before`` (``change.COUPLED_FALLBACK`` True, as in the package; every other flag of
``whole_drift.FLAGS`` off) and ``narrow`` (``change.NARROW_FALLBACK`` True as well).
"""
from __future__ import annotations

import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "whole_drift"))

import whole_drift  # noqa: E402

RULES = {"before": {"COUPLED_FALLBACK": True},
         "narrow": {"COUPLED_FALLBACK": True, "NARROW_FALLBACK": True}}
TITLE = ("Decision 072 on read zoos: a coupled drift named at all joints, at the narrower "
         "scope that explains as much")

if __name__ == "__main__":
    whole_drift.main(RULES, TITLE, __doc__)
