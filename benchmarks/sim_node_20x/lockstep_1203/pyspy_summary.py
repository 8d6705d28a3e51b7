"""Shares of a py-spy raw profile (``py-spy record --format raw``) of sim_node in lockstep: the
core step, the publishes, and what stays in the executor's native code (the samples whose
innermost Python frame is the spin loop).

    .venv/bin/python benchmarks/sim_node_20x/lockstep_1203/pyspy_summary.py \
        benchmarks/sim_node_20x/lockstep_1203/node_lockstep_pyspy.txt.gz
"""
from __future__ import annotations

import gzip
import sys
from collections import Counter


def main(path: str) -> int:
    opener = gzip.open if path.endswith(".gz") else open
    total, parts = 0, Counter()
    with opener(path, "rt") as f:
        for line in f:
            line = line.rstrip()
            if not line:
                continue
            stack, n = line.rsplit(" ", 1)
            frames = [x.split(" (")[0] for x in stack.split(";")]
            total += int(n)
            if "SimulatorCore._advance" in frames:
                i = frames.index("SimulatorCore._advance")
                parts["advance > " + (frames[i + 1] if i + 1 < len(frames) else "(own)")] += int(n)
            elif "_spin" in frames and frames[-1] == "_spin":
                parts["spin loop, native (executor: take, deserialise, wait bookkeeping)"] += int(n)
            else:
                parts["other"] += int(n)
    print(f"{total} samples")
    for k, v in parts.most_common():
        print(f"{100 * v / total:5.1f} %  {k}")
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1]))
