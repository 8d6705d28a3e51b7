"""The effects of zoo45 (SEALED): writes effects/<id>.yaml, control.yaml and truth.yaml.

Each effect is one plug-in of plugins.py switched on alone on top of the gap robot; the ids
z01..z12 are given in a random order. The truth names each in the vocabulary
(benchmarks/blind_zoo/vocabulary.md).

    PYTHONPATH=. .venv/bin/python benchmarks/blind_zoo/zoos/zoo45/effect_specs.py
"""
from __future__ import annotations

import sys
from pathlib import Path

import numpy as np
import yaml

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE.parents[3]))

from littledog_mlsim.robot.twin import load_twin  # noqa: E402

ID_SEED = 4084376926660011146                   # drawn fresh for this zoo: the order of the ids
EXCITED = 0.05


def specs() -> list[dict]:
    gap = load_twin(HERE / "gap_robot.json").robot
    shin_kg = 0.09
    out = [
        dict(cls="GearboxStribeck",
             params=dict(coulomb_Nm=0.05, static_Nm=0.08, stribeck_rad_s=0.3, joints="all"),
             family="joint_friction", scope="all",
             truth=dict(coulomb_Nm=0.05, static_Nm=0.08, stribeck_rad_s=0.3),
             description="gritty gearboxes on every joint: Coulomb friction with a higher "
                         "breakaway level that falls to it over a few tenths of a rad/s",
             learned_inputs=True, excitation=0.0),
        dict(cls="MotorSidePlay", params=dict(width_rad=0.04, joints="front_right"),
             family="backlash", scope="leg:front_right", truth=dict(width_rad=0.04),
             description="worn gear trains in one leg: play between the motor (where the "
                         "encoder is) and the link; no stiffness within it, and the encoder "
                         "reads the motor's side of it",
             learned_inputs=False, excitation=EXCITED),
        dict(cls="LateBusSegment", params=dict(delay_ms=16.0, joints="left"),
             family="command_delay", scope="side:left", truth=dict(delay_ms=16.0),
             description="the servo bus segment of one side delivers set-points late, "
                         "held as they arrive on the servo clock",
             learned_inputs=False, excitation=0.0),
        dict(cls="MisZeroedJoint",
             params=dict(offset_rad=-0.06, joints="front_left_hip_roll"),
             family="encoder_offset", scope="joint:front_left_hip_roll",
             truth=dict(offset_rad=-0.06, servo_loop=True),
             description="one joint re-zeroed wrongly; the servo closes its loop on the "
                         "offset encoder",
             learned_inputs=True, excitation=0.0),
        dict(cls="InclinedBoard", params=dict(slope_deg=2.5, uphill_direction_deg=305.0),
             family="ground_slope", scope="body",
             truth=dict(slope_deg=2.5, uphill_direction_deg=305.0),
             description="the robot walks on an inclined board in the level world",
             learned_inputs=False, excitation=0.0,
             floor=dict(slope_deg=2.5, uphill_direction_deg=305.0)),
        dict(cls="ElasticPayload",
             params=dict(mass_kg=0.28, offset_m=[-0.035, 0.02, 0.035], stiffness_N_m=4000.0,
                         damping_N_s_m=20.0),
             family="mass_com", scope="body",
             truth=dict(added_mass_kg=0.28, com_offset_m=[-0.035, 0.02, 0.035]),
             description="a payload on rubber isolators, off centre, carried on the body",
             learned_inputs=True, excitation=0.0),
        dict(cls="ShinGuard", params=dict(added_kg=shin_kg, leg="back_left"),
             family="leg_difference", scope="leg:back_left",
             truth=dict(scale=round((gap.leg_mass + shin_kg) / gap.leg_mass, 4),
                        quantity="mass of the leg's links (a guard on the lower leg)"),
             description="a guard clamped on one lower leg: that leg is heavier",
             learned_inputs=True, excitation=0.0),
        dict(cls="TapedFoot", params=dict(force_N=6.0, leg="front_left", release_m=0.015),
             family="contact_phase", scope="leg:front_left",
             truth=dict(magnitude=6.0, phase="lift-off"),
             description="tape under one foot: slack in stance, a downward pull at lift-off "
                         "that fades as the foot rises and peels free",
             learned_inputs=True, excitation=0.0),
        dict(cls="WarmingMotors", params=dict(rate_per_s=-0.07, joints="knees"),
             family="time_drift", scope="type:knees", truth=dict(rate_per_s=-0.07),
             description="knee motors warming during each move: their whole servo output "
                         "falls with time",
             learned_inputs=False, excitation=EXCITED),
        dict(cls="BenchTether", params=dict(stiffness_N_m=25.0, distance_m=1.2,
                                            direction_deg=200.0, anchor_height_m=0.2),
             family="other", scope="body",
             truth=dict(stiffness_N_m=25.0, anchor_distance_m=1.2, anchor_direction_deg=200.0),
             description="a coiled power tether to a bench beside the start: it pulls the "
                         "body back towards the bench as the robot walks away from it, and "
                         "hangs slack as it walks towards it",
             learned_inputs=False, excitation=0.0),
        dict(cls="FlakyMotorLead",
             params=dict(rate_hz=2.0, joints="back_left_hip_pitch", min_ms=10.0, max_ms=40.0),
             family="other", scope="joint:back_left_hip_pitch",
             truth=dict(rate_hz=2.0, dropout_ms=[10.0, 40.0]),
             description="a cracked motor lead: the joint's servo drops out for tens of ms "
                         "at random moments",
             learned_inputs=False, excitation=0.0),
        dict(cls="WrongGearRatio", params=dict(scale=round(135.0 / 126.0, 4),
                                                 joints="front_right_knee"),
             family="other", scope="joint:front_right_knee",
             truth=dict(encoder_scale=round(135.0 / 126.0, 4)),
             description="a knee rebuilt with a gearbox of another ratio than the firmware "
                         "assumes: angles and rates read scaled, the servo holds the wrong angle",
             learned_inputs=True, excitation=0.0),
    ]
    order = np.random.default_rng(ID_SEED).permutation(len(out))
    for k, i in enumerate(order):
        out[i]["id"] = f"z{k + 1:02d}"
    return sorted(out, key=lambda s: s["id"])


def main() -> int:
    (HERE / "effects").mkdir(exist_ok=True)
    truth = []
    for s in specs():
        entry = [{"class": f"../plugins.py:{s['cls']}", "params": s["params"]}]
        (HERE / "effects" / f"{s['id']}.yaml").write_text(
            yaml.safe_dump(entry, sort_keys=False, default_flow_style=None))
        truth.append({"id": s["id"], "file": f"{s['id']}.yaml", "family": s["family"],
                      "scope": s["scope"], "params": s["truth"],
                      "description": s["description"], "learned_inputs": s["learned_inputs"],
                      "recording": {"excitation": s["excitation"]}})
    (HERE / "truth.yaml").write_text(
        "# zoo45's sealed truth (benchmarks/blind_zoo/harness/run.py reads it)\n"
        + yaml.safe_dump({"effects": truth}, sort_keys=False, default_flow_style=None))
    (HERE / "control.yaml").write_text(
        "# a negligible perturbation: 2 mN along the body's x axis\n" + yaml.safe_dump(
            [{"class": "littledog_mlsim.robot.effects:BodyWrench",
              "params": {"force": [0.002, 0.0, 0.0]}}], default_flow_style=None))
    print(f"wrote {len(truth)} effect files, truth.yaml, control.yaml")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
