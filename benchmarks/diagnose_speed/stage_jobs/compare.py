"""Two diagnoses of the same data compared: wall time, each stage's report-model fit and
score time, and whether the stages' scores and what was found are the same.

    .venv/bin/python benchmarks/diagnose_speed/stage_jobs/compare.py \
        --before BEFORE/report.json --after AFTER/report.json \
        --out benchmarks/diagnose_speed/stage_jobs/z06

Writes OUT.md and OUT.json.
"""
from __future__ import annotations

import argparse
import json
from pathlib import Path

import numpy as np


def _found(r: dict) -> list[str]:
    rr = r.get("rollout_route") or {}
    return ([e.get("label") or e.get("augmentation") for e in r.get("effects", [])]
            + [e.get("label") for e in rr.get("effects", [])])


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--before", type=Path, required=True)
    p.add_argument("--after", type=Path, required=True)
    p.add_argument("--out", type=Path, required=True)
    a = p.parse_args()
    b, f = (json.loads(x.read_text()) for x in (a.before, a.after))
    rows = []
    for k, (sb, sa) in enumerate(zip(b["stages"], f["stages"])):
        nb, na = (np.array(list(x["nmse"].values()) if isinstance(x["nmse"], dict)
                           else x["nmse"], float) for x in (sb, sa))
        rb, ra = (np.array([v["final_xy_error_m"] for v in x["rollout"].values()], float)
                  for x in (sb, sa))
        rows.append({"stage": k, "before_s": sb["fit_and_score_seconds"],
                     "after_s": sa["fit_and_score_seconds"],
                     "nmse_same": sb["nmse"] == sa["nmse"],
                     "nmse_max_rel_diff": float(np.max(np.abs(na - nb) / np.abs(nb))),
                     "rollout_same": sb["rollout"] == sa["rollout"],
                     "final_xy_max_rel_diff": float(np.max(np.abs(ra - rb) / np.abs(rb)))})
    out = {"before": str(a.before), "after": str(a.after),
           "before_seconds": b.get("seconds"), "after_seconds": f.get("seconds"),
           "same_found": _found(b) == _found(f), "found": _found(f),
           "n_stages": [len(b["stages"]), len(f["stages"])], "stages": rows}
    a.out.with_suffix(".json").write_text(json.dumps(out, indent=1))
    L = ["| stage | fit and score before [s] | after [s] | nMSE the same (largest relative "
         "difference) | final xy error the same (largest relative difference) |",
         "|---|---|---|---|---|"]
    L += [f"| {r['stage']} | {r['before_s']:.1f} | {r['after_s']:.1f} | "
          f"{'yes' if r['nmse_same'] else 'no'} ({r['nmse_max_rel_diff']:.1e}) | "
          f"{'yes' if r['rollout_same'] else 'no'} ({r['final_xy_max_rel_diff']:.1e}) |"
          for r in rows]
    L += ["", f"diagnose: {out['before_seconds']:.0f} s before, {out['after_seconds']:.0f} s "
          f"after; the same effects found: {'yes' if out['same_found'] else 'no'} "
          f"({', '.join(map(str, out['found']))})"]
    a.out.with_suffix(".md").write_text("\n".join(L) + "\n")


if __name__ == "__main__":
    main()
