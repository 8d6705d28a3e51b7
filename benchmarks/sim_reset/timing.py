"""CPU time of a re-simulation's pieces with the code on the path: a reset (LittleDogSim.reset
from a measured state), a 1 s segment (reset and 100 control steps, as the physical diagnosis
re-simulates) and a calibration state (reset and 10 steps, as ``calibrate`` samples its
states). One process, the robot given, N repeats; prints the medians in milliseconds.

    OPENBLAS_NUM_THREADS=1 PYTHONPATH=CHECKOUT .venv/bin/python -P \\
        benchmarks/sim_reset/timing.py --robot measured
"""
from __future__ import annotations

import argparse
import statistics
import time

import numpy as np


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--robot", default="measured", help="robot name or twin file")
    ap.add_argument("-n", type=int, default=40, help="repeats of each piece")
    a = ap.parse_args()
    import littledog_mlsim
    from littledog_mlsim.robot.sim import LittleDogSim
    from littledog_mlsim.robot.twin import robot_config_from
    sim = LittleDogSim(robot_config_from(a.robot))
    q0 = sim.reset(seed=0)["q"]
    rng = np.random.default_rng(0)
    cmd = q0[None] + 0.25 * np.sin(np.arange(100) * 0.09)[:, None] * rng.normal(size=12)
    for u in cmd[:50]:
        sim.step(u)
    start = sim.true_state()
    out = {}
    for label, steps in (("reset", 0), ("calibration state (reset + 10 steps)", 10),
                         ("segment (reset + 100 steps)", 100)):
        times = []
        for _ in range(a.n):
            t = time.process_time()
            sim.reset(seed=0, initial=start)
            for u in cmd[:steps]:
                sim.step(u)
            times.append(time.process_time() - t)
        out[label] = 1e3 * statistics.median(times)
    print(f"# {littledog_mlsim.__file__}, robot {a.robot}, n={a.n}")
    for label, ms in out.items():
        print(f"{ms:8.2f} ms  {label}")


if __name__ == "__main__":
    main()
