"""The learned route's wall time before and after a change, and whether the report is the same.

Runs the same ``diagnose`` (learned route, ``--physics off --rollout-route``, optionally with a
``--reference``) once with each checkout's code, one after the other, each in its own process
tree (``CHECKOUT/.venv/bin/python -P -m littledog_mlsim.cli`` with ``PYTHONPATH=CHECKOUT``, run
from the checkout; the script checks which package that imports), and
compares the two ``report.json`` files with every key that holds a duration left out
(``seconds``, ``fit_and_score_seconds``, ``rollout_wall_s``, and anything under ``timing``).

    OPENBLAS_NUM_THREADS=1 .venv/bin/python benchmarks/learned_route/speed/run.py \\
        --data DATA --reference REFERENCE --before OLD_CHECKOUT --after NEW_CHECKOUT \\
        --work /tmp/speed --out benchmarks/learned_route/speed/result
"""
from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import time
from pathlib import Path

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE.parents[1]))

from _common import command_line, run_record, uptime, write_results  # noqa: E402

DURATION_KEYS = {"seconds", "fit_and_score_seconds", "rollout_wall_s", "timing"}


def strip_durations(obj):
    """``obj`` with every key naming a duration removed, recursively."""
    if isinstance(obj, dict):
        return {k: strip_durations(v) for k, v in obj.items() if k not in DURATION_KEYS}
    if isinstance(obj, list):
        return [strip_durations(v) for v in obj]
    return obj


def differences(a, b, path: str = "", out: list | None = None, limit: int = 20) -> list[str]:
    """Paths (at most ``limit``) where ``a`` and ``b`` differ."""
    out = [] if out is None else out
    if len(out) >= limit:
        return out
    if isinstance(a, dict) and isinstance(b, dict):
        for k in sorted(set(a) | set(b)):
            if k not in a or k not in b:
                out.append(f"{path}/{k}: only in {'after' if k in b else 'before'}")
            else:
                differences(a[k], b[k], f"{path}/{k}", out, limit)
    elif isinstance(a, list) and isinstance(b, list) and len(a) == len(b):
        for i, (x, y) in enumerate(zip(a, b)):
            differences(x, y, f"{path}[{i}]", out, limit)
    elif a != b:
        out.append(f"{path}: {str(a)[:80]} != {str(b)[:80]}")
    return out


def git_head(checkout: Path) -> str:
    r = subprocess.run(["git", "-C", str(checkout), "log", "-1", "--format=%h %s"],
                       capture_output=True, text=True)
    dirty = subprocess.run(["git", "-C", str(checkout), "status", "--porcelain",
                            "--untracked-files=no"], capture_output=True, text=True).stdout
    return r.stdout.strip() + (" + uncommitted changes" if dirty.strip() else "")


def run_one(checkout: Path, args: list[str], out: Path, log: Path) -> dict:
    python = str(checkout / ".venv" / "bin" / "python")
    cmd = [python, "-P", "-m", "littledog_mlsim.cli", "diagnose", *args, "--out", str(out)]
    # the checkout's package first, whatever the venv's editable install points at
    env = {**os.environ, "OPENBLAS_NUM_THREADS": "1", "PYTHONPATH": str(checkout)}
    where = subprocess.run([python, "-P", "-c", "import littledog_mlsim; "
                            "print(littledog_mlsim.__file__)"], env=env, capture_output=True,
                           text=True).stdout.strip()
    if not where.startswith(str(checkout)):
        raise SystemExit(f"{checkout}: its python imports littledog_mlsim from {where}")
    before = uptime()
    t0 = time.perf_counter()
    with open(log, "w") as fh:
        rc = subprocess.run(cmd, cwd=checkout, stdout=fh, stderr=subprocess.STDOUT,
                            env=env).returncode
    wall = time.perf_counter() - t0
    if rc != 0:
        raise SystemExit(f"diagnose with {checkout} failed (exit {rc}): see {log}")
    return {"code": git_head(checkout), "command": " ".join(cmd), "wall_s": wall,
            "report_seconds": json.loads((out / "report.json").read_text()).get("seconds"),
            "load_before": before, "load_after": uptime()}


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--data", required=True, type=Path)
    p.add_argument("--reference", type=Path, default=None)
    p.add_argument("--before", required=True, type=Path, help="checkout of the old code")
    p.add_argument("--after", required=True, type=Path, help="checkout of the new code")
    p.add_argument("--jobs", type=int, default=2)
    p.add_argument("--work", required=True, type=Path)
    p.add_argument("--out", type=Path, default=None)
    a = p.parse_args(argv)
    a.work.mkdir(parents=True, exist_ok=True)
    args = ["--data", str(a.data), "--no-figures", "--jobs", str(a.jobs), "--physics", "off",
            "--rollout-route"]
    if a.reference is not None:
        args += ["--reference", str(a.reference)]
    doc = run_record("learned_route/speed/run.py", argv)
    runs = {}
    for name, checkout in (("before", a.before), ("after", a.after)):
        runs[name] = run_one(checkout.resolve(), args, a.work / name, a.work / f"{name}.log")
        print(f"{name}: {runs[name]['wall_s']:.1f} s", flush=True)
    reports = {n: strip_durations(json.loads((a.work / n / "report.json").read_text()))
               for n in runs}
    diff = differences(reports["before"], reports["after"])
    doc.update(runs=runs, same_report=not diff, differences=diff,
               ratio=runs["after"]["wall_s"] / runs["before"]["wall_s"])
    lines = ["# The learned route's wall time, before and after", "",
             command_line(doc), "",
             "| run | code | wall [s] | report's `seconds` | load before | load after |",
             "|---|---|---|---|---|---|"]
    for n, r in runs.items():
        lines.append(f"| {n} | {r['code']} | {r['wall_s']:.1f} | {r['report_seconds']:.1f} | "
                     f"`{r['load_before']}` | `{r['load_after']}` |")
    lines += ["", f"after / before: {doc['ratio']:.3f}", "",
              "report.json without its durations: " + (
                  "**the same**" if not diff else "differs at:\n\n" + "\n".join(
                      f"- `{d}`" for d in diff))]
    write_results(a.out, doc, lines)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
