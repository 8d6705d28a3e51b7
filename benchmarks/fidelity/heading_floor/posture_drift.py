"""Where the straight trot's state goes after its first 4 s, against the recorded moves.

``heading_floor.py`` finds the remaining heading bias after the trot's first 4 s (a recorded
move's length) and mostly in two seeds. This script compares, per seed, pybullet's mean state
over 0.5-4 s and over 4-60 s of the 60 s straight trot (``heading_floor.py``'s saved runs in
``--work``) with the states of the first ``--moves`` recorded forward trots of ``--data``
after their first 0.5 s (the start from standing): each element's mean as a z-score
against the moves' mean and standard deviation, and the change from the first window to the
second. Writes ``--out``.json / .md with the elements whose change is largest.
"""
from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE.parents[1]))

from _common import command_line, run_record, write_results  # noqa: E402
from littledog_mlsim.data.dataset import load_moves, states_from_recording  # noqa: E402
from littledog_mlsim.layout import CONTROL_DT, STATE_NAMES  # noqa: E402

#: steps of a trot's start from standing left out of every window [0.5 s]
START = 50
#: a recorded move's length in steps [4 s]
MOVE = 400


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--data", type=Path, required=True, help="a forward-trot dataset")
    ap.add_argument("--work", type=Path, required=True, help="heading_floor.py's --work")
    ap.add_argument("--moves", type=int, default=120)
    ap.add_argument("--seeds", nargs="+", type=int, default=list(range(8)))
    ap.add_argument("--top", type=int, default=6)
    ap.add_argument("--out", type=Path, default=HERE / "posture_drift")
    a = ap.parse_args(argv)
    moves = load_moves(a.data, "all")[:a.moves]
    S = np.vstack([states_from_recording(m)[START:] for m in moves])
    mu, sd = S.mean(axis=0), S.std(axis=0)
    per_seed = {}
    for seed in a.seeds:
        with np.load(a.work / f"ref_s{seed}.npz") as z:
            st = z["states"]
        first = (st[START:MOVE].mean(axis=0) - mu) / sd
        after = (st[MOVE:].mean(axis=0) - mu) / sd
        per_seed[seed] = {"first": first.tolist(), "after": after.tolist()}
    change = np.array([np.subtract(per_seed[s]["after"], per_seed[s]["first"]) for s in a.seeds])
    top = np.argsort(-np.abs(change).max(axis=0))[:a.top]
    doc = {**run_record("fidelity/heading_floor/posture_drift.py", sys.argv[1:]),
           "moves": len(moves), "samples": int(S.shape[0]), "state_names": list(STATE_NAMES),
           "per_seed": per_seed}
    lines = [f"# The straight trot's mean state over {START * CONTROL_DT:g}-{MOVE * CONTROL_DT:g} s "
             f"and after {MOVE * CONTROL_DT:g} s, against {len(moves)} recorded forward trots",
             "", command_line(doc), "", f"Code: {doc['git']}; {doc['date']} UTC.", "",
             "z-scores against the recorded moves' states after their first "
             f"{START * CONTROL_DT:g} s ({S.shape[0]} states); the elements whose change "
             "(after minus first) is largest in some seed.", "",
             "| element | " + " | ".join(f"seed {s}: first / after" for s in a.seeds) + " |",
             "|---|" + "---|" * len(a.seeds)]
    for j in top:
        lines.append(f"| {STATE_NAMES[j]} | " + " | ".join(
            f"{per_seed[s]['first'][j]:.2f} / {per_seed[s]['after'][j]:.2f}" for s in a.seeds)
            + " |")
    write_results(a.out, doc, lines)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
