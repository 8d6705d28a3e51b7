"""What a dataset holds: bags per move type and split, samples, and how each move type moved.

Used by ``littledog-mlsim info`` (and ``make run``) to print what was recorded.
"""
from __future__ import annotations

import os
from dataclasses import dataclass, field

import numpy as np

from ..layout import DATASET_MOVE_TYPES
from ..rotations import quat_to_rpy
from .dataset import load_moves, read_index
from .recording import MoveRecording


@dataclass
class TypeSummary:
    move_type: str
    n_train: int = 0
    n_test: int = 0
    n_samples: int = 0
    forward_m: list[float] = field(default_factory=list)   # displacement in the start heading frame
    left_m: list[float] = field(default_factory=list)
    yaw_change_rad: list[float] = field(default_factory=list)
    max_abs_roll_pitch: float = 0.0
    min_height_m: float = np.inf
    problems: list[str] = field(default_factory=list)   # "<bag>: <why>" for moves that fail move_problems


@dataclass
class DatasetSummary:
    path: str
    info: dict
    types: dict[str, TypeSummary]
    bags_checked: bool

    @property
    def n_bags(self) -> int:
        return sum(t.n_train + t.n_test for t in self.types.values())

    @property
    def n_samples(self) -> int:
        return sum(t.n_samples for t in self.types.values())


def move_motion(rec: MoveRecording) -> tuple[float, float, float]:
    """(forward, left, yaw change) of a move, in the frame of its starting heading [m, m, rad]."""
    rpy = quat_to_rpy(rec.orientation)
    yaw = np.unwrap(rpy[:, 2])
    d = rec.position[-1, :2] - rec.position[0, :2]
    c, s = np.cos(yaw[0]), np.sin(yaw[0])
    return float(c * d[0] + s * d[1]), float(-s * d[0] + c * d[1]), float(yaw[-1] - yaw[0])


# Where each move type must go (docs/interface.md §3): sign of forward, left and yaw motion.
_FORWARD = {"F": 1, "FL": 1, "FR": 1, "DL": 1, "DR": 1, "B": -1, "BL": -1, "BR": -1}
_LEFT = {"L": 1, "DL": 1, "R": -1, "DR": -1}
_TURN = {"FL": 1, "BL": 1, "FR": -1, "BR": -1}
UPRIGHT_LIMIT_RAD = 0.3
MIN_BODY_HEIGHT_M = 0.10   # body origin; the shell's underside is 25 mm below it (robot/littledog.urdf)


def move_problems(rec: MoveRecording) -> list[str]:
    """Why a move is not a good trot of its type (empty when it is).

    Upright: |roll|, |pitch| < 0.3 rad and the body origin above 0.10 m throughout. Direction, in
    the start heading frame: F/FL/FR/DL/DR forward and B/BL/BR backward by more than 4 cm; L/DL
    left and R/DR right by more than 4 cm; straight moves (F, B) sideways less than half their
    forward motion and sideways moves (L, R) forward less than half their sideways motion;
    FL/BL turn left (yaw up) and FR/BR right by more than 0.3 rad; F/B turn less than 0.4 rad,
    sideways and diagonal moves less than 1.2 rad (the soft-servo robot drifts in yaw when it
    steps sideways); S stays within 5 cm and 0.3 rad.
    """
    out: list[str] = []
    t = rec.move_type
    rpy = quat_to_rpy(rec.orientation)
    tilt = float(np.abs(rpy[:, :2]).max())
    if tilt >= UPRIGHT_LIMIT_RAD:
        out.append(f"tilted {tilt:.2f} rad (limit {UPRIGHT_LIMIT_RAD})")
    if rec.position[:, 2].min() <= MIN_BODY_HEIGHT_M:
        out.append(f"body down to {rec.position[:, 2].min():.3f} m")
    fwd, left, dyaw = move_motion(rec)
    return out + motion_problems(t, fwd, left, dyaw)


def motion_problems(t: str, fwd: float, left: float, dyaw: float) -> list[str]:
    """Why a motion (forward, left, yaw change, in the start heading frame) does not fit move
    type ``t`` (the direction part of ``move_problems``; empty when it fits)."""
    out: list[str] = []
    fs, ls, ts = _FORWARD.get(t, 0), _LEFT.get(t, 0), _TURN.get(t, 0)
    if t == "S":
        if np.hypot(fwd, left) >= 0.05 or abs(dyaw) >= 0.3:
            out.append(f"standing move went {np.hypot(fwd, left):.3f} m, {dyaw:+.2f} rad")
        return out
    if fs and fs * fwd <= 0.04:
        out.append(f"forward motion {fwd:+.3f} m has the wrong sign or is too small")
    if ls and ls * left <= 0.04:
        out.append(f"sideways motion {left:+.3f} m has the wrong sign or is too small")
    if fs and not ls and not ts and abs(left) >= 0.5 * abs(fwd):
        out.append(f"straight move drifted sideways {left:+.3f} m")
    if ls and not fs and abs(fwd) >= 0.5 * abs(left):
        out.append(f"sideways move drifted forward {fwd:+.3f} m")
    if ts and ts * dyaw <= 0.3:
        out.append(f"yaw change {dyaw:+.2f} rad has the wrong sign or is too small")
    elif not ts and abs(dyaw) >= (1.2 if ls else 0.4):
        out.append(f"yaw drifted {dyaw:+.2f} rad")
    return out


