"""Rollout speed: all TestPool moves x 399 steps, batched, as a multiple of real time.

Usage (from the repo root, in the venv; models trained beforehand with ``littledog-mlsim train``):

    OPENBLAS_NUM_THREADS=1 nice -n 19 .venv/bin/python benchmarks/rollout_speed/rollout_speed.py \\
        --data bags/default --lgpr /tmp/pstudy2/lgpr_delta --lr /tmp/pstudy2/lr_delta

What is timed: ``rollout.simulate.rollout_moves(model, moves, projection)`` over every TestPool
move (66 moves of 399 steps on ``bags/default``, one batch: one model call and one projection
per step), wall clock (``time.perf_counter``). Real time = sum of the moves' steps x 10 ms
(66 x 3.99 s = 263.34 s); the factor is real time / wall. Configurations: LGPR + alpha-PROJ
(``--alpha``), LGPR + none, LGPR + BOUND, LR + alpha-PROJ. Each configuration is warmed up once
(``model.prepare()``, ``projection.nn.prepare()`` and one untimed rollout: the one-time index
build and first-touch costs are left out), then timed ``--repeats`` times in rounds (one rollout
of each configuration per round, the order reversed every other round, so that load from other
jobs on the shared cores hits all alike). Reported: median and min wall, median factor, and the
1-min load average before and after each round.

``--profile``: also a cProfile of one LGPR + alpha-PROJ rollout (top functions by own time).

LGPR's shared-kernel clusters compute kernel rows by one GEMM on inputs centred and scaled once
(``LGPR._shared_kernel_predict``); the earlier prototypes measured with this script (a leaner
per-cluster path, 94x, and GEMM rows, 132x) are in the git history of ``rollout_speed.md``.

Writes ``--out``.json and ``--out``.md (default ``benchmarks/rollout_speed/rollout_speed``).
"""
from __future__ import annotations

import argparse
import cProfile
import io
import json
import os
import platform
import pstats
import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[2]
sys.path.insert(0, str(ROOT))
sys.path.insert(0, str(ROOT / "benchmarks"))  # _common

