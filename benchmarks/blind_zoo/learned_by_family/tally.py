"""The no-twin arm's blind first runs, by the true family: how often each was found.

Reads only committed files: each zoo's ``runs/run1/learned*/results.json`` (the harness's
scoring of the first, blind run of the arm ``learned`` or ``learned+reference``) and the zoo's
``truth.yaml`` (for ``learned_inputs``). First-pass rows only (not the recommended recordings).
Zoos whose first run is of another arm are skipped; zoos named with ``--skip`` are left out
(a zoo still sealed must be). Usage, from the repository root:

    .venv/bin/python benchmarks/blind_zoo/learned_by_family/tally.py --skip zoo64,zoo65 > \
        benchmarks/blind_zoo/learned_by_family/result.md
"""
from __future__ import annotations

import argparse
import collections
import json
from pathlib import Path
from typing import Iterator

import yaml

ZOOS = Path(__file__).resolve().parents[1] / "zoos"


def first_runs(skip: set[str]) -> Iterator[tuple[str, Path, Path]]:
    """(zoo, run directory, truth.yaml) of each zoo's first no-twin run (the first of
    ``runs/run1/learned*`` with a ``results.json``), zoos in numeric order; zoos in ``skip``
    are not opened."""
    for zoo in sorted(ZOOS.iterdir(), key=lambda p: int(p.name[3:]) if p.name[3:].isdigit() else 0):
        if zoo.name in skip:
            continue
        found = sorted((zoo / "runs" / "run1").glob("learned*/results.json"))
        if found:
            yield zoo.name, found[0].parent, zoo / "truth.yaml"


def rows(skip: set[str]):
    """(zoo, row, learned_inputs) of every first-pass effect row of a no-twin first run."""
    for zoo, run, truth_file in first_runs(skip):
        truth = {e["id"]: e for e in yaml.safe_load(truth_file.read_text())["effects"]}
        for row in json.loads((run / "results.json").read_text())["rows"]:
            if row["id"] not in truth:      # a recommended recording's row
                continue
            yield zoo, row, bool(truth[row["id"]].get("learned_inputs", False))


def harm_of(row: dict, key: str = "rollout_before") -> float | None:
    """The effect's harm to the learned model: its TestPool error ``key`` (``rollout_before``:
    the final (x, y) error of the rollouts; ``onestep_before``: the one-step nMSE) before any
    fix over clean data's of the same seed (None where either is missing)."""
    before = (row.get("errors") or {}).get(key)
    clean = (row.get("clean") or {}).get(key)
    return before / clean if before and clean else None


def _median(xs: list) -> str:
    xs = sorted(x for x in xs if x is not None)
    if not xs:
        return "-"
    m = xs[len(xs) // 2] if len(xs) % 2 else 0.5 * (xs[len(xs) // 2 - 1] + xs[len(xs) // 2])
    return f"{m:.2f}"


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--skip", required=True,
                    help="comma-separated zoos left out (every sealed zoo), e.g. zoo64,zoo65")
    a = ap.parse_args()
    skip = {z.strip() for z in a.skip.split(",") if z.strip()}
    by = collections.defaultdict(lambda: collections.Counter())
    harm: dict[tuple, list] = collections.defaultdict(list)
    harm1: dict[tuple, list] = collections.defaultdict(list)
    found_harm: dict[tuple, list] = collections.defaultdict(list)
    missed_harm: dict[tuple, list] = collections.defaultdict(list)
    zoos: set[str] = set()
    for zoo, row, carried in rows(skip):
        zoos.add(zoo)
        key = (carried, row["truth"]["family"])
        s = row["score"]
        by[key]["n"] += 1
        by[key]["found"] += bool(s["found"])
        by[key]["family right"] += bool(s["family_right"])
        by[key]["scope right"] += bool(s["scope_right"])
        by[key]["named nothing"] += not s["named"]
        by[key]["suspected, not found"] += bool(s.get("suspected")) and not s["found"]
        harm[key].append(harm_of(row))
        harm1[key].append(harm_of(row, "onestep_before"))
        (found_harm if s["found"] else missed_harm)[key].append(harm_of(row))
    order = sorted(zoos, key=lambda z: int(z[3:]))
    print(f"# The no-twin arm's blind first runs by true family ({len(order)} zoos: "
          f"{order[0]}-{order[-1]})\n")
    print("Command: `.venv/bin/python benchmarks/blind_zoo/learned_by_family/tally.py "
          f"--skip {','.join(sorted(skip))}`\n")
    for carried in (False, True):
        title = ("Effects a learned model carries (`learned_inputs: true`): right when named right "
                 "or nothing is named" if carried else
                 "Effects outside a learned model's inputs (`learned_inputs: false`): the arm's "
                 "target counts these")
        print(f"## {title}\n")
        print("| family | effects | found | family right | scope right | named nothing | "
              "suspected, not found | rollout before / clean, median (found; not found) | "
              "one-step before / clean, median |")
        print("|---|---|---|---|---|---|---|---|---|")
        keys = sorted((k for k in by if k[0] == carried), key=lambda k: -by[k]["n"])
        total = collections.Counter()
        for k in keys:
            c = by[k]
            total.update(c)
            print(f"| {k[1]} | {c['n']} | {c['found']} ({c['found'] / c['n']:.0%}) | "
                  f"{c['family right']} | {c['scope right']} | {c['named nothing']} | "
                  f"{c['suspected, not found']} | {_median(harm[k])} "
                  f"({_median(found_harm[k])}; {_median(missed_harm[k])}) | "
                  f"{_median(harm1[k])} |")
        if total["n"]:
            print(f"| **all** | {total['n']} | {total['found']} ({total['found'] / total['n']:.0%})"
                  f" | {total['family right']} | {total['scope right']} | "
                  f"{total['named nothing']} | {total['suspected, not found']} | "
                  f"{_median([h for k in keys for h in harm[k]])} "
                  f"({_median([h for k in keys for h in found_harm[k]])}; "
                  f"{_median([h for k in keys for h in missed_harm[k]])}) | "
                  f"{_median([h for k in keys for h in harm1[k]])} |")
        print()


if __name__ == "__main__":
    main()
