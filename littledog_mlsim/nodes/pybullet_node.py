"""pybullet_node: the pybullet LittleDog behind the same topics, modes and rules as sim_node.

    pybullet_node --ros-args -p robot:=measured [-p step_mode:=lockstep] [-p effects:=FILE.yaml]

The robot (``robot.sim.LittleDogSim``, ``measured`` or ``nominal``) stands up once at start-up
(settled in the home stance) and every reset restarts from that settled stance with the same
``seed``, so a run is a pure function of (robot, seed, effects, commands): in lockstep mode,
replaying commands gives exactly ``simulate_move(commands, robot=..., seed=...)``'s
measurements. ``/littledog/joint_states`` and ``/littledog/odom`` carry what the robot's
sensors report (encoders, motion capture and its finite-difference twist, as written to the
bags); the odometry covariances are unknown (-1 in [0]), like in the bags. ``~/state`` (the
paper's 33-element state) is published from the first step on (s_0 needs the pose before the
start). Everything else (topics, step modes, command rule, timeout, services, counters) is
``nodes/simulator.py``, shared with sim_node.

Parameters: ``config/pybullet.yaml``.
"""
from __future__ import annotations

import sys
from typing import Sequence

import numpy as np

from ..data.dataset import states_from_recording
from ..data.recording import MoveRecording
from ..layout import CONTROL_DT_NS
from ._run import Param, StartupError
from .simulator import Backend, SimulatorNode, run_simulator

NODE_NAME = "pybullet_node"


class PybulletBackend(Backend):
    """A ``LittleDogSim`` as a Backend; outputs are the sensor measurements of the last step."""

    def __init__(self, robot: str, seed: int, effects: list) -> None:
        from ..robot.sim import LittleDogSim

        self.sim = LittleDogSim(robot)
        self.seed = seed
        self.effects = effects
        self.reset()

    def reset(self) -> None:
        self._obs = self.sim.reset(seed=self.seed, effects=self.effects)
        self.state = None
        self._set_outputs()

    def step(self, u: np.ndarray) -> bool:
        prev = self._obs
        try:
            self._obs = self.sim.step(u)
        except ValueError:
            return False
        both = {k: np.stack([prev[k], self._obs[k]]) for k in self._obs}
        rec = MoveRecording(name="F_00", move_type="F",
                            stamps_ns=np.array([0, CONTROL_DT_NS], dtype=np.int64),
                            cmd=np.asarray(u, dtype=np.float64)[None], **both)
        self.state = states_from_recording(rec)[0]
        self._set_outputs()
        return True

    def _set_outputs(self) -> None:
        o = self._obs
        self.q, self.dq = o["q"], o["dq"]
        self.position, self.orientation = o["position"], o["orientation"]
        self.linear_velocity, self.angular_velocity = o["linear_velocity"], o["angular_velocity"]
        self.pose_covariance = self.twist_covariance = None

    def outputs_finite(self) -> bool:
        vals = list(self._obs.values()) + ([] if self.state is None else [self.state])
        return all(np.all(np.isfinite(v)) for v in vals)


class PybulletNode(SimulatorNode):
    CONFIG_FILE = "pybullet.yaml"
    PARAMS = (
        Param("robot", "measured", "pybullet robot variant: measured (the stand-in for the real "
              "robot the data is recorded on) or nominal (URDF values, ideal servo)",
              "measured | nominal"),
        Param("seed", 0, "seeds the sensor noise and the effects' rng (the same on every reset)"),
        Param("effects", "", "YAML file of effects to switch on (as `littledog-mlsim record "
              "--effects`); empty: none"),
    )

    def __init__(self) -> None:
        super().__init__(NODE_NAME)
        self.get_logger().info(
            f"pybullet robot {self.param('robot')}, seed {self.param('seed')}, "
            f"{len(self.backend.effects)} effect(s), step_mode {self.step_mode}"
            + (f", defaults from {self.config_path}" if self.config_path else ""))

    def make_backend(self) -> Backend:
        from ..robot.config import ROBOT_NAMES
        from ..robot.effects import load_effects

        robot = self.param("robot")
        if robot not in ROBOT_NAMES:
            raise StartupError(f"parameter robot must be one of {', '.join(ROBOT_NAMES)}, "
                               f"got {robot!r}")
        effects = []
        if self.param("effects"):
            try:
                effects = load_effects(self.param("effects"))
            except ValueError as e:
                raise StartupError(str(e)) from None
        return PybulletBackend(robot, int(self.param("seed")), effects)


def main(args: Sequence[str] | None = None) -> int:
    return run_simulator(PybulletNode, NODE_NAME, args)


if __name__ == "__main__":
    sys.exit(main())
