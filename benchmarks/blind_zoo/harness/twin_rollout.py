"""TestPool rollout error of pybullet robots (names or twin files) on a dataset: the final
(x, y) error of a 4 s open-loop re-simulation of every TestPool move, mean and median, as
``calibrate`` reports before and after. For a gap zoo, the gap robot itself gives the floor a
calibrated twin can reach: the re-simulation is noise-free, but the recordings it starts from
and is scored against carry the gap robot's sensor noise.

    OPENBLAS_NUM_THREADS=1 .venv/bin/python benchmarks/blind_zoo/harness/twin_rollout.py \\
        --data /tmp/zoo8work/reference --robot nominal \\
        --robot benchmarks/blind_zoo/zoos/zoo8/gap_robot.json --robot /tmp/zoo8work/TWIN.json
"""
from __future__ import annotations

import argparse
import dataclasses
import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[3]))


def main() -> int:
    from littledog_mlsim.data.dataset import load_moves
    from littledog_mlsim.robot import baseline as bl
    from littledog_mlsim.robot.twin import robot_config_from

    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--data", required=True)
    p.add_argument("--robot", action="append", required=True, help="name or twin file")
    p.add_argument("--jobs", type=int, default=2)
    a = p.parse_args()
    test = bl.first_per_type(load_moves(a.data, "test"), None)
    for robot in a.robot:
        config = dataclasses.replace(robot_config_from(robot), sensor_noise=False)
        ev = bl.evaluate_baseline(test, config, one_step=False, jobs=a.jobs)
        print(f"{robot}: {len(test)} TestPool moves, final (x, y) error mean "
              f"{ev['final_xy_error_m']:.4f} m, median {ev['final_xy_error_m_median']:.4f} m",
              flush=True)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
