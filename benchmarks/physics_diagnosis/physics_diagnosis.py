"""Physics diagnosis: trace the tuned nominal robot's residual to a missing parameter, calibrate it.

Usage (from the repo root, in the venv):

    OPENBLAS_NUM_THREADS=1 .venv/bin/python benchmarks/physics_diagnosis/physics_diagnosis.py \
        [--data bags/default] [--start benchmarks/physics_baseline/nominal_tuned.json] [--stride 8] \
        [--test-stride 4] [--rounds 3] [--jobs 2] [--out benchmarks/physics_diagnosis/physics_diagnosis]
    .venv/bin/python benchmarks/physics_diagnosis/physics_diagnosis.py --from-json benchmarks/physics_diagnosis/physics_diagnosis.json

Runs ``littledog_mlsim.robot.calibrate.diagnose_physics`` with every TrainPool move of the
dataset (screening and calibration) and every TestPool move (scored only, before and after each
round), starting from the tuned nominal robot, and writes ``<out>.json`` (the full report) and
``<out>.md`` (the command, git state, date, wall time, the screening table of every round and
the TestPool before/after tables, and the stand-in robot's own values of the candidate parameters
read from its config). Every number in the .md comes from the run (``--from-json`` re-renders the
.md of a saved run without simulating).
"""
from __future__ import annotations

import argparse
import json
import os
import platform
import sys
import time
from datetime import datetime, timezone
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))  # benchmarks/: _common
from _common import ROOT, git_state  # noqa: E402

from littledog_mlsim.robot.baseline import load_robot_config  # noqa: E402
from littledog_mlsim.data.dataset import load_moves  # noqa: E402
from littledog_mlsim.robot.calibrate import diagnose_physics  # noqa: E402
from littledog_mlsim.fileio import atomic_write_text  # noqa: E402
from littledog_mlsim.layout import STATE_NAMES  # noqa: E402
from littledog_mlsim.robot.config import (URDF_BODY_MASS, URDF_LEG_MASS,  # noqa: E402
                                          robot_config)

# Elements shown in the one-step tables (all 33 are in the JSON): the body, and the front-left
# leg's joints (the four legs behave alike).
SHOWN = ("z_w", "dx_b", "dy_b", "dz_b", "roll", "pitch", "droll", "dpitch", "dyaw",
         "q_front_left_hip_roll", "q_front_left_hip_pitch", "q_front_left_knee",
         "dq_front_left_hip_roll", "dq_front_left_hip_pitch", "dq_front_left_knee")


def _f(v: float | None, nd: int = 4) -> str:
    return "—" if v is None else f"{v:.{nd}f}"


def _group_mean(d: dict[str, float | None], prefix: str) -> float | None:
    vals = [v for k, v in d.items() if k.startswith(prefix) and v is not None]
    return sum(vals) / len(vals) if vals else None


def stand_in_values() -> dict[str, str]:
    """The candidate parameters' values on the measured stand-in robot, from its config."""
    m = robot_config("measured")
    urdf = URDF_BODY_MASS + 4 * URDF_LEG_MASS
    total = (m.body_mass or URDF_BODY_MASS) + 4 * (m.leg_mass or URDF_LEG_MASS)
    return {"command_delay": "0 (none)", "rate_filter_hz": f"{m.rate_filter_hz:g} Hz",
            "knee_torque_limit": f"{m.torque_limit[2]:g} N m (of its PD servo)",
            "coulomb_friction": "0 (none)",
            "mass_scale": f"{total / urdf:.4f} ({total:.3f} kg / URDF {urdf:.3f} kg; plus rotor "
                          f"armature {', '.join(f'{a:.3g}' for a in m.armature)} kg m^2)"}


