"""Why the open-loop targets are or are not reachable: two floors under the 60 s errors.

Run after ``fidelity.py open-loop`` on the same schedules (same seeds, same scenarios):

1. Sensitivity floor (no model at all): the pybullet robot against itself, started from the
   same settled stance with every joint angle offset by N(0, ``--sigma``^2) (1 mrad: about 30
   encoder counts, far below the data's noise) and fed the same commands. Whatever (x, y) gap
   this opens in 60 s, no simulator that differs from pybullet by a small per-step error can be
   expected to beat it by much: it is how strongly the trotting robot amplifies a perturbation.
2. One-step floor (teacher forcing): the model predicts every step from pybullet's *measured*
   state (no feedback of its own predictions, no projection), and its predicted body
   displacements and yaw changes are integrated into a path (``integrate_path``). The gap of that
   path from pybullet's is what the model's one-step errors alone add up to over 60 s, with the
   state never leaving where pybullet is; the yaw error of that path is the sum of the one-step
   d_yaw errors (a heading bias).

Both are reported as final (x, y) gap, gap / path and final yaw gap, with the same path
definition as ``fidelity.py``. Writes ``floor.json``/``floor.md``.
"""
from __future__ import annotations

import argparse
import os
import sys
import time
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))
import fidelity as F  # noqa: E402

from _common import command_line, run_record, write_results  # noqa: E402
from littledog_mlsim.control.gait import StreamingTrot  # noqa: E402
from littledog_mlsim.control.schedule import (  # noqa: E402
    gait_switch_schedule, straight_trot_schedule)
from littledog_mlsim.data.dataset import integrate_path, states_from_recording  # noqa: E402
from littledog_mlsim.layout import CONTROL_DT, HOME_POSE  # noqa: E402
from littledog_mlsim.robot.sim import InitialState  # noqa: E402
from littledog_mlsim.rotations import quat_to_rpy  # noqa: E402


def _pybullet_run(seed: int, commands: np.ndarray, q_offset: np.ndarray | None):
    sim = F._pybullet()
    init = None
    if q_offset is not None:
        sim.reset(seed=seed)
        h = sim.true_state()
        init = InitialState(h.position, h.orientation, h.q + q_offset, h.dq,
                            h.linear_velocity, h.angular_velocity)
    obs = [sim.reset(initial=init, seed=seed)]
    obs.append(sim.step(HOME_POSE))
    for u in commands:
        obs.append(sim.step(u))
    return F._recording(obs, np.vstack([HOME_POSE[None], commands]))


def _gap(xy: np.ndarray, yaw: np.ndarray, ref_xy: np.ndarray, ref_yaw: np.ndarray,
         path: float) -> dict:
    e = float(np.linalg.norm(xy[-1] - ref_xy[-1]))
    return {"final_err_m": e, "err_per_m": e / path,
            "final_yaw_err_rad": float(abs(np.angle(np.exp(1j * (yaw[-1] - ref_yaw[-1])))))}


