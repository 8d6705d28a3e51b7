"""The no-fall check on the excited clean seed the freeze adds (``FREEZE.md``).

Every move of the dataset is read (``data.dataset.load_moves``) and counted fallen where the
body drops below 0.07 m or |roll| or |pitch| exceeds 0.7 rad at any step, the criterion of
the zoo's open page. Prints one line per dataset and writes ``check_excited_clean.json``.

    OPENBLAS_NUM_THREADS=1 .venv/bin/python \\
      benchmarks/blind_zoo/zoos/zoo65/runs/run1/check_excited_clean.py /tmp/z65w/clean/s561_e0.05
"""
from __future__ import annotations

import argparse
import json
import os

import numpy as np

from littledog_mlsim.data.dataset import load_moves
from littledog_mlsim.rotations import quat_to_rpy

HERE = os.path.dirname(os.path.abspath(__file__))
MIN_HEIGHT_M, MAX_TILT_RAD = 0.07, 0.7


def fallen(move) -> bool:
    """Whether the move's body drops below the height or tilts beyond the angle at any step."""
    rpy = quat_to_rpy(np.asarray(move.orientation))
    return bool((np.asarray(move.position)[:, 2] < MIN_HEIGHT_M).any()
                or (np.abs(rpy[:, :2]) > MAX_TILT_RAD).any())


def main(paths: list[str]) -> int:
    out = {}
    for path in paths:
        moves = load_moves(path, split="all")
        falls = [m.name for m in moves if fallen(m)]
        out[path] = {"moves": len(moves), "fallen": len(falls), "fallen_moves": falls}
        print(f"{path}: {len(moves)} moves, {len(falls)} fallen")
    with open(os.path.join(HERE, "check_excited_clean.json"), "w") as fh:
        json.dump(out, fh, indent=1)
    return 0 if all(v["fallen"] == 0 for v in out.values()) else 1


if __name__ == "__main__":
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("paths", nargs="+", metavar="DATASET", help="a dataset directory")
    raise SystemExit(main(ap.parse_args().paths))
