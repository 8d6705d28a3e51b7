"""One move as one rosbag2 bag (docs/interface.md §3), written and read with ``rosbags``.

A bag is a directory ``<TYPE>_<NN>`` (``layout.bag_name``) in rosbag2 format version 9, storage
``mcap`` (default) or ``sqlite3``, holding three topics stamped on one 100 Hz clock, with
``header.stamp`` equal to the bag (receive) time of every message:

- ``/littledog/cmd`` (``sensor_msgs/msg/JointState``): N messages at ``stamps_ns[:N]``, ``name`` =
  the 12 joint names, ``position`` = desired angles for step k -> k+1; velocity/effort empty.
- ``/littledog/joint_states`` (``sensor_msgs/msg/JointState``): N+1 messages at ``stamps_ns``,
  contract joint order, ``position`` and ``velocity``; effort empty.
- ``/littledog/odom`` (``nav_msgs/msg/Odometry``): N+1 messages at ``stamps_ns``, frame ``odom``,
  child ``base_link``, pose = measured position/orientation in odom, twist in base_link; both
  covariances are "unknown" (all zero except ``covariance[0] = -1``).

Offered QoS recorded in the metadata: reliable, volatile, keep-last 10 (docs/interface.md §2).

``read_bag`` is strict, because a silently mangled move poisons a regression data set: every
problem raises ``BagError`` with one line naming the bag and the topic. It accepts what the
contract allows beyond what ``write_bag`` produces: extra topics (ignored), ``/littledog/cmd`` and
``/littledog/joint_states`` names in any order (matched by name), and a command stream of N+1
messages (one per measurement; the last is ignored) as well as N. It requires the 100 Hz clock
exactly: consecutive stamps differ by exactly ``CONTROL_DT_NS`` (simulated and replayed data are
stamped by a step counter; there is no jitter tolerance). It does not require 400 steps.
``rosbags`` returns messages sorted by bag time whatever their order in the file, so messages
written out of order are reported through their header stamps (which then disagree with the bag
time) or as duplicated stamps; a bag whose stamps are consistent but stored out of order is
read as if stored in order.

The odometry quaternion must be unit length to 1e-6 (both when writing and when reading): a
sensor model that perturbs orientation must renormalise.

Speed: where every message of a topic has the first's length and the first's bytes outside its
stamp, its float fields and its alignment padding (one layout: the same names, frames and
sizes, as a recorder writes them), the topic's floats and stamps are read as arrays straight
from the CDR bytes (``decode.one_layout``); the first and last messages are decoded and checked
as usual, and their arrays must equal the decoder's bit for bit. Otherwise every message is
decoded on its own. The arrays are the same either way (``benchmarks/bag_read``).

Writing is the mirror image, a block of messages at a time: the block's first message of a
topic is serialized, the block's messages are laid out as it with their own stamps and numbers
(``decode.like_first``), and the layout is used where the block's first and last messages,
serialized on their own, come out the same byte for byte; otherwise each message is serialized
on its own. The bytes stored are the same either way (``benchmarks/bag_write``).
"""
from __future__ import annotations

import os
import re
from functools import lru_cache
from pathlib import Path
from typing import Any, Callable, Iterator

import numpy as np

from ..fileio import atomic_directory
from ..layout import (
    BASE_FRAME,
    CONTROL_DT_NS,
    JOINT_NAMES,
    DATASET_MOVE_TYPES,
    N_JOINTS,
    ODOM_FRAME,
    TOPIC_CMD,
    TOPIC_JOINT_STATES,
    TOPIC_ODOM,
    joint_permutation,
)
from .decode import like_first, one_layout
from .recording import MoveRecording

__all__ = ["BagError", "read_bag", "write_bag", "move_type_from_name", "STORAGES"]

MSGTYPE_JOINT_STATE = "sensor_msgs/msg/JointState"
MSGTYPE_ODOMETRY = "nav_msgs/msg/Odometry"
EXPECTED_MSGTYPES: dict[str, str] = {
    TOPIC_CMD: MSGTYPE_JOINT_STATE,
    TOPIC_JOINT_STATES: MSGTYPE_JOINT_STATE,
    TOPIC_ODOM: MSGTYPE_ODOMETRY,
}
STORAGES: tuple[str, ...] = ("mcap", "sqlite3")
QUATERNION_NORM_TOL = 1e-6
_MAX_STAMP_NS = (2**31 - 1) * 1_000_000_000  # builtin_interfaces/Time.sec is int32
_BAG_NAME_RE = re.compile(r"^(?P<type>[A-Z]+)_(?P<index>\d+)$")


