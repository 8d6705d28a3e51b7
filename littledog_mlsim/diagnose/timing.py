"""Sensor timing: do the joint states and the pose stamp the same instant? (both routes)

Why
---
A joint-state stream published late against the pose (or a pose stream late against the joint
states) is outside any one-step model's inputs: the model is given both as of one stamp. At one
step a late joint-state stream reads as a command delay on every joint (the measured joints
answer every command late), so the learned route names it ``command_delay @ all``; a late pose
stream it does not name at all. Neither is a change in the robot, and no search over model
inputs tells them apart. The robot's kinematics do: a walking robot stands on its feet, so the
world height of its two lowest feet, from the pose's height and attitude at a stamp and the
feet's body-frame positions (:func:`..gait.ik.forward_kinematics`) from the joint angles of the
same stamp, stays nearly constant over a move. Read the joint angles ``j`` steps later or
earlier, and the height scatters least at the streams' relative delay. A command delay, a
weaker servo or a push moves the joints and the body together and leaves that minimum where it
was.

Method
------
1. The floor: a plane through the world positions of the two lowest feet of every sample of a
   move (pose and joint angles of one stamp). A foot stands where it is one of the two lowest
   above that plane: on an inclined floor the lowest foot in the world can be a downhill foot
   in the air. Heights below are the feet's above the floor.
2. Per move, for each lead ``j`` in :data:`LEADS`, the RMS of the two lowest feet's mean
   height, the pose taken at ``t`` and the joint angles at ``t + j``, about a plane in the
   body's (x, y) position.
3. The move's lead: the minimum's position, to a fraction of a step by a parabola through the
   smallest value and its two neighbours, in ms (a step: the median of the move's stamp
   differences).
4. The shift: without a reference, the median lead (zero where both streams stamp one instant);
   with a reference recording, the median lead minus the reference's. Its test:
   Wilcoxon signed-rank against zero, or Mann-Whitney against the reference's leads, both
   two-sided. A timing finding: p below ``alpha`` and the shift at least
   :data:`MIN_SHIFT_MS` (half a control step) in size. A positive shift means the joint states
   lag the pose, a negative one that the pose lags the joint states. (Without a reference, the
   two-sided Wilcoxon test cannot go below 1e-4 with fewer than 15 moves.) Moves too short for
   the leads tried, or whose profile is flat (a robot standing still: no minimum to read), are
   skipped and counted.
5. Per leg (:func:`leg_timing`; decision 032): one leg's joint states late (its own message or
   encoder bus) moves the whole robot's lead little, since that leg stands half the time, and
   reads at one step as a set-point delay at that leg. A foot's position depends on its own
   leg's angles only, so each leg has its own profile: the RMS of its foot's height about a
   plane in the foot's (x, y) over the rows where it stands, the pose at ``t`` and that leg's
   angles at ``t + j``; the leg's lead and shift as in 3-4, each test's p times the 4 legs.
   Legs whose joint states alone are late: every leg read, the flagged legs (p below
   ``alpha``, shift at least :data:`MIN_SHIFT_MS`, one sign) not all four, and the smallest
   flagged shift at least :data:`MIN_SHIFT_MS` above the largest unflagged one. A pose
   latency moves every leg alike and is never one leg's. Such a finding comes before the whole
   robot's (whose shift is then that leg's): scope ``leg:X``, or ``side:X`` for a side's two
   legs (any other set reads as ``all``). A single foot's height is noisier than a stance
   pair's, and its minimum reads short, about half a leg's latency
   (``benchmarks/diagnose/leg_timing/README.md``), so the size is stated as "at least".

Every clean recording's median lead is the simulator's own, a little below zero and the same
on every clean recording; a late joint-state stream reads close to its latency, the more so as
a shift from the reference; and a command delay on one side stays below
:data:`MIN_SHIFT_MS` (``benchmarks/diagnose_timing/README.md``;
``benchmarks/blind_zoo/zoos/zoo12/runs/run3_timing/README.md``).

Report (:func:`sensor_timing`'s dict, report.json's ``timing``)
----------------------------------------------------------------
``n_moves`` (read), ``n_skipped`` (``{short, flat}``), ``median_ms``, ``iqr_ms`` ([25th,
75th] percentile of the moves' leads), with a reference ``reference_median_ms``,
``reference_n_moves`` and ``reference_n_skipped``; ``shift_ms``, ``p_value``,
``test``, ``alpha``, ``min_shift_ms``, ``significant`` (the whole robot's or the legs'
finding), ``legs`` (:func:`leg_timing`: ``per_leg`` ``[{leg, n_moves, median_ms, shift_ms,
p_value}]``, ``late`` (the legs found, possibly empty) and where some are ``scope`` and
``shift_ms``); where significant also ``stream`` ("joint_states" or "pose"), ``statement`` and
``vocabulary`` (``{family: "other", scope: "all" for the joint states, "body" for the pose, or
the late legs' scope, params: {latency_ms, stream, legs (the legs' finding only)},
statement}``, the vocabulary has no sensor-latency family), and ``recording`` (what to do
about it). Where it names a late stream, the diagnosis re-stamps the data before its search
(:mod:`.restamp`, decision 043).
"""
from __future__ import annotations

