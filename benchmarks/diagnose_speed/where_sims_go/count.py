"""Run one `diagnose` and count where its physical route's re-simulations go: every task the
search hands its transducer (`physical.resim.Memo.map`) is charged to the search step that
asked for it (the innermost caller among the steps named in STEPS), with the task's mode, and
the wall time of each map call likewise. Writes a table to OUT (Markdown) beside the diagnosis's
own output. The diagnosis itself is unchanged (the wrapper only counts).

    OPENBLAS_NUM_THREADS=1 .venv/bin/python -P benchmarks/diagnose_speed/where_sims_go/count.py \\
        OUT.md -- diagnose --data DATA --out DIR --no-figures --jobs 2 --twin TWIN --reference REF
"""
from __future__ import annotations

import collections
import sys
import time

from littledog_mlsim import cli
from littledog_mlsim.diagnose.physical import resim

#: the search steps a task is charged to (function names in diagnose/physical), innermost first
STEPS = ("start_side", "located_variants", "scope_variants", "form_variants", "wide_magnitude",
         "refine_wide", "ridge_mass", "refine_direction", "refine_position", "fit_magnitude", "fit",
         "screen",
         "validate", "reference_check", "unexplained", "_changed_alternative", "_rebase",
         "identify")


def _step() -> str:
    f = sys._getframe(2)
    names = []                      # innermost first
    while f is not None:
        if "diagnose/physical" in f.f_code.co_filename.replace("\\", "/"):
            names.append(f.f_code.co_name)
        f = f.f_back
    # a fit's magnitude search inside a variant pass is charged to the pass
    for step in ("located_variants", "scope_variants", "form_variants") + STEPS:
        if step in names:
            return step
    return names[0] if names else "?"


def main() -> int:
    out, rest = sys.argv[1], sys.argv[sys.argv.index("--") + 1:]
    tasks: collections.Counter = collections.Counter()
    fresh: collections.Counter = collections.Counter()
    wall: collections.Counter = collections.Counter()
    calls: collections.Counter = collections.Counter()
    inner_map = resim.Memo.map

    def counted(self, ts):
        step = _step()
        before = self.inner.n_sims
        t0 = time.perf_counter()
        result = inner_map(self, ts)
        wall[step] += time.perf_counter() - t0
        calls[step] += 1
        for t in ts:
            tasks[(step, t[2])] += 1
        fresh[step] += self.inner.n_sims - before
        return result

    resim.Memo.map = counted
    t0 = time.perf_counter()
    rc = cli.main(rest)
    total = time.perf_counter() - t0
    steps = sorted(wall, key=wall.get, reverse=True)
    lines = [f"`diagnose` {' '.join(rest[1:])}", "",
             f"whole run {total:.1f} s; re-simulations run {sum(fresh.values())}, "
             f"tasks asked {sum(tasks.values())}, in {sum(calls.values())} map calls "
             f"taking {sum(wall.values()):.1f} s", "",
             "| step | map calls | tasks asked (by mode) | re-simulations run | wall in map [s] | share of map wall |",
             "|---|---|---|---|---|---|"]
    W = sum(wall.values()) or 1.0
    for s in steps:
        modes = ", ".join(f"{m} {n}" for (st, m), n in sorted(tasks.items()) if st == s)
        lines.append(f"| {s} | {calls[s]} | {modes} | {fresh[s]} | {wall[s]:.1f} | "
                     f"{wall[s] / W:.1%} |")
    with open(out, "w", encoding="utf-8") as fh:
        fh.write("\n".join(lines) + "\n")
    print("\n".join(lines))
    return rc


if __name__ == "__main__":
    raise SystemExit(main())
