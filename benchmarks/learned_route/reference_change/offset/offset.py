"""Decision 039 on read zoos: an angle sensor's offset read where the servo response stands
alone, against the same screen without it.

    OPENBLAS_NUM_THREADS=1 .venv/bin/python \
        benchmarks/learned_route/reference_change/offset/offset.py --zoo-dir WORK23 \
        --truth benchmarks/blind_zoo/zoos/zoo23/truth.yaml --label zoo23 --only z09 --out OUT

WORK23 holds a zoo's recordings as the blind-zoo harness writes them (``reference``,
``effects/zNN``). For each effect of ``--only``, the search model fitted on the whole reference
at the route's start feature set is read through
:func:`littledog_mlsim.diagnose.change.reference_change`, as a diagnosis whose search accepted
nothing would read it, once with decision 039's offset screen (``change.SCREEN_OFFSET``) and
once without; each row gives what each names, the hypothesis kept with it (its share of the
excess explained and its size, named or not), and the offset screen's two tests (the
constant alone against the reference; the servo's other columns against the constant),
against the truth (read). Writes OUT.md and OUT.json (appending rows where OUT.json
exists).
"""
from __future__ import annotations

import os
import sys
from pathlib import Path

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
sys.path[:0] = [str(Path(__file__).resolve().parents[4]), str(Path(__file__).resolve().parents[3])]

from _common import named_change, save_study, study_commands, zoo_effect_study  # noqa: E402

from littledog_mlsim.diagnose import change   # noqa: E402

PRIMARY = {"encoder_offset": "offset_rad", "servo_gain": "gain_ratio"}


def _named(c: dict) -> str | None:
    if not c["named"]:
        return None
    v = c["vocabulary"]
    key = PRIMARY.get(v["family"])
    return named_change(c) + ("" if key is None else f" ({key} {v['params'].get(key)})")


def _stage(c: dict, stage: str) -> dict | None:
    return next((r for r in c["hypotheses"] if r["stage"] == stage), None)


def write_md(doc: dict, path: Path) -> None:
    num = lambda x, f: "-" if x is None else format(x, f)  # noqa: E731
    lines = ["# Decision 039 on read zoos: an angle sensor's offset", ""]
    lines += study_commands(doc)
    lines += ["", "| zoo | effect | truth | located | named without 039 | named with 039 | "
              "offset alone: p, gain | servo's columns over it: p, gain | kept with 039: "
              "explained, size | error | seconds |",
              "|---|---|---|---|---|---|---|---|---|---|---|"]
    for r in doc["rows"]:
        o, g = r["offset"] or {}, r["gain_over_offset"] or {}
        lines.append(
            f"| {r['zoo']} | {r['data']} | {r['truth']} | {r['scope']} ({r['ratio']:.2f}) | "
            f"{r['without'] or 'nothing'} | {r['with'] or 'nothing'} | "
            f"{num(o.get('p_value'), '.2g')}, {num(o.get('total_gain'), '.2f')} | "
            f"{num(g.get('p_value'), '.2g')}, {num(g.get('total_gain'), '.2f')} | "
            f"{r['kept'] or '-'}: {num(r['explained'], '.0%')}, "
            f"{', '.join(f'{k} {v}' for k, v in r['size'].items()) or '-'} | "
            f"{num(r['error'], '.0%')} | {r['seconds']} |")
    path.write_text("\n".join(lines) + "\n")


def main() -> None:
    a, start, ref, ref_fit, effects, doc = zoo_effect_study(__doc__.splitlines()[0])
    for name, e, r, seconds in effects:
        got = {}
        for on in (False, True):
            change.SCREEN_OFFSET = on
            got[on] = change.reference_change(r, ref, start, None, None, ref_fit)
        c = got[True]
        params = e.get("params") or {}
        key = PRIMARY.get(e["family"])
        tv = params.get(key) if key else None
        size = c.get("size") or {}
        gv = size.get(key) if key and c.get("family") == e["family"] else None
        row = {"zoo": a.label, "data": name,
               "truth": f"{e['family']} @ {e['scope']}" + (f": {key} {tv}" if key else ""),
               "scope": c["scope"], "ratio": c["ratio"], "significant": c["significant"],
               "without": _named(got[False]), "with": _named(c),
               "offset": _stage(c, "offset"), "gain_over_offset": _stage(c, "gain over offset"),
               "kept": c.get("label"), "explained": c.get("explained"),
               "size": {k: v for k, v in size.items() if k != "per_joint"},
               "per_joint": size.get("per_joint"),
               "error": None if gv is None or not tv else abs(gv / tv - 1.0),
               "seconds": seconds()}
        doc["rows"].append(row)
        print(row, flush=True)
    save_study(doc, a.out, write_md)


if __name__ == "__main__":
    main()
