"""zoo56's gap robot with its hip roll and hip pitch torque limits set to the nominal 1.7 N m
(the value the twin assumes and does not fit unless a round adds it); everything else as the
gap robot.

    .venv/bin/python benchmarks/calibrate/interval_honesty/hip_limits_probe/make_robot.py OUT.json
"""
from __future__ import annotations

import sys
from dataclasses import replace
from pathlib import Path

ROOT = Path(__file__).resolve().parents[4]
sys.path.insert(0, str(ROOT))

from littledog_mlsim.robot.twin import Twin, load_twin, save_twin  # noqa: E402

GAP = "benchmarks/blind_zoo/zoos/zoo56/gap_robot.json"


def main(out: str) -> int:
    robot = load_twin(ROOT / GAP).robot
    changed = replace(robot, torque_limit=(1.7, 1.7, robot.torque_limit[2]),
                      name="zoo56-gap-hip-limits-nominal")
    save_twin(Twin(changed, {"derived_from": GAP, "change": "hip roll and hip pitch torque "
                                                              "limits set to the nominal 1.7 N m"}),
              out)
    print(f"{GAP}: torque limits {robot.torque_limit} -> {changed.torque_limit}; wrote {out}")
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1]))
