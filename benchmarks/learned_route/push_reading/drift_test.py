"""The drift against the reference as a test: does it tell a push from every other effect?

    OPENBLAS_NUM_THREADS=1 .venv/bin/python benchmarks/learned_route/push_reading/drift_test.py \
        --zoo-dir WORK23 --truth benchmarks/blind_zoo/zoos/zoo23/truth.yaml --label zoo23 \
        --out OUT

WORK23 holds a zoo's recordings as the blind-zoo harness writes them (``reference``,
``effects/zNN``, ``clean/sNNN_eE``). For every effect and clean recording, the TrainPool's drift
against the reference's (:func:`littledog_mlsim.diagnose.push.drift_against_reference`,
decision 025: each move's displacement minus its type's mean in the reference, turned to its
start heading, per second, in odom) with its p-value of no drift. No model is fitted. The
truth is read (these zoos have had their first run). Writes OUT.md and OUT.json (appending
rows where OUT.json exists).
"""
from __future__ import annotations

import os
import sys
from pathlib import Path

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
sys.path[:0] = [str(Path(__file__).resolve().parents[3]), str(Path(__file__).resolve().parents[2])]

from _common import appended_study, save_study, study_commands, zoo_effects, \
    zoo_study_parser  # noqa: E402

from littledog_mlsim.data.dataset import load_moves   # noqa: E402
from littledog_mlsim.diagnose.push import drift_against_reference   # noqa: E402


def write_md(doc: dict, path: Path) -> None:
    lines = ["# The drift against the reference as a test", ""] + study_commands(doc)
    lines += ["", "| zoo | recording | truth | drift [cm/s] | toward [deg] | p (no drift) | "
              "moves |", "|---|---|---|---|---|---|---|"]
    for r in doc["rows"]:
        if r["speed_cm_s"] is None:
            lines.append(f"| {r['zoo']} | {r['data']} | {r['truth']} | - | - | - | - |")
            continue
        lines.append(f"| {r['zoo']} | {r['data']} | {r['truth']} | {r['speed_cm_s']:.2f} | "
                     f"{r['direction_deg']:.0f} | {r['p_value']:.2g} | {r['n_moves']} |")
    path.write_text("\n".join(lines) + "\n")


def main() -> None:
    a = zoo_study_parser(__doc__.splitlines()[0]).parse_args()
    truth = {}
    for e in zoo_effects(a.truth):
        p = e.get("params") or {}
        extra = (f" {p['force_N']:g} N toward {p['direction_deg']:g} deg"
                 if e["family"] == "odom_force" and "force_N" in p else "")
        truth[e["id"]] = f"{e['family']} @ {e['scope']}{extra}"
    ref = load_moves(a.zoo_dir / "reference", "train")
    doc = appended_study(a.out.with_suffix(".json"))
    data = (sorted(d for d in (a.zoo_dir / "effects").iterdir() if d.is_dir())
            + sorted(d for d in (a.zoo_dir / "clean").iterdir() if d.is_dir()))
    for d in data:
        drift = drift_against_reference(load_moves(d, "train"), ref)
        x = None if drift is None else drift.to_dict()
        row = {"zoo": a.label, "data": d.name, "truth": truth.get(d.name, "clean"),
               "speed_cm_s": None if x is None else 100 * x["speed_mps"],
               "direction_deg": None if x is None else x["direction_deg"],
               "p_value": None if x is None else x["p_value"],
               "n_moves": None if x is None else x["n_moves"]}
        doc["rows"].append(row)
        print(row, flush=True)
    save_study(doc, a.out, write_md)


if __name__ == "__main__":
    main()
