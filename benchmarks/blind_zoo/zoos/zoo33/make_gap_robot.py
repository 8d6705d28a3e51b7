"""Write zoo33's sealed gap robot, ``gap_robot.json`` (a twin file named ``zoo33-gap``).

SEALED: nobody on the calibration side reads this file (or gap_robot.json) before the first
run's result is committed (runs/run1/RULE.md).

The gap robot is the ``measured`` robot with many physical parameters moved, each by its own
hand-chosen factor, of the size by which a calibrated model misses a real rebuilt lab robot:
larger where the model's value is an assumption (reflected rotor inertia, motion-capture noise),
moderate for tunings and settings (servo gains, current limits, the rate filter's corner,
friction), smaller for weighed quantities (masses). Both directions, no common scale.

Unchanged: physics step, solver iterations, settle time, encoder resolution, servo kind,
command delay, the position servo's gains (unused by the torque-mode PD), mass_scale,
sensor_noise on.

Run from anywhere:  .venv/bin/python benchmarks/blind_zoo/zoos/zoo33/make_gap_robot.py
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

NAME = "zoo33-gap"
OUT = HERE / "gap_robot.json"

# Hand-chosen factors on the measured robot's values; triples are (hip_roll, hip_pitch, knee).
KP_FACTOR = (0.88, 1.12, 0.93)             # servo stiffness: a tuning
KD_FACTOR = (1.16, 0.87, 1.08)             # servo damping: a tuning
TORQUE_LIMIT_FACTOR = (0.92, 1.06, 1.13)   # current limits: a setting
ARMATURE_FACTOR = (1.29, 0.78, 1.22)       # reflected rotor inertia: an assumption
BODY_MASS_FACTOR = 1.035                   # weighed
LEG_MASS_FACTOR = 0.955                    # weighed
FOOT_FRICTION_FACTOR = 0.84                # rubber feet wear
GROUND_FRICTION_FACTOR = 1.12              # the lab's floor
RATE_FILTER_FACTOR = 0.86                  # encoder rate filter's corner: a setting
MOCAP_POSITION_STD_FACTOR = 1.32           # motion-capture noise: an assumption
MOCAP_ORIENTATION_STD_FACTOR = 0.74        # motion-capture noise: an assumption


def _scaled(triple: tuple[float, float, float],
            factor: tuple[float, float, float]) -> tuple[float, float, float]:
    return tuple(round(v * f, 9) for v, f in zip(triple, factor))  # type: ignore[return-value]


def gap_robot():
    """The gap robot's RobotConfig."""
    m = robot_config("measured")
    return dataclasses.replace(
        m,
        name=NAME,
        kp=_scaled(m.kp, KP_FACTOR),
        kd=_scaled(m.kd, KD_FACTOR),
        torque_limit=_scaled(m.torque_limit, TORQUE_LIMIT_FACTOR),
        armature=_scaled(m.armature, ARMATURE_FACTOR),
        body_mass=round(m.body_mass * BODY_MASS_FACTOR, 9),
        leg_mass=round(m.leg_mass * LEG_MASS_FACTOR, 9),
        foot_friction=round(m.foot_friction * FOOT_FRICTION_FACTOR, 9),
        ground_friction=round(m.ground_friction * GROUND_FRICTION_FACTOR, 9),
        rate_filter_hz=round(m.rate_filter_hz * RATE_FILTER_FACTOR, 9),
        mocap_position_std=round(m.mocap_position_std * MOCAP_POSITION_STD_FACTOR, 12),
        mocap_orientation_std=round(m.mocap_orientation_std * MOCAP_ORIENTATION_STD_FACTOR, 12),
    )


def main() -> None:
    robot = gap_robot()
    provenance = {
        "created_by": "benchmarks/blind_zoo/zoos/zoo33/make_gap_robot.py",
        "base_robot": "measured",
        "note": "zoo33's sealed gap robot: the measured robot with hand-chosen per-parameter "
                "factors (servo gains, torque limits and armature per joint kind, body and leg "
                "mass, foot and ground friction, encoder rate filter, motion-capture noise)",
    }
    save_twin(Twin(robot, provenance), OUT)
    assert load_twin(OUT).robot == robot, "the twin file does not read back as written"
    print(f"wrote {OUT} (robot {robot.name!r})")


if __name__ == "__main__":
    main()
