"""One recorded move re-simulated whole (the first TrainPool move of DATASET, from its measured
start), with every `stepSimulation` call timed inside it: the share of the move's time that is
pybullet's physics step, and the rest per physics step.

    OPENBLAS_NUM_THREADS=1 .venv/bin/python -P benchmarks/diagnose_speed/step_python/step_split.py ROBOT DATASET
"""
import sys
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[2]))   # benchmarks/, for _common
from _common import StepSimulationTimer  # noqa: E402

from littledog_mlsim.data.dataset import load_moves
from littledog_mlsim.robot.sim import InitialState, LittleDogSim
from littledog_mlsim.robot.twin import robot_config_from


def main() -> None:
    sim = LittleDogSim(robot_config_from(sys.argv[1]))
    rec = load_moves(sys.argv[2], split="train")[0]

    def move() -> None:
        sim.reset(initial=InitialState.at(rec, 0))
        for u in rec.cmd:
            sim.step(u)

    move()                                   # warm: the world built, the code loaded
    t0 = time.perf_counter()
    move()
    total = time.perf_counter() - t0
    with StepSimulationTimer() as timer:
        move()
    n, s = len(timer.calls), sum(timer.calls)
    print(f"{rec.cmd.shape[0]} control steps, {n} physics steps: all {total * 1e3:.0f} ms, "
          f"stepSimulation {s * 1e3:.0f} ms ({s / total:.0%}), {s / n * 1e6:.0f} us each; "
          f"the rest {(total - s) / n * 1e6:.0f} us per physics step")


if __name__ == "__main__":
    main()
