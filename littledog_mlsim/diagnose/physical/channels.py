"""Output channels of the physical route: what is compared with the measurement, and how.

Each move is re-simulated from measured states as 1 s segments (starts 0, 1, 2, 3 s) and, for
the long horizon, the whole 4 s move; the outputs are the 12 joint angles, the body position
(body frame of the measured heading for the segments, odom for the replay), roll, pitch and
yaw: 18 channels x 2 horizon classes = :data:`CHANNELS`, each with its per-move SSE.
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import Any, Mapping, Sequence

import numpy as np

from ...data.recording import MoveRecording
from ...layout import JOINT_NAMES

__all__ = ["SEG_STARTS", "SEG_LEN", "MIN_STEPS", "seg_starts", "SCREEN_SEGMENTS", "DEFAULT_HORIZONS_S", "CHANNELS", "N_CH",
           "SHORT", "LONG", "Measured", "measured", "errors", "sse", "flat", "horizon_errors",
           "channels_of"]

SEG_STARTS = (0, 100, 200, 300)
SEG_LEN = 100
#: a move needs this many control steps for the physical route: its last segment then starts
#: earlier, overlapping the third (:func:`seg_starts`); shorter moves are left out
MIN_STEPS = SEG_STARTS[2] + SEG_LEN
SCREEN_SEGMENTS = (1, 3)          # the segments a joint family's sensitivity is simulated on
DEFAULT_HORIZONS_S = (0.1, 0.5, 1.0, 4.0)
BODY_CH = ("x", "y", "z", "roll", "pitch", "yaw")
CHANNELS = tuple([f"short:q_{j}" for j in JOINT_NAMES] + [f"short:{c}_b" if c in "xy" else
                                                          f"short:{c}" for c in BODY_CH]
                 + [f"long:q_{j}" for j in JOINT_NAMES] + [f"long:{c}_odom" if c in "xy"
                                                           else f"long:{c}" for c in BODY_CH])
N_CH = len(CHANNELS)
SHORT = np.arange(18)
LONG = np.arange(18, 36)


def channels_of(scope: str) -> np.ndarray:
    """The channels of a vocabulary scope: the body's twelve (position and attitude, both
    horizon classes), or a joint scope's angles (both horizon classes)."""
    from ..families.scopes import scope_joints
    if scope == "body":
        return np.array([k for k, c in enumerate(CHANNELS) if ":q_" not in c])
    names = {f"q_{JOINT_NAMES[j]}" for j in scope_joints(scope)}
    return np.array([k for k, c in enumerate(CHANNELS) if c.split(":")[1] in names])


def rpy(orient: np.ndarray) -> np.ndarray:
    from ...rotations import quat_to_rpy
    return np.asarray(quat_to_rpy(orient))


@dataclass
class Measured:
    """Measured outputs aligned with :func:`.resim.simulate`'s."""

    segs: np.ndarray      # (4, 100, 18)
    full: np.ndarray      # (400, 18)


def seg_starts(n_steps: int) -> tuple[int, ...]:
    """The 1 s segments' start steps of a move of ``n_steps`` control steps: SEG_STARTS, the last
    one moved earlier on a move shorter than 4 s (an imported move cut a few steps short)."""
    if n_steps < MIN_STEPS:
        raise ValueError(f"a move of {n_steps} steps is shorter than the physical route's "
                         f"{MIN_STEPS}")
    return SEG_STARTS[:3] + (min(SEG_STARTS[3], n_steps - SEG_LEN),)


def measured(rec: MoveRecording) -> Measured:
    y = np.hstack([rec.q, rec.position, rpy(rec.orientation)])
    segs = np.stack([y[k0 + 1:k0 + 1 + SEG_LEN] for k0 in seg_starts(y.shape[0] - 1)])
    return Measured(segs, y[1:])


def _wrap(a: np.ndarray) -> np.ndarray:
    return (a + np.pi) % (2.0 * np.pi) - np.pi


def errors(sim: Mapping[str, np.ndarray], meas: Measured) -> dict[str, np.ndarray]:
    """Simulated minus measured outputs per channel: ``short`` (4, 100, 18) with the position
    error in the body frame of the measured heading, ``long`` (400, 18) in odom."""
    ms = meas.segs[sim["seg_idx"]]
    e = sim["segs"] - ms
    e[..., 17] = _wrap(e[..., 17])
    yaw = ms[..., 17]
    c, s = np.cos(yaw), np.sin(yaw)
    ex, ey = e[..., 12].copy(), e[..., 13].copy()
    e[..., 12] = c * ex + s * ey
    e[..., 13] = -s * ex + c * ey
    out = {"short": e}
    if "full" in sim:
        f = sim["full"] - meas.full
        f[..., 17] = _wrap(f[..., 17])
        out["long"] = f
    return out


def sse(err: Mapping[str, np.ndarray]) -> np.ndarray:
    """Per-channel SSE (36,) of one move's errors (NaN for a missing horizon class)."""
    out = np.full(N_CH, np.nan)
    out[SHORT] = (err["short"] ** 2).sum(axis=(0, 1))
    if "long" in err:
        out[LONG] = (err["long"] ** 2).sum(axis=0)
    return out


def flat(err: Mapping[str, np.ndarray], w: np.ndarray, long: bool) -> np.ndarray:
    """One move's errors as one weighted vector (sqrt of the channel weights)."""
    parts = [(err["short"] * np.sqrt(w[SHORT])).ravel()]
    if long:
        parts.append((err["long"] * np.sqrt(w[LONG])).ravel())
    return np.concatenate(parts)


def horizon_errors(errs: Sequence[Mapping[str, np.ndarray]],
                   horizons_s: Sequence[float] = DEFAULT_HORIZONS_S) -> dict[str, Any]:
    """Mean errors at each horizon: joint-angle RMS [rad], body-frame and odom (x, y) error
    [m], |yaw| error [rad]. Horizons up to 1 s come from the 1 s segments, longer ones from the
    4 s replay (the segment start 0)."""
    out = {}
    for h in horizons_s:
        k = int(round(h / 0.01)) - 1
        if k < SEG_LEN:
            e = np.stack([x["short"][:, k] for x in errs])          # (M, 4, 18)
            xy_b = np.hypot(e[..., 12], e[..., 13])
            out[f"{h:g}s"] = {"q_rms_rad": float(np.sqrt(np.mean(e[..., :12] ** 2))),
                              "xy_body_m": float(np.mean(xy_b)),
                              "yaw_rad": float(np.mean(np.abs(e[..., 17]))), "steps": k + 1,
                              "from": "1 s segments (starts 0, 1, 2, 3 s)"}
        elif all("long" in x for x in errs):
            kk = min([k] + [x["long"].shape[0] - 1 for x in errs])
            e = np.stack([x["long"][kk] for x in errs])             # (M, 18)
            out[f"{h:g}s"] = {"q_rms_rad": float(np.sqrt(np.mean(e[:, :12] ** 2))),
                              "xy_odom_m": float(np.mean(np.hypot(e[:, 12], e[:, 13]))),
                              "yaw_rad": float(np.mean(np.abs(e[:, 17]))), "steps": kk + 1,
                              "from": "4 s replay from the measured state at step 0"}
    return out
