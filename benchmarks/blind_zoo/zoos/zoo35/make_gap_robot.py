"""Build zoo35's sealed gap robot (SEALED: not to be read on the calibration side).

The ``measured`` robot with many physical parameters moved, each by its own hand-chosen factor,
written with the twin module's writer to ``gap_robot.json`` beside this script, read back through
the twin loader and checked equal to the robot built here.

Run from the repository root::

    .venv/bin/python benchmarks/blind_zoo/zoos/zoo35/make_gap_robot.py
"""
from __future__ import annotations

import dataclasses
import sys
from pathlib import Path

HERE = Path(__file__).resolve().parent
ROOT = HERE.parents[3]
if str(ROOT) not in sys.path:
    sys.path.insert(0, str(ROOT))

from littledog_mlsim.robot.config import robot_config  # noqa: E402
from littledog_mlsim.robot.twin import Twin, load_twin, robot_config_from, save_twin  # noqa: E402

OUT = HERE / "gap_robot.json"
NAME = "zoo35-gap"

# Hand-chosen factors, one per parameter; per joint kind as (hip_roll, hip_pitch, knee).
KP = (0.87, 1.16, 0.93)
KD = (1.19, 0.83, 1.08)
TORQUE_LIMIT = (1.21, 0.93, 1.11)
ARMATURE = (0.79, 1.24, 0.91)
BODY_MASS = 1.064
LEG_MASS = 0.917
FOOT_FRICTION = 0.81
GROUND_FRICTION = 1.12
RATE_FILTER_HZ = 0.74
MOCAP_POSITION_STD = 1.29
MOCAP_ORIENTATION_STD = 0.77


def _times(values: tuple[float, float, float], factors: tuple[float, float, float]):
    return tuple(float(v * f) for v, f in zip(values, factors))


def build():
    base = robot_config("measured")
    return dataclasses.replace(
        base,
        name=NAME,
        kp=_times(base.kp, KP),
        kd=_times(base.kd, KD),
        torque_limit=_times(base.torque_limit, TORQUE_LIMIT),
        armature=_times(base.armature, ARMATURE),
        body_mass=base.body_mass * BODY_MASS,
        leg_mass=base.leg_mass * LEG_MASS,
        foot_friction=base.foot_friction * FOOT_FRICTION,
        ground_friction=base.ground_friction * GROUND_FRICTION,
        rate_filter_hz=base.rate_filter_hz * RATE_FILTER_HZ,
        mocap_position_std=base.mocap_position_std * MOCAP_POSITION_STD,
        mocap_orientation_std=base.mocap_orientation_std * MOCAP_ORIENTATION_STD,
    )


def main() -> int:
    gap = build()
    base = robot_config("measured")
    # what describes the simulation rather than the robot is left as it is
    for field in ("servo", "physics_dt", "solver_iterations", "settle_time", "encoder_resolution",
                  "command_delay_ms", "mass_scale", "sensor_noise", "position_gain",
                  "velocity_gain"):
        assert getattr(gap, field) == getattr(base, field), field
    provenance = {"created_by": "benchmarks/blind_zoo/zoos/zoo35/make_gap_robot.py",
                  "base_robot": "measured",
                  "note": "zoo35 gap robot (sealed): measured robot with physical parameters moved"}
    save_twin(Twin(gap, provenance), OUT)
    back = load_twin(OUT)
    if back.robot != gap:
        raise SystemExit(f"{OUT}: read back differs from the robot built")
    if robot_config_from(str(OUT)) != gap:
        raise SystemExit(f"{OUT}: robot_config_from differs from the robot built")
    moved = [f.name for f in dataclasses.fields(gap)
             if f.name != "name" and getattr(gap, f.name) != getattr(base, f.name)]
    print(f"wrote {OUT} (robot {gap.name!r}); read back equal; {len(moved)} fields moved: "
          f"{', '.join(moved)}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
