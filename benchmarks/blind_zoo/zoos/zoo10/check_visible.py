"""Materiality and no-fall check of zoo10's effects (results: check.md, check.json).

Every effect is simulated on the gap robot (gap_robot.json) over exactly the moves the harness
records (``apps.record.plan_jobs``: seed 51, 10 moves per type, plain trots, no excitation, the
same gait and sensor seeds per move), and compared move by move with the same moves of the clean
gap robot and of a null control (controls/null_control.yaml: 0.001 N m of Coulomb friction on
every joint, far below anything a diagnosis could name; it measures how far two nearly identical
robots drift apart in these contact-rich moves).

Per dataset, over the 33 state elements the learned model sees (z_w, body twist in base_link,
roll, pitch, joint angles and rates) and every step of every move:

- ``rms_max``: the largest RMS difference (effect - clean) of one element divided by that
  element's standard deviation in the clean data (``rms_el``: which element);
- ``xy_cm``: the mean over moves of the distance between the effect's and the clean robot's
  final (x, y) body positions [cm].

An effect is **material** when rms_max >= max(0.20, 3 x the control's) or
xy_cm >= max(3.0, 3 x the control's). A move **falls** when the body's height drops below
0.06 m or |roll| or |pitch| exceeds 1.0 rad at any step (checked on the clean robot and the
control too). From the repository root:

    OPENBLAS_NUM_THREADS=1 .venv/bin/python \
        benchmarks/blind_zoo/zoos/zoo10/check_visible.py [--jobs 2] [--only z01,z02]
"""
from __future__ import annotations

import argparse
import json
import sys
import time
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE.parents[3]))          # the repository root

from littledog_mlsim.layout import MOVE_TYPES, STATE_NAMES  # noqa: E402

SEED = 51
MOVES_PER_TYPE = 10
FALL_Z = 0.06
FALL_ANGLE = 1.0
RMS_MIN, XY_MIN_CM, CONTROL_FACTOR = 0.20, 3.0, 3.0


