"""The calibrated arm's rows that have a report so far (a run the session ended before it was
through): each clean run's alarm and what it named, each effect's score against the truth, as
``harness/run.py`` scores them (its own functions), and the diagnoses still to run.

    .venv/bin/python benchmarks/blind_zoo/zoos/zoo30/runs/run2_calibrated/partial.py \
        --work WORK [--arm calibrated]

WORK as in RULE.md. The harness, run again with RULE.md's command, reuses every report and runs
the rest.
"""
from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

import yaml

HERE = Path(__file__).resolve().parent
ZOO = HERE.parents[1]
sys.path.insert(0, str(ZOO.parents[1] / "harness"))
import run as harness  # noqa: E402

SEED, CLEAN, CLEAN_EXCITED = 211, (211, 212, 213), (211,)


def _load(work: Path, arm: str, name: str) -> tuple[dict | None, float | None]:
    out = work / f"diag_{arm}" / name
    if not (out / "report.json").is_file():
        return None, None
    secs = out / "seconds.txt"
    return (json.loads((out / "report.json").read_text()),
            float(secs.read_text()) if secs.is_file() else None)


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--work", type=Path, required=True)
    ap.add_argument("--arm", default="calibrated")
    a = ap.parse_args()
    truth = yaml.safe_load((ZOO / "truth.yaml").read_text())
    truth = truth.get("effects", truth) if isinstance(truth, dict) else truth
    excitations = sorted({0.0} | {float((t.get("recording") or {}).get("excitation", 0.0))
                                  for t in truth})
    lines = ["| clean run | significant (false alarm) | named | diagnose [s] |",
             "|---|---|---|---|"]
    todo = []
    for e in excitations:
        for s in (CLEAN if e == 0 else CLEAN_EXCITED):
            name = f"clean_s{s}_e{e:g}"
            report, secs = _load(a.work, a.arm, name)
            if report is None:
                todo.append(name)
                continue
            row = harness.clean_row(harness.Dataset(name, Path(), s, e, diag_seconds=secs,
                                                    report=report))
            lines.append(f"| {name} | {row['significant']} | {row['named'] or '-'} | "
                         f"{harness._fmt(secs, '.0f')} |")
    lines += ["", "| effect | truth (family @ scope) | found | identified | named | diagnose [s] |",
              "|---|---|---|---|---|---|"]
    for t in truth:
        report, secs = _load(a.work, a.arm, t["id"])
        if report is None:
            todo.append(t["id"])
            continue
        s = harness.score(t, report)
        lines.append(f"| {t['id']} | {t['family']} @ {t['scope']} | {s['found']} | "
                     f"{s['identified']} | {harness._named(s) or '-'} | "
                     f"{harness._fmt(secs, '.0f')} |")
    lines += ["", f"Not run yet: {', '.join(todo) if todo else 'none'}."]
    print("\n".join(lines))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
