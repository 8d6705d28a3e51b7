"""A late sensor stream corrected in the data, not modelled (decision 043; both routes).

Why
---
The timing check (:mod:`.timing`) reads by how much the joint states lag the pose, or the pose
the joint states, from the robot's own kinematics. Neither is a change in the robot: a message
published late says where the robot was, not where it is. A one-step model given both streams
as of one stamp reads a late pose as a lagged state and a late joint-state stream as a command
delay, and an augmentation that models either leaves the rollout far from clean (a lagged
state for a late pose: decision 043, "Problem"). The measurement is what is wrong,
so the measurement is corrected: the late stream's samples are moved back to the stamps they
belong to, and the loop then runs on data whose streams agree.

Method
------
A stream late by ``s`` control steps (the timing check's shift over the step, a fraction
allowed) is read ``s`` steps later: its corrected value at row ``t`` is the measured one at
``t + s``, linearly interpolated between the two nearest rows (the orientation's quaternion
interpolated and normalised, its sign kept continuous). The last ``ceil(s)`` rows have no later
sample and are dropped, with the commands between them: a move of 400 steps late by 3 steps
keeps 397. The streams:

- ``pose``: position, orientation, linear and angular velocity (one odometry message);
- ``joint_states``: joint angles and velocities, of every joint or, where the check found some
  legs' joint states alone late, of those legs' joints.

The shift is the timing check's: against the reference's lead where a reference is given (the
data are brought to the reference's timing), else against zero. A leg's shift reads short
(:mod:`.timing`, 5), so a leg's correction can leave part of its latency.

Report (``report.json``'s ``sensor_correction``, where the timing check is significant)
--------------------------------------------------------------------------------------------
``stream``, ``shift_ms``, ``shift_steps``, ``fields`` (the recording fields moved), ``joints``
(the joints moved, ``joint_states`` only), ``rows_dropped`` (per move), ``statement``, and
``stage_as_recorded`` (the index of the stage fitted and scored on the data as recorded: the
report's ``before``; every later stage, and the search, use the corrected data).
"""
from __future__ import annotations

import math
from dataclasses import replace
from typing import Any, Mapping, Sequence

import numpy as np

from ..data.recording import MoveRecording
from ..layout import CONTROL_DT, JOINT_NAMES, LEG_JOINTS, LEGS

__all__ = ["POSE_FIELDS", "JOINT_FIELDS", "continuous_quaternions", "correction_from_timing",
           "restamp_move", "restamp"]

#: the fields of one odometry message
POSE_FIELDS = ("position", "orientation", "linear_velocity", "angular_velocity")
#: the fields of one joint-state message
JOINT_FIELDS = ("q", "dq")
#: a correction is at most this many steps (the timing check's leads reach 5)
MAX_SHIFT_STEPS = 10.0


def correction_from_timing(timing: Mapping[str, Any], dt: float = CONTROL_DT
                           ) -> dict[str, Any] | None:
    """The correction a significant timing finding (:func:`.timing.sensor_timing`'s dict)
    calls for, or None where it found nothing. The late stream is the finding's ``stream``;
    its shift the legs' where some legs alone are late, else the whole robot's."""
    if not timing.get("significant") or timing.get("stream") not in ("pose", "joint_states"):
        return None
    stream = timing["stream"]
    legs = list((timing.get("legs") or {}).get("late") or [])
    ms = abs(float(timing["legs"]["shift_ms"] if legs else timing["shift_ms"]))
    steps = ms / (dt * 1000.0)
    if not 0.0 < steps <= MAX_SHIFT_STEPS:
        return None
    if stream == "pose":
        fields, joints = list(POSE_FIELDS), []
    else:
        fields = list(JOINT_FIELDS)
        joints = [f"{leg}_{j}" for leg in (legs or LEGS) for j in LEG_JOINTS]
    what = ("the pose" if stream == "pose" else
            "the joint states" if not legs else
            " and ".join(f"the {leg.replace('_', '-')} leg" for leg in legs) + "'s joint states")
    return {"stream": stream, "shift_ms": round(ms, 2), "shift_steps": round(steps, 4),
            "fields": fields, "joints": joints, "rows_dropped": math.ceil(steps - 1e-9),
            "statement": (f"{what} re-stamped {ms:.1f} ms earlier before the search (each move "
                          f"loses its last {math.ceil(steps - 1e-9)} rows); the search, the "
                          "model after and its TestPool scores use the re-stamped data")}


def continuous_quaternions(quat: np.ndarray) -> np.ndarray:
    """(n, 4) quaternions with their signs made continuous (each row's sign flipped where its
    dot product with the row before, as flipped, is negative); a repeated row keeps its sign."""
    flip = np.cumsum(np.r_[0, (np.sum(quat[1:] * quat[:-1], axis=1) < 0)]) % 2 == 1
    return np.where(flip[:, None], -quat, quat)


def _read_later(x: np.ndarray, s: float, n: int, quaternion: bool = False) -> np.ndarray:
    """Rows ``t + s`` of ``x`` for t < n, linearly interpolated (a quaternion normalised, its
    sign made continuous first)."""
    if quaternion:
        x = continuous_quaternions(x)
    pos = np.arange(n) + s
    i0 = np.minimum(np.floor(pos).astype(int), len(x) - 1)
    i1 = np.minimum(i0 + 1, len(x) - 1)
    f = (pos - i0)[:, None]
    out = (1.0 - f) * x[i0] + f * x[i1]
    if quaternion:
        out /= np.linalg.norm(out, axis=1, keepdims=True)
    return out


def restamp_move(move: MoveRecording, correction: Mapping[str, Any]) -> MoveRecording:
    """``move`` with ``correction``'s stream read ``shift_steps`` later and its last
    ``rows_dropped`` rows dropped (module doc); refused in one line naming the move where it is
    too short to keep two rows."""
    s = float(correction["shift_steps"])
    n = move.stamps_ns.shape[0] - int(correction["rows_dropped"])
    if n < 2:
        raise ValueError(f"{move.name}: {move.stamps_ns.shape[0]} rows, too short to re-stamp by "
                         f"{s:g} steps")
    cols = [JOINT_NAMES.index(j) for j in correction.get("joints") or []]
    new: dict[str, np.ndarray] = {"stamps_ns": move.stamps_ns[:n].copy(),
                                  "cmd": move.cmd[:n - 1].copy()}
    for f in POSE_FIELDS + JOINT_FIELDS:
        x = getattr(move, f)
        if f not in correction["fields"]:
            new[f] = x[:n].copy()
        elif f in JOINT_FIELDS:
            y = x[:n].copy()
            y[:, cols] = _read_later(x[:, cols], s, n)
            new[f] = y
        else:
            new[f] = _read_later(x, s, n, quaternion=(f == "orientation"))
    out = replace(move, **new)
    out.validate()
    return out


def restamp(moves: Sequence[MoveRecording], correction: Mapping[str, Any]
            ) -> list[MoveRecording]:
    """Every move of ``moves`` re-stamped by ``correction`` (:func:`restamp_move`)."""
    return [restamp_move(m, correction) for m in moves]
