"""One recorded move re-simulated with ``simulate_move`` five times plain, then five times with
timers around the simulator's methods (``step``, ``_physics_step``, ``_measure``, ``reset``,
``observe``) and ``stepSimulation``: the time per move and per control step in each.

    OPENBLAS_NUM_THREADS=1 .venv/bin/python -P benchmarks/diagnose_speed/pool_use/step_methods.py ROBOT DATASET
"""
import sys, time, collections
import numpy as np
import pybullet as p
from littledog_mlsim.data.dataset import load_moves
from littledog_mlsim.robot import sim as S
from littledog_mlsim.robot.sim import InitialState, LittleDogSim, simulate_move
from littledog_mlsim.robot.twin import robot_config_from

def main():
    cfg = robot_config_from(sys.argv[1])
    rec = load_moves(sys.argv[2], split="train")[0]
    sim = S.get_sim(cfg)
    def move():
        return simulate_move(rec.cmd, robot=cfg, initial=InitialState.at(rec, 0))
    move()
    T = collections.Counter()
    orig = {n: getattr(LittleDogSim, n) for n in ("step", "_physics_step", "_measure", "reset", "observe")}
    def wrap(n):
        f = orig[n]
        def g(self, *a, **k):
            t = time.perf_counter(); r = f(self, *a, **k); T[n] += time.perf_counter() - t; return r
        return g
    step = p.stepSimulation
    def ts(**kw):
        t = time.perf_counter(); step(**kw); T["stepSimulation"] += time.perf_counter() - t
    N = 5
    t0 = time.perf_counter()
    for _ in range(N): move()
    plain = (time.perf_counter() - t0) / N
    for n in orig: setattr(LittleDogSim, n, wrap(n))
    p.stepSimulation = ts
    t0 = time.perf_counter()
    for _ in range(N): move()
    inst = (time.perf_counter() - t0) / N
    ncs = rec.cmd.shape[0]
    print(f"plain {plain*1e3:.1f} ms per move ({ncs} control steps), instrumented {inst*1e3:.1f} ms")
    for n, v in T.most_common():
        print(f"  {n:15s} {v/N*1e3:7.1f} ms  {v/N/ncs*1e6:6.1f} us per control step")
main()
