"""Materiality check of the zoo: every effect, recorded on the gap robot, must change the
recordings clearly against clean recordings of the gap robot with the same seed and commands,
and no move (clean or with an effect) may fall.

The moves are exactly the harness's (``record --seed SEED --moves-per-type N``: the same
``MoveJob`` seeds, trot parameters, commands and sensor seeds), simulated here in one process.

Per move: d_xy = |final body (x, y) with the effect - clean| [m] (motion capture, odom), and
rms_q = RMS over the move's 401 samples and the effect's scope joints (all 12 for a body-level
effect) of the reported joint-angle difference [rad].
Criterion (stated before the magnitudes were tuned): an effect is **material** when the median
over all moves of d_xy >= 0.02 m OR the median over all moves of rms_q >= 0.01 rad.
A move **falls** when the body's tilt (angle of its z axis from the vertical) exceeds 0.7 rad or
its height drops below half the standing height at any sample.
A control row (a 1 g payload at the body's origin) shows the floor of d_xy / rms_q that a
negligible change gives (the trot's sensitivity), which the thresholds must clear by far.

Run from the repository root:
    OPENBLAS_NUM_THREADS=1 python benchmarks/blind_zoo/zoos/zoo8/check_visible.py [--moves-per-type 10] [--only g01,g02]
"""
from __future__ import annotations

import argparse
import sys
import tempfile
import time
from pathlib import Path

import numpy as np
import yaml

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE.parents[3]))

from littledog_mlsim.apps.record import plan_jobs  # noqa: E402
from littledog_mlsim.gait.trot import excite_commands, sample_trot_params, trot_commands  # noqa: E402
from littledog_mlsim.layout import MOVE_TYPES  # noqa: E402
from littledog_mlsim.robot.effects import load_effects, resolve_joints  # noqa: E402
from littledog_mlsim.robot.sim import simulate_move  # noqa: E402
from littledog_mlsim.rotations import quat_to_matrix  # noqa: E402
from littledog_mlsim.robot.twin import robot_config_from  # noqa: E402

DXY_MIN = 0.02
RMSQ_MIN = 0.01
TILT_MAX = 0.7
CONTROL = "- class: littledog_mlsim.robot.effects:Payload\n  params: {mass: 0.001}\n"


def scope_joints(scope: str) -> np.ndarray:
    if scope == "body" or scope == "all":
        return resolve_joints("all")
    kind, _, name = scope.partition(":")
    return resolve_joints(name)


def move_commands(job):
    gait_seed, robot_seed = job.seeds()
    rng = np.random.default_rng(gait_seed)
    params = sample_trot_params(job.move_type, rng)
    return excite_commands(trot_commands(params), 0.0, rng), robot_seed


def fell(rec, z0: float) -> bool:
    r = quat_to_matrix(rec.orientation)
    tilt = np.arccos(np.clip(r[:, 2, 2], -1.0, 1.0))
    return bool(tilt.max() > TILT_MAX or rec.position[:, 2].min() < 0.5 * z0)


def run(robot, jobs, effects_file):
    out = []
    for job in jobs:
        cmd, seed = move_commands(job)
        eff = load_effects(effects_file) if effects_file else ()
        out.append(simulate_move(cmd, robot=robot, effects=eff, seed=seed, name=job.name,
                                 move_type=job.move_type))
    return out


