"""Physics baseline: the nominal pybullet robot, untuned and tuned on TrainPool, scored on TestPool.

Usage (from the repo root, in the venv):

    OPENBLAS_NUM_THREADS=1 .venv/bin/python benchmarks/physics_baseline/physics_baseline.py \
        [--data bags/default] [--per-type 2] [--budget 40] [--jobs 2] [--one-step-stride 2]

1. Tunes the nominal robot's position_gain, velocity_gain, mass_scale and ground_friction on the
   first ``--per-type`` TrainPool moves of every type (``baseline.tuning_moves``: the train split
   only) with ``baseline.tune_nominal`` (coarse grid, then Nelder-Mead, ``--budget`` evaluations).
2. Scores the untuned and the tuned nominal robot on every TestPool move with
   ``baseline.evaluate_baseline`` (``rollout_metrics`` of the physics rollouts, plus one-step nMSE
   of one physics step from every ``--one-step-stride``-th measured state), and, as a reference
   that is not a baseline, the noise-free ``measured`` robot itself (the robot that recorded the
   data: what is left is the effect of starting from a measured, noisy state).
3. Writes ``benchmarks/physics_baseline/nominal_tuned.json`` (the tuned RobotConfig, ``baseline.load_robot_config``),
   ``benchmarks/physics_baseline/physics_baseline.json`` (everything, including the tuning trail) and
   ``benchmarks/physics_baseline/physics_baseline.md``, and the animation of the first TestPool F move (measured vs
   nominal-tuned) as ``benchmarks/physics_baseline/animation_F.gif``.

``--skip-tuning`` reuses ``benchmarks/physics_baseline/nominal_tuned.json``; ``--no-animation`` skips step 3's GIF.
"""
from __future__ import annotations

import argparse
import dataclasses
import json
import os
import platform
import sys
import time
from pathlib import Path

from littledog_mlsim.robot.baseline import (evaluate_baseline, load_robot_config, physics_rollout,
                                      save_robot_config, tune_nominal, tuning_moves)
from littledog_mlsim.data.dataset import load_moves
from littledog_mlsim.layout import MOVE_TYPES, STATE_NAMES
from littledog_mlsim.robot.config import robot_config

HERE = Path(__file__).resolve().parent
REPO = HERE.parents[1]


def _fmt(v: float | None, nd: int = 4) -> str:
    return "—" if v is None else f"{v:.{nd}f}"


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--data", default="bags/default")
    ap.add_argument("--per-type", type=int, default=2)
    ap.add_argument("--budget", type=int, default=40)
    ap.add_argument("--jobs", type=int, default=2)
    ap.add_argument("--one-step-stride", type=int, default=2)
    ap.add_argument("--reference-one-step-stride", type=int, default=8,
                    help="one-step stride of the measured reference (0: skip)")
    ap.add_argument("--skip-tuning", action="store_true")
    ap.add_argument("--no-animation", action="store_true")
    a = ap.parse_args()
    t_all = time.perf_counter()
    load_before = os.getloadavg()[0]
    cfg_path = HERE / "nominal_tuned.json"
    data = Path(a.data)

    # 1. tuning, TrainPool only
    untuned = robot_config("nominal")
    if a.skip_tuning:
        tuned, tuning = load_robot_config(cfg_path), json.loads(cfg_path.read_text())["tuning"]
    else:
        train = tuning_moves(data, per_type=a.per_type)
        print(f"tuning on {len(train)} TrainPool moves, budget {a.budget}", flush=True)
        tuned, tuning = tune_nominal(train, untuned, budget=a.budget, jobs=a.jobs,
                                     progress=lambda m: print(m, flush=True))
        save_robot_config(tuned, cfg_path, extra={"tuning": tuning, "data": str(data)})
    print(f"tuned: {tuned}", flush=True)

    # 2. scoring, TestPool
    t0 = time.perf_counter()
    test = load_moves(data, "test")
    t_load = time.perf_counter() - t0
    results = {}
    reference = dataclasses.replace(robot_config("measured"), sensor_noise=False)
    for label, cfg, stride in (("nominal", untuned, a.one_step_stride),
                               ("nominal-tuned", tuned, a.one_step_stride),
                               ("measured (reference)", reference, a.reference_one_step_stride)):
        t0 = time.perf_counter()
        results[label] = evaluate_baseline(test, cfg, one_step=stride > 0,
                                           one_step_stride=max(1, stride), jobs=a.jobs)
        results[label]["wall_s"] = round(time.perf_counter() - t0, 2)
        r = results[label]
        print(f"{label}: final xy {r['final_xy_error_m']:.4f} m (median "
              f"{r['final_xy_error_m_median']:.4f}, p90 {r['final_xy_error_m_p90']:.4f}), "
              f"{r['wall_s']:.0f} s", flush=True)

    # 3. animation of one TestPool F move
    anim = None
    if not a.no_animation:
        from littledog_mlsim.apps.animate import animate_move
        rec = next(r for r in test if r.move_type == "F")
        t0 = time.perf_counter()
        pred = physics_rollout(rec, tuned)
        t_pred = time.perf_counter() - t0
        out = HERE / "animation_F.gif"
        anim = animate_move(rec, {"nominal-tuned": pred}, out)
        anim.update({"move": rec.name, "physics_rollout_s": round(t_pred, 2),
                     "bytes": out.stat().st_size, "path": str(out.relative_to(REPO))})
        print(f"animation: {anim}", flush=True)

    wall = time.perf_counter() - t_all
    command = ("OPENBLAS_NUM_THREADS=1 .venv/bin/python benchmarks/physics_baseline/physics_baseline.py "
               + " ".join(sys.argv[1:])).strip()
    doc = {"command": command, "wall_s": round(wall, 1), "date": time.strftime("%Y-%m-%d"),
           "cores": os.cpu_count(), "python": platform.python_version(),
           "load_average_1min_before": load_before, "load_average_1min_after": os.getloadavg()[0],
           "data": str(data), "n_test_moves": len(test), "test_load_s": round(t_load, 2),
           "one_step_stride": a.one_step_stride,
           "reference_one_step_stride": a.reference_one_step_stride, "tuned_config_file": str(cfg_path.relative_to(REPO)),
           "tuning": tuning, "results": results, "animation": anim}
    write_outputs(doc)
    print(f"wall {wall:.0f} s")
    return 0


