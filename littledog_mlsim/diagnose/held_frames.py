"""Held frames: a sensor stream that repeats its last frame (decision 044; both routes).

Why
---
A motion-capture system that loses the markers for a frame (occlusion, a dropped network
packet) leaves its driver two choices: publish nothing, or publish the last pose again. Many
drivers do the second, and some compute the twist as the difference of the poses they publish:
zero on a held frame, the whole jump at the next good one. An encoder bus that misses a cycle
does the same to the joint states. A held frame is no change in the robot, and nothing among a
one-step model's inputs predicts it: the model is trained on a robot that now and then stops
dead and then jumps, and its rollouts inherit the jumps. The sign is plain in the recording: a
stream whose every number equals its previous row's while the other stream moves. A walking
robot's pose never repeats to the last bit, and a clean recording of this project holds no
such row.

Method
------
1. A row of a stream is *held* where every number of its frame equals the previous row's
   (within :data:`EXACT`) while the other stream's frame changed: the pose (position and
   orientation) against the joint angles, the joint angles (all twelve) against the pose. A
   run held to a move's end has no good frame after it and does not count. The joint angles
   must also be caught up on: a run of k such rows counts only where the next frame jumps
   from the last one before the run by at least :data:`CATCH_UP` times (k + 1) typical steps
   (the motion per row over the gaps just before and just after the run). A lost frame's
   motion is caught up at once; a robot at rest, whose encoders count in steps while the
   motion capture's noise moves the pose, moves on by one step. The pose needs no such test:
   a motion capture's noise never repeats a pose to the last bit while the joints move, and
   at slow motion its steps are the noise's size, so that a catch-up cannot be read. A single
   leg's angles are not checked: on this project's clean recordings a leg's three angles
   repeat on 0.1-0.3 % of the rows.
2. Per move, the held fraction: held rows over the rows where the other stream changed.
3. A stream's finding: its pooled held fraction at least :data:`MIN_HELD_FRACTION`, and its
   per-move fractions above zero (Wilcoxon signed-rank, one-sided) or, with a reference, above
   the reference's (Mann-Whitney U, one-sided), p below ``alpha``, and the pooled fraction
   above the reference's by :data:`MIN_HELD_FRACTION`.
4. The velocity of a held frame (the twist, or the joint rates) is *held with it* where on most
   held rows it equals the previous row's, *zeroed* where it is zero (a difference of the
   published frames: the next good row then carries the whole jump), else left as measured.
5. The repair, of every stream whose own held fraction reaches :data:`MIN_HELD_FRACTION`
   (in the data, whether or not more than in the reference: a held frame is the
   measurement's fault either way): a held frame's values are interpolated linearly
   between the good frames around it (the quaternion's sign kept continuous, then
   normalised, with the recorded sign of the row before it); a held or zeroed velocity
   likewise, on the held rows and, where zeroed, on the good row after each run. No row is
   dropped and no other row changes. A reference whose own held fraction reaches
   :data:`MIN_HELD_FRACTION` is repaired the same way, so that both are whole.

Report (report.json's ``held_frames``; ``frame_repair`` where the data were repaired)
--------------------------------------------------------------------------------------
``held_frames``: ``streams`` ``[{stream ("pose" or "joint_states"), n_moves,
held_fraction, reference_held_fraction (with a reference), mean_run_frames, longest_run_frames,
velocity ("held", "zeroed" or "measured"), p_value, test, significant}]``, ``alpha``,
``min_held_fraction``, ``significant``; where significant also ``stream`` ("pose" or
"joint_states"), ``statement``, ``vocabulary`` (``{family: "other", scope: "body" for the pose,
"all" for the joint states, params: {held_fraction, mean_run_frames, stream},
statement}``; the vocabulary has no sensor family) and ``recording`` (what to do about it).
``held_frames`` also has ``reference_repaired`` (the reference's streams filled in, possibly
none) where a reference is given. ``frame_repair``: ``streams`` (the streams repaired),
``velocity``, ``rows_filled``, ``reference_repaired``, ``statement``, ``stage_as_recorded``.
"""
from __future__ import annotations

from dataclasses import replace
from typing import Any, Mapping, Sequence

import numpy as np

from ..data.recording import MoveRecording
from .restamp import continuous_quaternions

__all__ = ["EXACT", "MIN_HELD_FRACTION", "HELD_ALPHA", "CATCH_UP", "held_rows", "held_frames",
           "repair_move", "repair", "repair_plan", "reference_streams"]