def main() -> int:
    ap = argparse.ArgumentParser()
    ap.add_argument("--moves-per-type", type=int, default=10)
    ap.add_argument("--seed", type=int, default=31)
    ap.add_argument("--only", default="")
    ap.add_argument("--robot", default=str(HERE / "gap_robot.json"))
    ap.add_argument("--out", default="", help="write the table here (markdown)")
    ap.add_argument("--fall-seeds", default="32,33,80",
                    help="other seeds whose clean moves (the harness's clean and reference "
                         "datasets) are checked for falls too")
    a = ap.parse_args()
    robot = robot_config_from(a.robot)
    truth = yaml.safe_load((HERE / "truth.yaml").read_text())["effects"]
    only = {s for s in a.only.split(",") if s}
    truth = [t for t in truth if not only or t["id"] in only]
    jobs = plan_jobs(a.moves_per_type, MOVE_TYPES, a.seed)
    t0 = time.time()
    clean = run(robot, jobs, None)
    z0 = float(np.median([r.position[0, 2] for r in clean]))
    clean_falls = sum(fell(r, z0) for r in clean)
    lines = [f"Materiality check: gap robot `{Path(a.robot).name}`, seed {a.seed}, "
             f"{a.moves_per_type} moves per type ({len(jobs)} moves), no excitation.",
             f"Criterion: material if median d_xy >= {DXY_MIN} m or median rms_q >= {RMSQ_MIN} rad "
             f"(rms_q over the effect's scope joints); a fall is tilt > {TILT_MAX} rad or height "
             f"< half the standing height ({z0:.3f} m).",
             f"Clean gap robot: {clean_falls} of {len(clean)} moves fall; median final |xy| "
             f"travelled {np.median([np.hypot(*r.position[-1, :2] - r.position[0, :2]) for r in clean]):.3f} m.",
             "", "| effect | scope | median d_xy [m] | p90 d_xy [m] | median rms_q [rad] | "
             "moves over a threshold | per type median d_xy [cm] | falls | material |",
             "|---|---|---|---|---|---|---|---|---|"]
    rows = [("control (1 g)", "body", None)] + [(t["id"], t["scope"], t) for t in truth]
    all_ok = clean_falls == 0
    with tempfile.TemporaryDirectory() as tmp:
        ctrl = Path(tmp) / "control.yaml"
        ctrl.write_text(CONTROL)
        for rid, scope, t in rows:
            f = ctrl if t is None else HERE / "effects" / t.get("file", f"{rid}.yaml")
            recs = run(robot, jobs, str(f))
            idx = scope_joints(scope)
            dxy = np.array([np.hypot(*(e.position[-1, :2] - c.position[-1, :2]))
                            for e, c in zip(recs, clean)])
            rms = np.array([np.sqrt(np.mean((e.q[:, idx] - c.q[:, idx]) ** 2))
                            for e, c in zip(recs, clean)])
            falls = sum(fell(r, z0) for r in recs)
            over = int(np.sum((dxy >= DXY_MIN) | (rms >= RMSQ_MIN)))
            per_type = " ".join(f"{mt}:{100 * np.median(dxy[[j.move_type == mt for j in jobs]]):.1f}"
                                for mt in MOVE_TYPES)
            material = bool(np.median(dxy) >= DXY_MIN or np.median(rms) >= RMSQ_MIN)
            if t is not None:
                all_ok &= material and falls == 0
            lines.append(f"| {rid} | {scope} | {np.median(dxy):.4f} | {np.percentile(dxy, 90):.4f} | "
                         f"{np.median(rms):.4f} | {over}/{len(jobs)} | {per_type} | {falls} | "
                         f"{'-' if t is None else ('yes' if material else 'NO')} |")
            print(lines[-1], flush=True)
    for s in (int(x) for x in a.fall_seeds.split(",") if x):
        recs = run(robot, plan_jobs(a.moves_per_type, MOVE_TYPES, s), None)
        n = sum(fell(r, z0) for r in recs)
        all_ok &= n == 0
        lines.append(f"Clean gap robot, seed {s}: {n} of {len(recs)} moves fall.")
    lines += ["", f"All effects material and no move falls: {'yes' if all_ok else 'NO'} "
              f"({time.time() - t0:.0f} s)."]
    text = "\n".join(lines) + "\n"
    print(text)
    if a.out:
        Path(a.out).write_text(text)
    return 0 if all_ok else 1


if __name__ == "__main__":
    raise SystemExit(main())
