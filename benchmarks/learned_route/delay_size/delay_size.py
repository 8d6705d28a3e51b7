"""A set-point delay named since the reference on read zoos: the scan's integer lag against
its column alone at fractional delays (tried at dbab1d8, not adopted).

    OPENBLAS_NUM_THREADS=1 .venv/bin/python benchmarks/learned_route/delay_size/delay_size.py \
        --zoo-dir WORK19 --truth benchmarks/blind_zoo/zoos/zoo19/truth.yaml --label zoo19 \
        --out OUT

WORK19 holds a zoo's recordings as the blind-zoo harness writes them (``reference``,
``effects/zNN``). For every effect whose truth is a ``command_delay``, the search model fitted on
the whole reference at the route's start feature set is read through
:func:`littledog_mlsim.diagnose.change.reference_change`, as a diagnosis whose search accepted
nothing would read it. Each row gives the truth, what decision 027 names, the scan's integer lag
(``set-point delay k step(s)``, the size decision 027 gives) and the size of the tried code
(``size.delay_ms``: at dbab1d8 the kept delay's column alone, ``u(t - 0.5 - d) - u(t - 0.5)``
steps, on a grid of d; at any later commit the same as the scan's), each with its error against
the truth (these zoos' truth has been read). Writes OUT.md and OUT.json
(appending rows where OUT.json exists).
"""
from __future__ import annotations

import os
import sys
import time
from pathlib import Path

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
sys.path[:0] = [str(Path(__file__).resolve().parents[3]), str(Path(__file__).resolve().parents[2])]

import numpy as np  # noqa: E402
from _common import (appended_study, save_study, study_commands, zoo_effects,  # noqa: E402
                     zoo_study_parser)

from littledog_mlsim.data.dataset import load_moves   # noqa: E402
from littledog_mlsim.diagnose.candidates import measured_robot_features   # noqa: E402
from littledog_mlsim.diagnose.change import reference_change   # noqa: E402
from littledog_mlsim.diagnose.learned import LearnedOptions, _Route   # noqa: E402


def _err(ms: float | None, truth: float) -> float | None:
    return None if ms is None else round(abs(ms / truth - 1.0), 3)


def write_md(doc: dict, path: Path) -> None:
    """The study's table of ``doc``'s rows, under its commands."""
    lines = ["# The size of a set-point delay named since the reference, on read zoos "
             "(tried, not adopted)", ""]
    lines += study_commands(doc)
    lines += ["", "| zoo | effect | truth | named | scan's lag [ms] | error | sized [ms] | error |",
              "|---|---|---|---|---|---|---|---|"]
    for r in doc["rows"]:
        def e(v):
            return "" if v is None else f"{100 * v:.0f} %"
        lines.append(f"| {r['zoo']} | {r['data']} | {r['truth']} | {r['named'] or '-'} | "
                     f"{'' if r['scan_ms'] is None else r['scan_ms']} | {e(r['scan_error'])} | "
                     f"{'' if r['sized_ms'] is None else r['sized_ms']} | {e(r['sized_error'])} |")
    sized = [r for r in doc["rows"] if r["sized_error"] is not None]
    if sized:
        within = sum(r["sized_error"] <= 0.25 for r in sized)
        before = sum(r["scan_error"] <= 0.25 for r in sized)
        mean = [100 * np.mean([r[k] for r in sized]) for k in ("scan_error", "sized_error")]
        lines += ["", f"Within 25 %: {before} of {len(sized)} by the scan's lag, {within} of "
                  f"{len(sized)} sized (rows where a delay was named). Mean error: "
                  f"{mean[0]:.0f} % by the scan's lag, {mean[1]:.0f} % sized."]
    path.write_text("\n".join(lines) + "\n")


def main() -> None:
    p = zoo_study_parser(__doc__.splitlines()[0])
    a = p.parse_args()
    opts, start = LearnedOptions(), measured_robot_features()
    quiet = lambda s: None  # noqa: E731
    delays = [e for e in zoo_effects(a.truth) if e["family"] == "command_delay"]
    ref = _Route(load_moves(a.zoo_dir / "reference", "train"), start, opts, quiet)
    ref_fit = ref.fit(start, one_step=True)
    doc = appended_study(a.out.with_suffix(".json"))
    for e in delays:
        t = time.perf_counter()
        truth = float(e["params"]["delay_ms"])
        r = _Route(load_moves(a.zoo_dir / "effects" / e["id"], "train"), start, opts, quiet)
        c = reference_change(r, ref, start, None, None, ref_fit)
        voc = c.get("vocabulary") or {}
        scan = (10.0 * int(c["label"].split(" step")[0].rsplit(" ", 1)[1])
                if c.get("named") and c.get("family") == "command_delay" else None)
        sized = (voc.get("params") or {}).get("delay_ms") if c.get("named") else None
        row = {"zoo": a.label, "data": e["id"], "truth": f"command_delay @ {e['scope']}, "
               f"{truth:g} ms", "named": f"{voc['family']} @ {voc['scope']}" if voc else None,
               "scan_ms": scan, "scan_error": _err(scan, truth), "sized_ms": sized,
               "sized_error": _err(sized if voc.get("family") == "command_delay" else None,
                                   truth),
               "seconds": round(time.perf_counter() - t, 1)}
        doc["rows"].append(row)
        print(row, flush=True)
    save_study(doc, a.out, write_md)


if __name__ == "__main__":
    main()
