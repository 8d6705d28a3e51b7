"""Recording speed: how much faster than real time the pybullet LittleDog records, per core.

Usage (from the repo root, in the venv):

    .venv/bin/python benchmarks/record_speed/record_speed.py [--moves-per-type 2] [--repeats 3]

Records ``moves_per_type`` moves of every type with one worker process (per-core speed) and with
all cores (the default `record`), each ``repeats`` times into a temporary directory, and writes the
medians to ``benchmarks/record_speed/record_speed.json`` and ``benchmarks/record_speed/record_speed.md``.
Target (issue 2): at least 15x faster than real time per core.
"""
from __future__ import annotations

import argparse
import json
import os
import platform
import statistics
import sys
import tempfile
import time
from pathlib import Path

from littledog_mlsim.apps.record import record_dataset

HERE = Path(__file__).resolve().parent


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--moves-per-type", type=int, default=2)
    ap.add_argument("--repeats", type=int, default=3)
    a = ap.parse_args()
    cores = os.cpu_count() or 1
    load_before = os.getloadavg()[0]
    rows = {}
    for jobs in sorted({1, cores}):
        per_core, wall, rt_total = [], [], []
        for _ in range(a.repeats):
            with tempfile.TemporaryDirectory() as tmp:
                s = record_dataset(Path(tmp) / "ds", moves_per_type=a.moves_per_type, jobs=jobs,
                                   progress=False)
            per_core.append(s.realtime_factor_per_core)
            wall.append(s.wall_s)
            rt_total.append(s.n_steps * 0.01 / s.wall_s)
        rows[jobs] = {"n_bags": s.n_bags, "robot_time_s": s.n_steps * 0.01,
                      "median_wall_s": statistics.median(wall),
                      "median_realtime_factor_per_core": statistics.median(per_core),
                      "median_realtime_factor_total": statistics.median(rt_total),
                      "wall_s_all": wall}
    command = "make bench  # = .venv/bin/python benchmarks/record_speed/record_speed.py " + " ".join(sys.argv[1:])
    result = {"command": command, "cores": cores, "python": platform.python_version(),
              "moves_per_type": a.moves_per_type, "repeats": a.repeats,
              "date": time.strftime("%Y-%m-%d"), "jobs": rows,
              "load_average_1min_before": load_before, "load_average_1min_after": os.getloadavg()[0], "target_per_core": 15.0}
    (HERE / "record_speed.json").write_text(json.dumps(result, indent=2) + "\n")
    lines = ["# Recording speed", "", f"Command: `{command}`", "",
             f"Machine: {cores} cores (shared), Python {platform.python_version()}, {result['date']}. "
             f"{a.moves_per_type} moves per type x 11 types, {a.repeats} repeats, medians. "
             f"1-min load average {load_before:.1f} before, {result['load_average_1min_after']:.1f} after "
             "(other work was running: wall times are inflated, CPU-time figures less so).", "",
             "| worker processes | bags | robot time [s] | wall [s] | x real time per core | x real time total |",
             "|---|---|---|---|---|---|"]
    for jobs, r in rows.items():
        lines.append(f"| {jobs} | {r['n_bags']} | {r['robot_time_s']:.0f} | {r['median_wall_s']:.2f} | "
                     f"{r['median_realtime_factor_per_core']:.1f} | {r['median_realtime_factor_total']:.1f} |")
    lines += ["", "Per core = robot time / summed in-worker CPU time (simulation + bag writing); total = "
              "robot time / wall time including process start-up and dataset.yaml. Target: >= 15x per core."]
    (HERE / "record_speed.md").write_text("\n".join(lines) + "\n")
    print("\n".join(lines))
    return 0


if __name__ == "__main__":
    sys.exit(main())
