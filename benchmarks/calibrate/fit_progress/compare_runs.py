"""Two `calibrate` runs of one reference side by side, read off their committed logs and twins.

Per run: the wall time, the evaluation lines of the log, the wall time per evaluation line, the
mean time per evaluation of a Jacobian's batch over the first N batch evaluations (as the log
prints it: ``one of K in T s``), the evaluations of each fit (:func:`fit_progress.parse_fits`)
and the second starts' ``n_evals`` from the twin's report.

    .venv/bin/python benchmarks/calibrate/fit_progress/compare_runs.py RUN_DIR RUN_DIR [--first 230]
"""
from __future__ import annotations

import argparse
import json
import re
import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
from fit_progress import parse_fits  # noqa: E402

BATCH = re.compile(r"one of (\d+) in ([\d.]+) s\)")


def summary(run: Path, first: int) -> dict:
    log = (run / "logs" / "calibrate.log").read_text().splitlines()
    report = json.loads((run / "calibrated_twin.json").read_text())["provenance"]["calibration"]
    lines = sum(1 for line in log if line.startswith("  ["))
    per = []
    for line in log:
        m = BATCH.search(line)
        if m:
            per.append(float(m.group(2)) / int(m.group(1)))
            if len(per) == first:
                break
    fits = parse_fits(run / "logs" / "calibrate.log")
    split = report.get("split_starts") or {}
    return {"wall_s": report["wall_s"], "evaluation_lines": lines,
            "wall_per_line_s": report["wall_s"] / lines,
            f"batch_s_per_eval_first_{len(per)}": sum(per) / len(per),
            "fits": [(f["label"], len(f["evals"])) for f in fits],
            "refit_lines": sum(len(f["evals"]) for f in fits
                               if f["label"].startswith("bootstrap")),
            "second_starts_n_evals": [(c["start"], c.get("n_evals"))
                                      for c in split.get("candidates", [])
                                      if c["start"] != "fit"],
            "bootstrap_wall_s": (report.get("bootstrap") or {}).get("wall_s"),
            "split_starts_wall_s": split.get("wall_s")}


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("runs", nargs=2, type=Path)
    ap.add_argument("--first", type=int, default=230)
    args = ap.parse_args(argv)
    for run in args.runs:
        print(run)
        for k, v in summary(run, args.first).items():
            print(f"  {k}: {round(v, 3) if isinstance(v, float) else v}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
