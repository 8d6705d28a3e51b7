"""Decision 065's development comparison: the one-step loop with and without scoping a detected
play band by its columns, on recorded zoo datasets (not blind: the zoos' truths are open).

For each dataset: the TrainPool, the default starting feature set, ``select_effects`` with the
default library, once with ``scope_by_columns`` False (the loop before decision 065) and once
True; the accepted members of each, the scoping notes, and the seconds. A dataset directory is
``WORK/effects/ID`` or ``WORK/clean/sS_eE`` as the blind-zoo harness records it.

    OPENBLAS_NUM_THREADS=1 .venv/bin/python benchmarks/learned_route/play_scope/run.py \\
        --case zoo13:z13:/tmp/pdev/zoo13/effects/z13 --case zoo13:clean:/tmp/pdev/zoo13/clean/s81_e0 \\
        --out benchmarks/learned_route/play_scope/result
"""
from __future__ import annotations

import argparse
import json
import os
import sys
import time
from pathlib import Path

import yaml

ROOT = Path(__file__).resolve().parents[3]
sys.path.insert(0, str(ROOT))

from littledog_mlsim.data.dataset import load_moves  # noqa: E402
from littledog_mlsim.diagnose.candidates import BASELINES  # noqa: E402
from littledog_mlsim.diagnose.selection import select_effects  # noqa: E402


def truth_of(zoo: str, effect: str) -> str:
    """The truth's family @ scope (parameters) of an open zoo's effect; "clean" for a clean
    dataset."""
    if effect == "clean":
        return "clean"
    if zoo == "zoo65":
        raise SystemExit("zoo65 is sealed until its run is read")
    doc = yaml.safe_load((ROOT / "benchmarks/blind_zoo/zoos" / zoo / "truth.yaml").read_text())
    doc = doc.get("effects", doc) if isinstance(doc, dict) else doc
    (t,) = [t for t in doc if t["id"] == effect]
    return f"{t['family']} @ {t['scope']} {t.get('params')}"


def run_case(path: Path) -> dict:
    train = load_moves(path, "train")
    out = {}
    for scoped in (False, True):
        t0 = time.perf_counter()
        notes: list[str] = []
        sel = select_effects(train, BASELINES["measured"](), scope_by_columns=scoped,
                             progress=lambda s: notes.append(s))
        out["after" if scoped else "before"] = {
            "accepted": [c.label for c in sel.accepted],
            "p_values": [c.p_value for c in sel.accepted],
            "scoping_notes": [n for n in notes if "scoped by its columns" in n],
            "seconds": round(time.perf_counter() - t0, 1)}
    return out


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--case", action="append", required=True, metavar="ZOO:ID:DATASET")
    ap.add_argument("--out", required=True, help="writes OUT.json and OUT.md")
    a = ap.parse_args()
    rows = []
    for c in a.case:
        zoo, eid, path = c.split(":", 2)
        r = {"zoo": zoo, "id": eid, "dataset": path, "truth": truth_of(zoo, eid),
             **run_case(Path(path))}
        print(json.dumps(r), flush=True)
        rows.append(r)
    doc = {"command": "OPENBLAS_NUM_THREADS=%s .venv/bin/python %s" % (
               os.environ.get("OPENBLAS_NUM_THREADS"), " ".join(sys.argv)),
           "load_average": os.getloadavg(), "rows": rows}
    Path(a.out + ".json").write_text(json.dumps(doc, indent=1) + "\n")
    md = ["| zoo | id | truth | before (accepted) | after (accepted) |", "|---|---|---|---|---|"]
    md += [f"| {r['zoo']} | {r['id']} | {r['truth']} | {'; '.join(r['before']['accepted']) or '-'}"
           f" | {'; '.join(r['after']['accepted']) or '-'} |" for r in rows]
    Path(a.out + ".md").write_text(f"`{doc['command']}`\n\nLoad average at the end: "
                                   f"{doc['load_average']}\n\n" + "\n".join(md) + "\n")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
