"""docs/report.md read as data: the key names each of its sections documents."""
from __future__ import annotations

import re
from pathlib import Path

REPORT_DOC = Path(__file__).resolve().parents[1] / "docs" / "report.md"


def documented_report_keys() -> dict[str, set[str]]:
    """docs/report.md's key names by section (``## `` or ``### `` heading): the backticked names
    of each table row's first column, and each bullet's first backticked name."""
    sections: dict[str, set[str]] = {}
    current = None
    for line in REPORT_DOC.read_text().splitlines():
        if line.startswith(("## ", "### ")):
            current = sections.setdefault(line.lstrip("#").strip(), set())
        elif current is None:
            continue
        elif line.startswith("| `"):
            current |= set(re.findall(r"`([^`]+)`", line.split("|")[1]))
        elif re.match(r"\s*- `", line):
            current.add(re.findall(r"`([^`]+)`", line)[0])
    return sections
