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

import argparse
import shutil
import statistics
import sys
import tempfile
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))
from _common import command_line, run_record, uptime, write_results  # noqa: E402

MODES = ("per message", "one layout")


def _bags(data: Path) -> list[Path]:
    return sorted(p.parent for p in data.rglob("metadata.yaml"))


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
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--data", type=Path, default=None)
    ap.add_argument("--moves-per-type", type=int, default=2)
    ap.add_argument("--repeats", type=int, default=5)
    ap.add_argument("--out", type=Path, default=None)
    a = ap.parse_args(argv)
    from littledog_mlsim.data.bags import read_bag
    doc = run_record("bag_write/bag_write.py", argv)
    with tempfile.TemporaryDirectory() as tmp:
        data = a.data
        if data is None:
            from littledog_mlsim.apps.record import record_dataset
            data = Path(tmp) / "data"
            record_dataset(data, moves_per_type=a.moves_per_type, seed=0, jobs=1,
                           progress=False)
        bags = _bags(data)
        if not bags:
            sys.exit(f"bag_write: no bags under {data}")
        recs = [read_bag(b) for b in bags]
        names = [f"{i:04d}_{b.name}" for i, b in enumerate(bags)]   # unique under any DATA
        doc["bags"] = len(bags)
        work = Path(tmp) / "written"
        _write_all(recs[:2], names[:2], work, MODES[-1])     # imports, type store
        doc["load_before"] = uptime()
        ref = None
        times: dict[str, dict[str, list]] = {m: {"wall": [], "cpu": []} for m in MODES}
        for r in range(a.repeats):
            for mode in (MODES if r % 2 == 0 else MODES[::-1]):
                wall, cpu, paths = _write_all(recs, names, work, mode)
                stored = [_stored(p) for p in paths]
                if ref is None:
                    ref = stored
                elif stored != ref:
                    sys.exit(f"bag_write: {mode} stored other messages than the first mode")
                times[mode]["wall"].append(wall)
                times[mode]["cpu"].append(cpu)
        doc["load_after"] = uptime()
    n = len(bags)
    base = statistics.median(times[MODES[0]]["wall"])
    doc["modes"] = {m: {"wall_ms_per_bag": 1e3 * statistics.median(t["wall"]) / n,
                        "cpu_ms_per_bag": 1e3 * statistics.median(t["cpu"]) / n,
                        "speed_up": base / statistics.median(t["wall"]),
                        "wall_s": t["wall"], "cpu_s": t["cpu"]} for m, t in times.items()}
    lines = ["# Writing a dataset's bags (`write_bag`)", "",
             command_line(doc) + "  ", f"Code: {doc['git']}; date {doc['date']}; "
             f"{n} bags; {a.repeats} repeats, medians", "",
             f"Load before: `{doc['load_before']}`  ", f"after: `{doc['load_after']}`", "",
             "| mode | wall [ms per bag] | CPU [ms per bag] | speed-up (wall) |",
             "|---|---|---|---|"]
    for m, r in doc["modes"].items():
        lines.append(f"| {m} | {r['wall_ms_per_bag']:.1f} | {r['cpu_ms_per_bag']:.1f} | "
                     f"{r['speed_up']:.2f}x |")
    lines += ["", "Every bag written in either mode stored the same messages (topics, bag times "
              "and CDR bytes, in order) as in the first mode."]
    write_results(a.out, doc, lines)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
