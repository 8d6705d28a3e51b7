"""pybullet_node: the pybullet LittleDog behind the same topics, modes and rules as sim_node.

    pybullet_node --ros-args -p robot:=measured [-p step_mode:=lockstep] [-p effects:=FILE.yaml]

The robot (``robot.sim.LittleDogSim``, ``measured``, ``nominal`` or a twin file) stands up once at start-up
(settled in the home stance) and every reset restarts from that settled stance with the same
``seed``, so a run is a pure function of (robot, seed, effects, commands): in lockstep mode,
replaying commands gives exactly ``simulate_move(commands, robot=..., seed=...)``'s
measurements. ``/littledog/joint_states`` and ``/littledog/odom`` carry what the robot's
sensors report (encoders, motion capture and its finite-difference twist, as written to the
bags); the odometry covariances are unknown (-1 in [0]), like in the bags. ``~/state`` (the
paper's 33-element state) is published from the first step on (s_0 needs the pose before the
start). The robot is stepped by ``sim.backend.PybulletBackend``; everything else (topics,
step modes, command rule, timeout, services, counters) is ``nodes/simulator.py`` and
``sim/core.py``, shared with sim_node.

Parameters: ``config/pybullet.yaml``.
"""
from __future__ import annotations

import sys
from typing import TYPE_CHECKING, Sequence

from ..sim.backend import Backend, PybulletBackend
from ._run import Param, StartupError
from .simulator import SimulatorNode, run_simulator

if TYPE_CHECKING:
    from ..robot.config import RobotConfig

NODE_NAME = "pybullet_node"


class PybulletNode(SimulatorNode):
    CONFIG_FILE = "pybullet.yaml"
    PARAMS = (
        Param("robot", "measured", "pybullet robot: measured (the stand-in for the real "
              "robot the data is recorded on), nominal (URDF values, ideal servo), or the path "
              "of a twin file (`littledog-mlsim calibrate --out`)",
              "measured | nominal | TWIN.json"),
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
        robot = robot_from_parameter(self.param("robot"))   # before pybullet prints its banner
        from ..robot.effects import load_effects

        effects = []
        if self.param("effects"):
            try:
                effects = load_effects(self.param("effects"))
            except ValueError as e:
                raise StartupError(str(e)) from None
        return PybulletBackend(robot, int(self.param("seed")), effects)


def robot_from_parameter(value: object) -> "RobotConfig":
    """The RobotConfig the ``robot`` parameter names (a robot name or a twin file);
    StartupError with one line otherwise."""
    from ..robot.twin import robot_config_from

    if not isinstance(value, str):
        raise StartupError(f"parameter robot must be a robot name or a twin file path, "
                           f"got {value!r}")
    try:
        return robot_config_from(value)
    except ValueError as e:
        raise StartupError(f"parameter robot: {e}") from None


def main(args: Sequence[str] | None = None) -> int:
    return run_simulator(PybulletNode, NODE_NAME, args)


if __name__ == "__main__":
    sys.exit(main())
