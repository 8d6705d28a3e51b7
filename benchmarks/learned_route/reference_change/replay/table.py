"""Decision 036's evidence table: decision 027 at the start features with and without the replay.

    .venv/bin/python benchmarks/learned_route/reference_change/replay/table.py \
        --with benchmarks/learned_route/reference_change/replay/with \
        --without benchmarks/learned_route/reference_change/replay/without \
        --out benchmarks/learned_route/reference_change/replay/table.md

Reads each zoo's ``run.py`` result (``zooNN.json``, in both directories) and the zoo's
``truth.yaml`` (``benchmarks/blind_zoo/zoos/zooNN``), and writes one row per recording: the
truth, what decision 027 names without the replay and with it, the kept family's best replay
and the share of the excess it removes, and the size's error against the truth.
"""
from __future__ import annotations

import argparse
import json
from pathlib import Path

import yaml

ROOT = Path(__file__).resolve().parents[4]
PRIMARY = {"command_delay": "delay_ms", "command_filter": "time_constant_ms",
           "backlash": "width_rad"}


def _truth(zoo: str) -> dict[str, dict]:
    t = yaml.safe_load((ROOT / "benchmarks/blind_zoo/zoos" / zoo / "truth.yaml").read_text())
    return {e["id"]: e for e in (t.get("effects", t) if isinstance(t, dict) else t)}


def _named(x: dict) -> tuple[str, str, float | None]:
    if not x.get("named"):
        return "nothing", "", None
    size = x.get("size") or {}
    key = PRIMARY.get(x["family"])
    return x["family"], x["kept_scope"], (size.get(key) if key else None)


def _err(v: float | None, truth: float | None) -> str:
    return "-" if v is None or not truth else f"{abs(v / truth - 1.0):.0%}"


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--with", dest="with_", type=Path, required=True)
    p.add_argument("--without", type=Path, required=True)
    p.add_argument("--out", type=Path, required=True)
    a = p.parse_args()
    L = ["# Decision 036: set-point changes sized by replay (decision 027 at the start features)",
         "", "Command: `.venv/bin/python " + " ".join(
             [str(Path(__file__).resolve().relative_to(ROOT)), "--with",
              str(a.with_.resolve().relative_to(ROOT)), "--without",
              str(a.without.resolve().relative_to(ROOT)), "--out",
              str(a.out.resolve().relative_to(ROOT))]) + "`", ""]
    codes = set()
    rows = []
    for f in sorted(a.with_.glob("zoo*.json")):
        zoo = f.stem
        w = json.loads(f.read_text())
        wo = json.loads((a.without / f.name).read_text())
        codes |= {w["code"], wo["code"]}
        truth = _truth(zoo)
        by = {x["data"]: x for x in wo["rows"]}
        for x in w["rows"]:
            t = truth.get(x["data"])
            if t is None:
                continue
            key = PRIMARY.get(t["family"])
            tv = (t.get("params") or {}).get(key) if key else None
            b, af = _named(by[x["data"]]), _named(x)
            rp = x.get("replay")
            rows.append({"zoo": zoo, "id": x["data"], "truth": t, "truth_value": tv,
                         "before": b, "after": af, "replay": rp})
    L += [f"Code: {', '.join(sorted(codes))} (with, without: the result files' `code`)", "",
          "| recording | truth | without the replay | with it | kept family's best replay "
          "(share of the excess it removes) | size error without / with |",
          "|---|---|---|---|---|---|"]
    for r in rows:
        t = r["truth"]
        tv = r["truth_value"]
        cell = lambda n: (n[0] if n[0] == "nothing" else  # noqa: E731
                          f"`{n[0]} @ {n[1]}`" + (f" {n[2]:g}" if n[2] is not None else ""))
        rp = r["replay"]
        rc = ("-" if not rp else f"{rp['label'].split(' @')[0]} ({rp['explained']:.2f}"
              f"{', sizes it' if rp['kept'] else ', below 0.5'})")
        right = lambda n: n[0] == t["family"] and n[1] == t["scope"]  # noqa: E731
        L.append(f"| {r['zoo']} {r['id']} | `{t['family']} @ {t['scope']}` {tv if tv is not None else ''} | "
                 f"{cell(r['before'])} | {cell(r['after'])} | {rc} | "
                 f"{_err(r['before'][2], tv) if right(r['before']) else '-'} / "
                 f"{_err(r['after'][2], tv) if right(r['after']) else '-'} |")
    ident = lambda n, r: (n[0] == r["truth"]["family"] and n[1] == r["truth"]["scope"]  # noqa
                          and n[2] is not None and r["truth_value"]
                          and abs(n[2] / r["truth_value"] - 1.0) <= 0.25)
    found = lambda n, r: n[0] == r["truth"]["family"] and n[1] == r["truth"]["scope"]  # noqa
    L += ["", f"Found (family and scope right): {sum(found(r['before'], r) for r in rows)} "
          f"without, {sum(found(r['after'], r) for r in rows)} with, of {len(rows)}. "
          f"Identified (found and the size within 25 %): "
          f"{sum(bool(ident(r['before'], r)) for r in rows)} without, "
          f"{sum(bool(ident(r['after'], r)) for r in rows)} with."]
    a.out.write_text("\n".join(L) + "\n")
    (a.out.with_suffix(".json")).write_text(json.dumps(rows, indent=1, default=str))


if __name__ == "__main__":
    main()
