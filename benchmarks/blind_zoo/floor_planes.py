"""The floor plane (``diagnose.families.learned.floor_plane``) of each dataset of a zoo's work
directory: how much of the TrainPool's body-height variance a plane over (x, y) explains, and
its slope and uphill direction. The learned route names a position effect an inclined floor
where R² >= ``PLANE_R2``.

    OPENBLAS_NUM_THREADS=1 .venv/bin/python benchmarks/blind_zoo/floor_planes.py \\
        --work WORK --data DATA --out benchmarks/blind_zoo/zoos/zoo8/floor_planes

WORK: the harness's work directory (``effects/*``, ``clean/*``, ``reference``); ``--data``:
more datasets to include (for example the paper's).
"""
from __future__ import annotations

import argparse
import os
import sys
from pathlib import Path

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE.parents[1]))
os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

from benchmarks._common import command_line, run_record, write_results  # noqa: E402


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--work", type=Path, required=True)
    ap.add_argument("--data", type=Path, nargs="*", default=[])
    ap.add_argument("--out", type=Path, default=None)
    a = ap.parse_args(argv)
    from littledog_mlsim.data.dataset import load_moves
    from littledog_mlsim.diagnose.families.learned import PLANE_R2, floor_plane
    doc = run_record("blind_zoo/floor_planes.py", argv)
    sets = (sorted((a.work / "effects").glob("*")) + sorted((a.work / "clean").glob("*"))
            + [a.work / "reference"] + list(a.data))
    lines = [command_line(doc) + "  ", f"Code: {doc['git']}; date {doc['date']}; a position "
             f"effect reads as an inclined floor where R² >= {PLANE_R2}", "",
             "| dataset | R² | slope [deg] | uphill [deg, odom] | samples |", "|---|---|---|---|---|"]
    doc["datasets"] = {}
    for d in sets:
        if not (d / "dataset.yaml").is_file():
            continue
        name = d.name if d.parent.name != "clean" else f"clean {d.name}"
        f = floor_plane(load_moves(d, "train"))
        doc["datasets"][name] = f
        lines.append(f"| {name} | - | - | - | - |" if f is None else
                     f"| {name} | {f['r2']:.4f} | {f['slope_deg']:.3f} | "
                     f"{f['uphill_direction_deg']:.0f} | {f['n_samples']} |")
    write_results(a.out, doc, lines)
    print("\n".join(lines))
    return 0


if __name__ == "__main__":
    sys.exit(main())
