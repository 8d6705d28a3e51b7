"""Print what `record.py` recorded, round by round: the wide refits (J/J0 on the screening
moves before, on all fit moves after, re-simulations), the located pass (J/J0 at its start and
after its fit) and the held-out decision (each hypothesis's mean per-move cut).

    python benchmarks/diagnose_speed/contention/show.py RECORD.json [...]
"""
from __future__ import annotations

import json
import sys


def show(path: str) -> None:
    rec = json.load(open(path, encoding="utf-8"))
    print(f"# {path}: {rec['seconds']:.1f} s, {rec['sims']} re-simulations, code {rec['code']}")
    print("sims by step:", ", ".join(f"{k} {v}" for k, v in sorted(
        rec["sims_by_step"].items(), key=lambda kv: -kv[1])))
    for k, r in enumerate(rec["rounds"]):
        print(f"\n## round {k + 1}: {r.get('seconds', 0):.1f} s, {r.get('sims', 0)} sims")
        print("wide refits (kind, family scope, J/J0 screening -> fit moves, sims):")
        for w in r["wide"]:
            a, b = w["rel_screening"], w["rel_fit_moves"]
            print(f"  {w['kind']:12s} {w['family']} {w['scope']}: "
                  f"{a if a is None else round(a, 3)} -> {b if b is None else round(b, 3)}"
                  f"  ({w['sims']} sims{', known' if w['known'] else ''})")
        if r["located"]:
            starts = {(s["family"], s["scope"]): s["J_start"] for s in r["located_start"]}
            print("located pass (J/J0 at start -> fitted), joined:", r.get("located_joined"))
            for c in r["located"]:
                js = starts.get((c["family"], c["scope"]))
                st = None if js is None or not c["J0"] else round(js / c["J0"], 3)
                print(f"  {c['family']} {c['scope']}: {st} -> {round(c['rel'], 3)}")
        h = r["held_out"]
        if h:
            print("held out (move cut; * chosen; s significant):")
            order = sorted(range(len(h["move_cut"])), key=lambda i: -h["move_cut"][i])
            for i in order:
                x = h["hypotheses"][i]
                rel = x["rel_fit_moves"]
                print(f"  {'*' if i == h['chosen'] else ' '}{'s' if h['significant'][i] else ' '}"
                      f" {h['move_cut'][i]:8.3f}  {x['kind']:12s} {x['family']} {x['scope']}"
                      f"  J/J0 {rel if rel is None else round(rel, 3)}")


if __name__ == "__main__":
    for p in sys.argv[1:]:
        show(p)
