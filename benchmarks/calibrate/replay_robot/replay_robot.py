"""What a calibration worker spends per robot, with a new replay robot per config or one built
again in its client without standing up (``baseline._sim_for``, ``LittleDogSim.reconfigure``).

A worker of ``calibrate``'s pool re-simulates its chunk of the fitted moves (11 of 22 on two
processes) for each robot of a Jacobian's batch. This times that chunk for the 30 robots of a
central-difference Jacobian of a twin's 15 parameters, in one process, two ways, alternating:

- ``new_robot``: ``LittleDogSim(config)`` for each robot (as ``_sim_for`` did before
  4453fda5: a new pybullet client, the world built and the robot stood up);
- ``rebuilt``: ``_sim_for`` as it is (the world built again in the same client, no stand-up).

It checks that both give the same residuals, bit for bit, and prints the medians. With
``--pool`` it times the same batch as ``calibrate``'s pool runs it (all 22 moves, two
processes, each robot's moves in two chunks: ``baseline._MovePool.map_many``), the workers'
``_sim_for`` the old one or the new.

    OPENBLAS_NUM_THREADS=1 .venv/bin/python benchmarks/calibrate/replay_robot/replay_robot.py \
      --data REFERENCE --twin TWIN.json [--repeats 3]
"""
from __future__ import annotations

import argparse
import os
import statistics
import sys
import time

import numpy as np

from littledog_mlsim.data.dataset import load_moves
from littledog_mlsim.robot import baseline as bl
from littledog_mlsim.robot.parameters import TWIN_PARAMETERS
from littledog_mlsim.robot.sim import LittleDogSim
from littledog_mlsim.robot.twin import load_twin

STRIDE, HORIZON, INITIAL = 40, 10, "smoothed"


def chunk_new_robot(recs, config) -> list[np.ndarray]:
    """The chunk as a worker ran it before: a new robot for the config."""
    sim = LittleDogSim(bl._replay_config(config))
    try:
        out = []
        for rec in recs:
            ts = np.arange(1, rec.n_steps - HORIZON + 1, STRIDE)
            starts = bl._starts(rec, ts, INITIAL)
            drec = bl.delayed_recording(rec, config.command_delay_ms)
            out.append(np.stack([bl._replay(sim, drec, int(t), HORIZON, (), INITIAL,
                                            starts[int(t)]) for t in ts]))
        return out
    finally:
        sim.close()


def chunk_rebuilt(recs, config) -> list[np.ndarray]:
    """The chunk as a worker runs it now (``k_step_predictions`` through ``_sim_for``)."""
    return [bl.k_step_predictions(rec, config, HORIZON, STRIDE, initial=INITIAL)[2]
            for rec in recs]


_OLD_SIM = None


def _old_sim_for(config):
    """``baseline._sim_for`` before 4453fda5: a new robot (client, world, stand-up) per config."""
    global _OLD_SIM
    if _OLD_SIM is None or _OLD_SIM.config != config or _OLD_SIM.client < 0:
        if _OLD_SIM is not None:
            _OLD_SIM.close()
        _OLD_SIM = LittleDogSim(config)
    return _OLD_SIM


def _init(recs, old: bool) -> None:
    bl._init_worker(recs)
    if old:
        bl._sim_for = _old_sim_for


def pool_batch(recs, robots, old: bool, repeats: int) -> tuple[list[float], list]:
    """Per-robot wall time of the batch through a two-process pool, per repeat, and the
    last repeat's residuals."""
    from concurrent.futures import ProcessPoolExecutor

    from littledog_mlsim.robot.twin_fit import _residual_task
    from littledog_mlsim.workers import worker_context

    chunks = bl.move_chunks(len(recs), 2)
    head = (STRIDE, (1, HORIZON), INITIAL)
    times, out = [], None
    with ProcessPoolExecutor(2, mp_context=worker_context(), initializer=_init,
                             initargs=(recs, old)) as pool:
        for k in range(repeats + 1):                 # the first: the workers' start
            t0 = time.perf_counter()
            futures = [[pool.submit(bl._chunk_task, _residual_task, (c, *head), idx)
                        for idx in chunks] for c in robots]
            out = [[r for f in fs for r in f.result()] for fs in futures]
            if k:
                times.append((time.perf_counter() - t0) / len(robots))
    return times, out


def jacobian_robots(config, names) -> list:
    """The 30 robots of a central-difference Jacobian (5 % of each coordinate) at ``config``."""
    out = []
    for name in names:
        par = TWIN_PARAMETERS[name]
        x = par.to_x(par.get(config))
        for sign in (1, -1):
            v = par.from_x(x + sign * 0.05 * par.x_scale)
            out.append(par.set(config, min(max(v, par.bounds[0]), par.bounds[1])))
    return out


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--data", required=True)
    ap.add_argument("--twin", required=True)
    ap.add_argument("--repeats", type=int, default=3)
    ap.add_argument("--pool", action="store_true", help="time the batch through a two-process "
                    "pool over all 22 moves instead of one worker's chunk in this process")
    args = ap.parse_args(argv)
    twin = load_twin(args.twin)
    names = list(twin.provenance["parameters"])
    recs = bl.first_per_type(load_moves(args.data, "train"), 2)
    robots = jacobian_robots(twin.robot, names)
    if args.pool:
        times = {"new_robot": [], "rebuilt": []}
        res = {}
        for _ in range(args.repeats):
            for label in times:
                t, res[label] = pool_batch(recs, robots, label == "new_robot", 1)
                times[label] += t
        same = all(np.array_equal(a, b, equal_nan=True)
                   for ra, rb in zip(res["new_robot"], res["rebuilt"]) for a, b in zip(ra, rb))
        report(times, f"{len(recs)} moves through a pool of 2 processes", robots, names, same)
        return 0 if same else 1
    recs = recs[:11]                     # one worker's chunk
    for c in robots[:2]:                 # the starting states built, both paths warm
        chunk_new_robot(recs, c)
        chunk_rebuilt(recs, c)
    times = {"new_robot": [], "rebuilt": []}
    same = True
    for _ in range(args.repeats):
        for label, fn in (("new_robot", chunk_new_robot), ("rebuilt", chunk_rebuilt)):
            t0 = time.perf_counter()
            results = [fn(recs, c) for c in robots]
            times[label].append((time.perf_counter() - t0) / len(robots))
            if label == "new_robot":
                want = results
            else:
                same &= all(np.array_equal(a, b, equal_nan=True)
                            for ra, rb in zip(want, results) for a, b in zip(ra, rb))
    report(times, f"{len(recs)} moves (one worker's chunk) in this process", robots, names,
           same)
    return 0 if same else 1


def report(times: dict[str, list[float]], how: str, robots, names, same: bool) -> None:
    med = {k: statistics.median(v) for k, v in times.items()}
    print(f"{how}, {len(robots)} robots (a Jacobian of {len(names)} parameters), stride "
          f"{STRIDE}, horizon {HORIZON}, {INITIAL} starts; load average at the end: "
          f"{os.getloadavg()[0]:.2f}")
    for k, v in times.items():
        print(f"{k}: per robot " + ", ".join(f"{t:.3f}" for t in v) + f" s; median {med[k]:.3f} s")
    print(f"rebuilt / new_robot: {med['rebuilt'] / med['new_robot']:.3f}")
    print(f"residuals the same, bit for bit: {same}")


if __name__ == "__main__":
    sys.exit(main())
