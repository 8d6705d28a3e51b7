"""How much the TrainPool's moves of one type differ in their mean yaw rate.

A d_yaw is the difference of two yaw measurements, so within a move the measurement noise
telescopes: a move's mean d_yaw carries only its first and last measurements' noise,
sqrt(2) sigma / (T dt) (`README.md`, "Why the open-loop 2 % is not reached"). This prints, per move type,
each TrainPool move's mean yaw rate (d_yaw / 10 ms over its steps), their spread over the
moves, the standard error of their mean, and the telescoped noise bound for ``--sigma-mrad``
(the README's 1.25 mrad per measurement).

    OPENBLAS_NUM_THREADS=1 .venv/bin/python benchmarks/fidelity/yaw_by_move.py \\
        --data bags/default --out benchmarks/fidelity/yaw_by_move
"""
from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[2]
sys.path.insert(0, str(ROOT))

from benchmarks._common import command_line, run_record, write_results  # noqa: E402


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--data", type=Path, default=Path("bags/default"))
    ap.add_argument("--sigma-mrad", type=float, default=1.25)
    ap.add_argument("--out", type=Path, default=None)
    a = ap.parse_args(argv)
    from littledog_mlsim.data.dataset import load_moves
    from littledog_mlsim.data.states import states_from_recording
    from littledog_mlsim.layout import MOVE_TYPES, S
    doc = run_record("fidelity/yaw_by_move.py", argv)
    rows = []
    for t in MOVE_TYPES:
        moves = load_moves(a.data, split="train", types=[t])
        if not moves:
            continue
        rates, steps = [], []
        for rec in moves:
            d = states_from_recording(rec)[:, S.dyaw]
            rates.append(1e3 * d.mean() / 0.01)
            steps.append(len(d))
        r = np.array(rates)
        T = float(np.median(steps))
        noise_move = np.sqrt(2.0) * a.sigma_mrad / (T * 0.01)
        rows.append({"type": t, "moves": len(r), "rates_mrad_s": r.tolist(),
                     "mean": float(r.mean()), "std_over_moves": float(r.std(ddof=1)),
                     "std_error_of_mean": float(r.std(ddof=1) / np.sqrt(len(r))),
                     "telescoped_noise_per_move": noise_move,
                     "telescoped_noise_of_mean": noise_move / np.sqrt(len(r))})
    doc["rows"] = rows
    lines = [command_line(doc) + "  ", f"Code: {doc['git']}; date {doc['date']}", "",
             "Mean yaw rate of each TrainPool move, by type [mrad/s]:", "",
             "| type | moves | mean | std over moves | std error of the mean | noise bound per "
             f"move (sigma {a.sigma_mrad:g} mrad, telescoped) | noise bound of the mean |",
             "|---|---|---|---|---|---|---|"]
    lines += [f"| {r['type']} | {r['moves']} | {r['mean']:.2f} | {r['std_over_moves']:.2f} | "
              f"{r['std_error_of_mean']:.2f} | {r['telescoped_noise_per_move']:.2f} | "
              f"{r['telescoped_noise_of_mean']:.3f} |" for r in rows]
    write_results(a.out, doc, lines)
    return 0


if __name__ == "__main__":
    sys.exit(main())
