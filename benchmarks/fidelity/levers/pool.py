"""Pool the levers' runs over seeds: per lever and scenario, the median and worst gap / path
over every seed any of the given result files ran it on (``per_seed_err_per_m``).

    .venv/bin/python benchmarks/fidelity/levers/pool.py data_levers.json model_levers.json \\
        third_controller.json levers2_seeds3_7.json varied_blend_seeds0_2.json \\
        --out benchmarks/fidelity/levers/pooled
"""
from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

import os

import numpy as np

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE.parents[2]))
os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

from benchmarks._common import command_line, run_record, write_results  # noqa: E402

SCENARIOS = ("straight", "switch", "velocity", "waypoints", "trajectory")


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("results", nargs="+", type=Path, help="run.py result files (.json), "
                    "relative to this directory or absolute")
    ap.add_argument("--out", type=Path, default=None)
    a = ap.parse_args(argv)
    doc = run_record("fidelity/levers/pool.py", argv)
    seeds: dict = {}                      # (lever, scenario) -> {seed: gap / path}
    for f in a.results:
        path = f if f.is_absolute() or f.exists() else HERE / f
        for row in json.loads(path.read_text())["rows"]:
            for sc in SCENARIOS:
                per = (row.get(sc) or {}).get("per_seed_err_per_m") or {}
                for s, v in per.items():
                    old = seeds.setdefault((row["lever"], sc), {}).get(s)
                    if old is not None and old != v:
                        raise SystemExit(f"{path.name}: {row['lever']} {sc} seed {s} differs "
                                         f"from an earlier file ({v} vs {old})")
                    seeds[(row["lever"], sc)][s] = v
    levers = list(dict.fromkeys(k[0] for k in seeds))
    doc["pooled"] = {f"{lv}/{sc}": {"seeds": sorted(seeds[(lv, sc)], key=int),
                                    "median": float(np.median(list(seeds[(lv, sc)].values()))),
                                    "worst": float(max(seeds[(lv, sc)].values()))}
                     for lv in levers for sc in SCENARIOS if (lv, sc) in seeds}
    lines = [command_line(doc) + "  ", f"Code: {doc['git']}; date {doc['date']}", "",
             "| lever | " + " | ".join(SCENARIOS) + " |", "|---" * (len(SCENARIOS) + 1) + "|"]
    for lv in levers:
        cells = []
        for sc in SCENARIOS:
            p = doc["pooled"].get(f"{lv}/{sc}")
            cells.append("-" if p is None else f"{100 * p['median']:.1f} % "
                         f"({100 * p['worst']:.1f} %), {len(p['seeds'])} seeds")
        lines.append(f"| {lv} | " + " | ".join(cells) + " |")
    lines += ["", "Gap / path, median (worst) over the seeds each lever ran."]
    write_results(a.out, doc, lines)
    print("\n".join(lines))
    return 0


if __name__ == "__main__":
    sys.exit(main())
