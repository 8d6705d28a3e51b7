"""Does the objective's preference for a wrong robot come from the joint rates the
re-simulations start from?

The encoders report joint rates late: a backward difference of quantised angles at the servo
period (half a period) and a first-order filter (dt (1 - alpha) / alpha at the servo period,
``robot.sensors.JointEncoders``): 3.8 ms for zoo38's gap robot. The calibration starts each
re-simulation from those rates (``InitialState.smoothed``). For each starting-state kind
(``smoothed``: as calibrate does; ``smoothed_rates``: the joint rates moved forward by the
re-simulated robot's own lag times the measured rates' slope, a central difference over the
neighbouring steps; the rate filter still starting from what was reported), the k-step cost,
weighted at run1's optimum, at: the optimum (before the bootstrap), the gap robot, and the point
``basin.py limit`` reached from 0.6 (rebuilt from its errors against the gap robot). The second
kind is this script's own (it replaces ``baseline._replay`` in this process; one process).

    OPENBLAS_NUM_THREADS=1 .venv/bin/python benchmarks/blind_zoo/zoos/zoo38/runs/after_run1/rates_probe.py \
        TWIN.json GAP_ROBOT.json DATA BASIN_LIMIT.json OUT.json
"""
from __future__ import annotations

import json
import math
import sys
import time
from dataclasses import replace
from pathlib import Path

import numpy as np

from littledog_mlsim.data.dataset import load_moves
from littledog_mlsim.robot import baseline as bl
from littledog_mlsim.robot import twin_fit as tf
from littledog_mlsim.robot.parameters import TWIN_PARAMETERS
from littledog_mlsim.layout import CONTROL_DT
from littledog_mlsim.robot.sim import InitialState

sys.path.insert(0, str(Path(__file__).resolve().parents[4] / "harness"))
from fit_points import fit_points  # noqa: E402


def encoder_rate_lag(config) -> float:
    """How late [s] ``config``'s encoders report a steadily changing joint rate."""
    dt = float(config.physics_dt)
    f = config.rate_filter_hz
    alpha = 1.0 if f is None else 1.0 - math.exp(-2.0 * math.pi * float(f) * dt)
    return (0.0 if config.encoder_resolution is None else 0.5 * dt) + dt * (1.0 - alpha) / alpha


_PLAIN_REPLAY = bl._replay


def _replay_rates(sim, rec, k, n, effects=(), initial="measured"):
    """``baseline._replay`` for ``initial="smoothed_rates"``: the smoothed state, its joint rates
    moved forward by the robot's encoder lag."""
    if initial != "smoothed_rates":
        return _PLAIN_REPLAY(sim, rec, k, n, effects, initial)
    st = InitialState.smoothed(rec, k)
    lo, hi = max(0, k - 1), min(rec.q.shape[0] - 1, k + 1)
    slope = (np.asarray(rec.dq[hi], float) - np.asarray(rec.dq[lo], float)) / (
        (hi - lo) * CONTROL_DT)
    st = replace(st, dq=st.dq + encoder_rate_lag(sim.config) * slope)
    obs = [sim.reset(initial=st, effects=effects)]
    for u in rec.cmd[k:k + n]:
        obs.append(sim.step(u))
    arrays = {f: np.array([o[f] for o in obs], dtype=float) for f in bl.OBS_FIELDS}
    sim_rec = bl.MoveRecording(name=rec.name, move_type=rec.move_type,
                               stamps_ns=rec.stamps_ns[k:k + n + 1], cmd=rec.cmd[k:k + n],
                               **arrays)
    return bl.states_from_recording(sim_rec)


def main() -> None:
    twin_path, gap_path, data, limit_path, out = sys.argv[1:6]
    kinds = ("smoothed", "smoothed_rates")
    bl._replay = _replay_rates
    bl.INITIAL_STATES = bl.INITIAL_STATES + ("smoothed_rates",)
    pts = fit_points(twin_path, gap_path)
    settings, fit, gap = pts.settings, pts.fit, pts.gap
    limit_rows = [r for r in json.load(open(limit_path))["rows"] if r.get("factor") == 0.6]
    points = {"fit optimum": fit, "gap robot": gap}
    if limit_rows:
        pt = fit
        for name, err in limit_rows[0]["error_against_gap_robot"].items():
            par = TWIN_PARAMETERS[name]
            pt = par.set(pt, par.get(gap) * (1.0 + err))
        points["basin.py limit from 0.6"] = pt
    train = bl.first_per_type(load_moves(data, "train"), 2)
    rows = []
    t0 = time.perf_counter()
    with bl.move_pool(train, 1, None) as pool:      # one process: the replay replaced here
        for kind in kinds:
            def raw(robot):
                return tf.twin_residuals(pool, robot, settings["stride"],
                                         tuple(settings["horizons"]), kind)
            scale = tf._rms_scale(raw(fit))
            for label, robot in points.items():
                w = tf._weighted(raw(robot), scale)
                row = {"initial_state": kind, "at": label, "cost": 0.5 * float(w @ w),
                       "rate_lag_ms": 1e3 * encoder_rate_lag(robot) if kind == "smoothed_rates"
                       else 0.0}
                rows.append(row)
                print(json.dumps(row), flush=True)
    json.dump({"twin": twin_path, "gap_robot": gap_path, "rows": rows,
               "seconds": time.perf_counter() - t0}, open(out, "w"), indent=1)


if __name__ == "__main__":
    main()
