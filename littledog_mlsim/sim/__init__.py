"""The simulator without ROS: scheduling rules (:mod:`.core`), the command rule
(:mod:`.command`) and what is stepped (:mod:`.backend`). ``nodes/`` wires it to topics."""
from .backend import Backend, PybulletBackend
from .command import CommandCheck, check_command
from .core import (MAX_CATCH_UP, STEPS_PER_TICK, Clock, CoreConfig, Counters, SimulatorCore,
                   SystemClock)

__all__ = ["Backend", "PybulletBackend", "CommandCheck", "check_command", "MAX_CATCH_UP",
           "STEPS_PER_TICK",
           "Clock", "CoreConfig", "Counters", "SimulatorCore", "SystemClock"]