def floor_task(args) -> dict:
    scenario, seed, duration, sigma = args
    rng = np.random.default_rng(seed)
    sched = (straight_trot_schedule(duration, rng) if scenario == "straight"
             else gait_switch_schedule(duration, rng))
    U = StreamingTrot(phase=sched.phase).commands(sched.commands)
    ref = _pybullet_run(seed, U, None)
    ref_xy, ref_yaw = ref.position[2:, :2], quat_to_rpy(ref.orientation[2:])[:, 2]
    path = F.path_length(ref_xy)
    out = {"scenario": scenario, "seed": seed, "path_m": path}
    off = np.random.default_rng(500 + seed).normal(0.0, sigma, 12)
    pert = _pybullet_run(seed, U, off)
    out["sensitivity"] = _gap(pert.position[2:, :2], quat_to_rpy(pert.orientation[2:])[:, 2],
                              ref_xy, ref_yaw, path)
    states = states_from_recording(ref)            # s_1 .. s_{N+1}
    rpy1 = quat_to_rpy(ref.orientation[1])
    for name in ("lgpr", "lr"):
        model = F._model(name)
        X = np.hstack([states[:-1], U])               # (s_{k+1}, u_k) -> s_{k+2}
        pred = model.predict(X)
        path_tf = integrate_path(pred, ref.position[1, 0], ref.position[1, 1], rpy1[2],
                                 rpy1[:2])
        out[f"teacher_{name}"] = _gap(path_tf[:, :2], path_tf[:, 2], ref_xy, ref_yaw, path)
        err = pred - states[1:]
        out[f"teacher_{name}"]["dyaw_bias_per_s"] = float(err[:, F.S.dyaw].mean() / CONTROL_DT)
        out[f"teacher_{name}"]["db_rms_mm"] = float(
            1e3 * np.sqrt(np.mean(np.sum(err[:, F.S.d_b][:, :2] ** 2, axis=1))))
    return out


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--lgpr", type=Path, default=Path("bags/default_lgpr"))
    ap.add_argument("--lr", type=Path, default=Path("bags/default_lr"))
    ap.add_argument("--seeds", nargs="+", type=int, default=[0, 1, 2, 3, 4])
    ap.add_argument("--scenarios", nargs="+", default=["switch", "straight"],
                    choices=("switch", "straight"))
    ap.add_argument("--duration", type=float, default=60.0)
    ap.add_argument("--sigma", type=float, default=1e-3, help="joint-angle offset std [rad]")
    ap.add_argument("--workers", type=int, default=2)
    ap.add_argument("--out", type=Path, default=HERE / "floor")
    a = ap.parse_args(argv)
    jobs = [(sc, s, a.duration, a.sigma) for sc in a.scenarios for s in a.seeds]
    t0 = time.time()
    with ProcessPoolExecutor(max_workers=a.workers, initializer=F._setup,
                             initargs=({"lgpr": str(a.lgpr), "lr": str(a.lr)}, 0.0)) as ex:
        runs = list(ex.map(floor_task, jobs))
    wall = time.time() - t0
    doc = {**run_record("fidelity/floor.py", sys.argv[1:]), "wall_s": round(wall, 1),
           "load_after": os.getloadavg()[0], "sigma_rad": a.sigma, "runs": runs}
    lines = [f"# Floors under the open-loop error ({a.duration:g} s, seeds {a.seeds})", "",
             command_line(doc), "",
             f"Code: {doc['git']}; {doc['date']} UTC; wall {wall:.0f} s, load after "
             f"{doc['load_after']:.1f}.", "",
             "| scenario | path m | pybullet vs pybullet with joints offset "
             f"{1e3 * a.sigma:g} mrad: gap / path, yaw gap rad | LGPR teacher-forced: gap / "
             "path, yaw gap rad, d_yaw bias rad/s | LR teacher-forced: gap / path, yaw gap rad |",
             "|---|---|---|---|---|"]
    doc["summary"] = {}
    for sc in a.scenarios:
        rs = [r for r in runs if r["scenario"] == sc]
        med = lambda f: float(np.median([f(r) for r in rs]))  # noqa: E731
        s = {"path_m": med(lambda r: r["path_m"]),
             "sensitivity_err_per_m": med(lambda r: r["sensitivity"]["err_per_m"]),
             "sensitivity_yaw": med(lambda r: r["sensitivity"]["final_yaw_err_rad"]),
             "lgpr_tf_err_per_m": med(lambda r: r["teacher_lgpr"]["err_per_m"]),
             "lgpr_tf_yaw": med(lambda r: r["teacher_lgpr"]["final_yaw_err_rad"]),
             "lgpr_dyaw_bias": med(lambda r: abs(r["teacher_lgpr"]["dyaw_bias_per_s"])),
             "lr_tf_err_per_m": med(lambda r: r["teacher_lr"]["err_per_m"]),
             "lr_tf_yaw": med(lambda r: r["teacher_lr"]["final_yaw_err_rad"])}
        doc["summary"][sc] = s
        lines.append(
            f"| {sc} | {s['path_m']:.2f} | {100 * s['sensitivity_err_per_m']:.1f} %, "
            f"{s['sensitivity_yaw']:.3f} | {100 * s['lgpr_tf_err_per_m']:.1f} %, "
            f"{s['lgpr_tf_yaw']:.3f}, {s['lgpr_dyaw_bias']:.4f} | "
            f"{100 * s['lr_tf_err_per_m']:.1f} %, {s['lr_tf_yaw']:.3f} |")
    lines += ["", f"Medians over {len(a.seeds)} seeds. Per run (gap / path: sensitivity, LGPR "
              "teacher-forced):", ""]
    for r in runs:
        lines.append(f"- {r['scenario']} seed {r['seed']}: path {r['path_m']:.2f} m; "
                     f"{100 * r['sensitivity']['err_per_m']:.1f} %; "
                     f"{100 * r['teacher_lgpr']['err_per_m']:.1f} %")
    write_results(a.out, doc, lines)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