#: two numbers of a frame are the same within this (a held frame repeats them to the bit)
EXACT = 1e-12
#: a stream's finding needs at least this fraction of the moving rows held
MIN_HELD_FRACTION = 0.01
#: the check's level: two streams are tested (the timing check's 1e-4 would need 14 moves
#: or more at the least; the fraction's floor, not the level, keeps clean data quiet)
HELD_ALPHA = 1e-3
#: on more than this fraction of the held rows, the velocity is held or zeroed with the frame
VELOCITY_SHARE = 0.5
#: the streams whose runs must be caught up on (module doc, 1)
CATCH_UP_STREAMS = ("joint_states",)
#: a run of k held rows counts where the next frame jumps at least this times (k + 1) typical
#: steps (the mean of the steps just before and just after the run): a lost frame's motion is
#: caught up at once, a stream standing still moves on by one step
CATCH_UP = 0.75


def _changed(x: np.ndarray) -> np.ndarray:
    """(n - 1,) rows of ``x`` (n, k) that differ from the previous row in some number."""
    return np.any(np.abs(np.diff(x, axis=0)) > EXACT, axis=1)


def _streams(move: MoveRecording) -> dict[str, tuple[np.ndarray, np.ndarray, np.ndarray]]:
    """Per stream: (its frame (n, k), the other stream's frame, its velocity (n, v)); the
    pose's quaternion with its sign made continuous, so that a step is the motion's."""
    pose = np.hstack([move.position, continuous_quaternions(move.orientation)])
    return {"pose": (pose, move.q, np.hstack([move.linear_velocity, move.angular_velocity])),
            "joint_states": (move.q, pose, move.dq)}


def held_rows(frame: np.ndarray, other: np.ndarray, catch_up: bool = True
              ) -> tuple[np.ndarray, np.ndarray]:
    """(held (n,) bool, moving (n,) bool: rows where ``other`` changed). A row is held where it
    equals the previous row while ``other`` changed, in a run not held to the end and, with
    ``catch_up``, one the stream then catches up on (module doc, 1). Row 0 is neither."""
    n = frame.shape[0]
    held = np.zeros(n, bool)
    moving = np.zeros(n, bool)
    moving[1:] = _changed(other)
    held[1:] = ~_changed(frame) & moving[1:]
    idx = np.arange(n)
    last_good = np.maximum.accumulate(np.where(held, -1, idx))
    next_good = np.minimum.accumulate(np.where(held, n, idx)[::-1])[::-1]

    def rate(t0: int, t1: int) -> float:        # motion per row from good row t0 to good t1
        return float(np.linalg.norm(frame[t1] - frame[t0])) / (t1 - t0)

    for f, last in _runs(held):
        a, b = f - 1, last + 1                 # the last frame before the run, the next after
        if b >= n:                             # held to the move's end: no catch-up to see
            held[f:] = False
            continue
        if not catch_up:
            continue
        around = []
        if a >= 1:                             # over the gap before a (another run, perhaps)
            around.append(rate(last_good[a - 1], a))
        if b + 1 < n and next_good[b + 1] < n:
            around.append(rate(b, next_good[b + 1]))
        typical = float(np.mean(around)) if around else 0.0
        jump = float(np.linalg.norm(frame[b] - frame[a]))
        if typical <= 0.0 or jump < CATCH_UP * (b - a) * typical:
            held[f:last + 1] = False           # no catch-up: a stream standing still
    return held, moving


def _runs(held: np.ndarray) -> list[tuple[int, int]]:
    """[(first, last)] row of each run of held rows."""
    d = np.diff(np.r_[0, held.astype(int), 0])
    return list(zip(np.flatnonzero(d == 1), np.flatnonzero(d == -1) - 1))


def _velocity_kind(vel: np.ndarray, held: np.ndarray) -> str:
    """"held", "zeroed" or "measured" (module doc, 4)."""
    rows = np.flatnonzero(held)
    if len(rows) == 0:
        return "measured"
    zero = np.all(np.abs(vel[rows]) <= EXACT, axis=1)
    same = np.all(np.abs(vel[rows] - vel[rows - 1]) <= EXACT, axis=1)
    if zero.mean() > VELOCITY_SHARE:
        return "zeroed"
    if same.mean() > VELOCITY_SHARE:
        return "held"
    return "measured"