def _roll_pitch(quat: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    x, y, z, w = quat.T
    roll = np.arctan2(2 * (w * x + y * z), 1 - 2 * (x * x + y * y))
    pitch = np.arcsin(np.clip(2 * (w * y - z * x), -1, 1))
    return roll, pitch


def simulate(effects_file: str | None, moves_per_type: int = MOVES_PER_TYPE) -> dict:
    """States (n_moves, 401, 33), final (x, y) (n_moves, 2) and falls of one dataset."""
    from littledog_mlsim.apps.record import plan_jobs
    from littledog_mlsim.control.moves import open_loop_commands
    from littledog_mlsim.robot.effects import load_effects
    from littledog_mlsim.robot.sim import simulate_move
    from littledog_mlsim.robot.twin import robot_config_from

    robot = robot_config_from(str(HERE / "gap_robot.json"))
    states, finals, falls = [], [], []
    for job in plan_jobs(moves_per_type, MOVE_TYPES, SEED):
        gait_seed, robot_seed = job.seeds()
        effects = load_effects(effects_file) if effects_file else ()
        cmd = open_loop_commands(job.kind, job.move_type, np.random.default_rng(gait_seed), 0.0)
        rec = simulate_move(cmd, robot=robot, effects=effects, seed=robot_seed, name=job.name,
                            move_type=job.move_type)
        roll, pitch = _roll_pitch(np.asarray(rec.orientation))
        s = np.column_stack([rec.position[:, 2], rec.linear_velocity, roll, pitch,
                             rec.angular_velocity, rec.q, rec.dq])
        states.append(s)
        finals.append(np.asarray(rec.position)[-1, :2])
        if (np.min(rec.position[:, 2]) < FALL_Z or np.max(np.abs(roll)) > FALL_ANGLE
                or np.max(np.abs(pitch)) > FALL_ANGLE):
            falls.append(job.name)
    return {"states": np.array(states), "finals": np.array(finals), "falls": falls}


def compare(d: dict, clean: dict) -> dict:
    diff = d["states"] - clean["states"]
    scale = clean["states"].reshape(-1, len(STATE_NAMES)).std(axis=0)
    rms = np.sqrt(np.mean(diff.reshape(-1, len(STATE_NAMES)) ** 2, axis=0)) / scale
    k = int(np.argmax(rms))
    xy = float(np.mean(np.linalg.norm(d["finals"] - clean["finals"], axis=1)) * 100)
    return {"rms_max": float(rms[k]), "rms_el": STATE_NAMES[k], "xy_cm": xy,
            "falls": d["falls"]}


def main() -> int:
    ap = argparse.ArgumentParser()
    ap.add_argument("--jobs", type=int, default=2)
    ap.add_argument("--only", default="")
    ap.add_argument("--moves-per-type", type=int, default=MOVES_PER_TYPE)
    ap.add_argument("--out", default=str(HERE / "check.md"))
    a = ap.parse_args()
    ids = sorted(f.stem for f in (HERE / "effects").glob("z*.yaml"))
    if a.only:
        ids = [i for i in ids if i in a.only.split(",")]
    files = {"clean": None, "control": str(HERE / "controls" / "null_control.yaml")}
    files.update({i: str(HERE / "effects" / f"{i}.yaml") for i in ids})
    t0 = time.time()
    with ProcessPoolExecutor(max_workers=a.jobs) as pool:
        futs = {k: pool.submit(simulate, f, a.moves_per_type) for k, f in files.items()}
        data = {k: f.result() for k, f in futs.items()}
    clean = data["clean"]
    control = compare(data["control"], clean)
    rms_thr = max(RMS_MIN, CONTROL_FACTOR * control["rms_max"])
    xy_thr = max(XY_MIN_CM, CONTROL_FACTOR * control["xy_cm"])
    rows = {}
    for i in ids:
        r = compare(data[i], clean)
        r["material"] = bool(r["rms_max"] >= rms_thr or r["xy_cm"] >= xy_thr)
        rows[i] = r
    ok = all(r["material"] and not r["falls"] for r in rows.values()) and not clean["falls"] \
        and not data["control"]["falls"]
    n = len(clean["finals"])
    lines = [
        "# zoo10 check_visible: materiality and no falls", "",
        f"Gap robot `gap_robot.json`, seed {SEED}, {a.moves_per_type} moves per type "
        f"({n} moves, the moves `harness/run.py` records), no excitation. "
        f"Thresholds: rms_max >= {rms_thr:.3f} or xy_cm >= {xy_thr:.2f} "
        f"(max of the absolute floor and {CONTROL_FACTOR:g}x the null control). "
        f"Wall time {time.time() - t0:.0f} s.", "",
        f"Clean gap robot: falls {len(clean['falls'])} of {n}. "
        f"Null control: rms_max {control['rms_max']:.3f} ({control['rms_el']}), "
        f"xy_cm {control['xy_cm']:.2f}, falls {len(control['falls'])}.", "",
        "| effect | rms_max | element | xy_cm | falls | material |", "|---|---|---|---|---|---|"]
    for i, r in rows.items():
        lines.append(f"| {i} | {r['rms_max']:.3f} | {r['rms_el']} | {r['xy_cm']:.2f} | "
                     f"{len(r['falls'])} | {'yes' if r['material'] else 'NO'} |")
    lines += ["", f"**Result: {'PASS' if ok else 'FAIL'}** (every effect material, no move "
              f"falls on the clean robot, the control or any effect)."]
    Path(a.out).write_text("\n".join(lines) + "\n")
    Path(a.out).with_suffix(".json").write_text(json.dumps(
        {"control": control, "clean_falls": clean["falls"], "rows": rows, "pass": ok,
         "thresholds": {"rms_max": rms_thr, "xy_cm": xy_thr}}, indent=1) + "\n")
    print("\n".join(lines))
    return 0 if ok else 1


if __name__ == "__main__":
    raise SystemExit(main())
