"""Timer mode's catch-up policy (sim_node's ``steps_per_tick``) against the rate and what the
model is fed, at real_time_factor 20.

When sim_node is behind its schedule, a tick runs at most ``steps_per_tick`` of the steps due;
the rest run on the following ticks, and the node takes the commands that arrive in between.
``steps_per_tick`` 50 (= ``MAX_CATCH_UP``) runs the whole backlog in one tick on one held
command. This runs ``run.py``'s timer phase for each value of ``--steps-per-tick`` and each
controller (``stream``: one command per 1/2000 s of wall time, blind to the node's progress;
``reactive``: one command per joint state received, a controller in simulated time),
alternating, ``--repeats`` times, and reports the medians of: the published rate, the share of
steps that took a new command, the share of predictions outside the gate (the node's
``extrapolating_steps``: each needs the exact nearest-neighbour search) and the step CPU.

    OPENBLAS_NUM_THREADS=1 .venv/bin/python benchmarks/sim_node_20x/catch_up.py \\
        --model MODEL --data DATA --out benchmarks/sim_node_20x/quiet/catch_up
"""
from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import tempfile
from pathlib import Path

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE.parents[1]))

import numpy as np  # noqa: E402

from benchmarks._common import command_line, run_record, uptime, write_results  # noqa: E402


def one_run(a, spt: int, controller: str, out: Path) -> dict:
    subprocess.run([sys.executable, str(HERE / "run.py"), "--model", a.model, "--data", a.data,
                    "--phases", "timer", "--factor", str(a.factor), "--duration",
                    str(a.duration), "--controller", controller, "--node-param",
                    f"steps_per_tick={spt}", "--hogs", str(a.hogs), "--executor", a.executor,
                    "--out", str(out)],
                   check=True, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    t = json.loads(out.with_suffix(".json").read_text())["results"]["timer"]
    return {"published_rate_hz": t["published_rate_hz"],
            "fresh_command_share": t["fresh_command_share"],
            "outside_gate_share": t["outside_gate_share"], "skipped_share": t["skipped_share"],
            "step_cpu_p50_ms": t["step_cpu_ms"]["p50"], "step_cpu_p99_ms": t["step_cpu_ms"]["p99"],
            "load_before": t["load_before"], "load_after": t["load_after"]}


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--model", required=True)
    p.add_argument("--data", required=True)
    p.add_argument("--steps-per-tick", type=lambda s: [int(x) for x in s.split(",")],
                   default=[2, 50])
    p.add_argument("--controllers", default="stream,reactive")
    p.add_argument("--factor", type=float, default=20.0)
    p.add_argument("--duration", type=float, default=20.0, help="s measured per run")
    p.add_argument("--repeats", type=int, default=3)
    p.add_argument("--hogs", type=int, default=0, help="CPU busy loops beside each run (run.py)")
    p.add_argument("--executor", default="single", choices=("single", "events"))
    p.add_argument("--out", type=Path, default=None)
    a = p.parse_args(argv)
    doc = run_record("sim_node_20x/catch_up.py", argv)
    doc["load_start"] = uptime()
    runs: dict[str, list[dict]] = {}
    keys = [(s, c) for c in a.controllers.split(",") for s in a.steps_per_tick]
    with tempfile.TemporaryDirectory() as tmp:
        for r in range(a.repeats):
            for s, c in keys:
                runs.setdefault(f"{s} {c}", []).append(
                    one_run(a, s, c, Path(tmp) / f"r{r}_{s}_{c}"))
    doc["load_end"] = uptime()
    doc["runs"] = runs
    med = {k: {m: float(np.median([x[m] for x in v])) for m in
               ("published_rate_hz", "fresh_command_share", "outside_gate_share",
                "step_cpu_p50_ms", "step_cpu_p99_ms")} for k, v in runs.items()}
    doc["medians"] = med
    lines = [command_line(doc) + "  ", f"Code: {doc['git']}; date {doc['date']}; load at the "
             f"start `{doc['load_start']}`, at the end `{doc['load_end']}` (each run's own in the "
             f"JSON)", "",
             f"real_time_factor {a.factor:g} ({100 * a.factor:.0f} steps/s asked), "
             f"{a.duration:g} s per run, executor {a.executor}, {a.hogs} CPU hogs beside each, "
             f"medians of {a.repeats} "
             f"runs (configurations alternating).", "",
             "| steps_per_tick | controller | published [Hz] | steps with a new command | "
             "outside the gate | step CPU p50 / p99 [ms] | rates of the runs [Hz] |",
             "|---|---|---|---|---|---|---|"]
    for s, c in keys:
        m, v = med[f"{s} {c}"], runs[f"{s} {c}"]
        lines.append(f"| {s} | {c} | {m['published_rate_hz']:.0f} | "
                     f"{100 * m['fresh_command_share']:.1f} % | "
                     f"{100 * m['outside_gate_share']:.1f} % | {m['step_cpu_p50_ms']:.3f} / "
                     f"{m['step_cpu_p99_ms']:.3f} | "
                     + ", ".join(f"{x['published_rate_hz']:.0f}" for x in v) + " |")
    write_results(a.out, doc, lines)
    return 0


if __name__ == "__main__":
    sys.exit(main())
