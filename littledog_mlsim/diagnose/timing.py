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
1. Per move, for each lead ``j`` in :data:`LEADS`, the RMS of the two lowest feet's world
   height, the pose taken at ``t`` and the joint angles at ``t + j``, about a plane in the
   body's (x, y) position (so that an inclined floor is not read as a timing error).
2. The move's lead: the minimum's position, to a fraction of a step by a parabola through the
   smallest value and its two neighbours, in ms (a step: the median of the move's stamp
   differences).
3. The shift: without a reference, the median lead (zero where both streams stamp one instant);
   with a reference recording, the median lead minus the reference's. Its test:
   Wilcoxon signed-rank against zero, or Mann-Whitney against the reference's leads, both
   two-sided.
4. A timing finding: p below ``alpha`` and the shift at least :data:`MIN_SHIFT_MS` (half a
   control step) in size. A positive shift means the joint states lag the pose, a negative one
   that the pose lags the joint states. (Without a reference, the two-sided Wilcoxon test
   cannot go below 1e-4 with fewer than 15 moves.) Moves too short for the leads tried, or
   whose profile is flat (a robot standing still: no minimum to read), are skipped and
   counted.

On zoo12 (``benchmarks/blind_zoo/zoos/zoo12/runs/run3_timing``), the clean seeds' and the
reference's median leads are -1.6 to -1.8 ms (the simulator's own, the same on every clean
recording), the joint-state latency of 20 ms reads +18.2 ms (a shift of +19.8 ms from the
reference), and a 30 ms command delay on one side -2.9 ms.

Report (:func:`sensor_timing`'s dict, report.json's ``timing``)
----------------------------------------------------------------
``n_moves`` (read), ``n_skipped`` (``{short, flat}``), ``median_ms``, ``iqr_ms`` ([25th,
75th] percentile of the moves' leads), with a reference ``reference_median_ms``,
``reference_n_moves`` and ``reference_n_skipped``; ``shift_ms``, ``p_value``,
``test``, ``alpha``, ``min_shift_ms``, ``significant``; where significant also ``stream``
("joint_states" or "pose"), ``statement`` and ``vocabulary`` (``{family: "other", scope: "all"
for the joint states or "body" for the pose, params: {latency_ms, stream}, statement}``, the
vocabulary has no sensor-latency family), and ``recording`` (what to do about it).
"""
from __future__ import annotations

from typing import Any, Sequence

import numpy as np

from ..data.recording import MoveRecording
from ..gait.ik import forward_kinematics
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


def lead_profile(move: MoveRecording, leads: Sequence[int] = LEADS) -> np.ndarray:
    """(len(leads),) RMS [m] of the two lowest feet's world height over the move about a plane
    in the body's (x, y) position (a level or inclined floor), the pose at t and the joint
    angles at t + lead."""
    n = move.q.shape[0]
    R = quat_to_matrix(move.orientation)
    feet_all = forward_kinematics(move.q)                              # (n, 4, 3) body frame
    out = []
    for j in leads:
        t = np.arange(max(0, -j), min(n, n - j))
        if len(t) < 3:
            raise ValueError(f"{move.name}: too short ({n} samples) for a lead of {j} steps")
        height = move.position[t, 2][:, None] + np.einsum("tj,tfj->tf", R[t, 2],
                                                          feet_all[t + j])
        low = np.sort(height, axis=1)[:, :2].mean(axis=1)
        # about a plane in the body's (x, y): an inclined floor is not a timing error
        A = np.column_stack([np.ones(len(t)), move.position[t, :2]])
        coef, *_ = np.linalg.lstsq(A, low, rcond=None)
        out.append(float(np.sqrt(np.mean((low - A @ coef) ** 2))))
    return np.asarray(out)


def move_lead(move: MoveRecording, leads: Sequence[int] = LEADS) -> float:
    """The lead [ms] of the joint angles over the pose that makes the feet's height steadiest
    (a parabola through the smallest and its neighbours; at an end of ``leads``, that end);
    NaN where the profile is flat (:data:`MIN_PROFILE_RANGE_M`). The step is the median of the
    move's stamp differences."""
    p = lead_profile(move, leads)
    if p.max() - p.min() < MIN_PROFILE_RANGE_M:
        return float("nan")
    dt = float(np.median(np.diff(move.stamps_ns))) * 1e-9
    i = int(np.argmin(p))
    x = float(leads[i])
    if 0 < i < len(p) - 1:
        a, b, c = p[i - 1], p[i], p[i + 1]
        den = a - 2.0 * b + c
        if den > 0:
            x += 0.5 * (a - c) / den
    return x * dt * 1e3


def _leads(moves: Sequence[MoveRecording], what: str) -> tuple[np.ndarray, dict[str, int]]:
    """The leads [ms] of the moves that can be read, and how many were skipped: too short
    for the leads tried, or a flat profile (no minimum to read)."""
    span = 2 * max(abs(v) for v in LEADS) + 3
    short = [m for m in moves if m.q.shape[0] < span]
    leads = np.array([move_lead(m) for m in moves if m.q.shape[0] >= span])
    flat = int(np.isnan(leads).sum())
    leads = leads[~np.isnan(leads)]
    if len(leads) == 0:
        raise ValueError(f"sensor timing: no move of the {what} can be read ({len(short)} "
                         f"shorter than {span} samples, {flat} with a flat profile, e.g. "
                         "standing still)")
    return leads, {"short": len(short), "flat": flat}


def sensor_timing(moves: Sequence[MoveRecording],
                  reference: Sequence[MoveRecording] | None = None, *,
                  alpha: float = TIMING_ALPHA, min_shift_ms: float = MIN_SHIFT_MS
                  ) -> dict[str, Any]:
    """The timing check of the joint states against the pose (module doc) on ``moves``, against
    the ``reference`` recording's moves where given."""
    from scipy.stats import mannwhitneyu, wilcoxon
    if not moves:
        raise ValueError("sensor timing: no moves")
    leads, skipped = _leads(moves, "data")
    out: dict[str, Any] = {
        "n_moves": int(len(leads)), "n_skipped": skipped,
        "median_ms": float(np.median(leads)),
        "iqr_ms": [float(v) for v in np.percentile(leads, [25, 75])],
        "alpha": float(alpha), "min_shift_ms": float(min_shift_ms)}
    if reference:
        ref, ref_skipped = _leads(reference, "reference")
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
    out["significant"] = bool(p < alpha and abs(shift) >= min_shift_ms)
    if out["significant"]:
        late = "joint_states" if shift > 0 else "pose"
        ms = abs(shift)
        edge = max(abs(v) for v in LEADS) * 10.0 - 1.0   # near the leads' end (10 ms steps)
        about = "at least" if abs(out["median_ms"]) >= edge else "about"
        since = " more than in the reference" if reference else ""
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
                            "import again; the served model is not changed by this finding")
    return out