from typing import Any, Sequence

import numpy as np

from ..data.recording import MoveRecording
from ..gait.ik import forward_kinematics
from ..layout import LEGS
from ..rotations import quat_to_matrix

__all__ = ["LEADS", "MIN_SHIFT_MS", "TIMING_ALPHA", "move_lead", "lead_profile",
           "sensor_timing"]

#: the joint angles' leads over the pose that are tried, in control steps
LEADS = tuple(range(-5, 6))
#: the smallest shift reported, in ms: half a 10 ms control step
MIN_SHIFT_MS = 5.0
#: the test's level (the learned route's, ``LearnedOptions.alpha``)
TIMING_ALPHA = 1e-4
#: a move whose profile varies less than this over the leads [m] has no minimum to read (a
#: robot standing still); a clean walking move's varies by about 1 mm
MIN_PROFILE_RANGE_M = 1e-5
#: a leg's profile is read only where its foot stands (one of the two lowest) on this many rows
MIN_STANCE_ROWS = 20


def _plane_rms(h: np.ndarray, xy: np.ndarray) -> float:
    """RMS of heights ``h`` about a plane in the body's (x, y) ``xy`` (a level or inclined
    floor is not a timing error)."""
    A = np.column_stack([np.ones(len(h)), xy])
    coef, *_ = np.linalg.lstsq(A, h, rcond=None)
    return float(np.sqrt(np.mean((h - A @ coef) ** 2)))


