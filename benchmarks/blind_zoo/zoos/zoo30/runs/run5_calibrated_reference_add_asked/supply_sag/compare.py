"""Decisions 046 and 047's reruns of zoo30 run5 against run5's reports: what each names, its
score against the truth (the harness's ``score``), the excess left and where, and the time.

    python3 compare.py --rerun OUT > result.md
"""
from __future__ import annotations

import argparse
import json
from pathlib import Path

import yaml

HERE = Path(__file__).resolve().parent
ROOT = HERE.parents[6]


def _score(truth: dict, report: dict) -> dict:
    import sys
    sys.path.insert(0, str(ROOT))
    from benchmarks.blind_zoo.harness.run import named_effects, score
    s = score(truth, report)
    s["named_list"] = [f"{p.get('family')} @ {p.get('scope')}"
                       + (f" ({json.dumps(p.get('params'))})" if p.get("params") else "")
                       for p in named_effects(report)]
    return s


def _left(report: dict) -> str:
    u = ((report.get("physics") or {}).get("reference") or {}).get("unexplained") or {}
    if not u:
        return "-"
    where = f" at {u['scope']}" if "scope" in u else ""
    return (f"{u['pooled_ratio']:.2f}x (p {u['p_value']:.2g})" + where
            + (" named" if u.get("named") else ""))


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--rerun", type=Path, required=True)
    a = ap.parse_args()
    doc = yaml.safe_load((HERE.parents[2] / "truth.yaml").read_text())
    truth = {t["id"]: t for t in doc["effects"]}
    print("| id | truth | run5: named; left | rerun: named; left | found | identified "
          "| param error | seconds |")
    print("|---|---|---|---|---|---|---|---|")
    for d in sorted(p for p in a.rerun.iterdir() if (p / "report.json").is_file()):
        new = json.loads((d / "report.json").read_text())
        run5 = HERE.parent / "reports" / d.name / "report.json"
        old = json.loads(run5.read_text()) if run5.is_file() else {"effects": []}
        t = truth.get(d.name, {"family": "none (clean)", "scope": "-", "params": {}})
        s_old, s_new = _score(t, old), _score(t, new)
        sec = new.get("seconds")
        err = s_new["param_error"]
        print(f"| {d.name} | {t['family']} @ {t['scope']} | "
              f"{'; '.join(s_old['named_list']) or 'nothing'}; {_left(old)} | "
              f"{'; '.join(s_new['named_list']) or 'nothing'}; {_left(new)} | "
              f"{s_old['found']} -> {s_new['found']} | "
              f"{s_old['identified']} -> {s_new['identified']} | "
              f"{'-' if err is None else f'{100 * err:.0f} %'} | "
              f"{'-' if sec is None else f'{sec:.0f}'} |")
        print(f"|  | significant {old.get('significant')} -> {new.get('significant')} | | "
              + "; ".join(s["why"][:160] for s in new.get("suspected", [])
                          if s.get("kind") == "unexplained") + " | | | | |")


if __name__ == "__main__":
    main()
