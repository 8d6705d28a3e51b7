"""A second start across the masses' split: a calibrated twin with its legs made lighter by a
factor and its body heavier by what keeps the total mass, written as a twin file to fit from.

    OPENBLAS_NUM_THREADS=1 .venv/bin/python benchmarks/calibrate/split_start.py \\
        --twin benchmarks/blind_zoo/zoos/zoo52/runs/run1/calibrated_twin.json \\
        --legs 0.85 --out /tmp/step/zoo52_legs085.json

The legs' factor is a guess of how far the other basin lies (`README.md`, "Two basins along the
masses' split"), not read off any gap robot.
"""
from __future__ import annotations

import argparse
from dataclasses import replace

from littledog_mlsim.robot.parameters import total_mass
from littledog_mlsim.robot.twin import Twin, load_twin, save_twin


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--twin", required=True)
    ap.add_argument("--legs", type=float, required=True, help="factor on the leg mass")
    ap.add_argument("--out", required=True)
    a = ap.parse_args()
    twin = load_twin(a.twin)
    c = twin.robot
    m = total_mass(c)
    legs = c.leg_mass * a.legs
    # the body takes what the four legs give up, so that the total stays the weighed one
    moved = replace(c, leg_mass=legs, body_mass=c.body_mass + 4.0 * (c.leg_mass - legs))
    save_twin(Twin(moved, {"created_by": "benchmarks/calibrate/split_start.py",
                           "from": a.twin, "legs_factor": a.legs}), a.out)
    print(f"body {c.body_mass:.4g} -> {moved.body_mass:.4g} kg, legs {c.leg_mass:.4g} -> "
          f"{moved.leg_mass:.4g} kg, total {m:.4g} -> {total_mass(moved):.4g} kg")


if __name__ == "__main__":
    main()
