"""Run one `diagnose` and measure how busy its re-simulation workers are inside the physical
route's map calls: each worker sums the time it spends in `physical.resim.simulate` (written to
a file per worker process), and every `Runner.map` call's wall time and number of tasks are
recorded. Writes OUT (Markdown): the workers' busy share of the map calls' wall, overall and by
the size of the call. The diagnosis itself is unchanged (the wrappers only time).

    OPENBLAS_NUM_THREADS=1 .venv/bin/python -P benchmarks/diagnose_speed/pool_use/busy.py \\
        OUT.md -- diagnose --data DATA --out DIR --no-figures --jobs 2 --twin TWIN --reference REF
"""
from __future__ import annotations

import collections
import glob
import os
import sys
import tempfile
import time

from littledog_mlsim import cli
from littledog_mlsim.diagnose.physical import resim

SCRATCH = tempfile.mkdtemp(prefix="busy_")
_BUSY = [0.0, 0]


def _timed_simulate(task):
    t0 = time.perf_counter()
    out = _SIMULATE(task)
    _BUSY[0] += time.perf_counter() - t0
    _BUSY[1] += 1
    with open(os.path.join(SCRATCH, f"{os.getpid()}.txt"), "w") as f:
        f.write(f"{_BUSY[0]} {_BUSY[1]}")
    return out


_SIMULATE = resim.simulate


def main() -> int:
    out, rest = sys.argv[1], sys.argv[sys.argv.index("--") + 1:]
    resim.simulate = _timed_simulate          # the forked workers inherit it
    calls: list[tuple[int, float]] = []
    inner = resim.Runner.map

    def timed_map(self, tasks):
        t0 = time.perf_counter()
        r = inner(self, tasks)
        calls.append((len(tasks), time.perf_counter() - t0))
        return r

    resim.Runner.map = timed_map
    t0 = time.perf_counter()
    rc = cli.main(rest)
    whole = time.perf_counter() - t0
    busy = [tuple(float(x) for x in open(p).read().split())
            for p in glob.glob(os.path.join(SCRATCH, "*.txt"))]
    jobs = int(rest[rest.index("--jobs") + 1]) if "--jobs" in rest else 2
    in_map = sum(w for _, w in calls)
    total_busy = sum(b for b, _ in busy)
    lines = [f"`{' '.join(rest)}`", "",
             f"whole run {whole:.1f} s; {len(calls)} map calls, {sum(n for n, _ in calls)} "
             f"re-simulations, {in_map:.1f} s of wall in map calls; {len(busy)} worker processes "
             f"busy {total_busy:.1f} s in all ({', '.join(f'{b:.1f} s / {int(n)} tasks' for b, n in busy)})",
             "", f"the workers' busy share of {jobs} x the map calls' wall: "
             f"**{total_busy / (jobs * in_map):.3f}**", "",
             "| map call size (tasks) | calls | wall [s] |", "|---|---|---|"]
    by = collections.defaultdict(lambda: [0, 0.0])
    for n, w in calls:
        key = "1-2" if n <= 2 else "3-8" if n <= 8 else "9-16" if n <= 16 else \
            "17-64" if n <= 64 else "65+"
        by[key][0] += 1
        by[key][1] += w
    for key in ("1-2", "3-8", "9-16", "17-64", "65+"):
        if key in by:
            lines.append(f"| {key} | {by[key][0]} | {by[key][1]:.1f} |")
    with open(out, "w") as f:
        f.write("\n".join(lines) + "\n")
    print("\n".join(lines))
    return rc


if __name__ == "__main__":
    sys.exit(main())
