"""J of a payload hypothesis along its ridge of constant first moment, on a recorded dataset.

The blind zoos' payloads (``mass_com @ body``) came out with about the right first moment
(mass x horizontal offset) and a mass low in 8 of 10 fits (``payloads.txt``). This
study asks whether the data tell the mass apart along that ridge: it re-simulates the
diagnosis's own fit moves (and its held-out moves) with the twin, a payload of each mass in
``--masses`` placed at ``moment / mass`` (horizontal) and each height in ``--heights``, and
prints J (the diagnosis's weighted SSE, weights 1 / the twin's own SSE on the same moves)
relative to the twin alone.

    OPENBLAS_NUM_THREADS=1 .venv/bin/python benchmarks/diagnose_mass/ridge.py \
        --data DATASET --twin TWIN.json --moment-x MX --moment-y MY --out OUT.json
"""
from __future__ import annotations

import argparse
import json
import time
from dataclasses import replace

import numpy as np

from littledog_mlsim.data.dataset import load_moves
from littledog_mlsim.diagnose.physical.channels import errors, measured, seg_starts, LONG
from littledog_mlsim.diagnose.physical.context import SearchContext
from littledog_mlsim.diagnose.physical.driver import PhysicalOptions, _split
from littledog_mlsim.diagnose.physical.fit import ridge_mass
from littledog_mlsim.diagnose.physical.records import Candidate, Hypothesis
from littledog_mlsim.diagnose.physical.resim import Memo, Move, Runner
from littledog_mlsim.robot.config import as_config
from littledog_mlsim.robot.sim import InitialState
from littledog_mlsim.robot.twin import robot_config_from


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--data", required=True)
    ap.add_argument("--twin", required=True)
    ap.add_argument("--moment-x", type=float, required=True, help="mass x offset x [kg m]")
    ap.add_argument("--moment-y", type=float, required=True, help="mass x offset y [kg m]")
    ap.add_argument("--masses", default="0.08,0.1,0.13,0.16,0.2,0.25,0.3,0.4")
    ap.add_argument("--heights", default="-0.02,0.02,0.05")
    ap.add_argument("--walk-from", default=None, metavar="M,X,Y,Z",
                    help="instead of the grid: run the diagnosis's ridge_mass from this payload "
                         "(mass [kg], offset [m]) on the fit moves and print where it ends")
    ap.add_argument("--jobs", type=int, default=2)
    ap.add_argument("--out", required=True)
    a = ap.parse_args()
    t0 = time.perf_counter()
    o = PhysicalOptions(robot=robot_config_from(a.twin))
    cfg = replace(as_config(o.robot), sensor_noise=False)
    train = load_moves(a.data, "train")
    sp = _split(train, [], o)
    moves = [Move(r.name, r.move_type, np.asarray(r.cmd, dtype=np.float64),
                  {k: InitialState.at(r, k, o.initial_state) for k in seg_starts(r.n_steps)},
                  seg_starts(r.n_steps)) for r in sp.recs]
    runner = Memo(Runner(cfg, moves, a.jobs))
    try:
        meas = [measured(r) for r in sp.recs]
        sims = runner.map([(i, [], "full") for i in range(len(meas))])
        ctx = SearchContext(runner, (), [errors(s, m) for s, m in zip(sims, meas)], meas)
        out = {"data": a.data, "twin": a.twin, "moment_xy": [a.moment_x, a.moment_y],
               "rows": []}
        if a.walk_from:
            m, x, y, z = (float(v) for v in a.walk_from.split(","))
            c = Candidate("mass_com", "body", 0.0, m, fitted=m,
                          extra={"com_offset_m": (x, y, z)})
            w = ctx.weights(sp.F)
            c = replace(c, J=ctx.evaluate([c.hyp()], sp.F, w)[0], J0=ctx.baseline(sp.F, w))
            r = ridge_mass(ctx, c, sp.F)
            out["walk"] = {"start": {"mass": m, "pos": [x, y, z], "J": c.J / c.J0},
                           "end": {"mass": r.fitted, "pos": list(r.extra["com_offset_m"]),
                                   "J": r.J / c.J0},
                           "profile": r.profile}
            print(json.dumps(out["walk"], indent=1), flush=True)
            a.masses = ""
        sets = {"F": sp.F, "V": sp.V}
        w = {k: ctx.weights(v) for k, v in sets.items()}
        w_seg = {k: ctx.weights(v, segments_only=True) for k, v in sets.items()}
        base = {k: ctx.baseline(v, w[k]) for k, v in sets.items()}
        base_seg = {k: ctx.baseline(v, w_seg[k]) for k, v in sets.items()}
        for z in (float(x) for x in a.heights.split(",") if a.masses):
            for m in (float(x) for x in a.masses.split(",")):
                pos = (a.moment_x / m, a.moment_y / m, z)
                h = Hypothesis("mass_com", "body", {"added_mass_kg": m, "com_offset_m": pos})
                row = {"mass": m, "pos": [round(p, 4) for p in pos]}
                for k, v in sets.items():
                    row[f"J_{k}"] = ctx.evaluate([h], v, w[k])[0] / base[k]
                    row[f"Jseg_{k}"] = ctx.evaluate([h], v, w_seg[k], True)[0] / base_seg[k]
                out["rows"].append(row)
                print(f"z {z:+.2f} m {m:.3f} pos ({pos[0]:+.3f},{pos[1]:+.3f}) "
                      + " ".join(f"{k} {row[k]:.4f}" for k in row if k.startswith("J")),
                      flush=True)
    finally:
        runner.close()
    out["seconds"] = time.perf_counter() - t0
    with open(a.out, "w") as f:
        json.dump(out, f, indent=1)


if __name__ == "__main__":
    main()
