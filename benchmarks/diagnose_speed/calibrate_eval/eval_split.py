"""One evaluation of calibrate's residuals (every fitted TrainPool move re-simulated by one robot,
the k-step replays of ``twin_fit.twin_residuals``), timed three ways: in calibrate's pool of
``--jobs`` worker processes (the wall an evaluation costs), in this process move by move (its
CPU), and with every ``stepSimulation`` call timed inside that (pybullet's share).

    OPENBLAS_NUM_THREADS=1 .venv/bin/python -P benchmarks/diagnose_speed/calibrate_eval/eval_split.py \
        ROBOT DATASET [--jobs 2] [--repeats 5]

ROBOT: a robot name or twin file; DATASET: a dataset whose TrainPool calibrate fits (its first
two moves of each type, calibrate's default), from smoothed starting states, stride 20,
horizons 1 and 10 (calibrate's defaults). Each evaluation uses a robot with another body mass,
so that every one builds its world afresh as calibrate's do.
"""
from __future__ import annotations

import argparse
import dataclasses
import statistics
import sys
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[2]))   # benchmarks/, for _common
from _common import StepSimulationTimer  # noqa: E402

from littledog_mlsim.data.dataset import load_moves
from littledog_mlsim.robot import baseline as bl
from littledog_mlsim.robot.twin import robot_config_from
from littledog_mlsim.robot.twin_fit import _residual_task, twin_residuals


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("robot")
    ap.add_argument("data")
    ap.add_argument("--jobs", type=int, default=2)
    ap.add_argument("--repeats", type=int, default=5)
    a = ap.parse_args()
    recs = bl.first_per_type(load_moves(a.data, "train"), 2)
    cfg = robot_config_from(a.robot)
    mass = cfg.body_mass if cfg.body_mass is not None else 2.5
    robots = [dataclasses.replace(cfg, body_mass=mass * (1 + 0.001 * k))
              for k in range(2 * a.repeats + 2)]
    pool_s = []
    with bl.move_pool(recs, a.jobs) as pool:
        twin_residuals(pool, robots[0], 20, (1, 10), "smoothed")     # warm: workers started
        for r in robots[1:a.repeats + 1]:
            t0 = time.perf_counter()
            twin_residuals(pool, r, 20, (1, 10), "smoothed")
            pool_s.append(time.perf_counter() - t0)
    bl._init_worker(recs)
    serial_s, build_s, step_s = [], [], []
    for r in robots[a.repeats + 1:]:
        with StepSimulationTimer() as timer:
            t0 = time.perf_counter()
            bl._sim_for(bl._replay_config(r))
            t1 = time.perf_counter()
            for i in range(len(recs)):
                _residual_task(r, 20, (1, 10), "smoothed", i)
            t2 = time.perf_counter()
        build_s.append(t1 - t0)
        serial_s.append(t2 - t0)
        step_s.append(sum(timer.calls))
        calls = timer.calls
    med = statistics.median
    print(f"{len(recs)} moves, robot {cfg.name}, {a.repeats} evaluations each way (medians):")
    print(f"  in a pool of {a.jobs} processes: {med(pool_s):.3f} s wall per evaluation "
          f"(min {min(pool_s):.3f}, max {max(pool_s):.3f})")
    print(f"  in one process: {med(serial_s):.3f} s per evaluation, of it the world built for the "
          f"robot {med(build_s):.3f} s and stepSimulation {med(step_s):.3f} s "
          f"({med(step_s) / med(serial_s):.0%}; {len(calls)} calls, "
          f"{med(step_s) / len(calls) * 1e6:.0f} us each)")
    print(f"  the pool's parallel efficiency: one process's time / ({a.jobs} x the pool's wall) = "
          f"{med(serial_s) / (a.jobs * med(pool_s)):.2f}")


if __name__ == "__main__":
    main()
