"""The held-frame check (decision 044) on read zoos: every effect and clean seed against the
zoo's reference, and without it.

    OPENBLAS_NUM_THREADS=1 .venv/bin/python benchmarks/diagnose/held_frames/held_frames.py \
        --zoo-dir WORK29 --truth benchmarks/blind_zoo/zoos/zoo29/truth.yaml --label zoo29 \
        --out OUT

WORK29 holds a zoo's recordings as the blind-zoo harness writes them (``reference``,
``effects/zNN``, ``clean/sNNN_eX``). Each row: the truth (these zoos' truth has been read), each
stream's held fraction and p against the reference's moves and against zero
(:func:`littledog_mlsim.diagnose.held_frames.held_frames` on the TrainPool) and what the check
names. A follow-up recording of an effect (``zNN_e0.05``: the same effect under another
condition) has that effect's truth. Writes OUT.md and OUT.json (appending rows where OUT.json
exists).
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
from littledog_mlsim.diagnose.held_frames import held_frames   # noqa: E402

STREAMS = ("pose", "joint_states")


def write_md(doc: dict, path: Path) -> None:
    """The study's table of ``doc``'s rows, under its commands."""
    lines = ["# The held-frame check on read zoos", ""]
    lines += study_commands(doc)
    lines += ["", "Per stream: the held fraction of the rows where the other stream moves "
              "(the reference's in brackets), p against the reference's moves / against zero.",
              "", "| zoo | data | truth | " + " | ".join(STREAMS)
              + " | named (against the reference) | named (no reference) |",
              "|---" * (5 + len(STREAMS)) + "|"]
    for r in doc["rows"]:
        cells = " | ".join(
            f"{100 * v['held_fraction']:.2f} % ({100 * v['reference_held_fraction']:.2f} %), "
            f"p {v['p_value']:.0e} / {v['p_alone']:.0e}" for v in r["streams"])
        lines.append(f"| {r['zoo']} | {r['data']} | {r['truth']} | {cells} | "
                     f"{r['named'] or '-'} | {r['named_alone'] or '-'} |")
    path.write_text("\n".join(lines) + "\n")


def _named(h: dict) -> str | None:
    v = h.get("vocabulary")
    if not v:
        return None
    return (f"{v['family']} @ {v['scope']}, {v['params']['stream']} held "
            f"{100 * v['params']['held_fraction']:.1f} %")


def main() -> None:
    p = zoo_study_parser(__doc__.splitlines()[0])
    a = p.parse_args()
    truth = zoo_truth(a.truth)
    ref = load_moves(a.zoo_dir / "reference", "train")
    doc = appended_study(a.out.with_suffix(".json"))
    data = (sorted(d for d in (a.zoo_dir / "effects").iterdir() if d.is_dir())
            + sorted(d for d in (a.zoo_dir / "clean").iterdir() if d.is_dir())
            + [a.zoo_dir / "reference"])
    for d in data:
        t0 = time.perf_counter()
        moves = load_moves(d, "train")
        h, alone = held_frames(moves, ref), held_frames(moves)
        p_alone = {s["stream"]: s["p_value"] for s in alone["streams"]}
        effect = d.name.split("_")[0] if d.parent.name == "effects" else d.name
        row = {"zoo": a.label, "data": d.name, "truth": truth.get(effect, "clean"),
               "streams": [{"stream": s["stream"],
                            "held_fraction": round(s["held_fraction"], 5),
                            "reference_held_fraction": round(s["reference_held_fraction"], 5),
                            "p_value": s["p_value"], "p_alone": p_alone[s["stream"]],
                            "velocity": s["velocity"]} for s in h["streams"]],
               "named": _named(h), "named_alone": _named(alone),
               "seconds": round(time.perf_counter() - t0, 1)}
        doc["rows"].append(row)
        print(row, flush=True)
    save_study(doc, a.out, write_md)


if __name__ == "__main__":
    main()
