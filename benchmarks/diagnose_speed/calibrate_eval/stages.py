"""A calibrate log's evaluations summed by stage: each line ``[k/N] ... (T s)`` (a batch's line
``(t s: one of n in T s)`` counts t) under the last ``screening``, ``fitting``, ``testing`` or
``rolling`` line before it.

    python benchmarks/diagnose_speed/calibrate_eval/stages.py LOG [LOG ...]
"""
import re
import sys


def stages(path: str) -> list[tuple[str, int, float]]:
    out: list[list] = []
    for line in open(path):
        if line.startswith(("screening", "fitting", "testing", "rolling", "bootstrap: the twin")):
            out.append([line.split(" on ")[0][:60].strip(), 0, 0.0])
        m = re.search(r"^\s*\[\d+/\d+\].*\((\d+\.\d+) s", line)
        if m and out:
            out[-1][1] += 1
            out[-1][2] += float(m.group(1))
    return [tuple(s) for s in out if s[1]]


if __name__ == "__main__":
    for path in sys.argv[1:]:
        rows = stages(path)
        print(f"{path}: {sum(r[1] for r in rows)} evaluations, {sum(r[2] for r in rows):.0f} s")
        for name, n, t in rows:
            print(f"  {n:4d} evaluations {t:7.1f} s  {name}")
