"""Write zoo34's sealed gap robot: the ``measured`` robot with many physical parameters moved.

SEALED: nobody on the calibration side reads this file (or gap_robot.json) before the first
run's result is committed (runs/run1/RULE.md).

Each parameter has its own hand-chosen factor, as a rebuilt lab robot would differ from its
model: larger where the model's value is an assumption (reflected rotor inertia, motion-capture
noise), moderate for tunings and settings (servo gains, current limits, rate-filter corner,
friction), smaller for weighed quantities (masses). Unchanged: the physics step, solver
iterations, settle time, encoder resolution, servo kind, command delay, mass scale and the
sensor-noise switch.

Run from anywhere: ``.venv/bin/python benchmarks/blind_zoo/zoos/zoo34/make_gap_robot.py``
writes ``gap_robot.json`` beside this file.
"""
from __future__ import annotations

import dataclasses
import sys
from pathlib import Path

HERE = Path(__file__).resolve().parent
REPO = HERE.parents[3]
if str(REPO) not in sys.path:
    sys.path.insert(0, str(REPO))

from littledog_mlsim.robot.config import robot_config  # noqa: E402
from littledog_mlsim.robot.twin import Twin, load_twin, save_twin  # noqa: E402

NAME = "zoo34-gap"

# Per joint kind (hip_roll, hip_pitch, knee): factor on the measured robot's value.
KP_FACTOR = (1.11, 0.93, 1.17)             # servo stiffness (a tuning)
KD_FACTOR = (0.88, 0.83, 1.09)             # servo damping (a tuning)
TORQUE_LIMIT_FACTOR = (1.05, 0.91, 1.14)   # current limits (a setting)
ARMATURE_FACTOR = (0.79, 1.24, 1.33)       # reflected rotor inertia (an assumption)
BODY_MASS_FACTOR = 1.035                   # weighed
LEG_MASS_FACTOR = 0.955                    # weighed
FOOT_FRICTION_FACTOR = 0.86
GROUND_FRICTION_FACTOR = 1.09
RATE_FILTER_FACTOR = 1.18                  # encoder rate-filter corner (a setting)
MOCAP_POSITION_STD_FACTOR = 1.31           # motion-capture noise (an assumption)
MOCAP_ORIENTATION_STD_FACTOR = 0.74


def _scaled(triple, factors):
    return tuple(round(float(v) * f, 12) for v, f in zip(triple, factors))


def gap_robot():
    base = robot_config("measured")
    return dataclasses.replace(
        base,
        name=NAME,
        kp=_scaled(base.kp, KP_FACTOR),
        kd=_scaled(base.kd, KD_FACTOR),
        torque_limit=_scaled(base.torque_limit, TORQUE_LIMIT_FACTOR),
        armature=_scaled(base.armature, ARMATURE_FACTOR),
        body_mass=round(base.body_mass * BODY_MASS_FACTOR, 12),
        leg_mass=round(base.leg_mass * LEG_MASS_FACTOR, 12),
        foot_friction=round(base.foot_friction * FOOT_FRICTION_FACTOR, 12),
        ground_friction=round(base.ground_friction * GROUND_FRICTION_FACTOR, 12),
        rate_filter_hz=round(base.rate_filter_hz * RATE_FILTER_FACTOR, 12),
        mocap_position_std=round(base.mocap_position_std * MOCAP_POSITION_STD_FACTOR, 12),
        mocap_orientation_std=round(base.mocap_orientation_std * MOCAP_ORIENTATION_STD_FACTOR,
                                    12),
    )


def main() -> None:
    robot = gap_robot()
    base = robot_config("measured")
    moved = sorted(f.name for f in dataclasses.fields(robot)
                   if f.name != "name" and getattr(robot, f.name) != getattr(base, f.name))
    provenance = {
        "created_by": "benchmarks/blind_zoo/zoos/zoo34/make_gap_robot.py",
        "base_robot": "measured",
        "note": "zoo34 sealed gap robot: the measured robot with hand-chosen per-parameter factors",
        "moved_fields": moved,
    }
    out = save_twin(Twin(robot, provenance), HERE / "gap_robot.json")
    assert load_twin(out).robot == robot, "the written twin does not read back as written"
    print(f"wrote {out} ({len(moved)} fields moved: {', '.join(moved)})")


if __name__ == "__main__":
    main()
