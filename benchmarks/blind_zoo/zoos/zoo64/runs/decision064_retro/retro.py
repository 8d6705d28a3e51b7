"""Decision 064 read again over the committed reports (files only, nothing re-run).

For each diagnosis report under ``benchmarks/blind_zoo/zoos/*/runs/`` (but the zoos named in
``--skip``: a sealed zoo's reports are not read) whose reading of what is left against the
reference is marked as made across excitations (``comparable: false``, which decisions 031 and
052 added; earlier reports do not carry it), in either route
(``physics.reference.unexplained``, the physical route; ``unexplained_change``, the learned
route), this prints the scope and concentration it read, whether it was significant, whether
decision 033/052's rule counted it as concentrated, whether decision 064's does, and the
truth of the dataset (the zoo's ``truth.yaml``: family and scope, or ``clean``).

    .venv/bin/python benchmarks/blind_zoo/zoos/zoo64/runs/decision064_retro/retro.py
"""
from __future__ import annotations

import argparse
import glob
import json
import os
import re
import sys

import yaml

from littledog_mlsim.diagnose.learned import concentrated_at_joints, over_type_mates

ROOT = os.path.abspath(os.path.join(os.path.dirname(__file__), *[".."] * 6))
HERE = os.path.dirname(os.path.abspath(__file__))


def readings(report: dict):
    """(route, reading) for each reading made across excitations."""
    left = ((report.get("physics") or {}).get("reference") or {}).get("unexplained") or {}
    if left.get("comparable") is False:
        yield "physical", left

    def walk(o):
        if isinstance(o, dict):
            for k, v in o.items():
                if k == "unexplained_change" and isinstance(v, dict):
                    yield v
                else:
                    yield from walk(v)
        elif isinstance(o, list):
            for v in o:
                yield from walk(v)
    for uc in walk(report):
        if uc.get("comparable") is False:
            yield "learned", uc


def truth_of(zoo: str, name: str) -> str:
    if name.startswith("clean") or "clean_" in name or re.match(r"s\d+_e", name):
        return "clean"
    path = os.path.join(ROOT, "benchmarks/blind_zoo/zoos", zoo, "truth.yaml")
    if not os.path.exists(path):
        return "?"
    effects = yaml.safe_load(open(path)).get("effects", [])
    key = name.split(".")[0].split("_")[0].split(" ")[0]
    for e in effects:
        if e.get("id") == key:
            return f"{e.get('family')} @ {e.get('scope')}"
    return "?"


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--skip", required=True,
                    help="comma-separated zoos not to read (a sealed zoo), e.g. zoo65")
    skip = {z for z in ap.parse_args().skip.split(",") if z}
    rows = []
    pattern = os.path.join(ROOT, "benchmarks/blind_zoo/zoos/*/runs/**/*.json")
    for f in sorted(glob.glob(pattern, recursive=True)):
        if "/reports/" not in f or not (f.endswith("report.json")):
            continue
        try:
            report = json.load(open(f))
        except (OSError, ValueError):
            continue
        if not isinstance(report, dict):
            continue
        rel = os.path.relpath(f, os.path.join(ROOT, "benchmarks/blind_zoo/zoos"))
        zoo, _, run = rel.split("/")[:3]
        if zoo in skip:
            continue
        name = rel.split("/reports/")[1].replace("/report.json", "").replace(".report.json", "")
        for route, r in readings(report):
            before = bool(r.get("concentrated", False))
            after = concentrated_at_joints(r)
            kind, _, what = str(r.get("scope")).partition(":")
            mates = over_type_mates(r, what) if kind == "joint" else float("nan")
            rows.append({"zoo": zoo, "run": run, "dataset": name, "route": route,
                         "scope": r.get("scope"),
                         "concentration": round(float(r.get("concentration") or 0.0), 2),
                         "over_type_mates": None if mates != mates else round(mates, 2),
                         "significant": bool(r.get("significant")),
                         "concentrated_033": before, "concentrated_064": after,
                         "named_before": bool(r.get("named")) or (
                             route == "learned" and before and bool(r.get("significant"))),
                         "truth": truth_of(zoo, name)})
    lines = ["| zoo | run | dataset | route | scope (concentration) | significant | "
             "joint over its type's others | concentrated (033/052) | concentrated (064) | "
             "named before | truth |",
             "|---|---|---|---|---|---|---|---|---|---|---|"]
    for r in rows:
        lines.append(f"| {r['zoo']} | {r['run']} | {r['dataset']} | {r['route']} | "
                     f"{r['scope']} ({r['concentration']}) | {r['significant']} | "
                     f"{'' if r['over_type_mates'] is None else r['over_type_mates']} | "
                     f"{r['concentrated_033']} | {r['concentrated_064']} | "
                     f"{r['named_before']} | {r['truth']} |")
    changed = [r for r in rows if r["concentrated_033"] != r["concentrated_064"]]
    lines += ["", f"readings across excitations: {len(rows)}; whose concentration reading "
              f"decision 064 changes: {len(changed)}"
              + "".join(f"; {r['zoo']} {r['run']} {r['dataset']} ({r['scope']}, "
                        f"named before {r['named_before']}, truth {r['truth']})"
                        for r in changed)]
    text = "\n".join(lines) + "\n"
    sys.stdout.write(text)
    with open(os.path.join(HERE, "retro.md"), "w") as fh:
        fh.write(text)
    with open(os.path.join(HERE, "retro.json"), "w") as fh:
        json.dump(rows, fh, indent=1)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
