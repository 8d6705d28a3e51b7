"""Decision 029 on read zoos: where a change is located in one leg's swing, and what is named.

    OPENBLAS_NUM_THREADS=1 .venv/bin/python \
        benchmarks/learned_route/reference_change/swing_location.py --zoo-dir WORK16 \
        --truth benchmarks/blind_zoo/zoos/zoo16/truth.yaml --label zoo16 --out OUT

WORK16 holds a zoo's recordings as the blind-zoo harness writes them (``reference``,
``effects/zNN``, ``clean/sNNN_e0``). For every effect and clean seed, the search model fitted on
the whole reference at the route's start feature set (the measured robot's) is read through
:func:`littledog_mlsim.diagnose.change.reference_change`, as a diagnosis whose search accepted
nothing would read it; the table gives where it locates a change (over all rows, or in one
leg's swing), the swing cell of that leg, its stance ratio, the force test, and what is named,
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


def main() -> None:
    p = zoo_study_parser(__doc__.splitlines()[0])
    p.add_argument("--only", default=None,
                   help="comma-separated recordings (zNN, sNNN_e0) to read; default all")
    p.add_argument("--swing-min-ratio", type=float, default=None,
                   help="decision 029's material swing ratio (change.SWING_MIN_RATIO) to try")
    p.add_argument("--swing-concentration", type=float, default=None,
                   help="decision 029's concentration (change.SWING_CONCENTRATION) to try")
    p.add_argument("--screen-spread", action="store_true",
                   help="also screen a change spread over all joints (change.CONCENTRATION "
                        "set to 1 for this run; the way decision 035 was tried before it "
                        "became the package's rule)")
    p.add_argument("--no-swing-apart", action="store_true",
                   help="compare the leg with every other leg's swing (change.SWING_APART "
                        "False: the rule before decision 067)")
    a = p.parse_args()
    import littledog_mlsim.diagnose.change as change
    if a.no_swing_apart:
        change.SWING_APART = False
    if a.screen_spread:
        change.CONCENTRATION = 1.0
    if a.swing_min_ratio is not None:
        change.SWING_MIN_RATIO = a.swing_min_ratio
    if a.swing_concentration is not None:
        change.SWING_CONCENTRATION = a.swing_concentration
    opts, start = LearnedOptions(), measured_robot_features()
    quiet = lambda s: None  # noqa: E731
    truth = zoo_truth(a.truth)
    ref = _Route(load_moves(a.zoo_dir / "reference", "train"), start, opts, quiet)
    ref_fit = ref.fit(start, one_step=True)
    out_json = a.out.with_suffix(".json")
    doc = appended_study(out_json)
    data = (sorted(d for d in (a.zoo_dir / "effects").iterdir() if d.is_dir())
            + sorted(d for d in (a.zoo_dir / "clean").iterdir() if d.is_dir()))
    if a.only:
        data = [d for d in data if d.name in a.only.split(",")]
    for d in data:
        t = time.perf_counter()
        r = _Route(load_moves(d, "train"), start, opts, quiet)
        c = reference_change(r, ref, start, None, None, ref_fit)
        sw = c["swing"]
        sc = sw.get("screen") or {}
        force = next((h for h in sc.get("hypotheses", []) if h["stage"] == "force"), None)
        voc = c.get("vocabulary") or {}
        row = {"zoo": a.label, "data": d.name, "truth": truth.get(d.name, "clean"),
               "swing_min_ratio": change.SWING_MIN_RATIO,
               "swing_concentration_min": change.SWING_CONCENTRATION,
               "screen_spread": bool(a.screen_spread), "all_rows_scope": c["scope"],
               "family": c.get("family"), "kept_scope": c.get("kept_scope"),
               "explained": c.get("explained"),
               "all_rows_ratio": round(c["ratio"], 2), "located_by": c["located_by"],
               "swing_leg": sw.get("leg"), "swing_ratio": round(sw.get("ratio", 0.0), 2),
               "swing_concentration": round(sw.get("concentration", 0.0), 2),
               "swing_p": sw.get("p_value"), "swing_located": sw["located"],
               "swing_apart": change.SWING_APART, "against": sw.get("against"),
               "apart": {k: None if v != v else round(v, 2)
                         for k, v in (sw.get("apart") or {}).items()},
               **_all_legs(sw, change, opts.alpha),
               "stance_ratio": (round(sc["stance_ratio"], 2) if sc else None),
               "force_p": None if force is None else force["p_value"],
               "force_ok": None if force is None else bool(force["significant"]
                                                           and force["material"]),
               "named": (f"{voc['family']} @ {voc['scope']}" if c["named"] else None),
               "params": voc.get("params"), "seconds": round(time.perf_counter() - t, 1)}
        doc["rows"].append(row)
        print(row, flush=True)
    out_json.write_text(json.dumps(doc, indent=1))
    lines = ["# Decision 029 on read zoos: a change located in one leg's swing", ""]
    lines += study_commands(doc)
    lines += ["", "| zoo | data | truth | all rows | located by | swing leg: ratio, x others, "
              "located | x every other leg, located | its stance | force p (ok) | named | "
              "params |", "|---|---|---|---|---|---|---|---|---|---|---|"]
    for r in doc["rows"]:
        force = ("" if r["force_p"] is None else f"{r['force_p']:.2g} ({r['force_ok']})")
        stance = "" if r["stance_ratio"] is None else f"{r['stance_ratio']:.2f}"
        lines.append(
            f"| {r['zoo']} | {r['data']} | {r['truth']} | {r['all_rows_ratio']:.2f} | "
            f"{r['located_by'] or ''} | {r['swing_leg']}: {r['swing_ratio']:.2f}, "
            f"x{r['swing_concentration']:.2f}, {r['swing_located']} | "
            f"{_all_legs_cell(r)} | {stance} | {force} | "
            f"{r['named'] or ''} | {r['params'] or ''} |")
    a.out.with_suffix(".md").write_text("\n".join(lines) + "\n")


def _all_legs(sw: dict, change, alpha: float) -> dict:
    """The location by decision 029's comparison with every other leg's swing (the rule
    before decision 067), read off the same cells: its concentration and whether it locates."""
    cells = {k: v["swing"] for k, v in sw["cells"].items() if v["swing"] == v["swing"]}
    if sw.get("leg") is None or len(cells) < 2:
        return {"concentration_all_legs": None, "located_all_legs": False}
    rest = sum(v for k, v in cells.items() if k != sw["leg"]) / (len(cells) - 1)
    conc = cells[sw["leg"]] / rest if rest > 0 else float("inf")
    return {"concentration_all_legs": round(conc, 2),
            "located_all_legs": bool(sw["ratio"] >= change.SWING_MIN_RATIO
                                     and sw["p_value"] < alpha / len(cells)
                                     and conc >= change.SWING_CONCENTRATION)}


def _all_legs_cell(r: dict) -> str:
    """The table's cell of decision 034's location (empty where no leg was read)."""
    if r.get("concentration_all_legs") is None:
        return ""
    return f"x{r['concentration_all_legs']:.2f}, {r['located_all_legs']}"


if __name__ == "__main__":
    main()
