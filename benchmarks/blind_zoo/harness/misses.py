"""Where each effect a run did not identify stood in its diagnosis: a reading aid for a run's
misses, once the truth may be read.

    .venv/bin/python benchmarks/blind_zoo/harness/misses.py RUN ZOO/truth.yaml [--all]

RUN is a collected run directory (``results.json``, ``reports/<id>/report.json``,
``logs/diagnose_<id>.log``). For each effect not identified (every effect with ``--all``) it
prints, from the physical route's evidence (every round, accepted or not):

- the truth (family, scope, primary parameter) and what the run named;
- the screen: where the truth's family stood among the round's ten best (rank, scope, score),
  and whether the truth's own family x scope was among them;
- the fit: every fitted hypothesis of the truth's family (its scope, parameters, J on the fit
  moves over the base's, held-out move cut and p), next to the chosen hypothesis's;
- the log's line of the located pass (decision 051), where it fired.

Families are compared in the vocabulary (``vocabulary_family``: a searched form such as
``supply_sag`` counts as its vocabulary family ``time_drift``). Nothing is re-simulated; it
reads files only.
"""
from __future__ import annotations

import argparse
import json
import re
import sys
from pathlib import Path
from typing import Any

import yaml

sys.path.insert(0, str(Path(__file__).resolve().parents[3]))

from benchmarks.blind_zoo.harness.run import PRIMARY  # noqa: E402
from littledog_mlsim.diagnose.families import vocabulary_family  # noqa: E402


def evidences(report: dict[str, Any]) -> list[tuple[str, dict[str, Any]]]:
    """(label, evidence) of every physical round in the report: its findings, then its
    rejected best candidate."""
    out = []
    for e in report.get("effects", []):
        ev = e.get("evidence") or {}
        if "screening_top" in ev:
            p = e.get("physical") or {}
            out.append((f"round {e.get('round')}: found {p.get('family')} @ {p.get('scope')}",
                        ev))
    for r in (report.get("physics") or {}).get("rejected", []):
        if "screening_top" in r:
            out.append((f"rejected {r.get('family')} @ {r.get('scope')}", r))
    return out


def _num(x: Any, f: str) -> str:
    return "-" if x is None else format(x, f)


def _fmt_params(params: dict[str, Any] | None) -> str:
    out = []
    for k, v in (params or {}).items():
        if isinstance(v, float):
            out.append(f"{k}={v:.3g}")
        elif isinstance(v, (int, str)) and k not in ("quantity", "form"):
            out.append(f"{k}={v}")
    return ", ".join(out)


def screen_place(ev: dict[str, Any], family: str, scope: str) -> str:
    top = ev.get("screening_top") or []
    hits = [(k + 1, c) for k, c in enumerate(top) if vocabulary_family(c["family"]) == family]
    own = any(c["scope"] == scope for _, c in hits)
    if not hits:
        return f"not in the screen's best {len(top)}"
    where = "; ".join(f"#{k} {c['family']} @ {c['scope']} ({c['score']:.2f})" for k, c in hits)
    return where + ("" if own else f"; not at {scope}")


def fitted_place(ev: dict[str, Any], family: str, scope: str) -> str:
    alts = ev.get("alternatives") or []
    hits = [a for a in alts if a.get("family") == family]
    if not hits:
        return f"not fitted ({len(alts)} fitted)"
    rows = []
    for a in hits:
        mark = "**" if a.get("scope") == scope else ""
        rows.append(f"{mark}{a.get('searched_family')} @ {a.get('scope')}{mark} "
                    f"{_fmt_params(a.get('params'))}, J {_num(a.get('J_relative'), '.3f')}, "
                    f"cut {_num(a.get('held_out_move_cut'), '.3f')} "
                    f"(p {_num(a.get('held_out_p'), '.2g')})")
    return "; ".join(rows)


def chosen(ev: dict[str, Any]) -> str:
    alts = ev.get("alternatives") or []
    if not alts:
        return "-"
    best = max(alts, key=lambda a: (float("-inf") if a.get("held_out_move_cut") is None
                                    else a["held_out_move_cut"]))
    return (f"{best.get('searched_family')} @ {best.get('scope')}, J "
            f"{_num(best.get('J_relative'), '.3f')}, cut "
            f"{_num(best.get('held_out_move_cut'), '.3f')}")


def located_line(log: Path) -> str:
    if not log.exists():
        return "(no log)"
    lines = [ln for ln in log.read_text().splitlines()
             if re.search(r"excess over the reference lives at", ln)]
    if not lines:
        return "did not fire"
    return " / ".join(ln.split("physics ", 1)[-1][:400] for ln in lines)


def _truth_value(t: dict[str, Any]) -> str:
    key = PRIMARY.get(t["family"])
    v = (t.get("params") or {}).get(key) if key else None
    return f"{key}={v}" if v is not None else _fmt_params(t.get("params"))


def rows(run: Path, truth_file: Path, every: bool) -> list[str]:
    truth = {t["id"]: t for t in yaml.safe_load(truth_file.read_text())["effects"]}
    results = json.loads((run / "results.json").read_text())
    out = []
    for row in results.get("rows", []):
        s = row.get("score") or {}
        if s.get("identified") and not every:
            continue
        t = truth.get(row["id"])
        if t is None:      # a follow-up row ("... (recommended recording)"): not the run's own
            continue
        named = "; ".join(f"{n.get('family')} @ {n.get('scope')} {_fmt_params(n.get('params'))}"
                          for n in s.get("named", [])) or "nothing"
        out.append(f"### {row['id']}: {t['family']} @ {t['scope']} ({_truth_value(t)})")
        out.append(f"- named: {named}; found {s.get('found')}, identified {s.get('identified')}")
        rep = run / "reports" / row["id"] / "report.json"
        if not rep.exists():
            out.append("- no report")
            continue
        report = json.loads(rep.read_text())
        for label, ev in evidences(report):
            out.append(f"- {label}")
            out.append(f"  - screen: {screen_place(ev, t['family'], t['scope'])}")
            out.append(f"  - fitted: {fitted_place(ev, t['family'], t['scope'])}")
            out.append(f"  - best held-out cut: {chosen(ev)}")
        log = run / "logs" / f"diagnose_{row['id']}.log"
        out.append(f"- located pass: {located_line(log)}")
        out.append("")
    return out


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("run", type=Path)
    ap.add_argument("truth", type=Path)
    ap.add_argument("--all", action="store_true", help="every effect, identified or not")
    a = ap.parse_args(argv)
    print("\n".join(rows(a.run, a.truth, a.all)))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