def _stream_stats(moves: Sequence[MoveRecording]) -> dict[str, dict[str, Any]]:
    """Per stream: per-move held fractions, pooled counts, run lengths and the velocity kind."""
    acc: dict[str, dict[str, Any]] = {}
    for m in moves:
        for name, (frame, other, vel) in _streams(m).items():
            held, moving = held_rows(frame, other, name in CATCH_UP_STREAMS)
            a = acc.setdefault(name, {"fractions": [], "held": 0, "moving": 0, "runs": [],
                                      "kinds": []})
            a["fractions"].append(held.sum() / max(int(moving.sum()), 1))
            a["held"] += int(held.sum())
            a["moving"] += int(moving.sum())
            a["runs"] += [b - f + 1 for f, b in _runs(held)]
            if held.any():
                a["kinds"].append((_velocity_kind(vel, held), int(held.sum())))
    for a in acc.values():
        a["fractions"] = np.array(a["fractions"])
        a["fraction"] = a["held"] / max(a["moving"], 1)
        by: dict[str, int] = {}
        for k, n in a["kinds"]:
            by[k] = by.get(k, 0) + n
        a["velocity"] = max(by, key=by.get) if by else "measured"
    return acc


def held_frames(moves: Sequence[MoveRecording],
                reference: Sequence[MoveRecording] | None = None, *,
                alpha: float = HELD_ALPHA, min_fraction: float = MIN_HELD_FRACTION
                ) -> dict[str, Any]:
    """The held-frame check (module doc) of ``moves``, against the ``reference``'s moves where
    given."""
    from scipy.stats import mannwhitneyu, wilcoxon
    if not moves:
        raise ValueError("held frames: no moves")
    data = _stream_stats(moves)
    ref = _stream_stats(reference) if reference else None
    rows = []
    for name, a in data.items():
        x = a["fractions"]
        row: dict[str, Any] = {"stream": name, "n_moves": int(len(x)),
                               "held_fraction": float(a["fraction"]),
                               "mean_run_frames": (float(np.mean(a["runs"])) if a["runs"]
                                                   else 0.0),
                               "longest_run_frames": int(max(a["runs"], default=0)),
                               "velocity": a["velocity"]}
        if ref is not None:
            r = ref[name]["fractions"]
            row["reference_held_fraction"] = float(ref[name]["fraction"])
            p = (float(mannwhitneyu(x, r, alternative="greater").pvalue)
                 if np.ptp(np.r_[x, r]) > 0 else 1.0)          # every move alike: no test
            row["test"] = "Mann-Whitney U against the reference's moves, one-sided"
            excess = a["fraction"] - ref[name]["fraction"]
        else:
            p = float(wilcoxon(x, alternative="greater").pvalue) if np.any(x > 0) else 1.0
            row["test"] = "Wilcoxon signed-rank against 0, one-sided"
            excess = a["fraction"]
        row["p_value"] = p
        row["significant"] = bool(p < alpha and excess >= min_fraction)
        rows.append(row)
    out: dict[str, Any] = {"streams": rows, "alpha": float(alpha),
                           "min_held_fraction": float(min_fraction)}
    since = " more often than in the reference" if reference else ""
    found: list[dict[str, Any]] = []
    for r in rows:
        if not r["significant"]:
            continue
        plural = r["stream"] != "pose"              # "the joint rates are", "its twist is"
        vel = {"zeroed": f" {'are' if plural else 'is'} zero on a held frame and carr"
                         f"{'y' if plural else 'ies'} the whole jump at the next good one (a "
                         "difference of the published frames)",
               "held": f" {'are' if plural else 'is'} held with it"}.get(r["velocity"])
        if r["stream"] == "pose":
            what = (f"the pose repeats its last frame on {100 * r['held_fraction']:.1f} % of the "
                    f"rows where the joints move{since} (runs of {r['mean_run_frames']:.1f} "
                    f"frames on average, at most {r['longest_run_frames']})"
                    + (f"; its twist{vel}" if vel else "")
                    + ": motion-capture frames lost and held by the driver; a one-step model "
                    "reads a robot that stops and then jumps")
        else:
            what = (f"every joint angle repeats its last frame on {100 * r['held_fraction']:.1f}"
                    f" % of the rows where the body moves{since} (runs of "
                    f"{r['mean_run_frames']:.1f} frames on average, at most "
                    f"{r['longest_run_frames']})" + (f"; the joint rates{vel}" if vel else "")
                    + ": joint-state frames lost and held (a message or an encoder bus cycle "
                    "dropped); a one-step model reads joints that stop and then jump")
        found.append({"stream": r["stream"], "scope": "body" if r["stream"] == "pose" else "all",
                      "row": r, "what": what})
    out["significant"] = bool(found)
    if found:
        f = found[0]                                   # the pose first: the body's scope
        out["stream"] = f["stream"]
        out["statement"] = "; ".join(g["what"] for g in found)
        params = {"held_fraction": round(f["row"]["held_fraction"], 4),
                  "mean_run_frames": round(f["row"]["mean_run_frames"], 2),
                  "stream": f["stream"]}
        out["vocabulary"] = {"family": "other", "scope": f["scope"], "params": params,
                             "statement": f["what"] + " (no sensor family in the vocabulary: "
                             "named as other)"}
        out["recording"] = ("drop or interpolate held frames at import, or fix the stream "
                            "that holds them (markers occluded, packets lost), and record or "
                            "import again")
    return out


