"""Fingerprints of what the simulator computes, to compare two versions of the code bit for bit.

Prints one line per item: a label and the SHA-256 of the item's arrays. Run it once with each
version on the path (README.md) and compare the outputs with ``diff``:

1. **Moves in one process, effects interleaved.** One LittleDogSim per robot (measured,
   nominal, a torque-mode gap robot) simulates a sequence of 4 s moves in one process; the
   effects change from move to move, so that each kind of reset follows each other kind:
   none, a command-path effect (it keeps its own state), effects whose reset changes the world
   (a leg's mass, the gravity, a payload body, a foot's friction, the floor's pose), and a
   plug-in that changes a friction in a substep hook without saying so.
2. **Re-simulated segments.** As the physical diagnosis re-simulates: 1 s segments, each
   starting from the true state where the previous segment of the same move ended.
3. **record end to end.** ``record_dataset`` with two worker processes, with and without an
   effects file, every array of every bag it wrote.
"""
from __future__ import annotations

import argparse
import hashlib
import tempfile
from pathlib import Path

import numpy as np


def digest(*arrays: np.ndarray) -> str:
    h = hashlib.sha256()
    for a in arrays:
        h.update(np.ascontiguousarray(a).tobytes())
    return h.hexdigest()[:16]


class SoftFloorPatch:
    """A plug-in that changes the world in a substep hook and says nothing of it (no
    ``changes_world``): the front-left foot's friction is 0.3 from its first physics step on.
    The next move must start in the world as built again."""

    def substep(self, sim, t: float) -> None:
        import pybullet as p
        if t == 0.0:
            p.changeDynamics(sim.robot, sim.foot_links[0], lateralFriction=0.3,
                             physicsClientId=sim.client)


def effects_sequence():
    from littledog_mlsim.robot import effects as E
    from littledog_mlsim.apps.record import StartSpread
    return [("none", []), ("soft_floor_patch", [SoftFloorPatch()]), ("none", []), ("leg_mass", [E.LegMass(1.3, "front_left")]), ("none", []),
            ("setpoint_delay", [E.SetpointDelay(12.0)]), ("slope", [E.GroundSlope(3.0, 90.0)]),
            ("servo_gain", [E.ServoGain(0.7, joints="front_left_knee")]), ("none", []),
            ("payload", [E.Payload(0.3, [0.05, 0.0, 0.02])]), ("none", []),
            ("foot_friction", [E.FootFriction(0.5, "back_right")]), ("backlash",
             [E.SetpointBacklash(0.02)]), ("tilt", [E.GroundTilt(2.0, 45.0)]), ("none", []),
            ("start_spread", [StartSpread(0.3, 5)]), ("wind", [E.ConstantWind([0.0, 2.0])]),
            ("none", [])]


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--gap-robot", required=True, help="a torque-mode twin file")
    a = ap.parse_args()
    from littledog_mlsim.apps.record import record_dataset
    from littledog_mlsim.data.dataset import load_moves
    from littledog_mlsim.robot.sim import LittleDogSim
    from littledog_mlsim.robot.twin import robot_config_from

    rng = np.random.default_rng(3)
    for robot in ("measured", "nominal", a.gap_robot):
        name = Path(robot).stem
        sim = LittleDogSim(robot_config_from(robot))
        q0 = sim.reset(seed=0)["q"]
        for k, (label, effects) in enumerate(effects_sequence()):
            t = np.arange(400) * 0.01
            cmd = q0[None] + 0.25 * np.sin(2 * np.pi * (1.5 + rng.random()) * t)[:, None] \
                * rng.normal(size=12)[None]
            obs = [sim.reset(seed=k, effects=effects)]
            obs += [sim.step(u) for u in cmd]
            print(f"move {name} {k:02d} {label}",
                  digest(*[np.array([o[f] for o in obs]) for f in sorted(obs[0])]))
        # segments, as the physical diagnosis re-simulates them
        for k, (label, effects) in enumerate(effects_sequence()[:10]):
            cmd = q0[None] + 0.25 * np.sin(np.arange(400) * 0.09 + k)[:, None] \
                * rng.normal(size=12)[None]
            start = None
            for s0 in range(0, 400, 100):
                obs = [sim.reset(seed=0, initial=start, effects=effects)]
                obs += [sim.step(u) for u in cmd[s0:s0 + 100]]
                start = sim.true_state()
                print(f"segment {name} {k:02d} {label} {s0}",
                      digest(*[np.array([o[f] for o in obs]) for f in sorted(obs[0])]))
        sim.close()
    with tempfile.TemporaryDirectory() as tmp:
        eff = Path(tmp) / "effects.yaml"
        eff.write_text("- class: littledog_mlsim.robot.effects:LegMass\n"
                       "  params: {scale: 1.2, legs: back_left}\n"
                       "- class: littledog_mlsim.robot.effects:SetpointDelay\n"
                       "  params: {delay_ms: 8.0}\n")
        for tag, kw in (("clean", {}), ("effects", {"effects_file": str(eff)})):
            out = Path(tmp) / tag
            record_dataset(out, moves_per_type=2, types=["F", "L", "BL", "S"], seed=11, jobs=2,
                           progress=False, **kw)
            for m in load_moves(out, "all"):
                print(f"record {tag} {m.name}", digest(m.stamps_ns, m.cmd, m.q, m.dq,
                                                       m.position, m.orientation,
                                                       m.linear_velocity, m.angular_velocity))


if __name__ == "__main__":
    main()
