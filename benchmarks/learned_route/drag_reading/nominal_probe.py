"""Can the `nominal` robot size a drag on a swinging foot? Its one-step response to a probe.

    OPENBLAS_NUM_THREADS=1 .venv/bin/python benchmarks/learned_route/drag_reading/nominal_probe.py \
        --out benchmarks/learned_route/drag_reading/nominal_probe

A forward trot (seed 3, 2 s) is simulated on ``--robot`` (default ``nominal``). From each of its
states where the front-left leg's command lifts the foot (``change.SWING_ROW``), the robot is
stepped once (10 ms) with that state's command, with a drag of ``--probe`` newtons on the
front-left foot (``robot.effects.SwingDrag``) and without. The difference of the next joint
rates is regressed, per joint of the leg, on the drag's torque column
(``diagnose.change.swing_drag_torque``) beside a constant: the coefficient is the response
decision 029's sizes would be divided by. Writes OUT.md and OUT.json.
"""
from __future__ import annotations

import argparse
import json
import os
import sys
import time
from dataclasses import replace
from pathlib import Path

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
sys.path[:0] = [str(Path(__file__).resolve().parents[3]), str(Path(__file__).resolve().parents[2])]

import numpy as np  # noqa: E402
from _common import git_state, uptime  # noqa: E402

from littledog_mlsim.diagnose.change import SWING_ROW, swing_drag_torque, swing_weight  # noqa: E402
from littledog_mlsim.gait.trot import sample_trot_params, trot_commands  # noqa: E402
from littledog_mlsim.models.features import FeatureSet  # noqa: E402
from littledog_mlsim.robot.effects import SwingDrag  # noqa: E402
from littledog_mlsim.robot.sim import InitialState, LittleDogSim, simulate_move  # noqa: E402
from littledog_mlsim.robot.twin import robot_config_from  # noqa: E402


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--robot", default="nominal")
    p.add_argument("--probe", type=float, default=1.0, help="probe drag [N]")
    p.add_argument("--out", type=Path, required=True)
    a = p.parse_args()
    config = replace(robot_config_from(a.robot), sensor_noise=False)
    cmd = trot_commands(sample_trot_params("F", np.random.default_rng(3)))[:200]
    rec = simulate_move(cmd, robot=config, seed=0, name="F_00", move_type="F")
    X = np.hstack(FeatureSet(()).move_arrays(rec)[:2])   # row i: measurement i + 1
    rows = np.flatnonzero(swing_weight(X)[:, 0] > SWING_ROW)
    sim = LittleDogSim(config)
    t0 = time.perf_counter()
    nxt = {}
    for force in (a.probe, 0.0):
        out = []
        for i in rows:
            sim.reset(initial=InitialState.at(rec, int(i) + 1),
                      effects=[SwingDrag(force, legs=["front_left"])] if force else [])
            out.append(sim.step(cmd[int(i) + 1])["dq"])
        nxt[force] = np.array(out)
    sim.close()
    d = (nxt[a.probe] - nxt[0.0]) / a.probe
    T = swing_drag_torque(X[rows])
    joints = []
    for j in range(3):
        Z = np.stack([np.ones(len(rows)), T[:, j]], axis=1)
        c = np.linalg.lstsq(Z, d[:, j], rcond=None)[0]
        joints.append({"joint": j, "response": float(c[1]),
                       "correlation": float(np.corrcoef(T[:, j], d[:, j])[0, 1]),
                       "column_max_abs_m": float(np.abs(T[:, j]).max()),
                       "rate_change_max_abs": float(np.abs(d[:, j]).max())})
    others = np.abs(d[:, 3:]).max(axis=0)
    doc = {"command": "OPENBLAS_NUM_THREADS=1 .venv/bin/python "
                      "benchmarks/learned_route/drag_reading/nominal_probe.py "
                      + " ".join(sys.argv[1:]),
           "code": git_state(), "date": time.strftime("%Y-%m-%d %H:%M", time.gmtime()),
           "load": uptime(), "robot": a.robot, "probe_N": a.probe, "n_states": int(len(rows)),
           "seconds": round(time.perf_counter() - t0, 1), "leg_joints": joints,
           "other_legs_rate_change_max_abs": [float(x) for x in others]}
    a.out.with_suffix(".json").write_text(json.dumps(doc, indent=1))
    lines = [f"# The `{a.robot}` robot's one-step response to a {a.probe:g} N drag on the "
             "swinging front-left foot", "",
             f"Command: `{doc['command']}`  ", f"Code: {doc['code']}; {doc['date']} UTC; load "
             f"{doc['load']}", "",
             f"{doc['n_states']} swing states of one forward trot, each stepped twice "
             f"({doc['seconds']} s).", "",
             "| joint of the leg | response (rate change per step per m of the column per N) "
             "| correlation with the column | column max [m] | rate change max [rad/s per N] |",
             "|---|---|---|---|---|"]
    for r in joints:
        lines.append(f"| {r['joint']} | {r['response']:.4f} | {r['correlation']:.2f} | "
                     f"{r['column_max_abs_m']:.3f} | {r['rate_change_max_abs']:.4f} |")
    lines += ["", "The other legs' joints' largest rate change [rad/s per N]: "
              + ", ".join(f"{x:.3f}" for x in others) + "."]
    a.out.with_suffix(".md").write_text("\n".join(lines) + "\n")
    print("\n".join(lines))


if __name__ == "__main__":
    main()
