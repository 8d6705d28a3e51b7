"""Wall time to start a local pool of two workers and run one small task in each, by start
method: "spawn" (what the package's pools used) against the fork server with
``workers.PRELOAD`` (what they use). The first fork-server pool of a process also starts the
server; later pools fork from it. Prints each repeat and the medians.

    OPENBLAS_NUM_THREADS=1 .venv/bin/python -P benchmarks/ci_time/workers/pool_start.py
"""
from __future__ import annotations

import multiprocessing as mp
import statistics
import time
from concurrent.futures import ProcessPoolExecutor


def task(i: int) -> int:
    from littledog_mlsim.robot import baseline   # what a calibration worker imports
    return i + len(baseline.__name__)


def start_and_run(ctx) -> float:
    t = time.perf_counter()
    with ProcessPoolExecutor(2, mp_context=ctx) as pool:
        list(pool.map(task, range(2)))
    return time.perf_counter() - t


def main() -> None:
    from littledog_mlsim.workers import worker_context
    rows = {"spawn": [], "forkserver (first pool starts the server)": [], "forkserver": []}
    rows["forkserver (first pool starts the server)"].append(start_and_run(worker_context()))
    for _ in range(5):
        rows["spawn"].append(start_and_run(mp.get_context("spawn")))
        rows["forkserver"].append(start_and_run(worker_context()))
    for k, v in rows.items():
        print(f"{k}: " + ", ".join(f"{x:.2f}" for x in v) + f"  median {statistics.median(v):.2f} s")


if __name__ == "__main__":
    main()
