"""Build the sealed gap robot of the thirty-second blind zoo (``gap_robot.json``).

The ``measured`` LittleDog with many physical parameters moved, each by its own hand-chosen
factor, as a rebuilt and recalibrated lab robot of this size could differ from its model.
What describes the simulation (physics step, solver iterations, settle time), the encoders'
counts per radian and the servo structure are those of ``measured``.

SEALED: the calibration side must not read this file or ``gap_robot.json`` before the run.

    OPENBLAS_NUM_THREADS=1 .venv/bin/python benchmarks/blind_zoo/zoos/zoo32/make_gap_robot.py
"""
from __future__ import annotations

import dataclasses
from pathlib import Path

from littledog_mlsim.robot.config import robot_config
from littledog_mlsim.robot.twin import Twin, save_twin

HERE = Path(__file__).resolve().parent
OUT = HERE / "gap_robot.json"


def _scaled(base: tuple[float, float, float], factors: tuple[float, float, float],
            digits: int) -> tuple[float, float, float]:
    """Per-joint-kind triple (hip_roll, hip_pitch, knee) times its own factors, rounded."""
    return tuple(round(b * f, digits) for b, f in zip(base, factors))  # type: ignore[return-value]


def build():
    m = robot_config("measured")
    return dataclasses.replace(
        m,
        name="zoo32-gap",
        # servo: a re-tuned / re-wired set of joint controllers, differing per joint kind
        kp=_scaled(m.kp, (0.87, 1.11, 0.94), 3),
        kd=_scaled(m.kd, (1.21, 0.83, 1.09), 4),
        # current limits as set on the rebuilt amplifiers (and motor constants that differ)
        torque_limit=_scaled(m.torque_limit, (0.89, 1.07, 1.16), 3),
        # reflected rotor inertia: the assumed rotor inertia and stage inertias are guesses
        armature=_scaled(m.armature, (1.28, 0.80, 1.17), 8),
        # a different battery pack and cabling on the body; lighter legs after the rebuild
        body_mass=round(m.body_mass * 1.08, 4),
        leg_mass=round(m.leg_mass * 0.91, 4),
        # worn rubber feet on a grippier lab floor
        foot_friction=round(m.foot_friction * 0.84, 4),
        ground_friction=round(m.ground_friction * 1.09, 4),
        # encoder-rate filter corner as set in the firmware
        rate_filter_hz=round(m.rate_filter_hz * 0.78, 3),
        # motion-capture calibration of that day
        mocap_position_std=round(m.mocap_position_std * 1.33, 7),
        mocap_orientation_std=round(m.mocap_orientation_std * 0.76, 7),
    )


def main() -> None:
    config = build()
    provenance = {"created_by": "zoo32/make_gap_robot.py", "base_robot": "measured",
                  "note": "hand-made gap robot of the thirty-second blind zoo (sealed)"}
    save_twin(Twin(config, provenance), OUT)
    print(f"wrote {OUT}")


if __name__ == "__main__":
    main()
