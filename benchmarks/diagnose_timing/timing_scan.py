"""The sensor-timing check (``littledog_mlsim/diagnose/timing.py``) on a zoo's recordings.

For each zoo given as ``NAME=WORK`` (a blind-zoo harness work directory holding ``reference``,
``clean/<seed>`` and ``effects/<id>``), the check runs on every clean seed and effect dataset's
TrainPool, once without and once against the reference, exactly as ``diagnose`` runs it
(``sensor_timing``). The zoo's ``truth.yaml`` (``--zoos-dir``) gives each effect's family,
scope and parameters for the table. Writes ``OUT.md`` and ``OUT.json``.

    OPENBLAS_NUM_THREADS=1 .venv/bin/python benchmarks/diagnose_timing/timing_scan.py \\
        zoo11=WORK11 zoo12=WORK12 --out benchmarks/diagnose_timing/timing_scan
"""
from __future__ import annotations

import argparse
import json
import os
import sys
import time
from pathlib import Path

import yaml

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))
from _common import ROOT, git_state  # noqa: E402

from littledog_mlsim.data.dataset import load_moves  # noqa: E402
from littledog_mlsim.diagnose.timing import sensor_timing  # noqa: E402


def _truth(zoo: str, zoos_dir: Path) -> dict[str, dict]:
    t = yaml.safe_load((zoos_dir / zoo / "truth.yaml").read_text())
    effects = t.get("effects", t)
    return {e["id"]: e for e in effects} if isinstance(effects, list) else dict(effects)


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("zoos", nargs="+", help="NAME=WORK: a zoo's name and its harness work dir")
    ap.add_argument("--zoos-dir", default=str(ROOT / "benchmarks/blind_zoo/zoos"))
    ap.add_argument("--out", required=True, help="output path without suffix")
    a = ap.parse_args(argv)
    t0 = time.time()
    rows = []
    for spec in a.zoos:
        name, work = spec.split("=", 1)
        work = Path(work)
        truth = _truth(name, Path(a.zoos_dir))
        ref = load_moves(work / "reference", "train")
        sets = [(f"clean {d.name}", d, None) for d in sorted((work / "clean").iterdir())
                if d.is_dir()]
        sets += [(k, work / "effects" / k, truth.get(k)) for k in sorted(truth)]
        for label, path, tr in sets:
            moves = load_moves(path, "train")
            alone, against = sensor_timing(moves), sensor_timing(moves, ref)
            rows.append({"zoo": name, "dataset": label,
                         "truth": None if tr is None else {k: tr.get(k) for k in
                                                           ("family", "scope", "params")},
                         "without_reference": alone, "against_reference": against})
            print(f"{name} {label}: shift {against['shift_ms']:+.1f} ms against the reference, "
                  f"significant {against['significant']}", flush=True)
    doc = {"command": " ".join([os.path.relpath(sys.argv[0], ROOT)] + (argv or sys.argv[1:])),
           "code": git_state(), "load_average": list(os.getloadavg()),
           "seconds": time.time() - t0, "rows": rows}
    Path(a.out + ".json").write_text(json.dumps(doc, indent=1) + "\n")
    L = [f"# Sensor timing on the zoos' recordings\n",
         f"Command: `{doc['command']}` (work directories as in the README). Code: {doc['code']}. "
         f"Load average at the end: {', '.join(f'{v:.1f}' for v in doc['load_average'])}. "
         f"{doc['seconds']:.0f} s.\n",
         "| zoo | dataset | truth | median lead [ms] | without reference: finding | "
         "against the reference: shift [ms], p | finding |",
         "|---|---|---|---|---|---|---|"]
    for r in rows:
        tr = r["truth"]
        truth = "-" if tr is None else f"{tr['family']} @ {tr['scope']}: " + ", ".join(
            f"{k}={v}" for k, v in (tr.get("params") or {}).items() if not isinstance(v, (list,
                                                                                     dict)))
        w, g = r["without_reference"], r["against_reference"]

        def named(t):
            v = t.get("vocabulary")
            return "no" if not t["significant"] else (
                f"{v['family']} @ {v['scope']} ({v['params']['latency_ms']} ms)")
        L.append(f"| {r['zoo']} | {r['dataset']} | {truth} | {w['median_ms']:+.1f} | {named(w)} "
                 f"| {g['shift_ms']:+.1f}, {g['p_value']:.1e} | {named(g)} |")
    Path(a.out + ".md").write_text("\n".join(L) + "\n")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
