"""What a simulator node steps: the :class:`Backend` protocol and the pybullet backend.

Two implementations: the learned simulator (``rollout.learned_sim.LearnedSimulator``) and
:class:`PybulletBackend` (the pybullet LittleDog, ``robot.sim.LittleDogSim``). Neither knows
about ROS; :class:`..sim.core.SimulatorCore` schedules them and the nodes publish their
outputs.
"""
from __future__ import annotations

from typing import TYPE_CHECKING, Any, Protocol, runtime_checkable

import numpy as np

from ..data.states import states_from_measurements

if TYPE_CHECKING:
    from ..robot.config import RobotConfig

__all__ = ["Backend", "PybulletBackend"]


@runtime_checkable
class Backend(Protocol):
    """One simulated LittleDog. After ``reset``/``step`` the attributes hold the outputs:
    ``q``, ``dq`` (12,); ``position`` (3,), ``orientation`` (4,) xyzw of base_link in odom;
    ``linear_velocity``, ``angular_velocity`` (3,) in base_link; ``state`` (33,) or None (not
    known yet); ``pose_covariance``, ``twist_covariance`` (36,) row-major or None (unknown).

    Optional: ``extrapolating`` (bool, the last step left the data), ``nn_distance`` and
    ``trust_radius`` (floats): the core warns (throttled) on such steps."""

    q: np.ndarray
    dq: np.ndarray
    position: np.ndarray
    orientation: np.ndarray
    linear_velocity: np.ndarray
    angular_velocity: np.ndarray
    state: np.ndarray | None
    pose_covariance: np.ndarray | None
    twist_covariance: np.ndarray | None

    def reset(self) -> None:
        """Back to the initial state."""

    def step(self, u: np.ndarray) -> bool:
        """One 10 ms step with desired joint angles u (12,); False if it produced nothing
        finite (the core then resets)."""

    def outputs_finite(self) -> bool:
        """True if every output is finite."""

    def stats(self) -> dict[str, Any]:
        """Backend-specific ``~/stats`` entries (strings or numbers); may be empty."""


class PybulletBackend:
    """A ``LittleDogSim`` as a Backend; outputs are the sensor measurements of the last step,
    ``state`` is s_t from the last two measurements (``states_from_measurements``, the same
    extraction as the recorded data)."""

    def __init__(self, robot: "str | RobotConfig", seed: int, effects: list) -> None:
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
            self._obs = o = self.sim.step(u)
        except ValueError:
            return False
        self.state = states_from_measurements(
            np.stack([prev["position"], o["position"]]),
            np.stack([prev["orientation"], o["orientation"]]),
            np.stack([prev["q"], o["q"]]), np.stack([prev["dq"], o["dq"]]))[0]
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

    def stats(self) -> dict[str, Any]:
        return {}
