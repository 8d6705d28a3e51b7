"""Decision 052 read on committed runs: every diagnosis of a physical run with a reference whose
data were recorded under another command excitation than the reference, its excess left over
the reference (``physics.reference.unexplained``) named again with the reference's excitation
(``driver.name_left``). Only the naming changes under decision 052 (the search, its stopping
and its findings do not), so this reading is what the diagnosis with decision 052 reports.

    .venv/bin/python benchmarks/blind_zoo/zoos/zoo47/runs/decision052_retro/retro.py RUN... \\
        [--reference-excitation 0] [--json OUT]

The reference's excitation is the report's ``reference_conditions`` where it has one (decision
052 on); else ``--reference-excitation``: every reference the harness records for a run's
main rows is recorded without excitation (``harness/run.py``; a follow-up row's reference is
recorded with the data's and carries the suffix "_ref"), hence the default 0. A run directory
holds ``reports/<id>/report.json``.
"""
from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[6]))

from littledog_mlsim.diagnose.conditions import Conditions  # noqa: E402
from littledog_mlsim.diagnose.physical.driver import left_suspicion, name_left  # noqa: E402

#: the most twin errors the reference may cancel (``PhysicalOptions.reference_rounds``'s
#: default, which the blind runs use)
REFERENCE_ROUNDS = 3
READING = ("named", "statement", "vocabulary", "conditions", "comparable", "concentrated")


def reread(report: dict, reference_excitation: float) -> dict | None:
    left = ((report.get("physics") or {}).get("reference") or {}).get("unexplained")
    if not left or "scope" not in left:      # none, or a report from before decision 047
        return None
    data_exc = float((report.get("dataset_info") or {}).get("command_excitation_rad") or 0.0)
    given = report.get("reference_conditions") or {}
    cond = Conditions(data_exc, float(given.get("reference_excitation_rad",
                                                reference_excitation)))
    if cond.comparable:
        return None
    raw = {k: v for k, v in left.items() if k not in READING}
    again = name_left(raw, cond)
    ref = (report.get("physics") or {}).get("reference") or {}
    capped = len(ref.get("twin_errors") or []) >= REFERENCE_ROUNDS
    sus = left_suspicion(again, capped=capped)
    return {"data_excitation_rad": data_exc, "scope": left.get("scope"),
            "pooled_ratio": left.get("pooled_ratio"), "p_value": left.get("p_value"),
            "concentration": left.get("concentration"),
            "named_before": bool(left.get("named")), "named_after": bool(again["named"]),
            "significant_before": bool(report.get("significant")),
            "significant_after": bool(report.get("effects")) or bool(again["named"]),
            "suspected_after": [s["why"] for s in sus]}


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("runs", nargs="+", type=Path)
    ap.add_argument("--reference-excitation", type=float, default=0.0)
    ap.add_argument("--json", type=Path, default=None)
    a = ap.parse_args(argv)
    rows = []
    for run in a.runs:
        for rep in sorted(run.glob("reports/*/report.json")):
            r = reread(json.loads(rep.read_text()), a.reference_excitation)
            if r is not None:
                rows.append({"run": str(run), "id": rep.parent.name, **r})
    print("| run | dataset | excitation | excess (scope, ratio, p, concentration) "
          "| named before -> after | significant before -> after |")
    print("|---|---|---|---|---|---|")
    def num(x, f):
        return "-" if x is None else format(x, f)
    for r in rows:
        print(f"| {r['run']} | {r['id']} | {r['data_excitation_rad']:g} | {r['scope']}, "
              f"{num(r['pooled_ratio'], '.2f')}x, p {num(r['p_value'], '.2g')}, "
              f"{num(r['concentration'], '.2f')} | "
              f"{r['named_before']} -> {r['named_after']} | "
              f"{r['significant_before']} -> {r['significant_after']} |")
    changed = [r for r in rows if r["named_before"] != r["named_after"]]
    print(f"\n{len(rows)} diagnoses of data recorded under another excitation than the "
          f"reference; the naming changes on {len(changed)}: "
          + (", ".join(f"{r['run']} {r['id']}" for r in changed) or "none"))
    if a.json:
        a.json.write_text(json.dumps(rows, indent=1) + "\n")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
