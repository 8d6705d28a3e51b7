"""Kinds of recorded move beyond the paper's constant trots: what ``record --extra`` adds.

The paper's TrainPool holds constant trots only (kind ``trot``: one ``gait.trot`` move, its
parameters held after the ramp). A controller instead changes its command every step, so a
model trained on constant trots has never seen a transition. The other kinds record what a
controller asks of the robot:

- ``switch`` (open loop): a trot of the move's type that blends into another type within the
  move (``schedule.switch_move_schedule``);
- ``varied`` (open loop): a trot of the move's type whose every parameter moves continuously
  from one draw to the next (``schedule.varied_schedule``);
- ``velocity`` (closed loop): the PI velocity tracker (``controllers.VelocityTracker``) on the
  robot, following a reference that changes once within the move; the references are trots of
  random types with parameters drawn as the data's are;
- ``waypoints`` (closed loop): the waypoint follower (``controllers.WaypointFollower``) on the
  robot, through two random waypoints ahead of it.

The closed-loop kinds are the controllers' own runs on the robot (the data a DAgger-style
round adds): their commands depend on what the robot did. Open-loop kinds give (n, 12) joint
commands up front (:func:`open_loop_commands`); closed-loop kinds give a policy that maps each
measurement to the next joint command (:func:`closed_loop_policy`). Every draw comes from the
``rng`` passed in, so a move is a function of its seed.
"""
from __future__ import annotations

from dataclasses import replace
from typing import Any, Callable, Mapping

import numpy as np

from ..gait.trot import DEFAULT_RANGES, excite_commands, sample_trot_params, trot_commands
from ..layout import CONTROL_DT, MOVE_TYPES, STEPS_PER_MOVE
from ..rotations import rotate_xy
from .controllers import Observation, VelocityTracker, WaypointFollower
from .gait import StreamingTrot, TrotCommand
from .schedule import blend, switch_move_schedule, varied_schedule

__all__ = ["MOVE_KINDS", "OPEN_LOOP_KINDS", "CLOSED_LOOP_KINDS", "open_loop_commands",
           "closed_loop_policy", "SMOOTHING_TIME"]

OPEN_LOOP_KINDS = ("trot", "switch", "varied")
CLOSED_LOOP_KINDS = ("velocity", "waypoints")
MOVE_KINDS = OPEN_LOOP_KINDS + CLOSED_LOOP_KINDS
SMOOTHING_TIME = 0.3        # s, the controllers' StreamingTrot filter (as in the fidelity runs)

Policy = Callable[[Mapping[str, Any]], np.ndarray]


def open_loop_commands(kind: str, move_type: str, rng: np.random.Generator,
                       excitation: float = 0.0, n_steps: int = STEPS_PER_MOVE) -> np.ndarray:
    """Joint commands (n_steps, 12) of one open-loop move of ``kind`` and ``move_type``, plus
    white command noise of ``excitation`` [rad] (``gait.trot.excite_commands``)."""
    if kind == "trot":
        commands = trot_commands(replace(sample_trot_params(move_type, rng), n_steps=n_steps))
    elif kind in ("switch", "varied"):
        make = switch_move_schedule if kind == "switch" else varied_schedule
        sched = make(move_type, rng, n_steps=n_steps)
        commands = StreamingTrot(phase=sched.phase).commands(sched.commands)
    else:
        raise ValueError(f"{kind!r} is not an open-loop move kind; expected one of "
                         f"{' '.join(OPEN_LOOP_KINDS)}")
    return excite_commands(commands, excitation, rng)


def _reference_command(rng: np.random.Generator) -> TrotCommand:
    """The steady command of a trot of a random type, drawn as the data's are."""
    return TrotCommand.from_params(sample_trot_params(str(rng.choice(MOVE_TYPES)), rng))


class _RelativeWaypoints:
    """A :class:`WaypointFollower` whose waypoints are given in the frame of the robot's first
    measured pose (ahead = +x), so a move's route does not depend on where the robot stands."""

    def __init__(self, waypoints: np.ndarray, **kwargs: Any) -> None:
        self._relative = np.asarray(waypoints, dtype=np.float64)
        self._kwargs = kwargs
        self.follower: WaypointFollower | None = None

    def command(self, obs: Observation) -> TrotCommand:
        if self.follower is None:
            world = rotate_xy(self._relative, float(obs.rpy[2])) + obs.position[:2]
            self.follower = WaypointFollower(world, **self._kwargs)
        return self.follower.command(obs)


def closed_loop_policy(kind: str, rng: np.random.Generator,
                       n_steps: int = STEPS_PER_MOVE) -> Policy:
    """A policy (measurement dict -> joint command (12,)) for one closed-loop move of ``kind``.

    ``velocity``: the tracker's reference is one trot's (vx, vy, yaw rate) until a time drawn
    from 1.5-3 s, then blends over 0.5 s into another's; step height and period are drawn from
    the data's ranges. ``waypoints``: two waypoints, the first 0.12-0.25 m ahead within +-0.6
    rad, the second as far again after a turn within +-0.9 rad (in the frame of the first measured
    pose); the cruise speed is drawn from
    the forward trots' range.
    """
    r = DEFAULT_RANGES
    step_height = float(rng.uniform(*r.step_height))
    period = float(rng.uniform(*r.period))
    if kind == "velocity":
        a, b = _reference_command(rng), _reference_command(rng)
        k = int(round(rng.uniform(1.5, 3.0) / CONTROL_DT))
        nb = int(round(0.5 / CONTROL_DT))
        ref = np.vstack([np.tile(a.as_array()[:3], (k, 1)),
                         blend(a, b, nb)[:, :3],
                         np.tile(b.as_array()[:3], (max(0, n_steps - k - nb), 1))])[:n_steps]
        ctrl: Any = VelocityTracker(ref, step_height=step_height, period=period)
    elif kind == "waypoints":
        heading = float(rng.uniform(-0.6, 0.6))
        d1 = float(rng.uniform(0.12, 0.25))
        p1 = d1 * np.array([np.cos(heading), np.sin(heading)])
        heading += float(rng.uniform(-0.9, 0.9))
        p2 = p1 + d1 * np.array([np.cos(heading), np.sin(heading)])
        ctrl = _RelativeWaypoints(np.vstack([p1, p2]),
                                  cruise_speed=float(rng.uniform(*r.speed_forward)),
                                  step_height=step_height, period=period)
    else:
        raise ValueError(f"{kind!r} is not a closed-loop move kind; expected one of "
                         f"{' '.join(CLOSED_LOOP_KINDS)}")
    gait = StreamingTrot(smoothing_time=SMOOTHING_TIME, phase=0.5 * float(rng.integers(2)))

    def policy(obs: Mapping[str, Any]) -> np.ndarray:
        return gait.step(ctrl.command(Observation.from_mapping(obs)))

    return policy