def _profiles(move: MoveRecording, leads: Sequence[int] = LEADS
              ) -> tuple[np.ndarray, np.ndarray]:
    """(len(leads),) whole-robot profile and (len(leads), 4) per-leg profiles [m] of one move.

    The floor: a plane through the world positions of the two lowest feet of every sample (the
    pose and the joint angles of one stamp); a foot stands on the rows where it is one of the
    two lowest above that plane (on an inclined floor the lowest in the world can be a downhill
    foot in the air). Heights are the feet's above the floor. Whole robot: the RMS of the two
    lowest feet's mean height about a plane in the body's (x, y), the pose at t and every joint
    angle at t + lead. Per leg: the RMS of that leg's foot height about a plane in the foot's
    (x, y) over the rows where it stands, the pose at t and that leg's angles at t + lead (a
    foot's position depends on its own leg's angles only, so one forward kinematics per lead
    serves every leg); NaN where the leg stands on fewer than :data:`MIN_STANCE_ROWS` rows."""
    n = move.q.shape[0]
    R = quat_to_matrix(move.orientation)
    feet_all = forward_kinematics(move.q)                              # (n, 4, 3) body frame

    def world(t: np.ndarray, lead: int) -> np.ndarray:                  # (len(t), 4, 3)
        return move.position[t][:, None, :] + np.einsum("tij,tfj->tfi", R[t],
                                                        feet_all[t + lead])

    P0 = world(np.arange(n), 0)
    low = np.take_along_axis(P0, np.argsort(P0[..., 2], axis=1)[:, :2, None], axis=1)
    low = low.reshape(-1, 3)
    floor, *_ = np.linalg.lstsq(np.column_stack([np.ones(len(low)), low[:, :2]]), low[:, 2],
                                rcond=None)

    def above(P: np.ndarray) -> np.ndarray:
        return P[..., 2] - (floor[0] + P[..., 0] * floor[1] + P[..., 1] * floor[2])

    stands = np.zeros((n, 4), dtype=bool)                        # the two lowest above the floor
    np.put_along_axis(stands, np.argsort(above(P0), axis=1)[:, :2], True, axis=1)
    whole, legs = [], []
    for j in leads:
        t = np.arange(max(0, -j), min(n, n - j))
        if len(t) < 3:
            raise ValueError(f"{move.name}: too short ({n} samples) for a lead of {j} steps")
        P = world(t, j)
        height = above(P)
        whole.append(_plane_rms(np.sort(height, axis=1)[:, :2].mean(axis=1),
                                move.position[t, :2]))
        row = []
        for leg in range(4):
            s = stands[t, leg]
            row.append(_plane_rms(height[s, leg], P[s, leg, :2]) if s.sum() >= MIN_STANCE_ROWS
                       else float("nan"))
        legs.append(row)
    return np.asarray(whole), np.asarray(legs)


def lead_profile(move: MoveRecording, leads: Sequence[int] = LEADS) -> np.ndarray:
    """(len(leads),) RMS [m] of the two lowest feet's mean height above the floor over the
    move, about a plane in the body's (x, y) position, the pose at t and the joint angles at
    t + lead (:func:`_profiles`)."""
    return _profiles(move, leads)[0]


def _minimum_ms(p: np.ndarray, leads: Sequence[int], dt: float) -> float:
    """The lead [ms] at the profile's minimum (a parabola through the smallest value and its
    neighbours; at an end of ``leads``, that end); NaN where the profile is flat
    (:data:`MIN_PROFILE_RANGE_M`) or not read."""
    if not np.all(np.isfinite(p)) or p.max() - p.min() < MIN_PROFILE_RANGE_M:
        return float("nan")
    i = int(np.argmin(p))
    x = float(leads[i])
    if 0 < i < len(p) - 1:
        a, b, c = p[i - 1], p[i], p[i + 1]
        den = a - 2.0 * b + c
        if den > 0:
            x += 0.5 * (a - c) / den
    return x * dt * 1e3


def move_leads(move: MoveRecording, leads: Sequence[int] = LEADS) -> tuple[float, np.ndarray]:
    """The whole robot's lead [ms] of the joint angles over the pose (:func:`move_lead`) and
    each leg's (4,) (its own angles only, over its stance rows); NaN where not read."""
    whole, legs = _profiles(move, leads)
    dt = float(np.median(np.diff(move.stamps_ns))) * 1e-9
    return (_minimum_ms(whole, leads, dt),
            np.array([_minimum_ms(legs[:, i], leads, dt) for i in range(4)]))


def move_lead(move: MoveRecording, leads: Sequence[int] = LEADS) -> float:
    """The lead [ms] of the joint angles over the pose that makes the feet's height steadiest
    (a parabola through the smallest and its neighbours; at an end of ``leads``, that end);
    NaN where the profile is flat (:data:`MIN_PROFILE_RANGE_M`). The step is the median of the
    move's stamp differences."""
    return move_leads(move, leads)[0]


