"""The paper's model with many more forward trots, against the same number of trots of every type.

``heading_floor.py`` finds that a forward-trot model's heading floor falls with the number of
distinct forward trots up to about 120. This script builds the full models that test it on
the issue's own scenarios: LGPR with the paper's 45 inputs on

- ``paper``: the TrainPool of ``--data`` (the paper's dataset, 14 forward trots of 154 moves);
- ``forward``: that TrainPool plus the first ``--extra`` moves of ``--forward`` (a forward-trot
  dataset, ``record --types F``);
- ``spread``: that TrainPool plus the first ``--extra`` moves of ``--spread`` (a dataset of
  every type, ``record --seed`` other than the paper's): the same number of added trots,
  spread over the eleven types (the control).

Each is saved to ``--work``/NAME with its gate radius (the 0.9 quantile of its own
leave-move-out distances) in ``--work``/radii.json. ``../fidelity.py`` then runs each with
``--lgpr WORK/NAME --radius R`` (README).
"""
from __future__ import annotations

import argparse
import json
import os
import sys
import time
from pathlib import Path

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE.parents[1]))

from littledog_mlsim.data.dataset import load_moves  # noqa: E402
from littledog_mlsim.models.train import fit_onestep  # noqa: E402


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--data", type=Path, required=True, help="the paper's dataset")
    ap.add_argument("--forward", type=Path, required=True, help="a forward-trot dataset")
    ap.add_argument("--spread", type=Path, required=True, help="a dataset of every move type")
    ap.add_argument("--extra", type=int, default=110, help="moves added to the TrainPool")
    ap.add_argument("--work", type=Path, required=True)
    a = ap.parse_args(argv)
    base = load_moves(a.data, "train")
    added = {"paper": [], "forward": load_moves(a.forward, "all"),
             "spread": load_moves(a.spread, "all")}
    for name, moves in added.items():
        if name != "paper" and len(moves) < a.extra:
            print(f"error: {name}: {len(moves)} moves, --extra asks for {a.extra}",
                  file=sys.stderr)
            return 2
    a.work.mkdir(parents=True, exist_ok=True)
    radii = {}
    for name, moves in added.items():
        train = base + moves[:a.extra]
        t0 = time.perf_counter()
        model = fit_onestep(train, "lgpr", random_state=0,
                            info={"more_forward": name, "n_moves": len(train)})
        model.save(a.work / name)
        types = sorted({m.move_type for m in train})
        radii[name] = {"radius": float(model.gate["radius"]), "moves": len(train),
                       "forward_trots": sum(m.move_type == "F" for m in train),
                       "types": types, "fit_s": round(time.perf_counter() - t0, 1)}
        print(name, radii[name], flush=True)
    tmp = a.work / "radii.json.tmp"
    tmp.write_text(json.dumps(radii, indent=1) + "\n")
    os.replace(tmp, a.work / "radii.json")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
