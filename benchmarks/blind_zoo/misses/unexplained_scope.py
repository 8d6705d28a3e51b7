"""Where an unexplained excess over the reference was named, against the truth's scope, and
what one other rule would have named: a reading aid over the committed blind runs.

    .venv/bin/python benchmarks/blind_zoo/misses/unexplained_scope.py > benchmarks/blind_zoo/misses/unexplained_scope.md

For every committed report (``zoos/*/runs/*/reports/*/report.json``) whose
``physics.reference.unexplained`` was named, it prints the truth (the zoo's ``truth.yaml``),
the scope named (decision 048's body share over the location rule), the channel with the
largest ratio over the reference, the body's pooled ratio and the best joint scope's, and the
scope the rule "the body where the largest channel ratio is a body channel" would name. It
counts, over effects outside the vocabulary (``other``), the scopes each rule names right.
Nothing is re-simulated; it reads files only.
"""
from __future__ import annotations

import glob
import json
from pathlib import Path

import yaml

ROOT = Path(__file__).resolve().parents[1] / "zoos"


def _truths(zoo: Path) -> dict[str, dict]:
    try:
        doc = yaml.safe_load((zoo / "truth.yaml").read_text())
    except (OSError, yaml.YAMLError):
        return {}
    items = doc.get("effects") if isinstance(doc, dict) else doc
    return {e.get("id"): e for e in items} if isinstance(items, list) else {}


def _is_body(channel: str) -> bool:
    return not channel.split(":", 1)[-1].startswith("q_")


def main() -> None:
    print("| zoo | run | effect | truth | named | largest channel (ratio) | body | best joint scope "
          "| largest-channel rule |")
    print("|---|---|---|---|---|---|---|---|---|")
    right = {"named": 0, "rule": 0}
    n = 0
    for run in sorted(glob.glob(str(ROOT / "*" / "runs" / "*"))):
        zoo = Path(run).parents[1]
        truth = _truths(zoo)
        for rep in sorted(glob.glob(run + "/reports/*/report.json")):
            rid = Path(rep).parent.name
            u = ((json.loads(Path(rep).read_text()).get("physics") or {}).get("reference")
                 or {}).get("unexplained")
            if not u or not u.get("named") or rid not in truth:
                continue
            t = truth[rid]
            ch = u.get("channels") or []
            sr = u.get("scope_ratios") or {}
            joint = max(((k, v) for k, v in sr.items() if k != "body"), key=lambda x: x[1],
                        default=("-", 0.0))
            rule = ("body" if ch and _is_body(ch[0]["channel"]) else joint[0])
            top = f"{ch[0]['channel']} ({ch[0]['ratio']:.1f})" if ch else "-"
            print(f"| {zoo.name} | {Path(run).name} | {rid} | {t.get('family')} @ {t.get('scope')} "
                  f"| {u.get('scope')} | {top} | {sr.get('body', 0):.2f} | {joint[0]} "
                  f"{joint[1]:.2f} | {rule} |")
            if t.get("family") == "other" and Path(run).name == "run1":
                n += 1
                right["named"] += u.get("scope") == t.get("scope")
                right["rule"] += rule == t.get("scope")
    print(f"\nEffects outside the vocabulary, first runs: {n}; scope right as named "
          f"{right['named']}, by the largest-channel rule {right['rule']}.")


if __name__ == "__main__":
    main()