class BagError(ValueError):
    """A bag that does not hold a valid move. ``str(err)`` is one line naming bag and topic."""

    def __init__(self, bag: str | os.PathLike, topic: str | None, reason: str) -> None:
        self.bag = str(bag)
        self.topic = topic
        self.reason = " ".join(str(reason).split())  # one line, whatever the cause said
        where = f"topic {topic}" if topic else "whole bag"
        super().__init__(f"bag {self.bag} ({where}): {self.reason}")

    def __reduce__(self):  # picklable across process pools despite the 3-argument __init__
        return (type(self), (self.bag, self.topic, self.reason))


@lru_cache(maxsize=1)
def _typestore():
    from rosbags.typesys import Stores, get_typestore

    return get_typestore(Stores.ROS2_JAZZY)


def _qos():
    from rosbags.interfaces import (
        Qos, QosDurability, QosHistory, QosLiveliness, QosReliability, QosTime,
    )

    zero = QosTime(0, 0)  # rmw "default" (infinite) durations
    return [Qos(QosHistory.KEEP_LAST, 10, QosReliability.RELIABLE, QosDurability.VOLATILE,
                zero, zero, QosLiveliness.AUTOMATIC, zero, False)]


def move_type_from_name(name: str) -> str:
    """The move type of a bag directory name ``<TYPE>_<NN>``; ValueError if it is not one.

    TYPE is one of the 11 move types or ``U`` (``layout.UNKNOWN_MOVE_TYPE``: an imported move
    of unknown type).
    """
    m = _BAG_NAME_RE.match(name)
    if m is None or m.group("type") not in DATASET_MOVE_TYPES:
        raise ValueError(f"{name!r} is not a bag name <TYPE>_<NN> with TYPE in "
                         f"{DATASET_MOVE_TYPES}")
    return m.group("type")


# ---------------------------------------------------------------------------------------------
# writing


def _check_writable(rec: MoveRecording) -> np.ndarray:
    """Validate ``rec`` so that what we write is exactly what ``read_bag`` accepts."""
    rec.validate()
    stamps = np.asarray(rec.stamps_ns)
    if stamps.ndim != 1 or stamps.shape[0] < 2 or not np.issubdtype(stamps.dtype, np.integer):
        raise ValueError(f"{rec.name}: stamps_ns must be an integer array of >= 2 stamps")
    stamps = stamps.astype(np.int64)
    if stamps[0] < 0 or stamps[-1] > _MAX_STAMP_NS:
        raise ValueError(f"{rec.name}: stamps_ns outside the ROS time range")
    if np.any(np.diff(stamps) != CONTROL_DT_NS):
        raise ValueError(f"{rec.name}: stamps_ns are not one {CONTROL_DT_NS} ns clock")
    norm = np.linalg.norm(rec.orientation, axis=1)
    if np.any(np.abs(norm - 1.0) > QUATERNION_NORM_TOL):
        raise ValueError(f"{rec.name}: orientation quaternions are not unit length")
    return stamps


def write_bag(path: str | os.PathLike, rec: MoveRecording, storage: str = "mcap") -> None:
    """Write one move as a rosbag2 bag directory at ``path`` (docs/interface.md §3).

    The bag's name is the directory name (``layout.bag_name``), not ``rec.name``. The parent
    directory must exist; ``path`` must not (FileExistsError). The bag is written into a hidden
    temporary sibling directory and renamed into place, so a failure leaves nothing behind
    (:func:`..fileio.atomic_directory`; only a hard kill can leave a ``.<name>.partial-*``
    directory, which the next write of the same bag removes). ValueError if ``rec`` is
    inconsistent (shapes, NaN/inf, stamps not on one 100 Hz clock, non-unit quaternions) or
    ``storage`` is not ``mcap``/``sqlite3``.
    """
    from rosbags.rosbag2 import StoragePlugin, Writer

    path = Path(path)
    if storage not in STORAGES:
        raise ValueError(f"storage must be one of {STORAGES}, got {storage!r}")
    if path.exists() or path.is_symlink():
        raise FileExistsError(f"{path} exists already, not overwriting")
    if not path.parent.is_dir():
        raise FileNotFoundError(f"{path.parent} is not a directory")
    stamps = _check_writable(rec)
    plugin = StoragePlugin.MCAP if storage == "mcap" else StoragePlugin.SQLITE3

    # staged is named after the bag, so the storage file the Writer creates inside is too
    with atomic_directory(path, create=False) as staged:
        with Writer(staged, version=9, storage_plugin=plugin) as writer:
            _write_messages(writer, rec, stamps)


