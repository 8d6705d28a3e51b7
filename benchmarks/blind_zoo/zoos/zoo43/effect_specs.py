"""The zoo's effects as written (SEALED: it names what each effect is). ``write()`` writes
effects/zNN.yaml and truth.yaml from this one list, ids assigned in a random order."""
from __future__ import annotations

from pathlib import Path

import numpy as np
import yaml

HERE = Path(__file__).resolve().parent
ORDER_SEED = 2677911921626235309
EXC = 0.05

# (key, plug-in class, params, family, scope, primary params, description, learned_inputs,
#  excitation)
SPECS = [
    ("play", "GearPlay", {"width_rad": 0.04, "joints": "front_left"},
     "backlash", "leg:front_left", {"width_rad": 0.04},
     "worn gears in the front left leg: 0.04 rad of play in which the position error drives "
     "no servo torque (hip roll, hip pitch and knee)", True, EXC),
    ("gain", "SoftServo", {"gain_ratio": 0.5, "joints": "back_right_knee"},
     "servo_gain", "joint:back_right_knee", {"gain_ratio": 0.5},
     "the back right knee's servo P gain at half its normal value (mistuned driver)", True, 0.0),
    ("friction", "StickyGearbox", {"coulomb_Nm": 0.15, "joints": "hip_rolls"},
     "joint_friction", "type:hip_rolls", {"coulomb_Nm": 0.15},
     "dry gearboxes on the four hip rolls: 0.15 N m of extra Coulomb friction", True, EXC),
    ("limit", "CurrentLimit", {"torque_limit_Nm": 1.0, "joints": "hip_pitches"},
     "torque_saturation", "type:hip_pitches", {"torque_limit_Nm": 1.0},
     "the drivers of the four hip pitches current-limited to 1.0 N m", True, 0.0),
    ("offset", "ShiftedEncoder", {"offset_rad": 0.05, "joints": "front_right_hip_pitch"},
     "encoder_offset", "joint:front_right_hip_pitch", {"offset_rad": 0.05},
     "the front right hip pitch encoder zeroed 0.05 rad off (reads true + 0.05); the servo "
     "closes its loop on it", True, 0.0),
    ("slope", "InclinedFloor", {"slope_deg": 1.0, "uphill_direction_deg": 230.0},
     "ground_slope", "body", {"slope_deg": 1.0, "uphill_direction_deg": 230.0},
     "the floor inclined 1.0 deg, rising towards 230 deg in odom (gravity along -z)", True, 0.0),
    ("mass", "CarriedBox", {"mass_kg": 0.18, "offset_m": [-0.04, 0.03, 0.05]},
     "mass_com", "body", {"added_mass_kg": 0.18, "com_offset_m": [-0.04, 0.03, 0.05]},
     "a 0.18 kg box bolted on the body at (-0.04, 0.03, 0.05) m in base_link (com_offset_m is "
     "the box's position)", True, 0.0),
    ("pad", "WornFootPad", {"scale": 0.3, "leg": "back_left"},
     "leg_difference", "leg:back_left", {"scale": 0.3, "quantity": "foot friction coefficient"},
     "the back left foot's rubber pad worn: its friction coefficient 0.3 times normal", True, 0.0),
    ("snag", "SnaggedFoot", {"force_N": 1.0, "leg": "back_right"},
     "contact_phase", "leg:back_right", {"magnitude": 1.0, "phase": "swing"},
     "the back right foot drags something while it swings: a horizontal force up to 1.0 N "
     "against its velocity, off the ground only", True, 0.0),
    ("tether", "PowerTether", {"stiffness_N_m": 12.0, "slack_m": 0.05},
     "other", "body", {"stiffness_N_m": 12.0, "slack_m": 0.05},
     "a power tether clipped to the back of the body, anchored where each move starts: beyond "
     "0.05 m of slack it pulls back with 12 N/m (horizontal, at the clip point)", False, 0.0),
    ("packets", "LostPackets", {"p_loss": 0.15, "p_stay": 0.5},
     "other", "all", {"p_loss": 0.15, "p_stay": 0.5},
     "the command link drops packets in bursts (lost after a received one with 0.15, after a "
     "lost one with 0.5): the servos keep the previous set-point", False, 0.0),
    ("foam", "FoamMat", {"stiffness_N_m": 4000.0, "damping_N_s_m": 80.0},
     "other", "body", {"stiffness_N_m": 4000.0, "damping_N_s_m": 80.0},
     "the robot walks on a foam mat: soft floor contact, 4000 N/m and 80 N s/m", True, 0.0),
]


def ids() -> dict[str, str]:
    """key -> neutral id zNN, in a random order."""
    perm = np.random.default_rng(ORDER_SEED).permutation(len(SPECS))
    return {SPECS[i][0]: f"z{k + 1:02d}" for k, i in enumerate(perm)}


def write() -> None:
    idmap = ids()
    truth = []
    for key, cls, params, fam, scope, prim, desc, learned, exc in SPECS:
        i = idmap[key]
        (HERE / "effects" / f"{i}.yaml").write_text(yaml.safe_dump(
            [{"class": f"../plugins.py:{cls}", "params": params}], sort_keys=False))
        rec = {"excitation": exc}
        rec["note"] = ("recorded with command excitation (white noise of this std on every "
                       "joint command), which exposes it" if exc else "plain trot")
        truth.append({"id": i, "file": f"{i}.yaml", "family": fam, "scope": scope,
                      "params": prim, "description": desc, "learned_inputs": learned,
                      "recording": rec})
    truth.sort(key=lambda t: t["id"])
    header = ("# zoo43 truth (SEALED): read only by harness/run.py after every diagnosis.\n"
              "# Units: the vocabulary's (benchmarks/blind_zoo/vocabulary.md).\n")
    (HERE / "truth.yaml").write_text(header + yaml.safe_dump({"effects": truth},
                                                             sort_keys=False, width=100))


if __name__ == "__main__":
    write()
