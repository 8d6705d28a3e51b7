"""Writing a dataset's bags: ``write_bag`` per bag, with the one-layout write and without it.

Usage (from the repo root, in the venv):

    OPENBLAS_NUM_THREADS=1 .venv/bin/python benchmarks/bag_write/bag_write.py \
        [--data DATA] [--moves-per-type 2] [--repeats 5] [--out benchmarks/bag_write/result]

The moves of every bag under DATA (any depth) are read once, then written again into a
temporary directory in two modes, in turn, ``--repeats`` times (the order alternates each
repeat):

- ``per message``: every message built and serialized by ``rosbags`` on its own (the layout,
  ``decode.like_first``, off: the path every bag took before);
- ``one layout``: the first message of each topic serialized, the others laid out as it
  (what ``write_bag`` does).

Without ``--data`` it records ``--moves-per-type`` moves of every type (``record``, seed 0)
into a temporary directory first. Every bag written is checked to store the same messages as
the same move written in the first mode: the same topics, bag times and CDR bytes, in the same
order. Reported: the median over the repeats of the milliseconds per bag (wall and this
process's CPU), and the ratio to the first mode.
"""
from __future__ import annotations

import shutil
import sys
import tempfile
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))
from _common import (bag_benchmark_args, bags_to_time, per_bag_modes,  # noqa: E402
                     run_record, timed_modes, uptime, write_results)

MODES = ("per message", "one layout")


def _stored(bag: Path) -> list:
    from rosbags.rosbag2 import Reader
    with Reader(bag) as r:
        return [(c.topic, t, bytes(raw)) for c, t, raw in r.messages()]


def _write_all(recs, names, root: Path, mode: str) -> tuple[float, float, list[Path]]:
    from littledog_mlsim.data import bags as bags_mod
    real = bags_mod.like_first
    if mode == "per message":
        bags_mod.like_first = lambda *a: None
    out = root / mode.replace(" ", "_")
    shutil.rmtree(out, ignore_errors=True)
    out.mkdir(parents=True)
    paths = [out / n for n in names]
    try:
        c0, t0 = time.process_time(), time.perf_counter()
        for rec, p in zip(recs, paths):
            bags_mod.write_bag(p, rec)
        wall, cpu = time.perf_counter() - t0, time.process_time() - c0
    finally:
        bags_mod.like_first = real
    return wall, cpu, paths


def main(argv=None) -> int:
    a = bag_benchmark_args(__doc__.splitlines()[0], argv)
    from littledog_mlsim.data.bags import read_bag
    doc = run_record("bag_write/bag_write.py", argv)
    with tempfile.TemporaryDirectory() as tmp:
        bags = bags_to_time(a.data, a.moves_per_type, tmp, "bag_write")
        recs = [read_bag(b) for b in bags]
        names = [f"{i:04d}_{b.name}" for i, b in enumerate(bags)]   # unique under any DATA
        doc["bags"] = len(bags)
        work = Path(tmp) / "written"
        _write_all(recs[:2], names[:2], work, MODES[-1])     # imports, type store
        doc["load_before"] = uptime()

        def run(mode: str):
            wall, cpu, paths = _write_all(recs, names, work, mode)
            return wall, cpu, [_stored(p) for p in paths]
        times = timed_modes(MODES, a.repeats, run, lambda x, y: x == y, "bag_write")
        doc["load_after"] = uptime()
    lines = per_bag_modes(doc, times, len(bags), "Writing a dataset's bags (`write_bag`)",
                          a.repeats)
    lines += ["", "Every bag written in either mode stored the same messages (topics, bag times "
              "and CDR bytes, in order) as in the first mode."]
    write_results(a.out, doc, lines)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