def _write_messages(writer, rec: MoveRecording, stamps: np.ndarray) -> None:
    ts = _typestore()
    T = ts.types
    Time, Header = T["builtin_interfaces/msg/Time"], T["std_msgs/msg/Header"]
    JointState, Odometry = T[MSGTYPE_JOINT_STATE], T[MSGTYPE_ODOMETRY]
    Pose, PoseCov = T["geometry_msgs/msg/Pose"], T["geometry_msgs/msg/PoseWithCovariance"]
    Twist, TwistCov = T["geometry_msgs/msg/Twist"], T["geometry_msgs/msg/TwistWithCovariance"]
    Point, Quat = T["geometry_msgs/msg/Point"], T["geometry_msgs/msg/Quaternion"]
    Vector3 = T["geometry_msgs/msg/Vector3"]

    qos = _qos()
    conns = {
        topic: writer.add_connection(topic, msgtype, typestore=ts, offered_qos_profiles=qos)
        for topic, msgtype in EXPECTED_MSGTYPES.items()
    }
    names = list(JOINT_NAMES)
    empty = np.zeros(0, dtype=np.float64)
    unknown_cov = np.zeros(36, dtype=np.float64)
    unknown_cov[0] = -1.0
    f64 = lambda a: np.ascontiguousarray(a, dtype=np.float64)  # noqa: E731

    cmd, q, dq = f64(rec.cmd), f64(rec.q), f64(rec.dq)
    pos, ori = f64(rec.position), f64(rec.orientation)
    lin, ang = f64(rec.linear_velocity), f64(rec.angular_velocity)
    n = rec.n_steps

    def stamp(k: int):
        t = int(stamps[k])
        return Time(sec=t // 1_000_000_000, nanosec=t % 1_000_000_000)

    def joint_state(k: int):
        return JointState(header=Header(stamp=stamp(k), frame_id=""), name=names,
                          position=q[k].copy(), velocity=dq[k].copy(), effort=empty)

    def odometry(k: int):
        return Odometry(
            header=Header(stamp=stamp(k), frame_id=ODOM_FRAME), child_frame_id=BASE_FRAME,
            pose=PoseCov(
                pose=Pose(position=Point(x=pos[k, 0], y=pos[k, 1], z=pos[k, 2]),
                          orientation=Quat(x=ori[k, 0], y=ori[k, 1], z=ori[k, 2], w=ori[k, 3])),
                covariance=unknown_cov),
            twist=TwistCov(
                twist=Twist(linear=Vector3(x=lin[k, 0], y=lin[k, 1], z=lin[k, 2]),
                            angular=Vector3(x=ang[k, 0], y=ang[k, 1], z=ang[k, 2])),
                covariance=unknown_cov))

    def command(k: int):
        return JointState(header=Header(stamp=stamp(k), frame_id=""), name=names,
                          position=cmd[k].copy(), velocity=empty, effort=empty)

    topics = {
        TOPIC_JOINT_STATES: _serialized(ts, MSGTYPE_JOINT_STATE, joint_state, stamps,
                                        {"position": q, "velocity": dq}),
        TOPIC_ODOM: _serialized(ts, MSGTYPE_ODOMETRY, odometry, stamps,
                                {"pose": np.hstack([pos, ori]), "twist": np.hstack([lin, ang])}),
        TOPIC_CMD: _serialized(ts, MSGTYPE_JOINT_STATE, command, stamps[:n],
                               {"position": cmd[:n]}),
    }
    # Messages in time order, commands after the measurement they were computed from.
    for k in range(n + 1):
        t = int(stamps[k])
        writer.write(conns[TOPIC_JOINT_STATES], t, next(topics[TOPIC_JOINT_STATES]))
        writer.write(conns[TOPIC_ODOM], t, next(topics[TOPIC_ODOM]))
        if k < n:
            writer.write(conns[TOPIC_CMD], t, next(topics[TOPIC_CMD]))


#: messages laid out at a time (``_serialized``): bounds the memory of a long bag's write
LAYOUT_BLOCK = 2048


def _serialized(ts, msgtype: str, message: Callable[[int], Any], stamps: np.ndarray,
                fields: dict[str, np.ndarray]) -> Iterator[bytes]:
    """The CDR bytes of ``message(k)`` for every k of ``stamps``, in order, ``LAYOUT_BLOCK``
    messages at a time: each block's first message serialized, the block's messages laid out as
    it with their own header stamps and float fields (``decode.like_first``), kept where the
    block's first and last rows equal those messages serialized on their own, byte for byte;
    otherwise the block's every message serialized on its own.

    The layout holds only where the messages differ in nothing but their header stamp and the
    float fields given: ``_write_messages`` builds every message of a topic with the same
    frames, joint names, constant covariances and sequence lengths. The first-and-last check
    guards the layout's offsets, not that precondition.
    """
    n = stamps.shape[0]
    for a in range(0, n, LAYOUT_BLOCK):
        b = min(a + LAYOUT_BLOCK, n)
        first = bytes(ts.serialize_cdr(message(a), msgtype))
        buf = like_first(first, msgtype, stamps[a:b],
                         {k: v[a:b] for k, v in fields.items()})
        if (buf is not None and buf[0].tobytes() == first
                and buf[-1].tobytes() == bytes(ts.serialize_cdr(message(b - 1), msgtype))):
            for row in buf:
                yield row.tobytes()
        else:
            yield first
            for k in range(a + 1, b):
                yield ts.serialize_cdr(message(k), msgtype)


# ---------------------------------------------------------------------------------------------
# reading


def read_bag(path: str | os.PathLike, move_type: str | None = None) -> MoveRecording:
    """Read one move's bag back into a ``MoveRecording`` named after the bag directory.

    ``move_type`` defaults to the ``<TYPE>`` of the directory name ``<TYPE>_<NN>``. Raises
    ``BagError`` (one line naming bag and topic) for anything that is not a valid move: missing
    directory, corrupt or truncated storage, missing topic, wrong message type, undecodable
    message, NaN/inf, duplicated or out-of-order stamps, a gap in the 100 Hz clock, header
    stamps that differ from the bag time, topics not on one clock, wrong frames, wrong number,
    duplicated or unknown joint names, non-unit quaternions.
    """
    from rosbags.rosbag2 import Reader

    path = Path(path)
    bag = str(path)
    if move_type is None:
        try:
            move_type = move_type_from_name(path.name)
        except ValueError as exc:
            raise BagError(bag, None, f"cannot tell the move type ({exc}); "
                                      "pass move_type") from None
    elif move_type not in DATASET_MOVE_TYPES:
        raise BagError(bag, None, f"unknown move type {move_type!r}")
    if not path.is_dir():
        raise BagError(bag, None, "no such bag directory")

    try:
        reader = Reader(path)
        reader.open()
    except Exception as exc:  # rosbags raises several types for damaged metadata/storage
        raise BagError(bag, None, f"corrupt or truncated bag: {type(exc).__name__}: {exc}") from exc
    try:
        js = _read_topic(reader, bag, TOPIC_JOINT_STATES)
        odom = _read_topic(reader, bag, TOPIC_ODOM)
        cmd = _read_topic(reader, bag, TOPIC_CMD)
    finally:
        try:
            reader.close()
        except Exception:
            pass

    stamps = js["stamps"]
    if stamps.shape[0] < 2:
        raise BagError(bag, TOPIC_JOINT_STATES, f"{stamps.shape[0]} messages, need at least 2")
    _check_same_clock(bag, TOPIC_ODOM, odom["stamps"], stamps)
    n = stamps.shape[0] - 1
    n_cmd = cmd["stamps"].shape[0]
    if n_cmd not in (n, n + 1):
        raise BagError(bag, TOPIC_CMD, f"{n_cmd} messages, expected {n} or {n + 1} for "
                                       f"{n + 1} joint states")
    _check_same_clock(bag, TOPIC_CMD, cmd["stamps"], stamps[:n_cmd])

    return MoveRecording(
        name=path.name, move_type=move_type, stamps_ns=stamps,
        cmd=cmd["position"][:n], q=js["position"], dq=js["velocity"],
        position=odom["position"], orientation=odom["orientation"],
        linear_velocity=odom["linear_velocity"], angular_velocity=odom["angular_velocity"],
    )


def _check_same_clock(bag: str, topic: str, got: np.ndarray, ref: np.ndarray) -> None:
    if got.shape != ref.shape:
        raise BagError(bag, topic, f"{got.shape[0]} messages, expected {ref.shape[0]} "
                                   f"(one per {TOPIC_JOINT_STATES} message)")
    bad = np.flatnonzero(got != ref)
    if bad.size:
        k = int(bad[0])
        raise BagError(bag, topic, f"message {k} stamped {got[k]} ns, but "
                                   f"{TOPIC_JOINT_STATES} message {k} is at {ref[k]} ns "
                                   "(topics not on one clock)")


def _read_topic(reader, bag: str, topic: str) -> dict[str, np.ndarray]:
    """All messages of ``topic`` as arrays; checks types, stamps, clock, names, finiteness."""
    expected = EXPECTED_MSGTYPES[topic]
    conns = [c for c in reader.connections if c.topic == topic]
    if not conns:
        raise BagError(bag, topic, "missing topic")
    for c in conns:
        if c.msgtype != expected:
            raise BagError(bag, topic, f"message type {c.msgtype}, expected {expected}")
        digest = getattr(c, "digest", "") or ""
        if digest.startswith("RIHS01_") and digest != _typestore().hash_rihs01(expected):
            raise BagError(bag, topic, f"{expected} definition differs from ROS 2 Jazzy's "
                                       f"(type hash {digest})")
    ts = _typestore()
    decode = _decode_odom if topic == TOPIC_ODOM else _decode_joint_state
    bag_times: list[int] = []
    raws: list = []
    try:
        for _, t, raw in reader.messages(connections=conns):
            bag_times.append(int(t))
            raws.append(raw)
    except Exception as exc:
        raise BagError(bag, topic, f"corrupt or truncated data after {len(raws)} messages: "
                                   f"{type(exc).__name__}: {exc}") from exc
    columns = _same_layout_columns(raws, topic, ts, expected, bag)
    if columns is not None:
        header_times, fields = columns
    else:
        header_times, rows = [], []
        try:
            for raw in raws:
                msg = ts.deserialize_cdr(raw, expected)
                header_times.append(int(msg.header.stamp.sec) * 1_000_000_000
                                    + int(msg.header.stamp.nanosec))
                rows.append(decode(msg, bag, topic, len(rows)))
        except BagError:
            raise
        except Exception as exc:
            raise BagError(bag, topic, f"corrupt or truncated data after {len(rows)} messages: "
                                       f"{type(exc).__name__}: {exc}") from exc
        fields = list(zip(*rows))
    expected_count = sum(int(getattr(c, "msgcount", 0) or 0) for c in conns)
    if expected_count and expected_count != len(raws):
        raise BagError(bag, topic, f"truncated: metadata lists {expected_count} messages, "
                                   f"read {len(raws)}")
    if not raws:
        raise BagError(bag, topic, "no messages")

    t = np.asarray(bag_times, dtype=np.int64)
    h = np.asarray(header_times, dtype=np.int64)
    dt = np.diff(t)
    if np.any(dt == 0):
        k = int(np.flatnonzero(dt == 0)[0]) + 1
        raise BagError(bag, topic, f"duplicated stamp {t[k]} ns at message {k}")
    if np.any(dt < 0):
        k = int(np.flatnonzero(dt < 0)[0]) + 1
        raise BagError(bag, topic, f"out-of-order stamp {t[k]} ns at message {k}")
    bad = np.flatnonzero(h != t)
    if bad.size:
        k = int(bad[0])
        raise BagError(bag, topic, f"header.stamp {h[k]} ns differs from bag time {t[k]} ns "
                                   f"at message {k}")
    if np.any(dt != CONTROL_DT_NS):
        k = int(np.flatnonzero(dt != CONTROL_DT_NS)[0]) + 1
        what = "gap in" if dt[k - 1] % CONTROL_DT_NS == 0 else "stamp off"
        raise BagError(bag, topic, f"{what} the 100 Hz clock: {dt[k - 1]} ns between "
                                   f"messages {k - 1} and {k}, expected {CONTROL_DT_NS} ns")

    keys = _FIELDS[topic]
    out = {"stamps": t}
    for key, col in zip(keys, fields):
        arr = np.asarray(col, dtype=np.float64)
        if not np.all(np.isfinite(arr)):
            k = int(np.flatnonzero(~np.all(np.isfinite(arr.reshape(len(raws), -1)), axis=1))[0])
            raise BagError(bag, topic, f"NaN or inf in {key} of message {k}")
        out[key] = arr
    if topic == TOPIC_ODOM:
        norm = np.linalg.norm(out["orientation"], axis=1)
        bad = np.flatnonzero(np.abs(norm - 1.0) > QUATERNION_NORM_TOL)
        if bad.size:
            raise BagError(bag, topic, f"orientation of message {int(bad[0])} is not a unit "
                                       f"quaternion (norm {norm[bad[0]]:.9g})")
    return out


_FIELDS: dict[str, tuple[str, ...]] = {
    TOPIC_CMD: ("position",),
    TOPIC_JOINT_STATES: ("position", "velocity"),
    TOPIC_ODOM: ("position", "orientation", "linear_velocity", "angular_velocity"),
}


def _decode_joint_state(msg, bag: str, topic: str, k: int) -> tuple:
    perm = joint_permutation(tuple(msg.name))
    if isinstance(perm, str):
        raise BagError(bag, topic, f"message {k}: {perm}")
    pos = np.asarray(msg.position, dtype=np.float64)
    if pos.shape != (N_JOINTS,):
        raise BagError(bag, topic, f"message {k}: {pos.shape[0]} positions, expected {N_JOINTS}")
    if topic == TOPIC_CMD:
        return (pos[perm],)
    vel = np.asarray(msg.velocity, dtype=np.float64)
    if vel.shape != (N_JOINTS,):
        raise BagError(bag, topic, f"message {k}: {vel.shape[0]} velocities, expected {N_JOINTS}")
    return pos[perm], vel[perm]


def _decode_odom(msg, bag: str, topic: str, k: int) -> tuple:
    if msg.header.frame_id != ODOM_FRAME or msg.child_frame_id != BASE_FRAME:
        raise BagError(bag, topic, f"message {k}: frames {msg.header.frame_id!r} -> "
                                   f"{msg.child_frame_id!r}, expected {ODOM_FRAME!r} -> "
                                   f"{BASE_FRAME!r}")
    p, o = msg.pose.pose.position, msg.pose.pose.orientation
    v, w = msg.twist.twist.linear, msg.twist.twist.angular
    return (p.x, p.y, p.z), (o.x, o.y, o.z, o.w), (v.x, v.y, v.z), (w.x, w.y, w.z)


# ---------------------------------------------------------------------------------------------
# reading many messages of one layout at once

def _same_layout_columns(raws: list, topic: str, ts, msgtype: str, bag: str
                         ) -> tuple[np.ndarray, list[np.ndarray]] | None:
    """Header stamps (n,) and ``_FIELDS[topic]``'s columns (n, k) of messages that differ only
    in their stamps and numbers (``decode.one_layout``), read as arrays straight from the CDR
    bytes; None where they do not (then every message is decoded on its own, with its own
    checks).

    The first and last messages are decoded and checked as the per-message path checks them
    (names, frames, sizes; every other message has their structural bytes, so the same names,
    frames and sizes), and their numbers read here must equal the decoder's bit for bit, or the
    arrays are not used.
    """
    n = len(raws)
    if n < 2:
        return None
    shared = one_layout(raws, msgtype)
    if shared is None:
        return None
    stamps, f, _ = shared
    try:
        msgs = [ts.deserialize_cdr(bytes(raws[0]), msgtype),
                ts.deserialize_cdr(bytes(raws[-1]), msgtype)]
    except Exception:
        return None
    decode = _decode_odom if topic == TOPIC_ODOM else _decode_joint_state
    rows = [decode(m, bag, topic, k) for m, k in zip(msgs, (0, n - 1))]   # BagError as usual
    if topic == TOPIC_ODOM:
        fields = [np.ascontiguousarray(c) for c in (f["pose"][:, :3], f["pose"][:, 3:7],
                                                    f["twist"][:, :3], f["twist"][:, 3:])]
    else:
        perm = joint_permutation(tuple(msgs[0].name))
        fields = [np.ascontiguousarray(f[key][:, perm]) for key in _FIELDS[topic]]
    for k, m, row in zip((0, n - 1), msgs, rows):
        h = int(m.header.stamp.sec) * 1_000_000_000 + int(m.header.stamp.nanosec)
        if h != stamps[k] or not all(
                np.array_equal(np.asarray(v, dtype=np.float64).view(np.int64),
                               c[k].view(np.int64))
                for v, c in zip(row, fields)):
            return None
    return stamps, fields
