"""Decision 070's rule (README.md) on the study's rows: each condition's counts and verdict
(the conditions of ``../whole_drift/rule.py``, with ``before`` and ``checked`` as its two
readings).

    .venv/bin/python benchmarks/learned_route/reference_change/checked_drift/rule.py \
        [benchmarks/learned_route/reference_change/checked_drift/result.json] > rule.txt
"""
from __future__ import annotations

import sys
from pathlib import Path

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE.parent / "whole_drift"))

import rule  # noqa: E402  (../whole_drift/rule.py)

if __name__ == "__main__":
    rule.main("before", "checked", "070", HERE / "result.json")
