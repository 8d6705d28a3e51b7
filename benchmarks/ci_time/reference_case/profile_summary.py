"""Summarise a py-spy raw profile (``py-spy record -f raw``): each function line's share of the
samples as the innermost frame (self) and anywhere in the stack (inclusive). Usage:

    python benchmarks/ci_time/reference_case/profile_summary.py RAW [N]
"""
from __future__ import annotations

import sys
from collections import Counter


def frame_key(frame: str) -> str:
    """``function (path:line)`` as ``function file:line``."""
    name, _, where = frame.partition(" (")
    return f"{name} {where.rstrip(')').rsplit('/', 1)[-1]}"


def main() -> None:
    path, n = sys.argv[1], int(sys.argv[2]) if len(sys.argv) > 2 else 25
    own, incl, total = Counter(), Counter(), 0
    for line in open(path):
        line = line.rstrip()
        if not line:
            continue
        stack, count = line.rsplit(" ", 1)
        frames, k = stack.split(";"), int(count)
        total += k
        own[frame_key(frames[-1])] += k
        for key in {frame_key(f) for f in frames[1:]}:   # frames[0]: the process
            incl[key] += k
    print(f"{total} samples")
    for title, counter in (("self", own), ("inclusive", incl)):
        print(f"\n| {title} share | function, file:line |\n|---|---|")
        for key, k in counter.most_common(n):
            print(f"| {k / total:.1%} | `{key}` |")


if __name__ == "__main__":
    main()
