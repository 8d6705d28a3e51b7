"""The sensor-timing check per leg (decision 033) on read zoos: every effect and clean seed
against the zoo's reference.

    OPENBLAS_NUM_THREADS=1 .venv/bin/python benchmarks/diagnose/leg_timing/leg_timing.py \
        --zoo-dir WORK19 --truth benchmarks/blind_zoo/zoos/zoo19/truth.yaml --label zoo19 \
        --out OUT

WORK19 holds a zoo's recordings as the blind-zoo harness writes them (``reference``,
``effects/zNN``, ``clean/sNNN_eX``). Each row: the truth (these zoos' truth has been read), the
whole robot's shift and p, each leg's shift and p (times the 4 legs), the legs found late and
what the check names (:func:`littledog_mlsim.diagnose.timing.sensor_timing` on the TrainPool,
against the reference's). Writes OUT.md and OUT.json (appending rows where OUT.json exists).
"""
from __future__ import annotations

import os
import sys
import time
from pathlib import Path

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
sys.path[:0] = [str(Path(__file__).resolve().parents[3]), str(Path(__file__).resolve().parents[2])]

from _common import (appended_study, save_study, study_commands, zoo_study_parser,  # noqa: E402
                     zoo_truth)

from littledog_mlsim.data.dataset import load_moves   # noqa: E402
from littledog_mlsim.diagnose.timing import sensor_timing   # noqa: E402
from littledog_mlsim.layout import LEGS   # noqa: E402


def write_md(doc: dict, path: Path) -> None:
    """The study's table of ``doc``'s rows, under its commands."""
    lines = ["# The sensor-timing check per leg on read zoos", ""]
    lines += study_commands(doc)
    lines += ["", "Shifts in ms against the reference (p: the whole robot's; each leg's times "
              "the 4 legs).", "",
              "| zoo | data | truth | whole shift | p | " + " | ".join(LEGS)
              + " | legs late | named |", "|---" * (7 + len(LEGS)) + "|"]
    for r in doc["rows"]:
        legs = " | ".join("not read" if v["shift_ms"] is None
                          else f"{v['shift_ms']:+.1f} ({v['p_value']:.0e})"
                          for v in r["per_leg"])
        lines.append(f"| {r['zoo']} | {r['data']} | {r['truth']} | {r['shift_ms']:+.1f} | "
                     f"{r['p_value']:.0e} | {legs} | {', '.join(r['late']) or '-'} | "
                     f"{r['named'] or '-'} |")
    path.write_text("\n".join(lines) + "\n")


def main() -> None:
    p = zoo_study_parser(__doc__.splitlines()[0])
    a = p.parse_args()
    truth = zoo_truth(a.truth)
    ref = load_moves(a.zoo_dir / "reference", "train")
    doc = appended_study(a.out.with_suffix(".json"))
    data = (sorted(d for d in (a.zoo_dir / "effects").iterdir() if d.is_dir())
            + sorted(d for d in (a.zoo_dir / "clean").iterdir() if d.is_dir()))
    for d in data:
        t0 = time.perf_counter()
        t = sensor_timing(load_moves(d, "train"), ref)
        voc = t.get("vocabulary") or {}
        row = {"zoo": a.label, "data": d.name, "truth": truth.get(d.name, "clean"),
               "shift_ms": round(t["shift_ms"], 2), "p_value": t["p_value"],
               "per_leg": [{"leg": r["leg"], "shift_ms": None if r["shift_ms"] is None
                            else round(r["shift_ms"], 2), "p_value": r["p_value"]}
                           for r in t["legs"]["per_leg"]],
               "late": t["legs"]["late"],
               "named": (f"{voc['family']} @ {voc['scope']}, "
                         f"{voc['params']['latency_ms']} ms {voc['params']['stream']}"
                         if voc else None),
               "seconds": round(time.perf_counter() - t0, 1)}
        doc["rows"].append(row)
        print(row, flush=True)
    save_study(doc, a.out, write_md)


if __name__ == "__main__":
    main()
