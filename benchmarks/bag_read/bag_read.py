"""Reading a dataset's bags: ``read_bag`` per bag, with and without its two speed-ups.

Usage (from the repo root, in the venv):

    OPENBLAS_NUM_THREADS=1 .venv/bin/python benchmarks/bag_read/bag_read.py \
        [--data DATA] [--moves-per-type 2] [--repeats 5] [--out benchmarks/bag_read/result]

Every bag under DATA (any depth) is read. Without ``--data`` it records ``--moves-per-type``
moves of every type (``record``, seed 0)
into a temporary directory first. The bags are read in four modes, in
turn, ``--repeats`` times (the order rotates each repeat):

- ``per message, Python YAML``: every message decoded by ``rosbags`` on its own
  (``_same_layout_columns`` off) and the bag's metadata parsed by ruamel.yaml's pure-Python
  parser (its C parser hidden);
- ``per message, C YAML``: the metadata by ruamel.yaml.clib's parser;
- ``arrays, Python YAML``: a topic whose messages share one layout read as arrays;
- ``arrays, C YAML``: both (what ``read_bag`` does where ruamel.yaml.clib is installed).

Each mode's every read is checked to give the same ``MoveRecording`` as the first mode's, bit
for bit and in the same memory layout. Reported: the median over the repeats of the milliseconds per bag (wall and this
process's CPU), and the ratio to the first mode.
"""
from __future__ import annotations

import sys
import tempfile
import time
from pathlib import Path


sys.path.insert(0, str(Path(__file__).resolve().parents[1]))
from _common import (bag_benchmark_args, bags_to_time, per_bag_modes,  # noqa: E402
                     run_record, timed_modes, uptime, write_results)

FIELDS = ("stamps_ns", "cmd", "q", "dq", "position", "orientation", "linear_velocity",
          "angular_velocity")
MODES = ("per message, Python YAML", "per message, C YAML", "arrays, Python YAML",
         "arrays, C YAML")


def _read_all(bags, mode: str) -> tuple[float, float, list]:
    import ruamel.yaml.main as yaml_main

    from littledog_mlsim.data import bags as bags_mod
    real_parser, real_columns = yaml_main.CParser, bags_mod._same_layout_columns
    if "Python YAML" in mode:
        yaml_main.CParser = None
    if mode.startswith("per message"):
        bags_mod._same_layout_columns = lambda *a: None
    try:
        c0, t0 = time.process_time(), time.perf_counter()
        recs = [bags_mod.read_bag(b) for b in bags]
        wall, cpu = time.perf_counter() - t0, time.process_time() - c0
    finally:
        yaml_main.CParser, bags_mod._same_layout_columns = real_parser, real_columns
    return wall, cpu, recs


def _same(a, b) -> bool:
    """Bit for bit (-0.0 is not 0.0) and in the same memory layout."""
    return all(getattr(x, f).dtype == getattr(y, f).dtype
               and getattr(x, f).strides == getattr(y, f).strides
               and getattr(x, f).tobytes() == getattr(y, f).tobytes() for x, y in zip(a, b)
               for f in FIELDS)


def main(argv=None) -> int:
    a = bag_benchmark_args(__doc__.splitlines()[0], argv)
    import ruamel.yaml.main as yaml_main
    if yaml_main.CParser is None:
        sys.exit("bag_read: ruamel.yaml.clib is not installed (make venv installs it)")
    doc = run_record("bag_read/bag_read.py", argv)
    with tempfile.TemporaryDirectory() as tmp:
        bags = bags_to_time(a.data, a.moves_per_type, tmp, "bag_read")
        doc["bags"] = len(bags)
        doc["load_before"] = uptime()
        _read_all(bags[:2], MODES[-1])                    # imports, type store
        times = timed_modes(MODES, a.repeats, lambda mode: _read_all(bags, mode), _same,
                            "bag_read")
        doc["load_after"] = uptime()
    lines = per_bag_modes(doc, times, len(bags), "Reading a dataset's bags (`read_bag`)",
                          a.repeats)
    lines += ["", "Every mode read the same recordings as the first, bit for bit and in the same "
              "memory layout."]
    write_results(a.out, doc, lines)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
