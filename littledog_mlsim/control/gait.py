"""A streaming trot: the open-loop trot of ``gait.trot``, one 10 ms command at a time.

``gait.trot.trot_commands`` turns one fixed :class:`..gait.trot.TrotParams` into a 4 s command
array. A controller instead decides the body velocity, yaw rate, step height and period anew each
step. :class:`StreamingTrot` keeps the gait phase continuous (phase += dt / period each step) and
evaluates the same foot geometry (``gait.trot.foot_trajectories`` with the current command and
phase, no ramp) and the same IK, so with a constant command it gives exactly the commands
``trot_commands`` gives after its ramp.

:class:`TrotCommand` is the decision of one step. ``smoothing_time`` > 0 passes it through a
first-order filter (time constant in seconds) before it reaches the feet, so a controller may
switch between move types abruptly while the legs see a smooth blend.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..gait.ik import inverse_kinematics
from ..gait.trot import TrotParams, foot_trajectories
from ..layout import CONTROL_DT, HOME_POSE

__all__ = ["TrotCommand", "StreamingTrot", "STAND"]


@dataclass(frozen=True)
class TrotCommand:
    """One step's trot: body velocity (vx, vy) [m/s] in base_link, yaw rate [rad/s], swing foot
    lift [m] and gait period [s]. ``step_height = 0`` and zero velocities is standing."""

    vx: float = 0.0
    vy: float = 0.0
    yaw_rate: float = 0.0
    step_height: float = 0.0
    period: float = 0.35

    def __post_init__(self) -> None:
        v = self.as_array()
        if not np.all(np.isfinite(v)):
            raise ValueError(f"TrotCommand must be finite, got {v.tolist()}")
        if self.period <= 0 or self.step_height < 0:
            raise ValueError(f"TrotCommand: period must be > 0 and step_height >= 0, got "
                             f"period={self.period}, step_height={self.step_height}")

    def as_array(self) -> np.ndarray:
        """(5,) vx, vy, yaw_rate, step_height, period."""
        return np.array([self.vx, self.vy, self.yaw_rate, self.step_height, self.period])

    @classmethod
    def from_array(cls, a) -> "TrotCommand":
        a = np.asarray(a, dtype=np.float64).reshape(-1)
        if a.shape != (5,):
            raise ValueError(f"a TrotCommand array has 5 values, got {a.size}")
        return cls(*(float(x) for x in a))

    @classmethod
    def from_params(cls, params: TrotParams) -> "TrotCommand":
        """The steady command of an open-loop trot (its value after the ramp)."""
        return cls(params.velocity[0], params.velocity[1], params.yaw_rate,
                   params.step_height, params.period)


STAND = TrotCommand()


class StreamingTrot:
    """Joint commands of a trot whose parameters may change every step.

    Args:
        smoothing_time: time constant [s] of the first-order filter between the requested and
            the applied command (0: applied as given).
        phase: gait phase [cycles] at t = 0 (0.5 swaps which diagonal pair steps first), as
            ``TrotParams.phase``.
        initial: the applied command at t = 0 (default: standing).
        dt: step [s].
    """

    def __init__(self, smoothing_time: float = 0.0, phase: float = 0.0,
                 initial: TrotCommand = STAND, dt: float = CONTROL_DT) -> None:
        if not (np.isfinite(smoothing_time) and smoothing_time >= 0):
            raise ValueError(f"smoothing_time must be finite and >= 0, got {smoothing_time}")
        if dt <= 0:
            raise ValueError(f"dt must be > 0, got {dt}")
        self.smoothing_time = float(smoothing_time)
        self.dt = float(dt)
        self._phase0 = float(phase)
        self._initial = initial
        self.reset()

    def reset(self) -> None:
        """Back to t = 0: the initial phase and applied command."""
        self.phase = self._phase0
        self.applied = self._initial.as_array()
        self.steps = 0

    def step(self, command: TrotCommand) -> np.ndarray:
        """The joint command (12,) for the next 10 ms under ``command`` (after smoothing)."""
        target = command.as_array()
        if self.smoothing_time > 0:
            k = 1.0 - np.exp(-self.dt / self.smoothing_time)
            self.applied = self.applied + k * (target - self.applied)
        else:
            self.applied = target
        vx, vy, w, h, period = self.applied
        self.phase += self.dt / period
        self.steps += 1
        if h == 0.0 and vx == 0.0 and vy == 0.0 and w == 0.0:
            return HOME_POSE.copy()
        # foot_trajectories evaluates t = dt with phase t / period + params.phase
        params = TrotParams(move_type="S", velocity=(float(vx), float(vy)), yaw_rate=float(w),
                            period=float(period), step_height=float(h), ramp_time=0.0,
                            phase=self.phase - self.dt / period, n_steps=1, dt=self.dt)
        return inverse_kinematics(foot_trajectories(params), clip=True)[0]

    def commands(self, schedule: np.ndarray) -> np.ndarray:
        """Joint commands (n, 12) for a schedule (n, 5) of TrotCommand arrays, from the current
        phase (open loop)."""
        sched = np.asarray(schedule, dtype=np.float64)
        if sched.ndim != 2 or sched.shape[1] != 5:
            raise ValueError(f"schedule must be (n, 5), got {sched.shape}")
        return np.array([self.step(TrotCommand.from_array(c)) for c in sched])
