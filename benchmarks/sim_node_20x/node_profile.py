"""Where sim_node's own thread spends its time at 20x real time: a sampling profile of the
running node.

Runs ``run.py --phases timer`` (sim_node in its own process, a controller here) and, after
``--warmup`` s, samples the node with ``py-spy record --format raw`` for ``--seconds`` s; then
sums the samples by function: own (the innermost frame) and inclusive (anywhere on the stack).
A sample is a share of the wall time the node's threads were seen running, so the inclusive
shares say where a step's time goes.

    OPENBLAS_NUM_THREADS=1 .venv/bin/python benchmarks/sim_node_20x/node_profile.py \\
        --model MODEL --data DATA --out benchmarks/sim_node_20x/quiet/node_profile
"""
from __future__ import annotations

import argparse
import collections
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE.parents[1]))

from benchmarks._common import command_line, run_record, uptime, write_results  # noqa: E402


def _node_pid(parent: int, timeout: float = 60.0) -> int:
    t1 = time.monotonic() + timeout
    while time.monotonic() < t1:
        r = subprocess.run(["pgrep", "-P", str(parent), "-f", "littledog_mlsim.nodes.sim_node"],
                           capture_output=True, text=True)
        if r.stdout.strip():
            return int(r.stdout.split()[0])
        time.sleep(0.2)
    raise SystemExit("sim_node did not start")


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--model", required=True)
    p.add_argument("--data", required=True)
    p.add_argument("--executor", default="single", choices=("single", "events"))
    p.add_argument("--controller", default="stream", choices=("stream", "reactive"))
    p.add_argument("--warmup", type=float, default=8.0,
                   help="s from the node's start to the first sample (the model loads in 2-3 s, "
                        "then run.py's own 3 s warm-up)")
    p.add_argument("--node-param", action="append", default=[], metavar="NAME=VALUE",
                   help="a sim_node parameter, passed to run.py (repeatable)")
    p.add_argument("--seconds", type=float, default=15.0)
    p.add_argument("--rate", type=int, default=500, help="py-spy samples per second")
    p.add_argument("--top", type=int, default=25)
    p.add_argument("--out", type=Path, required=True)
    a = p.parse_args(argv)
    doc = run_record("sim_node_20x/node_profile.py", argv)
    spy = Path(sys.executable).parent / "py-spy"
    with tempfile.TemporaryDirectory() as tmp:
        raw = Path(tmp) / "raw.txt"
        bench = subprocess.Popen(
            [sys.executable, str(HERE / "run.py"), "--model", a.model, "--data", a.data,
             "--phases", "timer", "--executor", a.executor, "--controller", a.controller,
             "--duration", str(a.warmup + a.seconds + 5),
             *(x for kv in a.node_param for x in ("--node-param", kv))],
            stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
        ok = False
        try:
            pid = _node_pid(bench.pid)
            time.sleep(a.warmup)
            load = uptime()
            subprocess.run([str(spy), "record", "--pid", str(pid), "--duration",
                            str(int(a.seconds)), "--rate", str(a.rate), "--format", "raw",
                            "--nonblocking", "-o", str(raw)], check=True,
                           capture_output=True)
            ok = True
        finally:
            if not ok:
                bench.terminate()
            try:
                bench.wait(300)
            except subprocess.TimeoutExpired:
                bench.kill()
                bench.wait()
        own, incl, total = collections.Counter(), collections.Counter(), 0
        for line in raw.read_text().splitlines():
            stack, _, n = line.rpartition(" ")
            frames = stack.split(";")
            total += int(n)
            own[frames[-1]] += int(n)
            for f in set(frames):
                incl[f] += int(n)
    doc.update(samples=total, load=load, executor=a.executor, controller=a.controller,
               node_params=a.node_param,
               own=own.most_common(a.top), inclusive=incl.most_common(2 * a.top))
    lines = [command_line(doc) + "  ", f"Code: {doc['git']}; date {doc['date']}; load `{load}`",
             "", f"{total} samples over {a.seconds:g} s of sim_node at real_time_factor 20 "
             f"(executor {a.executor}, controller {a.controller}"
             + "".join(f", `{kv}`" for kv in a.node_param) + ").", "",
             "| own share | function |", "|---|---|"]
    lines += [f"| {100 * n / total:.1f} % | `{f}` |" for f, n in own.most_common(a.top)]
    lines += ["", "| inclusive share | function |", "|---|---|"]
    lines += [f"| {100 * n / total:.1f} % | `{f}` |" for f, n in incl.most_common(2 * a.top)]
    write_results(a.out, doc, lines)
    return 0


if __name__ == "__main__":
    sys.exit(main())
