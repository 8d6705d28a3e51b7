"""What run7's README quotes from the reports that are not committed: each learned-route
report's ``start_spread`` and, for every effect and every shared finding, its statement, its
reference contrast and its scope and parameter scan (run8's README uses it too). Usage (from the repository root):

    .venv/bin/python benchmarks/blind_zoo/zoos/zoo11/runs/run7_start_spread/extract.py \
      WORK/diag_learned+reference/*/report.json
"""
from __future__ import annotations

import json
import sys


def main(paths: list[str]) -> None:
    for path in paths:
        rr = json.load(open(path))["rollout_route"]
        print(f"== {path}")
        print(f"  start_spread {rr.get('start_spread')}")
        shared = (rr.get("reference") or {}).get("shared", [])
        for kind, e in [("effect", e) for e in rr["effects"]] + [("shared", e) for e in shared]:
            c = e.get("reference") or {}
            print(f"  {kind} {e['label']} gain {e['gain']:+.3f}; p_change {c.get('p_change')} "
                  f"changed {c.get('changed')}")
            print(f"    statement: {e['statement']}")
            for s in e["scan"]:
                extra = "".join(f" {k} {s[k]}" for k in ("p_wider", "kept_scope") if k in s)
                print(f"    {s['stage']:9s} {s['label']:55s} gain {s['total_gain']:+.3f} "
                      f"p {s['p_value']:.3g}{extra}")


if __name__ == "__main__":
    main(sys.argv[1:])
