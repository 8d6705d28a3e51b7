"""Can the body heights' plane tell a slope from a push? ``floor_plane`` (the position family's
slope reading) on a zoo's recordings, each dataset's TrainPool.

    OPENBLAS_NUM_THREADS=1 .venv/bin/python benchmarks/learned_route/push_reading/floor_plane_check.py \
        --zoo-dir WORK24 --datasets effects/z08,effects/z12,reference,clean/s151_e0 \
        --out benchmarks/learned_route/push_reading/floor_plane_zoo24

Writes OUT.md and OUT.json: per dataset the plane's slope, uphill direction (odom), rise per
metre and the share of the body height's variance it explains (r2; the slope reading needs
``PLANE_R2``), and the body's lowest height (over all moves, and the median of each move's).
"""
from __future__ import annotations

import argparse
import json
import os
import sys
from pathlib import Path

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
sys.path.insert(0, str(Path(__file__).resolve().parents[3]))

import numpy as np   # noqa: E402

from littledog_mlsim.data.dataset import load_moves   # noqa: E402
from littledog_mlsim.diagnose.families.learned import PLANE_R2, floor_plane   # noqa: E402


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--zoo-dir", type=Path, required=True)
    p.add_argument("--datasets", required=True, help="comma-separated, relative to --zoo-dir")
    p.add_argument("--out", type=Path, required=True)
    a = p.parse_args()
    rows = []
    for name in a.datasets.split(","):
        recs = load_moves(a.zoo_dir / name, "train")
        fp = floor_plane(recs)
        low = [float(np.min(np.asarray(r.position)[:, 2])) for r in recs]
        rows.append({"dataset": name, **(fp or {}), "lowest_body_z_m": min(low),
                     "median_move_lowest_body_z_m": float(np.median(low))})
        print(rows[-1], flush=True)
    cmd = " ".join(["OPENBLAS_NUM_THREADS=1 .venv/bin/python",
                    str(Path(sys.argv[0]))] + sys.argv[1:])
    a.out.with_suffix(".json").write_text(json.dumps({"command": cmd, "plane_r2": PLANE_R2,
                                                      "rows": rows}, indent=1))
    lines = ["# The body heights' plane on a zoo's recordings", "", f"Command: `{cmd}`", "",
             "| dataset | slope [deg] | uphill direction [deg, odom] | rise [m/m] | r2 | "
             "lowest body height [m] | median over moves of each move's lowest [m] |",
             "|---|---|---|---|---|---|---|"]
    for r in rows:
        lines.append(f"| {r['dataset']} | {r.get('slope_deg', float('nan')):.2f} | "
                     f"{r.get('uphill_direction_deg', float('nan')):.0f} | "
                     f"{r.get('rise_per_m', float('nan')):.3f} | {r.get('r2', float('nan')):.3f} | "
                     f"{r['lowest_body_z_m']:.3f} | {r['median_move_lowest_body_z_m']:.3f} |")
    a.out.with_suffix(".md").write_text("\n".join(lines) + "\n")


if __name__ == "__main__":
    main()
