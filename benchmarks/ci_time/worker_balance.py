"""How the suite's modules fell on the two pytest-xdist workers, from a time-stamped ``-v`` log.

Usage: ``python benchmarks/ci_time/worker_balance.py LOG``, where LOG is pytest's ``-v`` output
with each line prefixed by the seconds since the start (``suite_*_verbose.txt``; README.md
gives the command that made it). A module's span on its worker runs from the worker's previous
result line to the module's last one. Prints each worker's end and its modules of over 15 s,
then the modules' total spans, largest first.
"""
from __future__ import annotations

import collections
import re
import sys

RESULT = re.compile(r"^\s*([\d.]+) \[(gw\d+)\] \[\s*\d+%\] \w+ (test/[^:]+)::")


def spans(lines):
    """{(worker, module): [start, end]} in seconds, in the order the modules began."""
    last: dict[str, float] = {}
    out: dict[tuple[str, str], list[float]] = {}
    for line in lines:
        m = RESULT.match(line)
        if not m:
            continue
        t, worker, module = float(m[1]), m[2], m[3]
        out.setdefault((worker, module), [last.get(worker, 0.0), t])[1] = t
        last[worker] = t
    return out


def main(argv=None) -> int:
    argv = sys.argv[1:] if argv is None else argv
    if len(argv) != 1:
        sys.exit(__doc__.splitlines()[2])
    with open(argv[0]) as f:
        s = spans(f.read().splitlines())
    if not s:
        sys.exit(f"worker_balance: no time-stamped xdist result lines in {argv[0]}")
    for w in sorted({k[0] for k in s}):
        end = max(b for (ww, _), (_, b) in s.items() if ww == w)
        print(f"{w} ends at {end:.1f} s")
        for (ww, mod), (a, b) in s.items():
            if ww == w and b - a > 15:
                print(f"  {a:7.1f} {b:7.1f} {b - a:7.1f}  {mod}")
    total = collections.Counter()
    for (_, mod), (a, b) in s.items():
        total[mod] += b - a
    print(f"all modules: {sum(total.values()):.1f} worker-seconds")
    for mod, t in total.most_common(12):
        print(f"{t:7.1f}  {mod}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
