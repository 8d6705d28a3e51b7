"""Message conversion shared by the nodes: arrays <-> ROS messages, and the command rule.

Everything here translates; the numbers come from the core. Topics and frames are those of
docs/interface.md §2; arrays of 12 joint values are in ``layout.JOINT_NAMES`` order.

Command rule (``check_command``), applied by both simulators to every ``/littledog/cmd``:

- ``name`` must hold each of the 12 contract joint names exactly once (any order). Anything else
  (unknown, missing or duplicated names) rejects the command (reason ``names``).
- ``position`` must have one value per name (reason ``length``). ``velocity``/``effort`` are
  ignored (the contract leaves them empty).
- every position must be finite (reason ``nonfinite``): NaN or +-inf rejects the command.
- positions outside ``layout.JOINT_LOWER``/``JOINT_UPPER`` are clipped to the limits and the
  command is used (reason ``clipped``; the pybullet servo clips the same way).

A rejected command is not used at all: the simulator keeps holding the previous valid command.
"""
from __future__ import annotations

from dataclasses import dataclass
from functools import lru_cache
from typing import Mapping

import numpy as np
from builtin_interfaces.msg import Time
from diagnostic_msgs.msg import DiagnosticStatus, KeyValue
from nav_msgs.msg import Odometry
from rosgraph_msgs.msg import Clock
from sensor_msgs.msg import JointState

from ..layout import (
    BASE_FRAME,
    JOINT_LOWER,
    JOINT_NAMES,
    JOINT_UPPER,
    N_JOINTS,
    N_STATE,
    ODOM_FRAME,
    STATE_NAMES,
)

__all__ = [
    "REJECT_REASONS", "CommandCheck", "check_command", "stamp", "stamp_ns", "clock_msg",
    "joint_state_msg", "odometry_msg", "state_msg", "state_array", "status_msg",
    "joint_state_arrays",
    "odometry_arrays", "status_values", "UNKNOWN_COVARIANCE",
]

REJECT_REASONS: tuple[str, ...] = ("names", "length", "nonfinite")
_JOINT_LIST = list(JOINT_NAMES)
_STATE_LIST = list(STATE_NAMES)
_INDEX = {n: i for i, n in enumerate(JOINT_NAMES)}
UNKNOWN_COVARIANCE = np.zeros(36)
UNKNOWN_COVARIANCE[0] = -1.0  # "unknown" per the message convention


# ---------------------------------------------------------------------------------------------
# time


