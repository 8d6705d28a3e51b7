"""The learned route's stiffness drift against a reference (``diagnose/servo_drift.py``) on the
gap zoos' battery sags, not blind.

For each case: record the effect on the zoo's gap robot (its seed) and a clean reference of the
same robot (another seed), 10 moves per type, unless WORK has them (the same names as
``../push_reading/push_reading.py``, so one WORK serves both); measure each joint's stiffness
rate on the effect's TrainPool and the reference's; report the median difference over all
joints (the truths are all at all joints). Clean seeds against the reference must read near 0.
True values from the zoo's ``truth.yaml`` (zoos whose truth was read before this study).

    OPENBLAS_NUM_THREADS=1 .venv/bin/python \\
        benchmarks/learned_route/drift_reading/drift_reading.py --work WORK \\
        --out benchmarks/learned_route/drift_reading/result
"""
from __future__ import annotations

import argparse
import json
import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[3]
sys.path.insert(0, str(ROOT))
sys.path.insert(0, str(ROOT / "benchmarks" / "learned_route" / "push_reading"))

from push_reading import recorded, run_meta, truth  # noqa: E402

from littledog_mlsim.diagnose.learned import _moves  # noqa: E402
from littledog_mlsim.diagnose.servo_drift import joint_rates, rate_against_reference  # noqa: E402

#: (zoo, effect id or None for a clean seed, seed, reference seed)
CASES = [("zoo8", "g06", 31, 93), ("zoo9", "g11", 41, 94), ("zoo10", "z01", 51, 95),
         ("zoo11", "z05", 61, 96), ("zoo12", "z08", 71, 97),
         ("zoo8", None, 31, 93), ("zoo10", None, 51, 95), ("zoo12", None, 71, 97)]


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--work", required=True)
    ap.add_argument("--out", required=True, help="path stem: writes STEM.json and STEM.md")
    a = ap.parse_args()
    work = Path(a.work)
    rows = []
    for zoo, effect, seed, ref_seed in CASES:
        mv, mv_ref = (_moves(r) for r in recorded(work, zoo, effect, seed, ref_seed))
        t0 = time.perf_counter()
        got = rate_against_reference(mv, mv_ref)
        raw = float(np.nanmedian(joint_rates(mv)))
        secs = time.perf_counter() - t0
        tr = truth(zoo, effect) if effect else {"rate_per_s": 0.0}
        err = None if not tr["rate_per_s"] else abs(got["rate_per_s"] / tr["rate_per_s"] - 1)
        rows.append({"zoo": zoo, "effect": effect or "clean", "seed": seed,
                     "reference_seed": ref_seed, "truth": tr, "reading": got,
                     "no_reference_rate_per_s": raw, "param_error": err,
                     "seconds": secs})
        print(f"{zoo} {effect or 'clean'}: {got['rate_per_s']:+.3f}/s (data {raw:+.3f}, "
              f"reference {got['reference_rate_per_s']:+.3f}); truth {tr['rate_per_s']:+g}; "
              f"{secs:.1f} s", flush=True)
    out = Path(a.out)
    meta = run_meta()
    out.with_suffix(".json").write_text(json.dumps({"meta": meta, "cases": rows}, indent=1))
    lines = ["# The servos' stiffness drift against a reference", "",
             f"Command: `{meta['command']}`", "",
             f"Code: {meta['commit']}; {meta['date_utc']} UTC; "
             f"load after {meta['load_after']:.1f}.",
             "", "| zoo | effect | truth [1/s] | read against the reference [1/s] | error | "
             "the data alone [1/s] | the reference alone [1/s] |",
             "|---|---|---|---|---|---|---|"]
    for r in rows:
        g = r["reading"]
        def pct(e):
            return "-" if e is None else f"{100 * e:.0f} %"
        lines.append(
            f"| {r['zoo']} | {r['effect']} | {r['truth']['rate_per_s']:+g} | "
            f"{g['rate_per_s']:+.3f} | {pct(r['param_error'])} | "
            f"{r['no_reference_rate_per_s']:+.3f} | {g['reference_rate_per_s']:+.3f} |")
    out.with_suffix(".md").write_text("\n".join(lines) + "\n")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
