"""Decision 033 on the blind runs' own readings: decision 026 across excitations, by where it lives.

    OPENBLAS_NUM_THREADS=1 .venv/bin/python \
        benchmarks/learned_route/excitation_mismatch/concentrated.py \
        --run zoo20=WORK20/diag_learned+reference \
        --truth zoo20=benchmarks/blind_zoo/zoos/zoo20/truth.yaml \
        --out benchmarks/learned_route/excitation_mismatch/concentrated

Each ``--run`` is a blind run's diagnosis directory as the harness writes it (one ``NAME/
report.json`` per recording: ``zNN``, ``clean_sNNN_eE``), or the OUT directory of this study's
``run.py`` (``LABEL_NAME/report.json``). For every recording made with command
excitation (the effect's ``recording.excitation`` in the zoo's truth, or a clean name ending in
``e`` and a positive number; every zoo's reference is recorded without), the table gives decision
026's reading as the run measured it (``rollout_route.unexplained_change``: ratio, p, scope and
concentration, and the largest ratios of its scopes), whether it was significant as measured,
and whether decision 033 (:func:`littledog_mlsim.diagnose.learned.concentrated_at_joints`) counts
it across the excitations, beside the truth (read after each run), and decision 027's reading
(``reference_change``: ratio, scope, concentration), which 033 leaves set aside. No diagnosis is
run: 033 changes only whether a reading measured the same way counts.
"""
from __future__ import annotations

import argparse
import json
import os
import sys
from pathlib import Path

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
sys.path[:0] = [str(Path(__file__).resolve().parents[3]), str(Path(__file__).resolve().parents[2])]

from _common import appended_study, save_study, study_commands, zoo_effects  # noqa: E402

from littledog_mlsim.diagnose.learned import concentrated_at_joints  # noqa: E402


def _pairs(items: list[str], what: str) -> dict[str, Path]:
    out = {}
    for s in items:
        label, sep, path = s.partition("=")
        if not sep:
            raise SystemExit(f"{what} must be LABEL=PATH, got {s!r}")
        out[label] = Path(path)
    return out


def _excitation(name: str, effects: dict[str, dict]) -> float:
    if name in effects:
        return float((effects[name].get("recording") or {}).get("excitation", 0.0))
    tail = name.rpartition("_e")[2]
    try:
        return float(tail)
    except ValueError:
        return 0.0


def _rc(rc: dict) -> str:
    if rc.get("ratio") is None:
        return ""
    return f"{rc['ratio']:.1f}, {rc['scope']} ({rc['concentration']:.2f})"


def write_md(doc: dict, path: Path) -> None:
    lines = ["# Decision 026 across excitations, by where it lives (decision 033)", ""]
    lines += study_commands(doc)
    lines += ["", "| zoo | data | excitation | truth | ratio | p | scope | concentration | "
              "largest scope ratios | significant as measured | counted by 033 | "
              "decision 027: ratio, scope (concentration) |",
              "|---|---|---|---|---|---|---|---|---|---|---|---|"]
    for r in doc["rows"]:
        top = ", ".join(f"{k} {v:.2f}" for k, v in r["top_scopes"])
        lines.append(f"| {r['zoo']} | {r['data']} | {r['excitation']} | {r['truth']} | "
                     f"{r['ratio']:.2f} | {r['p_value']:.2g} | {r['scope']} | "
                     f"{r['concentration']:.2f} | {top} | {r['significant_as_measured']} | "
                     f"{r['counted']} | {_rc(r['reference_change'])} |")
    path.write_text("\n".join(lines) + "\n")


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--run", action="append", required=True, help="LABEL=DIAGDIR")
    p.add_argument("--truth", action="append", required=True, help="LABEL=truth.yaml")
    p.add_argument("--out", type=Path, required=True)
    a = p.parse_args()
    runs, truths = _pairs(a.run, "--run"), _pairs(a.truth, "--truth")
    doc = appended_study(a.out.with_suffix(".json"))
    for label, diag in runs.items():
        effects = {e["id"]: e for e in zoo_effects(truths[label])}
        dirs = sorted(x for x in diag.iterdir() if x.is_dir())
        prefixed = [x for x in dirs if x.name.startswith(f"{label}_")]   # run.py's OUT
        for d in prefixed or dirs:
            name = d.name.removeprefix(f"{label}_") if prefixed else d.name
            exc = _excitation(name, effects)
            rep = d / "report.json"
            if exc <= 0:
                continue
            if not rep.exists():
                print(f"{label} {name}: no report.json", flush=True)
                continue
            rr = json.loads(rep.read_text()).get("rollout_route") or {}
            u, rc = rr.get("unexplained_change") or {}, rr.get("reference_change") or {}
            if not u:
                continue
            e = effects.get(name)
            measured = bool(u["material"] and u["p_value"] < u["alpha"])
            top = sorted(u.get("scope_ratios", {}).items(), key=lambda kv: -kv[1])[:3]
            row = {"zoo": label, "data": name, "excitation": exc,
                   "truth": "clean" if e is None else f"{e['family']} @ {e['scope']}",
                   "ratio": u["ratio"], "p_value": u["p_value"], "scope": u["scope"],
                   "concentration": u["concentration"], "top_scopes": top,
                   "significant_as_measured": measured,
                   "counted": bool(measured and concentrated_at_joints(u)),
                   "reference_change": {k: rc.get(k) for k in ("ratio", "scope",
                                                               "concentration")}}
            doc["rows"].append(row)
            print(row, flush=True)
    save_study(doc, a.out, write_md)


if __name__ == "__main__":
    main()