def _fill(x: np.ndarray, bad: np.ndarray, quaternion: bool = False) -> np.ndarray:
    """``x`` with the rows ``bad`` interpolated linearly (by row) between the good rows around
    them; only those rows change. A quaternion is interpolated with its sign made continuous,
    normalised, and given the sign of the recorded row before it."""
    good = np.flatnonzero(~bad)
    rows = np.flatnonzero(bad)
    out = x.copy()
    if len(rows) == 0:
        return out
    y = continuous_quaternions(x) if quaternion else x
    for c in range(y.shape[1]):
        out[rows, c] = np.interp(rows, good, y[good, c])
    if quaternion:
        out[rows] /= np.linalg.norm(out[rows], axis=1, keepdims=True)
        prev = x[rows - 1]
        out[rows] *= np.where(np.sum(out[rows] * prev, axis=1) < 0, -1.0, 1.0)[:, None]
    return out


def repair_move(move: MoveRecording, streams: Sequence[str],
                velocity: Mapping[str, str] | None = None) -> tuple[MoveRecording, int]:
    """(``move`` with the held frames of ``streams`` ("pose", "joint_states") filled in
    (module doc, 5), rows filled). ``velocity``: per stream, how its velocity goes with a held
    frame ("held", "zeroed" or "measured"; default: read from the move)."""
    velocity = velocity or {}
    parts = _streams(move)
    new: dict[str, np.ndarray] = {}
    filled = 0
    for s in streams:
        frame, other, vel = parts[s]
        b = held_rows(frame, other, s in CATCH_UP_STREAMS)[0]
        if not b.any():
            continue
        filled += int(b.sum())
        kind = velocity.get(s) or _velocity_kind(vel, b)
        vb = b.copy()
        if kind == "zeroed":                 # the good row after a run carries the whole jump
            vb[np.flatnonzero(b[:-1] & ~b[1:]) + 1] = True
        if s == "pose":
            new["position"] = _fill(move.position, b)
            new["orientation"] = _fill(move.orientation, b, quaternion=True)
            if kind != "measured":
                new["linear_velocity"] = _fill(move.linear_velocity, vb)
                new["angular_velocity"] = _fill(move.angular_velocity, vb)
        else:
            new["q"] = _fill(move.q, b)
            if kind != "measured":
                new["dq"] = _fill(move.dq, vb)
    out = replace(move, **new)
    out.validate()
    return out, filled


def repair(moves: Sequence[MoveRecording], streams: Sequence[str],
           velocity: Mapping[str, str] | None = None) -> tuple[list[MoveRecording], int]:
    """(every move repaired (:func:`repair_move`), rows filled in all)."""
    out, filled = [], 0
    for m in moves:
        r, f = repair_move(m, streams, velocity)
        out.append(r)
        filled += f
    return out, filled


def repair_plan(check: Mapping[str, Any]) -> dict[str, Any] | None:
    """The streams of the data the check (:func:`held_frames`'s dict) repairs, those whose own
    held fraction reaches the check's ``min_held_fraction`` (whether or not it is more than the
    reference's: a held frame is a measurement's fault either way), and their velocities'
    kinds; None where there are none."""
    rows = [r for r in check.get("streams", [])
            if r["held_fraction"] >= check.get("min_held_fraction", MIN_HELD_FRACTION)]
    if not rows:
        return None
    return {"streams": [r["stream"] for r in rows],
            "velocity": {r["stream"]: r["velocity"] for r in rows}}


def reference_streams(reference: Sequence[MoveRecording],
                      min_fraction: float = MIN_HELD_FRACTION) -> list[str]:
    """The streams of a reference recording whose own held fraction reaches ``min_fraction``
    (they are repaired too, so that data and reference are both whole)."""
    return [s for s, a in _stream_stats(reference).items() if a["fraction"] >= min_fraction]