from _common import git_state  # noqa: E402
from littledog_mlsim.data.dataset import load_moves  # noqa: E402
from littledog_mlsim.models.onestep import OneStepModel  # noqa: E402
from littledog_mlsim.rollout.metrics import rollout_metrics  # noqa: E402
from littledog_mlsim.rollout.simulate import prepare_test_moves, rollout_moves  # noqa: E402


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--data", required=True, type=Path)
    ap.add_argument("--lgpr", required=True, help="LGPR model directory")
    ap.add_argument("--lr", required=True, help="LR model directory")
    ap.add_argument("--alpha", type=float, default=0.5)
    ap.add_argument("--repeats", type=int, default=5)
    ap.add_argument("--profile", action="store_true")
    ap.add_argument("--out", type=Path,
                    default=ROOT / "benchmarks" / "rollout_speed" / "rollout_speed")
    a = ap.parse_args(argv)

    moves = prepare_test_moves(load_moves(a.data, split="test"))
    robot_s = sum(m.n_steps for m in moves) * 0.01
    lgpr, lr = OneStepModel.load(a.lgpr), OneStepModel.load(a.lr)
    configs = {
        f"LGPR + alpha {a.alpha:g}": (lgpr, lgpr.projection("alpha", alpha=a.alpha)),
        "LGPR + none": (lgpr, lgpr.projection("none")),
        "LGPR + bound": (lgpr, lgpr.projection("bound")),
        f"LR + alpha {a.alpha:g}": (lr, lr.projection("alpha", alpha=a.alpha)),
    }
    first: dict[str, np.ndarray] = {}
    for name, (model, proj) in configs.items():
        model.prepare()
        if hasattr(proj, "nn"):
            proj.nn.prepare()
        first[name] = np.array(rollout_moves(model, moves, proj))     # warm-up, untimed
    walls: dict[str, list[float]] = {name: [] for name in configs}
    loads = []
    same = {name: True for name in configs}
    names = list(configs)
    for r in range(a.repeats):
        before = os.getloadavg()[0]
        for name in (names if r % 2 == 0 else names[::-1]):
            model, proj = configs[name]
            t0 = time.perf_counter()
            pred = rollout_moves(model, moves, proj)
            walls[name].append(time.perf_counter() - t0)
            same[name] &= bool(np.array_equal(np.array(pred), first[name]))
        loads.append((before, os.getloadavg()[0]))
        print(f"round {r + 1}: " + ", ".join(f"{n} {walls[n][-1]:.3f} s" for n in names)
              + f" (load {loads[-1][0]:.2f} -> {loads[-1][1]:.2f})", flush=True)
    res = {
        "command": " ".join(["benchmarks/rollout_speed/rollout_speed.py", *(argv or sys.argv[1:])]),
        "git": git_state(),
        "python": platform.python_version(), "numpy": np.__version__,
        "openblas_num_threads": os.environ.get("OPENBLAS_NUM_THREADS"),
        "date": time.strftime("%Y-%m-%d %H:%M"), "n_moves": len(moves),
        "n_steps": [int(m.n_steps) for m in moves][:1], "robot_time_s": robot_s,
        "load_avg_1min_per_round": loads,
        "configs": {n: {"walls_s": w, "median_wall_s": float(np.median(w)),
                        "min_wall_s": float(np.min(w)),
                        "realtime_factor_median": robot_s / float(np.median(w)),
                        "realtime_factor_best": robot_s / float(np.min(w)),
                        "identical_predictions_every_repeat": same[n],
                        "final_xy_error_m": rollout_metrics(moves, list(first[n]))[
                            "final_xy_error_m"]}
                    for n, w in walls.items()},
    }
    if a.profile:
        model, proj = configs[names[0]]
        pr = cProfile.Profile()
        pr.enable()
        rollout_moves(model, moves, proj)
        pr.disable()
        buf = io.StringIO()
        pstats.Stats(pr, stream=buf).sort_stats("tottime").print_stats(18)
        res["profile"] = buf.getvalue()
    a.out.parent.mkdir(parents=True, exist_ok=True)
    Path(f"{a.out}.json").write_text(json.dumps(res, indent=1) + "\n")
    Path(f"{a.out}.md").write_text(report(res))
    for n, c in res["configs"].items():
        print(f"{n:<18} median {c['median_wall_s']:.3f} s = {c['realtime_factor_median']:.0f}x "
              f"real time (best {c['realtime_factor_best']:.0f}x)")
    print(f"wrote {a.out}.json and .md")
    return 0


def report(res: dict) -> str:
    lines = ["# Rollout speed (generated by benchmarks/rollout_speed/rollout_speed.py)", "",
             f"Command: `OPENBLAS_NUM_THREADS={res['openblas_num_threads']} "
             f".venv/bin/python {res['command']}`", "",
             f"Code: {res['git']}. Python {res['python']}, NumPy {res['numpy']}, {res['date']}, "
             "2 shared cores. "
             f"{res['n_moves']} TestPool moves x {res['n_steps'][0]} steps in one batch "
             f"= {res['robot_time_s']:.2f} s of robot time; factor = robot time / wall. "
             "Warmed up (index built, one untimed rollout), then "
             f"{len(res['load_avg_1min_per_round'])} rounds; 1-min load average before -> "
             "after each round: "
             + ", ".join(f"{b:.2f} -> {e:.2f}" for b, e in res["load_avg_1min_per_round"]) + ".",
             "", "| configuration | median wall [s] | min wall [s] | x real time (median) | "
             "x real time (best) | same predictions every repeat | mean final (x,y) error [m] |",
             "|---|---|---|---|---|---|---|"]
    for n, c in res["configs"].items():
        lines.append(f"| {n} | {c['median_wall_s']:.3f} | {c['min_wall_s']:.3f} | "
                     f"{c['realtime_factor_median']:.0f} | {c['realtime_factor_best']:.0f} | "
                     f"{c['identical_predictions_every_repeat']} | {c['final_xy_error_m']:.4f} |")
    if "profile" in res:
        lines += ["", "cProfile of one LGPR + alpha rollout (own time):", "", "```",
                  res["profile"].strip(), "```"]
    return "\n".join(lines) + "\n"


if __name__ == "__main__":
    raise SystemExit(main())
