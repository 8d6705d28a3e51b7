"""Where a calibration's mass split comes from: the k-step cost at the fitted twin against the
cost at the truth, and at points that swap one group of parameters between them.

A twin fitted on a blind zoo's reference (for example zoo51's ``calibrated_twin.json``) and the
gap robot that recorded the reference (``gap_robot.json``) share one structure (the torque-mode
PD servo), so the truth is a point of the fit's own parameter space. If the truth has the lower
cost, the optimiser stopped short of it (``converged`` false); if the fitted twin has the lower
cost, the residual itself prefers the wrong split (a bias of the fit's residual: its starting
states, its noise, its horizons), and more evaluations would not mend it.

    OPENBLAS_NUM_THREADS=1 .venv/bin/python benchmarks/calibrate/split_probe.py \
        --data /tmp/z51w/reference \
        --twin benchmarks/blind_zoo/zoos/zoo51/runs/run1/calibrated_twin.json \
        --truth benchmarks/blind_zoo/zoos/zoo51/gap_robot.json \
        --out benchmarks/calibrate/split_probe_zoo51.json

Every point is re-simulated with the calibration's own settings (stride, horizons, starting
states, moves per type) on the reference's TrainPool moves; the cost is 0.5 * sum of the
residuals squared, each divided by its (horizon, element) RMS at the fitted twin, as the fit's
second stage weighs them.
"""
from __future__ import annotations

import argparse
import json
import time
from dataclasses import replace
from pathlib import Path

import numpy as np

from littledog_mlsim.data.dataset import load_moves
from littledog_mlsim.robot import baseline as bl
from littledog_mlsim.robot.twin import load_twin, robot_config_from
from littledog_mlsim.robot.twin_fit import _rms_scale, twin_residuals_many

GROUPS = {
    "masses": ("body_mass", "leg_mass"),
    "gains": ("kp", "kd"),
    "armature": ("armature",),
    "limits": ("torque_limit",),
    "contact": ("foot_friction", "ground_friction"),
    "timing": ("command_delay_ms", "rate_filter_hz"),
}


def physical(cfg) -> dict:
    return {k: getattr(cfg, k) for g in GROUPS.values() for k in g}


def with_fields(cfg, src, fields) -> object:
    return replace(cfg, **{f: getattr(src, f) for f in fields})


def contact_as_twin(truth, twin):
    """The truth's contact expressed with the twin's foot friction (pybullet multiplies the
    two coefficients)."""
    return replace(truth, foot_friction=twin.foot_friction,
                   ground_friction=truth.foot_friction * truth.ground_friction / twin.foot_friction)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--data", required=True)
    ap.add_argument("--twin", required=True)
    ap.add_argument("--truth", required=True)
    ap.add_argument("--out", required=True)
    ap.add_argument("--jobs", type=int, default=2)
    ap.add_argument("--also", action="append", default=[], metavar="NAME=TWIN.json",
                    help="one more point: another twin file (its physical fields), repeatable")
    ap.add_argument("--pre-bootstrap", action="store_true",
                    help="one more point: the twin's fit before its bootstrap correction "
                         "(its report's bootstrap.params.<name>.fitted)")
    a = ap.parse_args()

    twin_file = load_twin(a.twin)
    settings = twin_file.provenance["calibration"]["settings"]
    twin = replace(robot_config_from(a.twin), sensor_noise=False)
    truth = contact_as_twin(replace(robot_config_from(a.truth), sensor_noise=False), twin)
    # the truth with the twin's sensing (read on the recording), so that only physics differs
    truth = replace(truth, encoder_resolution=twin.encoder_resolution,
                    mocap_position_std=twin.mocap_position_std,
                    mocap_orientation_std=twin.mocap_orientation_std)
    points = {"fitted": twin, "truth": truth}
    for g, fields in GROUPS.items():
        points[f"fitted, truth's {g}"] = with_fields(twin, truth, fields)
        points[f"truth, fitted {g}"] = with_fields(truth, twin, fields)
    if a.pre_bootstrap:
        from littledog_mlsim.robot.parameters import TWIN_PARAMETERS
        pre = twin
        for name, b in twin_file.provenance["calibration"]["bootstrap"]["params"].items():
            pre = TWIN_PARAMETERS[name].set(pre, b["fitted"])
        points["fitted, before its bootstrap"] = pre
    for spec in a.also:
        name, _, path = spec.partition("=")
        other = replace(robot_config_from(path), sensor_noise=False)
        points[name] = with_fields(twin, other, [f for g in GROUPS.values() for f in g])
    recs = bl.first_per_type(load_moves(a.data, "train"), 2)
    stride, horizons = int(settings["stride"]), tuple(settings["horizons"])
    initial = settings["initial_state"]
    t0 = time.perf_counter()
    with bl.move_pool(recs, a.jobs, None) as pool:
        raws = twin_residuals_many(pool, list(points.values()), stride, horizons, initial)
    wall = time.perf_counter() - t0
    scale = _rms_scale(raws[0])
    rows = {}
    for (name, cfg), raw in zip(points.items(), raws):
        r = np.concatenate(raw, axis=0) / scale           # (n, horizons, 33)
        rows[name] = {"cost": float(0.5 * np.sum(r ** 2)),
                      "cost_by_horizon": [float(0.5 * np.sum(r[:, i] ** 2))
                                          for i in range(r.shape[1])],
                      "cost_body": float(0.5 * np.sum(r[:, :, :9] ** 2)),
                      "cost_joint_angles": float(0.5 * np.sum(r[:, :, 9:21] ** 2)),
                      "cost_joint_rates": float(0.5 * np.sum(r[:, :, 21:] ** 2)),
                      "config": {k: (list(v) if isinstance(v, tuple) else v)
                                 for k, v in physical(cfg).items()}}
    result = {"command": "benchmarks/calibrate/split_probe.py " + " ".join(
                  f"--{k} {v}" for k, v in vars(a).items()),
              "settings": {"stride": stride, "horizons": list(horizons),
                           "initial_state": initial, "train_moves": [r.name for r in recs]},
              "wall_s": round(wall, 1), "points": rows}
    Path(a.out).write_text(json.dumps(result, indent=1) + "\n")
    w = max(len(n) for n in rows)
    print(f"{'point':<{w}}  {'cost':>9}  {'h1':>9}  {'h10':>9}  {'body':>9}  {'q':>9}  {'dq':>9}")
    for n, row in rows.items():
        print(f"{n:<{w}}  {row['cost']:9.1f}  " + "  ".join(f"{c:9.1f}" for c in row['cost_by_horizon'])
              + f"  {row['cost_body']:9.1f}  {row['cost_joint_angles']:9.1f}  {row['cost_joint_rates']:9.1f}")
    print(f"{len(points)} robots re-simulated in {wall:.0f} s")


if __name__ == "__main__":
    main()
