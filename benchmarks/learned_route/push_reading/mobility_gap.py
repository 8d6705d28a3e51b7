"""Whose push response sizes a push: the gap robots' own, `nominal`'s and `measured`'s, not blind.

The learned route sizes a push fixed in odom as the drift against the reference over a physics
robot's push response M, (m/s) per newton (``diagnose/push.py``, ``push_robot`` "nominal").
This study measures M, as ``push.push_mobility`` does (two reference moves per type, each
walked with no push and with 1 N along odom x and along y), on each zoo's reference commands,
for three robots: the zoo's own gap robot (its ``gap_robot.json``, an exact twin no real robot
has), ``nominal`` and ``measured`` (the robot the gap robots perturb). It also gives how far
each robot walks the same commands against the recording (``speed_ratio``: the recorded
displacement over the robot's, summed over those moves; near 1 for the gap robot checks that
the walk reproduces the recording).

Each ZOO=WORK pair names a zoo whose truth has been read and a harness work directory holding
its ``reference/`` recording (``benchmarks/blind_zoo/README.md``, "Running a zoo",
``--record-only``):

    OPENBLAS_NUM_THREADS=1 .venv/bin/python benchmarks/learned_route/push_reading/mobility_gap.py \
        --out benchmarks/learned_route/push_reading/mobility_gap zoo15=WORK15 zoo16=WORK16 ...
"""
from __future__ import annotations

import argparse
import json
import os
import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[3]
sys.path.insert(0, str(ROOT))

from benchmarks._common import git_state  # noqa: E402
from littledog_mlsim.data.dataset import load_moves  # noqa: E402
from littledog_mlsim.diagnose.push import (MOBILITY_MOVES_PER_TYPE,  # noqa: E402
                                           PybulletPushes, _start_and_displacement,
                                           first_per_type, push_mobility)

ZOOS = ROOT / "benchmarks" / "blind_zoo" / "zoos"
ROBOTS = ("gap", "nominal", "measured")


def measure(zoo: str, work: Path) -> dict:
    ref = load_moves(work / "reference", "train")
    moves = first_per_type(ref, MOBILITY_MOVES_PER_TYPE)
    recorded = np.array([_start_and_displacement(r)[1] for r in moves])
    row = {}
    for name in ROBOTS:
        robot = str(ZOOS / zoo / "gap_robot.json") if name == "gap" else name
        t0 = time.perf_counter()
        sim = PybulletPushes(robot)
        M, n = push_mobility(ref, sim)
        walked = np.array([sim.displacement(r, None) for r in moves])
        row[name] = {"mobility_mps_per_N": M.tolist(), "moves": n,
                     "speed_ratio": float(np.linalg.norm(recorded, axis=1).sum()
                                          / np.linalg.norm(walked, axis=1).sum()),
                     "seconds": time.perf_counter() - t0}
        print(zoo, name, np.round(100 * M, 2).tolist(), round(row[name]["speed_ratio"], 3),
              flush=True)
    return row


def markdown(doc: dict) -> str:
    lines = ["# The push response of the gap robots, `nominal` and `measured`", "",
             f"Command: `{doc['command']}`", "",
             f"Code: {doc['code']}; load average at the start {doc['load_start']}.", "",
             "Drift per newton in cm/s (M's diagonal: a push along odom x, along odom y) and "
             "how far the recording walks against each robot walking its commands.", "",
             "| zoo | gap M_xx | gap M_yy | nominal M_xx | nominal M_yy | measured M_xx | "
             "measured M_yy | nominal M_yy / gap M_yy | speed ratio gap / nominal / measured |",
             "|---|---|---|---|---|---|---|---|---|"]
    for zoo, row in doc["zoos"].items():
        m = {k: np.array(v["mobility_mps_per_N"]) * 100 for k, v in row.items()}
        lines.append(
            f"| {zoo} | {m['gap'][0, 0]:.2f} | {m['gap'][1, 1]:.2f} | {m['nominal'][0, 0]:.2f} | "
            f"{m['nominal'][1, 1]:.2f} | {m['measured'][0, 0]:.2f} | {m['measured'][1, 1]:.2f} | "
            f"{m['nominal'][1, 1] / m['gap'][1, 1]:.2f} | "
            + " / ".join(f"{row[k]['speed_ratio']:.2f}" for k in ROBOTS) + " |")
    return "\n".join(lines) + "\n"


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--out", required=True, help="writes OUT.md and OUT.json")
    ap.add_argument("zoos", nargs="+", metavar="ZOO=WORK")
    a = ap.parse_args(argv)
    doc = {"command": "OPENBLAS_NUM_THREADS=%s .venv/bin/python %s" % (
               os.environ.get("OPENBLAS_NUM_THREADS"), " ".join(sys.argv)),
           "code": git_state(), "load_start": [round(x, 2) for x in os.getloadavg()],
           "zoos": {}}
    for pair in a.zoos:
        zoo, work = pair.split("=", 1)
        doc["zoos"][zoo] = measure(zoo, Path(work))
    Path(a.out + ".json").write_text(json.dumps(doc, indent=1) + "\n")
    Path(a.out + ".md").write_text(markdown(doc))
    print(markdown(doc))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
