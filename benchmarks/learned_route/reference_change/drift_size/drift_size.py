"""Decision 038 on read zoos: a time drift decision 027 names, sized by a direct regression on
each recording against the correction's coefficient over the servo slope.

    OPENBLAS_NUM_THREADS=1 .venv/bin/python \
        benchmarks/learned_route/reference_change/drift_size/drift_size.py --zoo-dir WORK23 \
        --truth benchmarks/blind_zoo/zoos/zoo23/truth.yaml --label zoo23 --only z04 --out OUT

WORK23 holds a zoo's recordings as the blind-zoo harness writes them (``reference``,
``effects/zNN``). For each effect of ``--only``, the search model fitted on the whole reference
at the route's start feature set is read through
:func:`littledog_mlsim.diagnose.change.reference_change`, as a diagnosis whose search accepted
nothing would read it; where it names a time drift, the row gives its rate (decision 038:
each joint's coefficient of t (u - q) over that of u - q in its rate's one-step change, on the
data minus on the reference, the median over the scope) and ``model_rate_per_s`` (the
correction's coefficient over the reference's servo slope, decision 027's size before),
against the truth (read). Writes OUT.md and OUT.json (appending rows where OUT.json exists).
"""
from __future__ import annotations

import os
import sys
from pathlib import Path

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
sys.path[:0] = [str(Path(__file__).resolve().parents[4]), str(Path(__file__).resolve().parents[3])]

from _common import named_change, save_study, study_commands, zoo_effect_study  # noqa: E402

from littledog_mlsim.diagnose.change import reference_change   # noqa: E402


def _err(got, truth):
    return None if got is None or not truth else abs(got / truth - 1.0)


def write_md(doc: dict, path: Path) -> None:
    num = lambda x, f: "-" if x is None else format(x, f)  # noqa: E731
    lines = ["# Decision 038 on read zoos: a time drift sized by a direct regression", ""]
    lines += study_commands(doc)
    lines += ["", "| zoo | effect | truth | named | rate, direct [1/s] | error | rate, "
              "correction over servo slope [1/s] | error | seconds |",
              "|---|---|---|---|---|---|---|---|---|"]
    for r in doc["rows"]:
        lines.append(f"| {r['zoo']} | {r['data']} | {r['truth']}: {r['truth_rate']} | "
                     f"{r['named'] or 'nothing'} | {num(r['rate'], '.4f')} | "
                     f"{num(r['error'], '.0%')} | {num(r['model_rate'], '.4f')} | "
                     f"{num(r['model_error'], '.0%')} | {r['seconds']} |")
    path.write_text("\n".join(lines) + "\n")


def main() -> None:
    a, start, ref, ref_fit, effects, doc = zoo_effect_study(__doc__.splitlines()[0])
    for name, e, r, seconds in effects:
        c = reference_change(r, ref, start, None, None, ref_fit)
        tr = (e.get("params") or {}).get("rate_per_s")
        drift = c["named"] and c.get("family") == "time_drift"
        size = c.get("size") or {}
        rate = size.get("rate_per_s") if drift else None
        model_rate = size.get("model_rate_per_s") if drift else None
        row = {"zoo": a.label, "data": name, "truth": f"{e['family']} @ {e['scope']}",
               "truth_rate": tr,
               "named": named_change(c),
               "rate": rate, "error": _err(rate, tr), "model_rate": model_rate,
               "model_error": _err(model_rate, tr), "per_joint": size.get("per_joint"),
               "seconds": seconds()}
        doc["rows"].append(row)
        print(row, flush=True)
    save_study(doc, a.out, write_md)


if __name__ == "__main__":
    main()