def markdown(rep: dict, meta: dict) -> str:
    L = ["# Physics diagnosis of the tuned nominal robot", "",
         f"Command: `{meta['command']}`", "",
         f"Git state: `{meta['git']}`. Date {meta['date']}. Wall time {meta['wall_s']:.0f} s on "
         f"{meta['cores']} shared cores (1-min load average {meta['load_before']:.1f} before, "
         f"{meta['load_after']:.1f} after), Python {meta['python']}.", "",
         f"Data `{meta['data']}`: {len(rep['train_moves'])} TrainPool moves (screening and "
         f"calibration), {len(rep['test_moves'])} TestPool moves (scored only). Start robot "
         f"`{meta['start']}`. One-step samples every {rep['stride']} steps on TrainPool, every "
         f"{rep['test_stride']} on TestPool; {rep['n_folds']} move folds; alpha {rep['alpha']}, "
         f"materiality {rep['min_gain']:.0%}; at most {rep['max_rounds']} rounds. "
         f"Stopped: {rep['stopped']}.", "",
         "Method (details in `littledog_mlsim/robot/calibrate.py`): the residual is one physics "
         "step from each measured TrainPool state; each candidate parameter is re-simulated at a "
         "few values, its value chosen on the other move folds and its one-step SSE cut measured "
         "on the held-out fold; per-move t-tests (moves are the independent unit), Bonferroni "
         "over elements, two tests and candidates; the material candidate with the largest "
         "summed held-out gain is calibrated on the TrainPool one-step residual (grid, then a "
         "bounded scalar search for continuous parameters), kept only if the TrainPool rollout "
         "objective J (`baseline.tuning_objective`) does not get worse, and the loop repeats.", ""]
    L += ["## What was found", ""]
    if rep["found"]:
        L += ["| round | family | parameter | screening estimate | calibrated value | TrainPool "
              "rollout J before -> after | kept | elements (p < alpha, held-out gain >= half "
              "the minimum) |", "|---|---|---|---|---|---|---|---|"]
        for e in rep["rounds"]:
            f = e["found"]
            if not f:
                continue
            els = ", ".join(f["elements"][:8]) + (f" (+{len(f['elements']) - 8})"
                                                  if len(f["elements"]) > 8 else "")
            L.append(f"| {e['round']} | {f['family']} | `{f['param']}` | "
                     f"{f['screening_estimate']:g} | {f['calibrated_value']:.4g} | "
                     f"{f['train_J_before']['objective']:.4f} -> "
                     f"{f['train_J_after']['objective']:.4f} | "
                     f"{'yes' if f['accepted'] else 'no (rollout worse)'} | {els} |")
    else:
        L.append("Nothing material: no candidate cut the held-out residual significantly.")
    L += ["", "The stand-in robot that recorded the data (`robot_config(\"measured\")`) has, for "
          "comparison (its servo is a torque-mode PD with rotor armature, which no candidate "
          "models, so a found value may be a proxy rather than the stand-in's value): "
          + "; ".join(f"{k} {v}" for k, v in stand_in_values().items()) + ".", ""]
    for e in rep["rounds"]:
        L += [f"## Round {e['round']}: screening (held-out by move fold, TrainPool)", "",
              "| parameter | family | current | values | fold choices | held-out gain sum | "
              "best elements (gain) | worst element (gain) | p (adjusted) | material |",
              "|---|---|---|---|---|---|---|---|---|---|"]
        for row in sorted(e["screen"], key=lambda r: -(r["gain_sum"] if r["gain_sum"]
                                                         is not None else -1e9)):
            g = {k: v for k, v in row["gain"].items() if v is not None}
            best = sorted(g, key=lambda k: -g[k])[:3]
            worst = min(g, key=lambda k: g[k]) if g else None
            L.append(f"| `{row['param']}` | {row['family']} | {row['current']} | "
                     f"{', '.join(f'{v:g}' for v in row['values'])} | "
                     f"{', '.join(f'{v:g}' for v in row['fold_choices'])} | "
                     f"{_f(row['gain_sum'], 3)} | "
                     + ", ".join(f"{k} ({g[k]:+.3f})" for k in best) + " | "
                     + (f"{worst} ({g[worst]:+.3f})" if worst else "—") + " | "
                     f"{row['p_value']:.2g} | {'yes' if row['material'] else 'no'} |")
        if e["found"]:
            c = e["found"]["calibration"]
            trail = ", ".join(f"{t['value']:.4g}: {_f(t['train_cut'], 3)}" for t in c["trail"])
            L += ["", f"Calibration of `{e['found']['param']}` ({c['objective']}; value: summed "
                  f"relative SSE cut): {trail} -> **{e['found']['calibrated_value']:.4g}**. "
                  f"Round wall time {e['wall_s']:.0f} s."]
        L.append("")
    T = rep["test"]
    L += ["## TestPool before and after (moves that took no part in choosing or calibrating)", "",
          "| robot | command delay | rate filter [Hz] | knee limit [N m] | Coulomb [N m] | "
          "mass scale | mean final xy [m] | median | diverged | one-step nMSE mean q | mean dq |"
          " mean body (9) |", "|---|---|---|---|---|---|---|---|---|---|---|---|"]
    for t in T:
        m, n = t["model"], t["one_step_nmse"]
        body = [n[k] for k in STATE_NAMES[:9] if n[k] is not None]
        L.append(f"| {t['label']} | {m['command_delay']} | {m['rate_filter_hz']} | "
                 f"{m['torque_limit'][2]:.4g} | {m['coulomb_friction']:.4g} | "
                 f"{m['mass_scale']:.4g} | {_f(t['final_xy_error_m'])} | "
                 f"{_f(t['final_xy_error_m_median'])} | {t['n_nan_moves']} | "
                 f"{_f(_group_mean(n, 'q_'))} | {_f(_group_mean(n, 'dq_'))} | "
                 f"{_f(sum(body) / len(body) if body else None)} |")
    L += ["", "One-step nMSE per element on TestPool (variance of all TestPool responses; all 33 "
          "elements in the JSON):", "",
          "| element | " + " | ".join(t["label"] for t in T) + " |",
          "|---|" + "---|" * len(T)]
    for k in SHOWN:
        L.append(f"| {k} | " + " | ".join(_f(t["one_step_nmse"][k]) for t in T) + " |")
    types = list(T[0]["by_move_type"])
    L += ["", "Mean final (x, y) error per move type on TestPool [m]:", "",
          "| robot | " + " | ".join(types) + " |", "|---|" + "---|" * len(types)]
    for t in T:
        L.append(f"| {t['label']} | " + " | ".join(_f(t["by_move_type"][ty], 3)
                                                     for ty in types) + " |")
    L.append("")
    return "\n".join(L)


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--data", default="bags/default")
    ap.add_argument("--start", default="benchmarks/physics_baseline/nominal_tuned.json")
    ap.add_argument("--stride", type=int, default=8)
    ap.add_argument("--test-stride", type=int, default=4)
    ap.add_argument("--rounds", type=int, default=3)
    ap.add_argument("--folds", type=int, default=3)
    ap.add_argument("--jobs", type=int, default=2)
    ap.add_argument("--out", default="benchmarks/physics_diagnosis/physics_diagnosis")
    ap.add_argument("--from-json", metavar="JSON",
                    help="only re-render the .md of an earlier run's JSON (no simulation)")
    a = ap.parse_args()
    if a.from_json:
        doc = json.loads(Path(a.from_json).read_text(encoding="utf-8"))
        md = Path(a.from_json).with_suffix(".md")
        atomic_write_text(md, markdown(doc["report"], doc["meta"]))
        print(f"wrote {md}")
        return 0
    t0 = time.perf_counter()
    load_before = os.getloadavg()[0]
    start = load_robot_config(a.start)
    train = load_moves(a.data, "train")
    test = load_moves(a.data, "test")
    rep = diagnose_physics(train, test, start, stride=a.stride, test_stride=a.test_stride,
                           max_rounds=a.rounds, n_folds=a.folds, jobs=a.jobs,
                           progress=lambda s: print(s, flush=True))
    meta = {"command": ("OPENBLAS_NUM_THREADS=1 .venv/bin/python benchmarks/physics_diagnosis/physics_diagnosis.py "
                        + " ".join(sys.argv[1:])).strip(),
            "git": git_state(), "date": datetime.now(timezone.utc).strftime("%Y-%m-%d %H:%M UTC"),
            "wall_s": time.perf_counter() - t0, "cores": os.cpu_count(),
            "python": platform.python_version(), "load_before": load_before,
            "load_after": os.getloadavg()[0], "data": a.data, "start": a.start}
    out = Path(a.out)
    out = out if out.is_absolute() else ROOT / out
    atomic_write_text(out.with_suffix(".json"),
                      json.dumps({"meta": meta, "report": rep}, indent=1, allow_nan=False) + "\n")
    atomic_write_text(out.with_suffix(".md"), markdown(rep, meta))
    print(f"wrote {out.with_suffix('.md')} and .json ({meta['wall_s']:.0f} s)")
    return 0


if __name__ == "__main__":
    sys.exit(main())
