"""One recorded move re-simulated whole (the first TrainPool move of DATASET, from its measured
start), with every `stepSimulation` call timed inside it: the share of the move's time that is
pybullet's physics step, and the rest per physics step.

    OPENBLAS_NUM_THREADS=1 .venv/bin/python -P benchmarks/diagnose_speed/step_python/step_split.py ROBOT DATASET
"""
import sys
import time

import pybullet as p

from littledog_mlsim.robot.twin import robot_config_from
from littledog_mlsim.robot.sim import LittleDogSim
from littledog_mlsim.data.dataset import load_moves
robot = robot_config_from(sys.argv[1])
rec = load_moves(sys.argv[2], split="train")[0]
sim = LittleDogSim(robot)
from littledog_mlsim.robot.sim import InitialState
def full():
    sim.reset(initial=InitialState.at(rec, 0))
    for u in rec.cmd: sim.step(u)
calls = []
orig = p.stepSimulation
def timed(**kw):
    t = time.perf_counter(); orig(**kw); calls.append(time.perf_counter() - t)
full()
t = time.perf_counter(); full(); T = time.perf_counter() - t
import littledog_mlsim.robot.sim as sm
sm.p.stepSimulation = timed
full(); sm.p.stepSimulation = orig
n = len(calls); S = sum(calls)
print(f"{rec.cmd.shape[0]} control steps, {n} physics steps: all {T*1e3:.0f} ms, stepSimulation {S*1e3:.0f} ms ({S/T:.0%}), {S/n*1e6:.0f} us each; the rest {(T-S)/n*1e6:.0f} us per physics step")
