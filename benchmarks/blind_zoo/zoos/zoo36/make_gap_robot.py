"""SEALED. Build zoo36's gap robot from the `measured` robot and write gap_robot.json.

Run from the repository root:

    OPENBLAS_NUM_THREADS=1 .venv/bin/python benchmarks/blind_zoo/zoos/zoo36/make_gap_robot.py

Every moved number has its own factor (a seeded draw, numpy default_rng(36277), then adjusted by
hand); the command delay, zero on `measured`, is set to a small value. The file is written with
the twin module's own writer and read back with both loaders; the script fails unless both give
back the robot built here, and unless every field it leaves alone equals `measured`'s.
"""
from __future__ import annotations

import dataclasses
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[4]
if str(ROOT) not in sys.path:
    sys.path.insert(0, str(ROOT))

from littledog_mlsim.robot.config import robot_config  # noqa: E402
from littledog_mlsim.robot.twin import Twin, load_twin, robot_config_from, save_twin  # noqa: E402

OUT = Path(__file__).resolve().with_name("gap_robot.json")
NAME = "zoo36-gap"

# per joint kind: (hip_roll, hip_pitch, knee)
FACTORS_TRIPLE = {
    "kp": (0.950, 1.284, 1.190),
    "kd": (0.921, 1.062, 1.220),
    "torque_limit": (1.252, 0.760, 0.823),
    "armature": (0.942, 0.730, 1.100),
}
FACTORS_SCALAR = {
    "body_mass": 0.874,
    "leg_mass": 0.960,
    "foot_friction": 0.842,
    "ground_friction": 0.917,
    "rate_filter_hz": 0.889,
    "mocap_position_std": 1.144,
    "mocap_orientation_std": 0.931,
}
SET_VALUES = {
    "command_delay_ms": 3.0,   # measured has none; a rebuilt robot's servo boards add a little
}
# fields that describe the simulation, not the robot: never moved here
SIMULATION_FIELDS = ("servo", "physics_dt", "solver_iterations", "settle_time",
                     "encoder_resolution", "mass_scale", "sensor_noise", "position_gain",
                     "velocity_gain")


def build():
    measured = robot_config("measured")
    changes: dict = {"name": NAME}
    for field, factors in FACTORS_TRIPLE.items():
        base = getattr(measured, field)
        changes[field] = tuple(float(b * f) for b, f in zip(base, factors))
    for field, factor in FACTORS_SCALAR.items():
        changes[field] = float(getattr(measured, field) * factor)
    changes.update(SET_VALUES)
    gap = dataclasses.replace(measured, **changes)
    return measured, gap


def check_factors() -> None:
    """Every factor within a third of 1 and at least a few per cent from it; masses within 15 %."""
    for field, factors in FACTORS_TRIPLE.items():
        for f in factors:
            assert 0.03 <= abs(f - 1.0) <= 1.0 / 3.0, (field, f)
    for field, f in FACTORS_SCALAR.items():
        limit = 0.15 if field.endswith("_mass") else 1.0 / 3.0
        assert 0.03 <= abs(f - 1.0) <= limit, (field, f)
    assert FACTORS_SCALAR["body_mass"] != FACTORS_SCALAR["leg_mass"]
    assert FACTORS_SCALAR["foot_friction"] != FACTORS_SCALAR["ground_friction"]
    moved = set(FACTORS_TRIPLE) | set(FACTORS_SCALAR) | set(SET_VALUES)
    assert not moved & set(SIMULATION_FIELDS), moved & set(SIMULATION_FIELDS)


def main() -> int:
    check_factors()
    measured, gap = build()
    moved = set(FACTORS_TRIPLE) | set(FACTORS_SCALAR) | set(SET_VALUES) | {"name"}
    for f in dataclasses.fields(measured):
        if f.name not in moved:
            assert getattr(gap, f.name) == getattr(measured, f.name), f"{f.name} changed"
        elif f.name != "name":
            assert getattr(gap, f.name) != getattr(measured, f.name), f"{f.name} not moved"
    for field in SIMULATION_FIELDS:
        assert getattr(gap, field) == getattr(measured, field), field

    provenance = {"created_by": "benchmarks/blind_zoo/zoos/zoo36/make_gap_robot.py",
                  "base_robot": "measured",
                  "note": "zoo36's sealed gap robot (blind calibration)"}
    save_twin(Twin(gap, provenance), OUT)

    twin = load_twin(OUT)
    if twin.robot != gap:
        raise SystemExit(f"load_twin({OUT}) does not give back the robot built")
    if dict(twin.provenance) != provenance:
        raise SystemExit(f"load_twin({OUT}) does not give back the provenance written")
    if robot_config_from(str(OUT)) != gap:
        raise SystemExit(f"robot_config_from({OUT}) does not give back the robot built")
    n_numbers = 3 * len(FACTORS_TRIPLE) + len(FACTORS_SCALAR) + len(SET_VALUES)
    n_fields = len(FACTORS_TRIPLE) + len(FACTORS_SCALAR) + len(SET_VALUES)
    print(f"wrote {OUT.relative_to(ROOT)}: robot {gap.name!r}, {n_fields} fields "
          f"({n_numbers} numbers) moved from 'measured'; read back equal with load_twin and "
          f"robot_config_from; unchanged fields equal measured's")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