def stamp(ns: int) -> Time:
    """builtin_interfaces/Time of a non-negative time in nanoseconds."""
    ns = int(ns)
    return Time(sec=ns // 1_000_000_000, nanosec=ns % 1_000_000_000)


def stamp_ns(t: Time) -> int:
    return int(t.sec) * 1_000_000_000 + int(t.nanosec)


def clock_msg(ns: int) -> Clock:
    return Clock(clock=stamp(ns))


# ---------------------------------------------------------------------------------------------
# commands


@dataclass(frozen=True)
class CommandCheck:
    """Outcome of ``check_command``: ``u`` (12,) in contract order, or None if rejected.

    ``reason``: None (used as sent), ``"clipped"`` (used after clipping to the joint limits) or
    one of ``REJECT_REASONS``; ``detail`` is a short human-readable explanation.
    """

    u: np.ndarray | None
    reason: str | None = None
    detail: str = ""

    @property
    def accepted(self) -> bool:
        return self.u is not None


@lru_cache(maxsize=64)
def _permutation(names: tuple[str, ...]) -> np.ndarray | str:
    """Index into ``names`` of each contract joint, or why ``names`` is not usable."""
    unknown = [n for n in names if n not in _INDEX]
    if unknown:
        return f"unknown joint name(s) {', '.join(repr(n) for n in unknown[:3])}"
    if len(set(names)) != len(names):
        return "duplicated joint names"
    if len(names) != N_JOINTS:
        missing = [n for n in JOINT_NAMES if n not in names]
        return f"{len(names)} joint names, missing {', '.join(missing[:3])}"
    where = {n: i for i, n in enumerate(names)}
    return np.array([where[n] for n in JOINT_NAMES])


def check_command(names, positions) -> CommandCheck:
    """Apply the command rule (module doc) to a JointState's ``name`` and ``position``."""
    perm = _permutation(tuple(names))
    if isinstance(perm, str):
        return CommandCheck(None, "names", perm)
    pos = np.asarray(positions, dtype=np.float64)
    if pos.shape != (N_JOINTS,):
        return CommandCheck(None, "length", f"{pos.size} positions for {N_JOINTS} names")
    u = pos[perm]
    if not np.all(np.isfinite(u)):
        bad = [JOINT_NAMES[i] for i in np.flatnonzero(~np.isfinite(u))]
        return CommandCheck(None, "nonfinite", f"NaN/inf for {', '.join(bad[:3])}")
    clipped = np.clip(u, JOINT_LOWER, JOINT_UPPER)
    if np.any(clipped != u):
        bad = [JOINT_NAMES[i] for i in np.flatnonzero(clipped != u)]
        return CommandCheck(clipped, "clipped", f"outside the joint limits: {', '.join(bad[:3])}")
    return CommandCheck(u)


# ---------------------------------------------------------------------------------------------
# outgoing messages


def joint_state_msg(ns: int, q: np.ndarray, dq: np.ndarray | None = None) -> JointState:
    """JointState in contract order; ``dq`` None gives an empty velocity (a command)."""
    msg = JointState()
    msg.header.stamp = stamp(ns)
    msg.name = _JOINT_LIST
    msg.position = np.asarray(q, dtype=np.float64).tolist()
    if dq is not None:
        msg.velocity = np.asarray(dq, dtype=np.float64).tolist()
    return msg


def odometry_msg(ns: int, position, orientation, linear, angular,
                 pose_covariance: np.ndarray | None = None,
                 twist_covariance: np.ndarray | None = None) -> Odometry:
    """Odometry odom -> base_link; quaternion (x, y, z, w); twist in base_link.

    Covariances: 36 values (row-major 6x6) or None for "unknown" (-1 in [0], zeros elsewhere).
    """
    msg = Odometry()
    msg.header.stamp = stamp(ns)
    msg.header.frame_id = ODOM_FRAME
    msg.child_frame_id = BASE_FRAME
    p, o = msg.pose.pose.position, msg.pose.pose.orientation
    p.x, p.y, p.z = (float(v) for v in position)
    o.x, o.y, o.z, o.w = (float(v) for v in orientation)
    v, w = msg.twist.twist.linear, msg.twist.twist.angular
    v.x, v.y, v.z = (float(a) for a in linear)
    w.x, w.y, w.z = (float(a) for a in angular)
    msg.pose.covariance = (UNKNOWN_COVARIANCE if pose_covariance is None
                           else np.asarray(pose_covariance, dtype=np.float64).reshape(36))
    msg.twist.covariance = (UNKNOWN_COVARIANCE if twist_covariance is None
                            else np.asarray(twist_covariance, dtype=np.float64).reshape(36))
    return msg


def state_msg(ns: int, state: np.ndarray) -> JointState:
    """The paper's 33-element state s_t as a stamped named vector: a JointState whose ``name``
    is ``layout.STATE_NAMES`` and ``position`` the values (velocity/effort empty)."""
    msg = JointState()
    msg.header.stamp = stamp(ns)
    msg.name = _STATE_LIST
    msg.position = np.asarray(state, dtype=np.float64).tolist()
    return msg


def state_array(msg: JointState) -> np.ndarray:
    """s_t (33,) from a ``state_msg``; ValueError if the names are not ``STATE_NAMES``."""
    if list(msg.name) != _STATE_LIST or len(msg.position) != N_STATE:
        raise ValueError("not a state message (names must be layout.STATE_NAMES)")
    return np.asarray(msg.position, dtype=np.float64)


def status_msg(name: str, values: Mapping[str, object], level: int = 0,
               message: str = "") -> DiagnosticStatus:
    """DiagnosticStatus with ``values`` as key/value strings (counters, rates, latencies)."""
    return DiagnosticStatus(level=bytes([level]), name=name, message=message,
                            values=[KeyValue(key=k, value=str(v)) for k, v in values.items()])


# ---------------------------------------------------------------------------------------------
# incoming messages (tests, recorder)


def joint_state_arrays(msg: JointState) -> tuple[np.ndarray, np.ndarray]:
    """(q, dq) (12,) each, in contract order, from a JointState (names matched)."""
    perm = _permutation(tuple(msg.name))
    if isinstance(perm, str):
        raise ValueError(perm)
    q = np.asarray(msg.position, dtype=np.float64)[perm]
    dq = (np.asarray(msg.velocity, dtype=np.float64)[perm] if len(msg.velocity)
          else np.zeros(0))
    return q, dq


def odometry_arrays(msg: Odometry) -> dict[str, np.ndarray]:
    """position (3,), orientation (4,) xyzw, linear/angular velocity (3,), covariances (36,)."""
    p, o = msg.pose.pose.position, msg.pose.pose.orientation
    v, w = msg.twist.twist.linear, msg.twist.twist.angular
    return {"position": np.array([p.x, p.y, p.z]), "orientation": np.array([o.x, o.y, o.z, o.w]),
            "linear_velocity": np.array([v.x, v.y, v.z]),
            "angular_velocity": np.array([w.x, w.y, w.z]),
            "pose_covariance": np.asarray(msg.pose.covariance, dtype=np.float64),
            "twist_covariance": np.asarray(msg.twist.covariance, dtype=np.float64)}


def status_values(msg: DiagnosticStatus) -> dict[str, str]:
    return {kv.key: kv.value for kv in msg.values}
