"""Message conversion shared by the nodes: arrays <-> ROS messages, and the command rule.

Everything here translates; the numbers come from the core. Topics and frames are those of
docs/interface.md §2; arrays of 12 joint values are in ``layout.JOINT_NAMES`` order.

The command rule (``check_command``) lives in ``sim/command.py`` (no ROS types) and is
re-exported here.
"""
from __future__ import annotations

from array import array
from typing import Mapping

import numpy as np
from builtin_interfaces.msg import Time
from diagnostic_msgs.msg import DiagnosticStatus, KeyValue
from nav_msgs.msg import Odometry
from rosgraph_msgs.msg import Clock
from sensor_msgs.msg import JointState

from ..layout import BASE_FRAME, CONTROL_DT_NS, JOINT_NAMES, N_STATE, ODOM_FRAME, STATE_NAMES
from ..sim.command import REJECT_REASONS, CommandCheck, check_command
from ..sim.command import joint_permutation as _permutation

__all__ = [
    "REJECT_REASONS", "CommandCheck", "check_command", "stamp", "stamp_ns", "clock_msg",
    "joint_state_msg", "odometry_msg", "state_msg", "state_array", "status_msg",
    "joint_state_arrays",
    "odometry_arrays", "status_values", "UNKNOWN_COVARIANCE", "CONTROL_DT_NS",
    "JointStateWriter", "OdometryWriter", "TfOdometry", "tf_message_type", "robot_description",
]

_JOINT_LIST = list(JOINT_NAMES)
_STATE_LIST = list(STATE_NAMES)
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


class JointStateWriter:
    """``joint_state_msg(ns, q, dq)`` for the per-step topic, reusing one message (rclpy
    serialises at ``publish``, so the next step may overwrite it)."""

    def __init__(self) -> None:
        self.msg = JointState()
        self.msg.name = _JOINT_LIST

    def __call__(self, ns: int, q: np.ndarray, dq: np.ndarray) -> JointState:
        msg = self.msg
        msg.header.stamp = stamp(ns)
        msg.position = _doubles(q)
        msg.velocity = _doubles(dq)
        return msg


class OdometryWriter:
    """``odometry_msg(...)`` for the per-step topic, reusing one message (see
    :class:`JointStateWriter`)."""

    def __init__(self) -> None:
        self.msg = Odometry()
        self.msg.header.frame_id = ODOM_FRAME
        self.msg.child_frame_id = BASE_FRAME

    def __call__(self, ns: int, position, orientation, linear, angular,
                 pose_covariance: np.ndarray | None = None,
                 twist_covariance: np.ndarray | None = None) -> Odometry:
        msg = self.msg
        msg.header.stamp = stamp(ns)
        pose, twist = msg.pose, msg.twist
        _set_xyz(pose.pose.position, position)
        o = pose.pose.orientation
        o.x, o.y, o.z, o.w = orientation.tolist()
        _set_xyz(twist.twist.linear, linear)
        _set_xyz(twist.twist.angular, angular)
        pose.covariance = UNKNOWN_COVARIANCE if pose_covariance is None else pose_covariance
        twist.covariance = UNKNOWN_COVARIANCE if twist_covariance is None else twist_covariance
        return msg


def _set_xyz(v, a: np.ndarray) -> None:
    v.x, v.y, v.z = a.tolist()


def _doubles(a: np.ndarray):
    """A float64 array as what a sequence<double> field takes fastest (array.array)."""
    return array("d", np.ascontiguousarray(a, dtype=np.float64).tobytes())


def tf_message_type():
    """tf2_msgs/TFMessage, or None where tf2_msgs is not installed (the pip wheels)."""
    try:
        from tf2_msgs.msg import TFMessage
    except ImportError:
        return None
    return TFMessage


class TfOdometry:
    """The ``odom -> base_link`` transform of a pose as a ``tf_type`` message (TFMessage, or a
    stand-in with a ``transforms`` list), reusing one message."""

    def __init__(self, tf_type) -> None:
        from geometry_msgs.msg import TransformStamped

        self.tf = TransformStamped()
        self.tf.header.frame_id = ODOM_FRAME
        self.tf.child_frame_id = BASE_FRAME
        self.msg = tf_type()
        self.msg.transforms = [self.tf]

    def __call__(self, ns: int, position: np.ndarray, orientation: np.ndarray):
        tf = self.tf
        tf.header.stamp = stamp(ns)
        t, r = tf.transform.translation, tf.transform.rotation
        t.x, t.y, t.z = position.tolist()
        r.x, r.y, r.z, r.w = orientation.tolist()
        self.msg.transforms = [tf]
        return self.msg


def robot_description() -> str:
    """The LittleDog URDF as ``/robot_description`` carries it: the model's root link ``body``
    gets a parent ``base_link`` (fixed joint, identity: the same frame, the odometry's child
    frame), so ``odom -> base_link`` on /tf plus robot_state_publisher give the whole tree."""
    from ..robot.config import URDF_PATH

    text = URDF_PATH.read_text(encoding="utf-8")
    root = ('<link name="base_link"/>\n  <joint name="base_link_to_body" type="fixed">\n'
            '    <parent link="base_link"/>\n    <child link="body"/>\n'
            '    <origin xyz="0 0 0" rpy="0 0 0"/>\n  </joint>\n  ')
    i = text.index('<link name="body">')
    return text[:i] + root + text[i:]


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
