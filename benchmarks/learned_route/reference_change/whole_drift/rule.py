"""Decision 068's rule (README.md) on the study's rows: each condition's counts and verdict.

    .venv/bin/python benchmarks/learned_route/reference_change/whole_drift/rule.py \
        [RESULT] [--before NAME --after NAME --decision N] > rule.txt

RESULT defaults to this study's ``result.json``. The studies that reuse the rule name their
result and their two readings: decisions 069 (``../coupled_drift/result.json``, ``--before
before --after coupled --decision 069``), 070 (``../checked_drift/result.json``, ``--after
checked --decision 070``), 071 (``../coupled_fallback/result.json``, ``--after fallback
--decision 071``) and 072 (``../narrow_fallback/result.json``, ``--after narrow --decision
072``).
"""
from __future__ import annotations

import argparse
import json
from pathlib import Path

HERE = Path(__file__).resolve().parent


def right(reading: dict, truth: str) -> bool:
    """Named at the truth's family and scope."""
    return reading["named"] == truth


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("result", nargs="?", type=Path, default=HERE / "result.json")
    p.add_argument("--before", default="stiffness", help="the rows' reading before")
    p.add_argument("--after", default="whole", help="the rows' reading under the candidate")
    p.add_argument("--decision", default="068")
    a = p.parse_args()
    before, after, decision = a.before, a.after, a.decision
    rows = json.loads(a.result.read_text())["rows"]
    for r in rows:
        r["stiffness"], r["whole"] = r[before], r[after]
    seen, unique = set(), []
    for r in rows:                               # one row per recording
        if (r["zoo"], r["data"]) not in seen:
            seen.add((r["zoo"], r["data"]))
            unique.append(r)
    drifts = [r for r in unique if r["truth"].startswith("time_drift") and not r["excitation"]]
    clean = [r for r in unique if r["truth"] == "clean" and not r["excitation"]]
    other = [r for r in unique if r["truth"] not in ("clean",)
             and not r["truth"].startswith("time_drift")]
    out = [f"rows: {len(unique)} recordings ({len(rows)} rows); time drifts without excitation "
           f"{len(drifts)}, clean without excitation {len(clean)}, other effects {len(other)}"]
    before = [r for r in drifts if right(r["stiffness"], r["truth"])]
    after = [r for r in drifts if right(r["whole"], r["truth"])]
    lost = [f"{r['zoo']} {r['data']}" for r in before if not right(r["whole"], r["truth"])]
    gain = len(after) - len(before)
    ok1 = gain >= 2 and not lost
    out.append(f"1. gain: drifts named right {len(before)} -> {len(after)} ({gain:+d}); lost: "
               f"{', '.join(lost) or 'none'} -> {'holds' if ok1 else 'fails'}")
    new_named = [f"{r['zoo']} {r['data']}" for r in clean
                 if r["whole"]["named"] and not r["stiffness"]["named"]]
    new_conf = [f"{r['zoo']} {r['data']}" for r in clean
                if r["whole"]["confirmed"] and not r["stiffness"]["confirmed"]]
    ok2 = not new_named and not new_conf
    out.append(f"2. clean: named {sum(bool(r['stiffness']['named']) for r in clean)} -> "
               f"{sum(bool(r['whole']['named']) for r in clean)} (newly: "
               f"{', '.join(new_named) or 'none'}); 028 confirmed "
               f"{sum(r['stiffness']['confirmed'] for r in clean)} -> "
               f"{sum(r['whole']['confirmed'] for r in clean)} (newly: "
               f"{', '.join(new_conf) or 'none'}) -> {'holds' if ok2 else 'fails'}")
    broke = [f"{r['zoo']} {r['data']}" for r in other if right(r["stiffness"], r["truth"])
             and r["whole"]["named"] != r["stiffness"]["named"]]
    to_drift = [f"{r['zoo']} {r['data']}" for r in other
                if (r["whole"]["named"] or "").startswith("time_drift")
                and not (r["stiffness"]["named"] or "").startswith("time_drift")]
    changed = [f"{r['zoo']} {r['data']}: {r['stiffness']['named']} -> {r['whole']['named']}"
               for r in other if r["whole"]["named"] != r["stiffness"]["named"]
               and f"{r['zoo']} {r['data']}" not in broke + to_drift]
    ok3 = not broke and not to_drift and len(changed) <= 2
    out.append(f"3. nothing else: named right and changed: {', '.join(broke) or 'none'}; newly "
               f"a drift: {', '.join(to_drift) or 'none'}; other changes {len(changed)}"
               + "".join(f"\n   - {c}" for c in changed)
               + f" -> {'holds' if ok3 else 'fails'}")
    out.append(f"decision {decision} {'adopted' if ok1 and ok2 and ok3 else 'not adopted'}")
    excited = [r for r in unique if r["truth"].startswith("time_drift") and r["excitation"]]
    out.append("beside the rule:")
    for r in drifts + excited:
        rates = r.get("rates_at_truth_scope") or {}
        out.append(f"   {r['zoo']} {r['data']} {r['truth']} {r['truth_params']} exc "
                   f"{r['excitation']:g}: before {r['stiffness']['named'] or 'nothing'} "
                   f"(kept {r['stiffness']['family']}, {r['stiffness']['explained']}; 028 "
                   f"{r['stiffness']['confirmed']}), after {r['whole']['named'] or 'nothing'} "
                   f"(kept {r['whole']['family']}, {r['whole']['explained']}; 028 "
                   f"{r['whole']['confirmed']}); rate 038 {rates.get('stiffness_slope')}, "
                   f"with t dq {rates.get('with_t_dq')}")
    other_conf = [f"{r['zoo']} {r['data']}" for r in other
                  if r["whole"]["confirmed"] != r["stiffness"]["confirmed"]]
    out.append(f"   other effects whose 028 reading at all joints changed: "
               f"{', '.join(other_conf) or 'none'}")
    print("\n".join(out))


if __name__ == "__main__":
    main()
