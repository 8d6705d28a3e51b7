"""How far DaD's added inputs lie from the state they are asked to step to, against recorded steps.

For every ``--every``-th TrainPool move of DATA, the model is rolled out as ``train --dad`` rolls
it out (``models.dad.dad_pairs``: gated alpha-PROJ at the model's radius). Per state group, the
mean over pairs of |s^_k - s_{k+1}| (a DaD pair's input state against its target) and of
|s_k - s_{k+1}| (a recorded step), each element divided by the TrainPool's standard deviation
of that element.

    OPENBLAS_NUM_THREADS=1 .venv/bin/python benchmarks/fidelity/levers/dad_pairs.py \\
        --model MODEL --data DATA --out benchmarks/fidelity/levers/dad_pairs
"""
from __future__ import annotations

import argparse
import os
import sys
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE.parents[2]))
os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

from benchmarks._common import command_line, run_record, write_results  # noqa: E402


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--model", type=Path, required=True)
    ap.add_argument("--data", type=Path, required=True)
    ap.add_argument("--every", type=int, default=5)
    ap.add_argument("--out", type=Path, default=None)
    a = ap.parse_args(argv)
    from littledog_mlsim.data.dataset import load_moves
    from littledog_mlsim.layout import S
    from littledog_mlsim.models.dad import dad_pairs
    from littledog_mlsim.models.onestep import OneStepModel
    from littledog_mlsim.rollout.simulate import prepare_test_moves
    doc = run_record("fidelity/levers/dad_pairs.py", argv)
    model = OneStepModel.load(a.model)
    moves = load_moves(a.data, "train")[::a.every]
    X, Y, _ = dad_pairs(model, moves)
    recorded = np.vstack([np.abs(t.states[:-1] - t.states[1:]) for t in prepare_test_moves(moves)])
    sd = model.train_states.std(axis=0)
    groups = {"z_w": S.z_w, "d_b": S.d_b, "roll,pitch": S.roll_pitch, "d_rpy": S.d_rpy,
              "q": S.q, "dq": S.dq}
    doc.update(n_moves=len(moves), n_pairs=int(X.shape[0]), groups={})
    lines = [command_line(doc) + "  ", f"Code: {doc['git']}; date {doc['date']}; "
             f"{len(moves)} TrainPool moves, {X.shape[0]} DaD pairs", "",
             "| state group | DaD pair: mean \\|s^_k - s_k+1\\| / std | recorded step: mean "
             "\\|s_k - s_k+1\\| / std | ratio |", "|---|---|---|---|"]
    for name, sl in groups.items():
        d = float(np.mean(np.abs(X[:, :33][:, sl] - Y[:, sl]) / sd[sl]))
        r = float(np.mean(recorded[:, sl] / sd[sl]))
        doc["groups"][name] = {"dad": d, "recorded": r}
        lines.append(f"| {name} | {d:.3f} | {r:.3f} | {d / r:.2f} |")
    write_results(a.out, doc, lines)
    print("\n".join(lines))
    return 0


if __name__ == "__main__":
    sys.exit(main())
