"""Decision 030 on read zoos: a family is kept only where its column alone explains as much as
the servo response alone.

    OPENBLAS_NUM_THREADS=1 .venv/bin/python \
        benchmarks/learned_route/reference_change/family_alone.py --zoo-dir WORK16 \
        --truth benchmarks/blind_zoo/zoos/zoo16/truth.yaml --label zoo16 --out OUT

WORK16 holds a zoo's recordings as the blind-zoo harness writes them (``reference``,
``effects/zNN``, ``clean/sNNN_e0``). For every effect and clean seed, the search model fitted on
the whole reference at the route's start feature set (the measured robot's) is read through
:func:`littledog_mlsim.diagnose.change.reference_change`, as a diagnosis whose search accepted
nothing would read it; the table gives where it locates a change, the servo response's and each
family's best held-out one-step SSE alone at that scope (relative to the servo's; a family
"stands" at 1.00 or below), the families kept on top of the servo response, and what is named,
beside the truth (these zoos' truth has been read). Writes OUT.md and OUT.json (appending rows
where OUT.json exists).
"""
from __future__ import annotations

import json
import os
import sys
import time
from pathlib import Path

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
sys.path[:0] = [str(Path(__file__).resolve().parents[3]), str(Path(__file__).resolve().parents[2])]

from _common import appended_study, study_commands, zoo_study_parser, zoo_truth  # noqa: E402

from littledog_mlsim.data.dataset import load_moves   # noqa: E402
from littledog_mlsim.diagnose.candidates import measured_robot_features   # noqa: E402
from littledog_mlsim.diagnose.change import reference_change   # noqa: E402
from littledog_mlsim.diagnose.learned import LearnedOptions, _Route   # noqa: E402


def write_md(doc: dict, path: Path) -> None:
    """The study's table of ``doc``'s rows, under its commands."""
    lines = ["# Decision 030 on read zoos: a family stands alone or is not kept", ""]
    lines += study_commands(doc)
    fams = ["command_delay", "command_filter", "backlash", "contact_phase", "time_drift"]
    lines += ["", "Alone: each family's best held-out one-step SSE at the scope, its column and a "
              "constant, over the servo response's alone (at most 1.00: it stands).", "",
              "| zoo | data | truth | ratio | located by | scope | servo ok | "
              + " | ".join(f"alone: {f}" for f in fams) + " | kept | explained | named | params |",
              "|---" * (11 + len(fams)) + "|"]
    for r in doc["rows"]:
        al = [f"{r['alone'][f]:.2f}" if f in r["alone"] else "" for f in fams]
        ex = "" if r["explained"] is None else f"{r['explained']:.2f}"
        lines.append(
            f"| {r['zoo']} | {r['data']} | {r['truth']} | {r['all_rows_ratio']:.2f} | "
            f"{r['located_by'] or ''} | {r['scope']} | "
            f"{'' if r['servo_ok'] is None else r['servo_ok']} | " + " | ".join(al)
            + f" | {r['family'] or ''} | {ex} | {r['named'] or ''} | {r['params'] or ''} |")
    path.write_text("\n".join(lines) + "\n")


def main() -> None:
    p = zoo_study_parser(__doc__.splitlines()[0])
    a = p.parse_args()
    opts, start = LearnedOptions(), measured_robot_features()
    quiet = lambda s: None  # noqa: E731
    truth = zoo_truth(a.truth)
    ref = _Route(load_moves(a.zoo_dir / "reference", "train"), start, opts, quiet)
    ref_fit = ref.fit(start, one_step=True)
    out_json = a.out.with_suffix(".json")
    doc = appended_study(out_json)
    data = (sorted(d for d in (a.zoo_dir / "effects").iterdir() if d.is_dir())
            + sorted(d for d in (a.zoo_dir / "clean").iterdir() if d.is_dir()))
    for d in data:
        t = time.perf_counter()
        r = _Route(load_moves(d, "train"), start, opts, quiet)
        c = reference_change(r, ref, start, None, None, ref_fit)
        hyps = c["hypotheses"]
        servo = next((h for h in hyps if h["stage"] == "servo"), None)
        alone = {h["family"]: round(h["sse"] / servo["sse"], 3)
                 for h in hyps if h["stage"] == "alone"} if servo and "sse" in servo else {}
        voc = c.get("vocabulary") or {}
        row = {"zoo": a.label, "data": d.name, "truth": truth.get(d.name, "clean"),
               "all_rows_ratio": round(c["ratio"], 2), "located_by": c["located_by"],
               "scope": c["scope"], "servo_ok": None if servo is None else bool(
                   servo["significant"] and servo["material"]),
               "alone": alone, "family": c.get("family"),
               "explained": None if c.get("explained") is None else round(c["explained"], 3),
               "named": (f"{voc['family']} @ {voc['scope']}" if c["named"] else None),
               "params": voc.get("params"), "seconds": round(time.perf_counter() - t, 1)}
        doc["rows"].append(row)
        print(row, flush=True)
    out_json.write_text(json.dumps(doc, indent=1))
    write_md(doc, a.out.with_suffix(".md"))


if __name__ == "__main__":
    main()
