"""Writes zoo23's effects/zNN.yaml and truth.yaml. SEALED with the truth (it is the truth).

    .venv/bin/python benchmarks/blind_zoo/zoos/zoo23/write_truth.py
"""
import math, sys
from pathlib import Path
import numpy as np, yaml

ZOO = Path(__file__).resolve().parent
M_ROBOT = 2.1005 + 4 * 0.1838  # gap robot's mass

def payload(m, r):
    com = [round(m * x / (M_ROBOT + m), 4) for x in r]
    return m, com

mp, com = payload(0.30, [0.05, -0.03, 0.035])
wind_dir, wind_f = 235.0, 1.2
E = [
 dict(key="payload", cls="littledog_mlsim.robot.effects:Payload",
      params={"mass": mp, "offset": [0.05, -0.03, 0.035]},
      family="mass_com", scope="body",
      tparams={"added_mass_kg": mp, "com_offset_m": com, "payload_at_m": [0.05, -0.03, 0.035]},
      learned=True, exc=0.0,
      desc="a payload fixed to the body, off its centre"),
 dict(key="delay", cls="littledog_mlsim.robot.effects:SetpointDelay",
      params={"delay_ms": 30.0, "joints": "back_right"},
      family="command_delay", scope="leg:back_right", tparams={"delay_ms": 30.0},
      learned=False, exc=0.0, desc="one leg's set-points arrive late (its bus segment)"),
 dict(key="sag", cls="littledog_mlsim.robot.effects:ServoGain",
      params={"gain_ratio": 1.0, "drift_per_s": -0.07, "joints": "all"},
      family="time_drift", scope="all", tparams={"rate_per_s": -0.07, "gain_ratio_at_start": 1.0},
      learned=False, exc=0.0, desc="battery sag: every servo's P gain falls 7 % per second of the move"),
 dict(key="wind", cls="littledog_mlsim.robot.effects:ConstantWind",
      params={"force_xy": [round(wind_f * math.cos(math.radians(wind_dir)), 4),
                           round(wind_f * math.sin(math.radians(wind_dir)), 4)]},
      family="odom_force", scope="body", tparams={"force_N": wind_f, "direction_deg": wind_dir},
      learned=False, exc=0.0, desc="a steady draught fixed in the room"),
 dict(key="fric", cls="littledog_mlsim.robot.effects:JointFriction",
      params={"coulomb": 0.08, "joints": "hip_pitches"},
      family="joint_friction", scope="type:hip_pitches", tparams={"coulomb_Nm": 0.08},
      learned=True, exc=0.0, desc="stiffer hip pitch gearboxes (Coulomb friction)"),
 dict(key="play", cls="littledog_mlsim.robot.effects:SetpointBacklash",
      params={"width_rad": 0.05, "joints": "right"},
      family="backlash", scope="side:right", tparams={"width_rad": 0.05},
      learned=False, exc=0.05, desc="play in the right side's joints"),
 dict(key="offset", cls="littledog_mlsim.robot.effects:EncoderOffset",
      params={"offset_rad": 0.06, "joints": "back_left_hip_pitch", "servo_loop": True},
      family="encoder_offset", scope="joint:back_left_hip_pitch", tparams={"offset_rad": 0.06},
      learned=True, exc=0.0, desc="one encoder mounted off by a few degrees (servo closes on it)"),
 dict(key="legmass", cls="littledog_mlsim.robot.effects:LegMass",
      params={"scale": 1.6, "legs": "front_right"},
      family="leg_difference", scope="leg:front_right", tparams={"scale": 1.6, "quantity": "mass"},
      learned=True, exc=0.0, desc="one leg heavier (a replacement motor and a guard)"),
 dict(key="sticky", cls="littledog_mlsim.robot.effects:FootAdhesion",
      params={"force_N": 3.0, "legs": "back_left", "height_m": 0.01},
      family="contact_phase", scope="leg:back_left", tparams={"magnitude": 3.0, "phase": "stance and lift-off"},
      learned=False, exc=0.0, desc="one foot sticks to the floor (tape on its pad)"),
 dict(key="patch", cls="../plugins.py:WetFloorPatch",
      params={"friction_scale": 0.3, "direction_deg": 20.0, "offset_m": 0.10},
      family="other", scope="body",
      tparams={"friction_scale": 0.3, "direction_deg": 20.0, "offset_m": 0.10},
      learned=False, exc=0.0, desc="a wet region of the floor: where a foot stands decides its grip (position)"),
 dict(key="thermal", cls="../plugins.py:ThermalFade",
      params={"heating_K_per_Nm2": 1500.0, "time_constant_s": 1.5, "alpha_per_K": 0.005,
              "joints": "knees"},
      family="other", scope="type:knees",
      tparams={"heating_K_per_Nm2": 1500.0, "time_constant_s": 1.5, "alpha_per_K": 0.005, "start_rise_K": 0.0},
      learned=False, exc=0.0, desc="knee motors heat with their torque history; their torque fades"),
 dict(key="spring", cls="../plugins.py:HarnessSpring",
      params={"stiffness_Nm_per_rad": 2.0, "rest_rad": 0.0, "joints": "hip_rolls"},
      family="other", scope="type:hip_rolls",
      tparams={"stiffness_Nm_per_rad": 2.0, "rest_rad": 0.0},
      learned=True, exc=0.0, desc="a cable bundle across the hip roll joints acts as a torsional spring"),
]

def main(only_write_effects_to=None):
    order = np.random.default_rng(23_0577).permutation(len(E))
    truth = []
    outdir = Path(only_write_effects_to) if only_write_effects_to else ZOO / "effects"
    outdir.mkdir(parents=True, exist_ok=True)
    for n, i in enumerate(order, 1):
        e = E[i]
        zid = f"z{n:02d}"
        (outdir / f"{zid}.yaml").write_text(
            f"# zoo23 effect {zid} (sealed: see ../truth.yaml)\n" +
            yaml.safe_dump([{"class": e["cls"], "params": e["params"]}], sort_keys=False))
        truth.append({"id": zid, "file": f"{zid}.yaml", "family": e["family"], "scope": e["scope"],
                      "params": e["tparams"], "learned_inputs": e["learned"],
                      "recording": {"excitation": e["exc"]}, "description": e["desc"]})
        print(zid, e["key"])
    if not only_write_effects_to:
        (ZOO / "truth.yaml").write_text(
            "# zoo23's SEALED truth: read only by harness/run.py, after every diagnosis.\n"
            "# family / scope / primary parameter in the vocabulary of ../../vocabulary.md;\n"
            "# learned_inputs: whether the effect's cause is among a one-step model's inputs\n"
            "# (state and command); recording.excitation: the command excitation recorded with.\n"
            + yaml.safe_dump({"effects": truth}, sort_keys=False, default_flow_style=None))

if __name__ == "__main__":
    main(*sys.argv[1:])