def summarise_dataset(path: str | os.PathLike, check_bags: bool = True) -> DatasetSummary:
    """Read dataset.yaml and (with ``check_bags``) every bag, which also validates them."""
    index = read_index(path)
    types: dict[str, TypeSummary] = {}
    for e in index.entries:
        ts = types.setdefault(e.move_type, TypeSummary(e.move_type))
        if e.split == "train":
            ts.n_train += 1
        else:
            ts.n_test += 1
    if check_bags:
        for rec in load_moves(path, split="all"):
            ts = types[rec.move_type]
            ts.n_samples += max(rec.n_steps - 1, 0)
            fwd, left, dyaw = move_motion(rec)
            ts.forward_m.append(fwd)
            ts.left_m.append(left)
            ts.yaw_change_rad.append(dyaw)
            rpy = quat_to_rpy(rec.orientation)
            ts.max_abs_roll_pitch = max(ts.max_abs_roll_pitch, float(np.abs(rpy[:, :2]).max()))
            ts.min_height_m = min(ts.min_height_m, float(rec.position[:, 2].min()))
            ts.problems += [f"{rec.name}: {p}" for p in move_problems(rec)]
    order = [t for t in DATASET_MOVE_TYPES if t in types]
    return DatasetSummary(str(path), dict(index.info), {t: types[t] for t in order}, check_bags)


def format_summary(s: DatasetSummary) -> str:
    def short(v):   # long lists (an import's bag list) as a count; mappings left out below
        return f"[{len(v)} items]" if isinstance(v, list) and len(v) > 3 else v
    info = ", ".join(f"{k}={short(v)}" for k, v in s.info.items()
                     if k != "types" and not isinstance(v, dict))
    n_train = sum(t.n_train for t in s.types.values())
    lines = [f"dataset {s.path}: {s.n_bags} bags ({n_train} TrainPool / {s.n_bags - n_train} TestPool)"
             + (f", {s.n_samples} samples (features 45 -> responses 33)" if s.bags_checked else ""),
             f"  recorded with {info}"]
    if not s.bags_checked:
        lines += [f"  {t}: {v.n_train} train / {v.n_test} test" for t, v in s.types.items()]
        return "\n".join(lines)
    lines.append("  per type: mean [min, max] over its moves, in the frame of each move's start heading")
    lines.append("  type  train test samples  forward [m]           left [m]              yaw change [rad]      max|roll,pitch|  min z [m]")
    for t, v in s.types.items():
        def rng(x: list[float]) -> str:
            return f"{np.mean(x):+.3f} [{np.min(x):+.2f},{np.max(x):+.2f}]".ljust(21)
        lines.append(f"  {t:<4}  {v.n_train:>5} {v.n_test:>4} {v.n_samples:>7}  {rng(v.forward_m)} "
                     f"{rng(v.left_m)} {rng(v.yaw_change_rad)} {v.max_abs_roll_pitch:>15.3f}  {v.min_height_m:9.3f}")
    problems = [p for v in s.types.values() for p in v.problems]
    if problems:
        lines.append(f"  {len(problems)} problem(s): " + "; ".join(problems))
    else:
        lines.append("  every move stayed upright and went where its type says")
    return "\n".join(lines)


# Nominal heading of each type's motion in the start heading frame [rad] (0 = forward, left +).
_HEADING = {"F": 0.0, "FL": 0.0, "FR": 0.0, "B": np.pi, "BL": np.pi, "BR": np.pi,
            "L": np.pi / 2, "R": -np.pi / 2, "DL": np.pi / 4, "DR": -np.pi / 4}


def infer_move_type(rec: MoveRecording) -> str | None:
    """The move type a recording's motion fits, or None when it fits none.

    The motion is scaled to a move of ``layout.MOVE_DURATION_S`` (the mean body velocity and yaw
    rate over the recording, times 4 s), so that a segment of any length is judged by the same
    thresholds as ``move_problems`` (which defines the types). The recording must also stay
    upright. When several types fit (e.g. a straight move with a yaw change between 0.3 and 0.4
    rad fits F and FL), the turning type wins over the straight one, and otherwise the type
    whose nominal direction is closest to the direction of travel.
    """
    from ..layout import CONTROL_DT, MOVE_DURATION_S, MOVE_TYPES

    rpy = quat_to_rpy(rec.orientation)
    if float(np.abs(rpy[:, :2]).max()) >= UPRIGHT_LIMIT_RAD or \
            rec.position[:, 2].min() <= MIN_BODY_HEIGHT_M:
        return None
    duration = max(rec.n_steps, 1) * CONTROL_DT
    k = MOVE_DURATION_S / duration
    fwd, left, dyaw = (k * v for v in move_motion(rec))
    fits = [t for t in MOVE_TYPES if not motion_problems(t, fwd, left, dyaw)]
    if len(fits) <= 1:
        return fits[0] if fits else None
    turning = [t for t in fits if t in _TURN]
    if turning:
        fits = turning
    if "S" in fits:
        return "S"
    heading = np.arctan2(left, fwd)
    return min(fits, key=lambda t: abs(float(np.angle(np.exp(1j * (heading - _HEADING[t]))))))