def slim(doc: dict) -> dict:
    """Keep the JSON small (~0.5 MB instead of 2.3): per-type error-vs-time curves keep only
    ``time_s`` and ``mean`` (rounded to 1 um); the all-moves curves and everything else stay whole.
    Idempotent."""
    for r in doc["results"].values():
        for bt in r["by_move_type"].values():
            xt = bt["xy_error_vs_time"]
            bt["xy_error_vs_time"] = {"time_s": xt["time_s"],
                                      "mean": [None if v is None else round(v, 6)
                                               for v in xt["mean"]]}
    return doc


def write_outputs(doc: dict) -> None:
    """``physics_baseline.json`` (slimmed, one line per top-level key) and ``.md``."""
    doc = slim(doc)
    body = ",\n".join(f" {json.dumps(k)}: {json.dumps(v, allow_nan=False)}" for k, v in doc.items())
    (HERE / "physics_baseline.json").write_text("{\n" + body + "\n}\n")
    (HERE / "physics_baseline.md").write_text(render_md(doc) + "\n")


def render_md(doc: dict) -> str:
    t, res = doc["tuning"], doc["results"]
    labels = list(res)
    L = ["# Physics baseline (nominal pybullet robot) on TestPool", "",
         f"Command: `{doc['command']}`", "",
         f"Wall time {doc['wall_s']:.0f} s on {doc['cores']} shared cores (1-min load average "
         f"{doc['load_average_1min_before']:.1f} before, {doc['load_average_1min_after']:.1f} after: "
         f"other work was running), Python {doc['python']}, {doc['date']}. Data `{doc['data']}`, "
         f"{doc['n_test_moves']} TestPool moves. These are the numbers the learned simulator must beat "
         "(same alignment, `rollout_metrics`: s_1 given, u_1..u_{N-1} replayed, s_2..s_N compared; "
         "rollouts run without a projection, the physics keeps states physical).", "",
         "## Tuning (TrainPool only)", "",
         f"Objective `{t['objective']}` with D_ref = {t['D_ref_m']:.4f} m (mean distance the tuning "
         f"moves travel) and Q_ref = {t['Q_ref_rad']:.4f} rad (RMS of q_(t+1) - u_t: the error of "
         f"assuming perfect servo tracking), on {t['n_moves']} TrainPool moves "
         f"({', '.join(t['moves'])}); coarse grid {t['grid']} then bounded Nelder-Mead, "
         f"{t['n_evals']} of {t['budget']} evaluations, {t['wall_s']:.0f} s.", "",
         "| | " + " | ".join(t["params"]) + " | J | mean final xy [m] | q RMS [rad] |",
         "|---|" + "---|" * (len(t["params"]) + 3)]
    for name, row in (("untuned (base)", t["base"]), (f"tuned (eval {t['best']['eval']})", t["best"])):
        L.append(f"| {name} | " + " | ".join(f"{row[p]:.4g}" for p in t["params"])
                 + f" | {row['objective']:.4f} | {row['final_xy_error_m']:.4f} | {row['q_rms_rad']:.4f} |")
    L += ["", f"Objective improvement on the tuning moves: {100 * t['improvement']:.1f} %. "
          f"Tuned config: `{doc['tuned_config_file']}` (`baseline.load_robot_config`). "
          "Full trail in the JSON (`tuning.trail`); the JSON also holds `per_move` results, the "
          "all-moves error-vs-time curves and per-type mean curves (Figs 5-6) of every robot.", "",
          "## TestPool rollouts", "",
          "Final (x, y) error = cumulative error at the end of the move (3.99 s after s_1). "
          "`measured (reference)` is not a baseline: it is the recording robot's own physics "
          "(noise-free) started from the measured state, i.e. the floor any simulator starting from "
          "a measured state can hope for.", "",
          "| robot | mean final xy [m] | median | p90 | diverged moves | wall [s] |", "|---|---|---|---|---|---|"]
    for lab in labels:
        r = res[lab]
        L.append(f"| {lab} | {_fmt(r['final_xy_error_m'])} | {_fmt(r['final_xy_error_m_median'])} | "
                 f"{_fmt(r['final_xy_error_m_p90'])} | {r['n_nan_moves']} | {r['wall_s']:.0f} |")
    L += ["", "Mean final (x, y) error per move type [m]:", "",
          "| robot | " + " | ".join(MOVE_TYPES) + " |", "|---|" + "---|" * len(MOVE_TYPES)]
    for lab in labels:
        bt = res[lab]["by_move_type"]
        L.append(f"| {lab} | " + " | ".join(_fmt(bt[m]["final_xy_error_m"], 3) if m in bt else "—"
                                             for m in MOVE_TYPES) + " |")
    L += ["", "Mean (x, y) error vs time [m] (all moves):", "",
          "| robot | 0.5 s | 1 s | 2 s | 3 s | 3.99 s |", "|---|---|---|---|---|---|"]
    for lab in labels:
        xt = res[lab]["xy_error_vs_time"]
        L.append(f"| {lab} | " + " | ".join(_fmt(xt["mean"][k - 1]) for k in (50, 100, 200, 300, 399)) + " |")
    os_labels = [lab for lab in labels if "one_step_nmse" in res[lab]]
    L += ["", "## Element error sums and nMSE", "",
          "`sum_t |s_t - s_t*|` per element (mean over moves, paper Fig. 7); rollout nMSE 1 s after "
          "s_1 and at the end (variance of the TestPool ground-truth states); one-step nMSE of one "
          "physics step from each measured state s_t (t = 1, 1 + stride, ...; variance of all "
          "TestPool responses, as the learned models' `evaluate`).", ""]
    hdr = ("| element | " + " | ".join(f"err sum {lab}" for lab in labels) + " | "
           + " | ".join(f"nMSE 1 s {lab}" for lab in labels[:2]) + " | "
           + " | ".join(f"nMSE 3.99 s {lab}" for lab in labels[:2]) + " | "
           + " | ".join(f"one-step nMSE {lab}" for lab in os_labels) + " |")
    L += [hdr, "|---|" + "---|" * (len(labels) + 4 + len(os_labels))]
    for n in STATE_NAMES:
        cells = [_fmt(res[lab]["element_error_sum_mean"][n], 4) for lab in labels]
        cells += [_fmt(res[lab]["nmse_at_horizon"]["1"]["nmse"][n], 3) for lab in labels[:2]]
        cells += [_fmt(res[lab]["nmse_at_horizon"]["4"]["nmse"][n], 3) for lab in labels[:2]]
        cells += [_fmt(res[lab]["one_step_nmse"][n], 4) for lab in os_labels]
        L.append(f"| {n} | " + " | ".join(cells) + " |")
    if len(labels) >= 2:
        a_, b_ = (res[lab]["element_error_sum_mean"] for lab in labels[:2])
        worse = [n for n in STATE_NAMES if None not in (a_[n], b_[n]) and b_[n] > a_[n]]
        L += ["", f"The objective targets only the final (x, y) error and the joint angles; elements "
              f"whose error sum got worse with tuning ({labels[1]} vs {labels[0]}): "
              f"{', '.join(worse) if worse else 'none'}."]
    ref = "measured (reference)"
    if ref in os_labels:
        L += ["", f"The `{ref}` one-step column is the noise floor: the recording robot's own physics "
              "still scores what motion-capture noise in s_t (the start velocity is a finite "
              "difference of noisy poses) and in the recorded s_(t+1) leaves; elements near or above "
              "1 there (body displacements) cannot be predicted one step ahead by any simulator."]
    L.append("")
    for lab in os_labels:
        o = res[lab]["one_step"]
        L.append(f"One-step ({lab}): stride {o['stride']}, {o['n_samples']} samples, "
                 f"{o['wall_s']:.0f} s (each sample rebuilds the pybullet world, ~10-30 ms).  ")
    if doc.get("animation"):
        an = doc["animation"]
        L += ["", "## Animation", "",
              f"`{an['path']}`: TestPool move {an['move']}, panels {an['labels']}, {an['n_frames']} "
              f"frames at {an['fps']} fps, {an['size'][0]}x{an['size'][1]} per panel, "
              f"{an['bytes'] / 1e6:.2f} MB; rendering took {an['wall_s']:.1f} s "
              f"(physics rollout {an['physics_rollout_s']:.1f} s)."]
    return "\n".join(L)


if __name__ == "__main__":
    sys.exit(main())