def _leads(moves: Sequence[MoveRecording], what: str
           ) -> tuple[np.ndarray, np.ndarray, dict[str, int]]:
    """The whole robot's leads [ms] of the moves that can be read, each leg's (moves, 4) (NaN
    where that leg's profile is not read), and how many moves were skipped: too short for the
    leads tried, or a flat profile (no minimum to read)."""
    span = 2 * max(abs(v) for v in LEADS) + 3
    short = [m for m in moves if m.q.shape[0] < span]
    read = [move_leads(m) for m in moves if m.q.shape[0] >= span]
    leads = np.array([w for w, _ in read])
    legs = np.array([g for _, g in read]).reshape(-1, 4)
    flat = int(np.isnan(leads).sum())
    legs, leads = legs[~np.isnan(leads)], leads[~np.isnan(leads)]
    if len(leads) == 0:
        raise ValueError(f"sensor timing: no move of the {what} can be read ({len(short)} "
                         f"shorter than {span} samples, {flat} with a flat profile, e.g. "
                         "standing still)")
    return leads, legs, {"short": len(short), "flat": flat}


def _leg_scope(legs: Sequence[str]) -> str:
    """The vocabulary's scope of the legs whose joint states are late: one leg, or a side's two
    legs; any other set is read as all joints (the vocabulary has no scope for it)."""
    if len(legs) == 1:
        return f"leg:{legs[0]}"
    for side in ("left", "right"):
        if sorted(legs) == sorted(leg for leg in LEGS if leg.endswith(side)):
            return f"side:{side}"
    return "all"


def leg_timing(legs: np.ndarray, ref_legs: np.ndarray | None, alpha: float,
               min_shift_ms: float) -> dict[str, Any]:
    """Each leg's shift (its own joint angles against the pose, over its stance rows) and the
    legs whose joint states alone are late (module doc, 5): ``per_leg`` (``leg``, ``n_moves``,
    ``median_ms``, ``shift_ms``, ``p_value`` times the 4 legs tested, capped at 1), ``late``
    (the legs found, possibly empty) and, where some are, ``scope`` and ``shift_ms`` (their
    median shift)."""
    from scipy.stats import mannwhitneyu, wilcoxon
    per = []
    for i, leg in enumerate(LEGS):
        x = legs[:, i][np.isfinite(legs[:, i])]
        r = (None if ref_legs is None
             else ref_legs[:, i][np.isfinite(ref_legs[:, i])])
        if len(x) < 3 or (r is not None and len(r) < 3):
            per.append({"leg": leg, "n_moves": int(len(x)), "median_ms": None,
                        "shift_ms": None, "p_value": 1.0})
            continue
        if r is None:
            shift = float(np.median(x))
            p = float(wilcoxon(x).pvalue) if np.any(x != 0) else 1.0
        else:
            shift = float(np.median(x) - np.median(r))
            p = float(mannwhitneyu(x, r, alternative="two-sided").pvalue)
        per.append({"leg": leg, "n_moves": int(len(x)), "median_ms": float(np.median(x)),
                    "shift_ms": shift, "p_value": min(1.0, p * len(LEGS))})
    flagged = [r for r in per if r["shift_ms"] is not None and r["p_value"] < alpha
               and abs(r["shift_ms"]) >= min_shift_ms]
    rest = [abs(r["shift_ms"]) for r in per if r not in flagged and r["shift_ms"] is not None]
    late: list[str] = []
    if (all(r["shift_ms"] is not None for r in per)        # every leg read: the others are
            and 0 < len(flagged) < len(LEGS)               # known not to be late
            and len({np.sign(r["shift_ms"]) for r in flagged}) == 1
            and min(abs(r["shift_ms"]) for r in flagged) - max(rest, default=0.0)
            >= min_shift_ms):
        late = [r["leg"] for r in flagged]
    out: dict[str, Any] = {"per_leg": per, "late": late}
    if late:
        out["scope"] = _leg_scope(late)
        out["shift_ms"] = float(np.median([r["shift_ms"] for r in flagged]))
    return out


