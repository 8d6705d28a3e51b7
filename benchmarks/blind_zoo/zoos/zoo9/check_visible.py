"""Materiality and no-fall check of the ninth blind zoo (results: check.md).

Simulates exactly the moves ``harness/run.py --record-only`` records (``record``'s MoveJob plan
and seeds, plain trots, no excitation, 10 moves per type) with the gap robot, clean and with
each effect of truth.yaml (plus a control row, ``check_control.yaml``), and per move computes

- d_xy: |final body (x, y) with the effect - clean| [m] (motion capture, same sensor seed),
- rms_q: RMS over the move of the reported joint-angle difference over the effect's scope
  joints (all 12 for a body-level effect) [rad].

An effect is material when median d_xy >= 2 cm or median rms_q >= 0.01 rad. A move falls when
the body tilts more than 0.7 rad or its height drops below half the standing height; no move may
fall, clean (seeds 41, 42, 43, 90) or with an effect (seed 41).

    OPENBLAS_NUM_THREADS=1 .venv/bin/python benchmarks/blind_zoo/zoos/zoo9/check_visible.py
"""
from __future__ import annotations

import argparse
import os
import sys
import time
from multiprocessing import Pool
from pathlib import Path

import numpy as np
import yaml

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE.parents[3]))      # the repository root

from littledog_mlsim.apps.record import MoveJob, plan_jobs  # noqa: E402
from littledog_mlsim.layout import MOVE_TYPES  # noqa: E402
from littledog_mlsim.rotations import quat_to_matrix  # noqa: E402

D_XY_MIN, RMS_Q_MIN, TILT_MAX = 0.02, 0.01, 0.7


def scope_joints(scope: str) -> np.ndarray:
    from littledog_mlsim.robot.effects import resolve_joints
    if scope in ("body", "all"):
        return resolve_joints("all")
    kind, _, name = scope.partition(":")
    return resolve_joints(name)


def simulate(effects_file: str | None, seed: int, moves: int, robot: str):
    """(final xy (n, 2), q (n, 401, 12), fell (n,), max tilt, min height ratio) of the plan."""
    from littledog_mlsim.control.moves import open_loop_commands
    from littledog_mlsim.robot.effects import load_effects
    from littledog_mlsim.robot.sim import simulate_move
    from littledog_mlsim.robot.twin import robot_config_from
    config = robot_config_from(robot)
    xy, qs, tilt, hr = [], [], [], []
    for job in plan_jobs(moves, MOVE_TYPES, seed):
        gait_seed, robot_seed = job.seeds()
        effects = load_effects(effects_file) if effects_file else ()
        commands = open_loop_commands(job.kind, job.move_type, np.random.default_rng(gait_seed), 0.0)
        rec = simulate_move(commands, robot=config, effects=effects, seed=robot_seed,
                            name=job.name, move_type=job.move_type)
        xy.append(rec.position[-1, :2])
        qs.append(rec.q)
        zaxis = np.array([quat_to_matrix(o)[:, 2] for o in rec.orientation])
        tilt.append(float(np.max(np.arccos(np.clip(zaxis[:, 2], -1, 1)))))
        hr.append(float(np.min(rec.position[:, 2]) / rec.position[0, 2]))
    tilt, hr = np.array(tilt), np.array(hr)
    return np.array(xy), np.array(qs), (tilt > TILT_MAX) | (hr < 0.5), tilt, hr


def _task(args):
    return args[0], simulate(*args[1:])


def main() -> int:
    ap = argparse.ArgumentParser()
    ap.add_argument("--robot", default=str(HERE / "gap_robot.json"))
    ap.add_argument("--seed", type=int, default=41)
    ap.add_argument("--moves-per-type", type=int, default=10)
    ap.add_argument("--only", default="")
    ap.add_argument("--jobs", type=int, default=2)
    ap.add_argument("--out", default=str(HERE / "check.md"))
    a = ap.parse_args()
    t0 = time.time()
    truth = yaml.safe_load((HERE / "truth.yaml").read_text())["effects"]
    only = {s for s in a.only.split(",") if s}
    truth = [t for t in truth if not only or t["id"] in only]
    rows = [("control", str(HERE / "check_control.yaml"), "all")] + [
        (t["id"], str(HERE / "effects" / t["file"]), t["scope"]) for t in truth]
    tasks = [(f"clean_s{s}", None, s, a.moves_per_type, a.robot) for s in (a.seed, 42, 43, 90)]
    tasks += [(name, f, a.seed, a.moves_per_type, a.robot) for name, f, _ in rows]
    with Pool(a.jobs) as pool:
        res = dict(pool.map(_task, tasks, chunksize=1))
    lines = [f"# check_visible (gap robot, seed {a.seed}, {a.moves_per_type} moves per type)", "",
             f"Material: median d_xy >= {D_XY_MIN * 100:g} cm or median rms_q >= {RMS_Q_MIN:g} rad "
             f"(rms_q over the effect's scope joints; all 12 for body-level). Fall: tilt > "
             f"{TILT_MAX} rad or height < half standing.", "",
             "| dataset | moves | falls | max tilt [rad] | min height / standing |", "|---|---|---|---|---|"]
    for s in (a.seed, 42, 43, 90):
        xy, q, fell, tilt, hr = res[f"clean_s{s}"]
        lines.append(f"| clean seed {s} | {len(fell)} | {int(fell.sum())} | {tilt.max():.3f} | {hr.min():.3f} |")
    lines += ["", "| effect | median d_xy [m] | median rms_q [rad] | material | falls | "
              "max tilt [rad] |", "|---|---|---|---|---|---|"]
    cxy, cq = res[f"clean_s{a.seed}"][:2]
    ok = True
    for name, _, scope in rows:
        xy, q, fell, tilt, hr = res[name]
        j = scope_joints(scope)
        dxy = np.linalg.norm(xy - cxy, axis=1)
        rms = np.sqrt(np.mean((q[:, :, j] - cq[:, :, j]) ** 2, axis=(1, 2)))
        mat = bool(np.median(dxy) >= D_XY_MIN or np.median(rms) >= RMS_Q_MIN)
        if name != "control":
            ok &= mat and not fell.any()
        lines.append(f"| {name} | {np.median(dxy):.4f} | {np.median(rms):.4f} | "
                     f"{'yes' if mat else 'no'} | {int(fell.sum())} | {tilt.max():.3f} |")
    clean_ok = not any(res[f"clean_s{s}"][2].any() for s in (a.seed, 42, 43, 90))
    lines += ["", f"All effects material and no fall: {'yes' if ok and clean_ok else 'no'} "
              f"(control row expected not material). Wall time {time.time() - t0:.0f} s.", ""]
    text = "\n".join(lines)
    if not only:
        Path(a.out).write_text(text)
    print(text)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
