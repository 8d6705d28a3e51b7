"""Decision 045's reruns against run5's reports: for each rerun recording, whether the effects
(family, scope, parameters), `significant` and `physics.reference.unexplained` are run5's, and
what the rerun adds (`remainder`, `stand_in`, the statement), with both runs' seconds and
re-simulations.

    python3 compare.py --rerun OUT [--ids z02,z06,z01] > result.md

OUT holds one diagnose output directory per id (OUT/z02/report.json, ...); run5's reports are
read from ../reports/.
"""
from __future__ import annotations

import argparse
import json
from pathlib import Path

HERE = Path(__file__).resolve().parent


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--rerun", type=Path, required=True)
    ap.add_argument("--ids", default="z02,z06,z01")
    a = ap.parse_args()
    print("| id | effects as run5 | significant as run5 | unexplained as run5 | ratio without / with the findings | share removed | reading | stand_in | seconds run5 / rerun | re-simulations run5 / rerun |")
    print("|---|---|---|---|---|---|---|---|---|---|")
    statements = []
    for z in a.ids.split(","):
        old = json.loads((HERE.parent / "reports" / z / "report.json").read_text())
        new = json.loads((a.rerun / z / "report.json").read_text())
        key = lambda d: [(e["family"], e["physical"]["scope"], e["params"]) for e in d["effects"]]
        u = lambda d: d["physics"]["reference"]["unexplained"]
        rem = [e.get("remainder") for e in new["effects"]]
        r = rem[0] if rem and rem[0] else {}
        share = r.get("share_of_excess_removed")
        print(f"| {z} | {key(old) == key(new)} | {old['significant'] == new['significant']} | "
              f"{u(old) == u(new)} | "
              + (f"{r['ratio_before']:.2f} / {r['ratio_after']:.2f}" if r else "-") + " | "
              + ("-" if share is None else f"{100 * share:.0f} %") + " | "
              + f"{r.get('reading', '-')} | {[e.get('stand_in') for e in new['effects']]} | "
              f"{old['seconds']:.0f} / {new['seconds']:.0f} | "
              f"{old['physics']['n_simulations']} / {new['physics']['n_simulations']} |")
        statements += [f"- {z}: {e['physical']['statement']}" for e in new["effects"]]
    print("\nThe reruns' statements:\n")
    print("\n".join(statements))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