def sensor_timing(moves: Sequence[MoveRecording],
                  reference: Sequence[MoveRecording] | None = None, *,
                  alpha: float = TIMING_ALPHA, min_shift_ms: float = MIN_SHIFT_MS
                  ) -> dict[str, Any]:
    """The timing check of the joint states against the pose (module doc) on ``moves``, against
    the ``reference`` recording's moves where given."""
    from scipy.stats import mannwhitneyu, wilcoxon
    if not moves:
        raise ValueError("sensor timing: no moves")
    leads, legs, skipped = _leads(moves, "data")
    out: dict[str, Any] = {
        "n_moves": int(len(leads)), "n_skipped": skipped,
        "median_ms": float(np.median(leads)),
        "iqr_ms": [float(v) for v in np.percentile(leads, [25, 75])],
        "alpha": float(alpha), "min_shift_ms": float(min_shift_ms)}
    ref_legs = None
    if reference:
        ref, ref_legs, ref_skipped = _leads(reference, "reference")
        out["reference_n_moves"] = int(len(ref))
        out["reference_n_skipped"] = ref_skipped
        out["reference_median_ms"] = float(np.median(ref))
        shift = float(np.median(leads) - np.median(ref))
        p = float(mannwhitneyu(leads, ref, alternative="two-sided").pvalue)
        out["test"] = "Mann-Whitney U against the reference's moves, two-sided"
    else:
        shift = float(np.median(leads))
        p = float(wilcoxon(leads).pvalue) if np.any(leads != 0) else 1.0
        out["test"] = "Wilcoxon signed-rank against 0, two-sided"
    out["shift_ms"] = shift
    out["p_value"] = p
    out["legs"] = lg = leg_timing(legs, ref_legs, alpha, min_shift_ms)
    whole = bool(p < alpha and abs(shift) >= min_shift_ms)
    out["significant"] = whole or bool(lg["late"])
    since = " more than in the reference" if reference else ""
    if lg["late"]:             # some legs' own joint states: the whole robot's shift is theirs
        ms = abs(lg["shift_ms"])
        which = " and ".join(f"the {leg.replace('_', '-')} leg" for leg in lg["late"])
        verb = "lag" if lg["shift_ms"] > 0 else "lead"
        what = (f"{which}'s joint states {verb} the pose by at least {ms:.0f} ms{since}, the "
                f"other legs' by less than {min_shift_ms:g} ms (that leg's joint-state message or "
                "encoder bus late, or stamped early); a one-step model reads it as a set-point "
                "delay at that leg")
        out.update(stream="joint_states", statement=what, vocabulary={
            "family": "other", "scope": lg["scope"],
            "params": {"latency_ms": round(ms, 1), "stream": "joint_states",
                       "legs": list(lg["late"])},
            "statement": what + " (no sensor-latency family in the vocabulary: named as other)"},
            recording=(f"re-stamp {which}'s joint states about {ms:.0f} ms earlier or more (or "
                       "fix that publisher's stamps) and record or import again"))
    elif whole:
        late = "joint_states" if shift > 0 else "pose"
        ms = abs(shift)
        edge = max(abs(v) for v in LEADS) * 10.0 - 1.0   # near the leads' end (10 ms steps)
        about = "at least" if abs(out["median_ms"]) >= edge else "about"
        if late == "joint_states":
            what = (f"the joint states lag the pose by {about} {ms:.0f} ms{since} (a joint-state "
                    "message published late, or the pose stamped early); a one-step model "
                    "reads it as a command delay on every joint")
        else:
            what = (f"the pose lags the joint states by {about} {ms:.0f} ms{since} (a pose "
                    "message published late, as from a motion-capture pipeline, or the joint "
                    "states stamped early)")
        out["stream"] = late
        out["statement"] = what
        out["vocabulary"] = {"family": "other", "scope": "all" if late == "joint_states"
                             else "body", "params": {"latency_ms": round(ms, 1),
                                                     "stream": late},
                             "statement": what + " (no sensor-latency family in the "
                             "vocabulary: named as other)"}
        out["recording"] = (f"re-stamp the {'joint states' if late == 'joint_states' else 'pose'}"
                            f" {ms:.0f} ms earlier (or fix the publisher's stamps) and record or "
                            "import again")
    return out
