"""The fit objective of one hypothesis along its magnitude, on a dataset's fit moves.

Prints, per magnitude, the weighted output-error SSE relative to no effect (the J of
``diagnose/physid.py``) over all channels, over the 1 s segments' channels only and over the
4 s replays' only. This is how LOG.md's side-friction profile was measured:

    OPENBLAS_NUM_THREADS=1 .venv/bin/python benchmarks/blind_zoo/harness/fit_profile.py \
        DATA joint_friction side:right coulomb_Nm 0.06,0.09,0.12,0.15,0.19,0.24

with DATA the side-friction effect dataset that ``run.py`` records (seed 4 for run 2). A
family with several parameters takes ``-`` as the parameter and a JSON list of parameter sets,
e.g. ``ground_tilt body - '[{"sx": -1.41, "sy": -0.513}]'`` (a 1.5 deg floor rising towards
200 deg).
"""
from __future__ import annotations

import argparse
import json
from dataclasses import replace

import numpy as np

from littledog_mlsim.data.dataset import load_moves, read_index
from littledog_mlsim.diagnose import physid as P
from littledog_mlsim.robot.config import as_config
from littledog_mlsim.robot.sim import InitialState


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("data", help="dataset directory")
    ap.add_argument("family", help="a family of physid.FAMILIES with one component")
    ap.add_argument("scope", help="e.g. side:right, joint:back_left_knee, leg:front_right")
    ap.add_argument("parameter", help="the family's primary parameter, e.g. coulomb_Nm")
    ap.add_argument("magnitudes", help="comma-separated values (or, with parameter '-', a JSON "
                                       "list of parameter sets)")
    ap.add_argument("--moves", type=int, default=4, help="fit moves used (as diagnose screens)")
    ap.add_argument("--jobs", type=int, default=2)
    ap.add_argument("--friction-smoothing", type=float, default=None, metavar="RAD_S",
                    help="the velocity over which JointFriction's Coulomb term passes through "
                         "zero, for this run (default: the library's)")
    a = ap.parse_args()
    if a.friction_smoothing is not None:   # the workers are forked: they see the new default
        from littledog_mlsim.robot import effects as fx
        *head, _ = fx.JointFriction.__init__.__defaults__
        fx.JointFriction.__init__.__defaults__ = (*head, a.friction_smoothing)
    index = read_index(a.data)
    train = load_moves(a.data, "train")
    cfg = replace(as_config(index.info.get("robot", "measured")), sensor_noise=False)
    recs = [train[i] for i in P._pick_moves(train, 1)]
    moves = [P._Move(r.name, r.move_type, np.asarray(r.cmd, dtype=float),
                     {k: InitialState.from_recording(r, k) for k in P.SEG_STARTS}) for r in recs]
    meas = [P._measured(r) for r in recs]
    F = list(range(len(recs)))[::max(1, len(recs) // a.moves)][:a.moves]
    runner = P._Runner(cfg, moves, a.jobs)
    try:
        base = [P._errors(s, meas[i]) for i, s in zip(F, runner.map([(i, [], "full") for i in F]))]
        w = P._weights(base, list(range(len(F))))
        masks = {"all": w, "short": np.where(np.isin(np.arange(P.N_CH), P.SHORT), w, 0.0),
                 "long": np.where(np.isin(np.arange(P.N_CH), P.LONG), w, 0.0)}
        J0 = {k: P._J(base, m) for k, m in masks.items()}
        sets = (json.loads(a.magnitudes) if a.parameter == "-" else
                [{a.parameter: float(x)} for x in a.magnitudes.split(",")])
        for par in sets:
            sims = runner.map([(i, [(a.family, a.scope, par)], "full") for i in F])
            errs = [P._errors(s, meas[i]) for i, s in zip(F, sims)]
            label = (f"{par[a.parameter]:.4g}" if a.parameter != "-" else json.dumps(par))
            print(f"{label}: " + " ".join(f"{k} {P._J(errs, m) / J0[k]:.3f}"
                                          for k, m in masks.items()), flush=True)
    finally:
        runner.close()


if __name__ == "__main__":
    main()
