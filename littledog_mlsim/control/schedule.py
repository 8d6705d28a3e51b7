"""Open-loop command schedules beyond the 4 s moves of the data: gait switching and long trots.

A schedule is an (n, 5) array of :class:`.gait.TrotCommand` values, one per 10 ms step, for
:meth:`.gait.StreamingTrot.commands`. Segments are trots of the data's move types with
parameters drawn as the data's were (``gait.trot.sample_trot_params``); consecutive segments are
joined by a smoothstep blend of every parameter over ``blend_time`` (a change of move type with
no jump in velocity, yaw rate, step height or period), and the schedule starts from standing
with the data's ramp (smoothstep over the first segment's ``ramp_time``).
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..gait.trot import DEFAULT_RANGES, TrotRanges, sample_trot_params
from ..layout import CONTROL_DT, MOVE_TYPES, STEPS_PER_MOVE
from .gait import TrotCommand

__all__ = ["Segment", "Schedule", "gait_switch_schedule", "straight_trot_schedule", "blend",
           "switch_move_schedule", "varied_schedule"]


@dataclass(frozen=True)
class Segment:
    """One segment: its move type, steady command, first step and ramp time [s]."""

    move_type: str
    command: TrotCommand
    start_step: int
    ramp_time: float


@dataclass(frozen=True)
class Schedule:
    """``commands`` (n, 5) per step; ``segments`` in time order; ``phase`` the gait phase at
    t = 0 (of the first segment, as the data samples it)."""

    commands: np.ndarray
    segments: tuple[Segment, ...]
    phase: float

    @property
    def n_steps(self) -> int:
        return int(self.commands.shape[0])

    def move_type_at(self, k: int) -> str:
        """The move type of the segment holding step k."""
        cur = self.segments[0].move_type
        for s in self.segments:
            if s.start_step <= k:
                cur = s.move_type
        return cur


def _smoothstep(x: np.ndarray) -> np.ndarray:
    x = np.clip(x, 0.0, 1.0)
    return x * x * (3.0 - 2.0 * x)


def blend(a: TrotCommand, b: TrotCommand, n: int) -> np.ndarray:
    """(n, 5): smoothstep from ``a`` (excluded) to ``b`` (reached at the last row)."""
    w = _smoothstep(np.arange(1, n + 1) / n)[:, None]
    return (1.0 - w) * a.as_array() + w * b.as_array()


def _build(types: list[str], segment_steps: list[int], rng: np.random.Generator,
           blend_steps: int, ranges: TrotRanges) -> Schedule:
    params = [sample_trot_params(t, rng, ranges) for t in types]
    rows, segs, k = [], [], 0
    prev = TrotCommand(period=params[0].period)          # standing, at the first period
    for t, p, n in zip(types, params, segment_steps):
        cmd = TrotCommand.from_params(p)
        nb = max(1, int(round(p.ramp_time / CONTROL_DT))) if not segs else blend_steps
        nb = min(nb, n)
        rows.append(blend(prev, cmd, nb))
        rows.append(np.tile(cmd.as_array(), (n - nb, 1)))
        segs.append(Segment(t, cmd, k, p.ramp_time))
        prev, k = cmd, k + n
    return Schedule(np.vstack(rows), tuple(segs), float(params[0].phase))


def gait_switch_schedule(duration: float, rng: np.random.Generator, segment_time: float = 4.0,
                         blend_time: float = 0.5, types: tuple[str, ...] = MOVE_TYPES,
                         ranges: TrotRanges = DEFAULT_RANGES) -> Schedule:
    """``duration`` [s] of trots switching move type every ``segment_time`` [s] (a type drawn
    uniformly from ``types``, never the previous one), blended over ``blend_time`` [s]."""
    n_total = int(round(duration / CONTROL_DT))
    n_seg = int(round(segment_time / CONTROL_DT))
    if n_total < 1 or n_seg < 1 or blend_time <= 0:
        raise ValueError("duration, segment_time and blend_time must be positive")
    seq: list[str] = []
    sizes: list[int] = []
    left = n_total
    while left > 0:
        choices = [t for t in types if not seq or t != seq[-1]] or list(types)
        seq.append(str(rng.choice(choices)))
        sizes.append(min(n_seg, left))
        left -= sizes[-1]
    return _build(seq, sizes, rng, int(round(blend_time / CONTROL_DT)), ranges)


def straight_trot_schedule(duration: float, rng: np.random.Generator, move_type: str = "F",
                           ranges: TrotRanges = DEFAULT_RANGES) -> Schedule:
    """One trot of ``move_type`` for ``duration`` [s] (parameters drawn as the data's)."""
    n_total = int(round(duration / CONTROL_DT))
    if n_total < 1:
        raise ValueError("duration must be positive")
    return _build([move_type], [n_total], rng, 1, ranges)


def switch_move_schedule(move_type: str, rng: np.random.Generator,
                         n_steps: int = STEPS_PER_MOVE, switch_time: tuple[float, float] = (1.0, 2.5),
                         blend_time: float = 0.5, types: tuple[str, ...] = MOVE_TYPES,
                         ranges: TrotRanges = DEFAULT_RANGES) -> Schedule:
    """One move with a transition: a trot of ``move_type`` that, at a time drawn uniformly from
    ``switch_time`` [s], blends over ``blend_time`` [s] into a trot of another type drawn
    uniformly from ``types`` (the gait-switching schedule's join, within one move)."""
    if move_type not in MOVE_TYPES:
        raise ValueError(f"unknown move type {move_type!r}")
    others = [t for t in types if t != move_type]
    if not others:
        raise ValueError("a transition needs a second move type")
    k = int(round(rng.uniform(*switch_time) / CONTROL_DT))
    if not 0 < k < n_steps:
        raise ValueError(f"switch_time {switch_time} does not fall inside {n_steps} steps")
    other = str(rng.choice(others))
    return _build([move_type, other], [k, n_steps - k], rng,
                  max(1, int(round(blend_time / CONTROL_DT))), ranges)


def varied_schedule(move_type: str, rng: np.random.Generator, n_steps: int = STEPS_PER_MOVE,
                    knot_time: tuple[float, float] = (0.6, 1.2),
                    ranges: TrotRanges = DEFAULT_RANGES) -> Schedule:
    """One move whose command varies continuously: every parameter of a ``move_type`` trot is
    drawn anew (as ``sample_trot_params`` draws it for that type) at knots spaced by a time drawn
    uniformly from ``knot_time`` [s], and the command moves from knot to knot by smoothstep over
    the whole interval, so it never holds still. The first knot is reached by the data's ramp
    from standing."""
    if move_type not in MOVE_TYPES:
        raise ValueError(f"unknown move type {move_type!r}")
    if n_steps < 1 or not 0 < knot_time[0] <= knot_time[1]:
        raise ValueError("n_steps and knot_time must be positive")
    sizes: list[int] = []
    left = n_steps
    while left > 0:
        sizes.append(min(left, max(1, int(round(rng.uniform(*knot_time) / CONTROL_DT)))))
        left -= sizes[-1]
    return _build([move_type] * len(sizes), sizes, rng, n_steps, ranges)
