"""Where the blind runs of the arm with a reference miss: every effect outside a one-step
model's inputs of zoo10-NN's first runs, by class, found or not.

Reads only committed files: each zoo's `truth.yaml` and its first run's
`runs/run1/learned+reference/results.json`. The class is the truth's family, with two
refinements: an effect recorded with command excitation is its own class (decision 031 sets
its reading against the unexcited reference aside), and an `other` effect is split by the
words of its description (:data:`OTHER_CLASSES`, first match; the table lists each one so the
split can be checked).

    .venv/bin/python benchmarks/blind_zoo/misses/misses.py [--first 10] [--last 25] \
        [--out benchmarks/blind_zoo/misses/misses]
"""
from __future__ import annotations

import argparse
import json
import re
import sys
from collections import defaultdict
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[3]))   # the repository root
from benchmarks._common import git_state, zoo_effects  # noqa: E402

ZOOS = Path(__file__).resolve().parents[1] / "zoos"
ARM = "learned+reference"
#: an ``other`` effect's class from its description (first match; case-insensitive)
OTHER_CLASSES = (
    ("other: tether or cable to the room", r"\btether|\bleash|\banchor|cable from|cable to|trailing"),
    ("other: sensor latency", r"latenc|\bstale\b|\blags?\b|\bms (later|old)|late than|later than"
                              r"|are \d+ ms|delays every joint reading|publishes every"),
    ("other: lost set-point packets", r"packet|lossy|\blost\b"),
    ("other: floor that varies", r"slipp|\bwet\b|patch|\bice\b|\bgrip\b|carpet|\bbump|\bramp\b"
                                 r"|\bmat\b|\btiles?\b|polish|board on|\bslab\b|terrain|mopped"),
)


def klass(truth: dict, excitation: float) -> str:
    if excitation:
        return f"recorded with excitation ({truth['family']})"
    if truth["family"] != "other":
        return truth["family"]
    words = " ".join(str(truth.get(k) or "") for k in ("description", "params")).lower()
    for name, pattern in OTHER_CLASSES:
        if re.search(pattern, words):
            return name
    return "other: else"


def rows(first: int, last: int | None = None) -> list[dict]:
    out = []
    for zoo in sorted(ZOOS.glob("zoo*"), key=lambda p: int(p.name[3:])):
        res = zoo / "runs" / "run1" / ARM / "results.json"
        k = int(zoo.name[3:])
        if k < first or (last is not None and k > last) or not res.is_file():
            continue
        truth = {e["id"]: e for e in zoo_effects(zoo / "truth.yaml")}
        doc = json.loads(res.read_text())
        for row in doc["rows"]:
            t = truth.get(row["id"])
            if t is None or t.get("learned_inputs") is not False:
                continue             # a follow-up row, or an effect a model carries
            out.append({"zoo": zoo.name, "id": row["id"], "family": t["family"],
                        "scope": t["scope"], "excitation": row.get("excitation") or 0.0,
                        "class": klass(t, row.get("excitation") or 0.0),
                        "found": bool(row["score"]["found"]),
                        "named": [f"{n['family']} @ {n['scope']}"
                                  for n in row["score"].get("named") or []],
                        "description": " ".join(str(t.get("description") or "").split())})
    return out


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--first", type=int, default=10, help="the first zoo counted")
    ap.add_argument("--last", type=int, default=None, help="the last zoo counted (default: all)")
    ap.add_argument("--out", default=None, help="write OUT.md and OUT.json")
    a = ap.parse_args(argv)
    rs = rows(a.first, a.last)
    by = defaultdict(list)
    for r in rs:
        by[r["class"]].append(r)
    zoos = sorted({r["zoo"] for r in rs}, key=lambda z: int(z[3:]))
    lines = [f"# Blind misses by class, arm `{ARM}`, run1 of {zoos[0]}-{zoos[-1]}", "",
             f"Command: `.venv/bin/python benchmarks/blind_zoo/misses/misses.py --first "
             f"{a.first}" + (f" --last {a.last}" if a.last is not None else "")
             + f"` (code {git_state()}). Effects outside a one-step model's inputs only "
             "(`learned_inputs: false`).", "",
             "| class | effects | found | missed (zoo/effect) |", "|---|---|---|---|"]
    for k, v in sorted(by.items(), key=lambda kv: (-sum(not r["found"] for r in kv[1]), kv[0])):
        miss = [f"{r['zoo']}/{r['id']}" for r in v if not r["found"]]
        lines.append(f"| {k} | {len(v)} | {sum(r['found'] for r in v)} | {', '.join(miss)} |")
    n, f = len(rs), sum(r["found"] for r in rs)
    lines += ["", f"All: {f} of {n} found ({100 * f / n:.0f} %).", "",
              "## Each effect", "", "| zoo | effect | class | truth | found | named |",
              "|---|---|---|---|---|---|"]
    for r in rs:
        d = r["description"][:90] + ("..." if len(r["description"]) > 90 else "")
        lines.append(f"| {r['zoo']} | {r['id']} | {r['class']} | {r['family']} @ {r['scope']}: "
                     f"{d} | {'yes' if r['found'] else 'no'} | {'; '.join(r['named']) or '-'} |")
    text = "\n".join(lines) + "\n"
    if a.out:
        Path(a.out + ".md").write_text(text)
        Path(a.out + ".json").write_text(json.dumps({"rows": rs}, indent=1) + "\n")
    print(text)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
