"""One diagnosis, run by two checkouts of the code: its wall time and whether the reports agree.

Usage (from the repo root):

    OPENBLAS_NUM_THREADS=1 .venv/bin/python benchmarks/diagnose_speed/zoo_diagnosis/compare.py \
        --before OLD_CHECKOUT --data DATA --work WORK --out OUT [-- DIAGNOSE_ARGS ...]

``OLD_CHECKOUT`` is a checkout of earlier code with its own ``.venv`` (``make venv`` there); the
repository this script lives in is "after". Each runs ``littledog-mlsim diagnose --data DATA
--out WORK/<side> DIAGNOSE_ARGS`` with its own interpreter and its own package first on the
path (``python -P``), one at a time, "after" first unless ``--before-first``. Written: ``OUT.json`` and
``OUT.md``: each side's wall time, the time its report gives, the load before and after, and
the fields of the two ``report.json`` files that differ, leaving out timings (keys with
``seconds`` in their name or ending in ``wall_s``) and the output paths; the ``model`` directories are compared file
by file too (size only: the model file holds its paths).
"""
from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[2]))
from _common import run_record, uptime, write_results  # noqa: E402

ROOT = Path(__file__).resolve().parents[3]


def _diagnose(tree: Path, data: Path, out: Path, extra: list[str], log: Path) -> float:
    cmd = [str(tree / ".venv/bin/python"), "-P", "-m", "littledog_mlsim.cli", "diagnose",
           "--data", str(data), "--out", str(out), *extra]
    env = {**os.environ, "PYTHONPATH": str(tree), "OPENBLAS_NUM_THREADS": "1"}
    t0 = time.perf_counter()
    with open(log, "w") as f:
        rc = subprocess.run(cmd, env=env, stdout=f, stderr=subprocess.STDOUT).returncode
    if rc != 0:
        sys.exit(f"compare: diagnose in {tree} exited {rc}; see {log}")
    return time.perf_counter() - t0


def _differences(a, b, where: str = "") -> list[str]:
    """Paths in two JSON values that differ (timings and paths left out)."""
    if isinstance(a, dict) and isinstance(b, dict):
        out = []
        for k in sorted(set(a) | set(b)):
            if "seconds" in str(k) or str(k).endswith("wall_s"):
                continue
            if k not in a or k not in b:
                out.append(f"{where}/{k}: only in {'after' if k in a else 'before'}")
                continue
            out += _differences(a[k], b[k], f"{where}/{k}")
        return out
    if isinstance(a, list) and isinstance(b, list):
        if len(a) != len(b):
            return [f"{where}: {len(a)} items against {len(b)}"]
        return [d for i, (x, y) in enumerate(zip(a, b)) for d in _differences(x, y, f"{where}[{i}]")]
    if isinstance(a, str) and isinstance(b, str) and ("/after" in a or "/before" in b):
        return []
    return [] if a == b else [f"{where}: {a!r} against {b!r}"]


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--before", type=Path, required=True)
    ap.add_argument("--data", type=Path, required=True)
    ap.add_argument("--work", type=Path, required=True)
    ap.add_argument("--out", type=Path, required=True)
    ap.add_argument("--before-first", action="store_true",
                    help="run the before side first (to alternate the order between runs)")
    ap.add_argument("diagnose_args", nargs=argparse.REMAINDER)
    a = ap.parse_args(argv)
    extra = [x for x in a.diagnose_args if x != "--"]
    doc = run_record("diagnose_speed/zoo_diagnosis/compare.py", argv)
    before_head = subprocess.run(["git", "-C", str(a.before), "rev-parse", "--short", "HEAD"],
                                 capture_output=True, text=True).stdout.strip()
    doc["before"] = before_head
    a.work.mkdir(parents=True, exist_ok=True)
    sides = {}
    order = [("after", ROOT), ("before", a.before.resolve())]
    for side, tree in (order[::-1] if a.before_first else order):
        out = a.work / side
        if out.exists():
            sys.exit(f"compare: {out} exists; give a new --work")
        load0 = uptime()
        wall = _diagnose(tree, a.data, out, extra, a.work / f"{side}.log")
        rep = json.loads((out / "report.json").read_text())
        said = (a.work / f"{side}.log").read_text().splitlines()
        sides[side] = {"wall_s": wall, "load_before": load0, "load_after": uptime(),
                       "log_tail": said[-4:], "report": rep,
                       "model_files": sorted((p.relative_to(out / "model").as_posix(),
                                              p.stat().st_size)
                                             for p in (out / "model").rglob("*") if p.is_file())
                       if (out / "model").is_dir() else []}
    diffs = _differences(sides["after"]["report"], sides["before"]["report"])
    same_model = sides["after"]["model_files"] == sides["before"]["model_files"]
    doc.update({"data": str(a.data), "diagnose_args": extra, "differences": diffs,
                "model_files_same_sizes": same_model,
                "sides": {k: {kk: v for kk, v in s.items() if kk != "report"}
                          for k, s in sides.items()}})
    r = sides["after"]["wall_s"] / sides["before"]["wall_s"]
    lines = ["# One diagnosis, before and after", "",
             f"Command: `OPENBLAS_NUM_THREADS=1 .venv/bin/python {doc['command']}`  ",
             f"After: {doc['git']}; before: {before_head}; date {doc['date']}", "",
             "| side | wall [s] | load before | load after |", "|---|---|---|---|"]
    for k, s in sides.items():   # in the order they ran
        lines.append(f"| {k} | {s['wall_s']:.1f} | `{s['load_before']}` | `{s['load_after']}` |")
    lines += ["", f"After / before: {r:.3f}.", "",
              f"report.json, timings and output paths left out: "
              f"{'the same' if not diffs else f'{len(diffs)} differences'}; the model "
              f"directories' files {'have the same names and sizes' if same_model else 'differ'}."]
    lines += [f"- {d}" for d in diffs[:40]]
    write_results(a.out, doc, lines)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
