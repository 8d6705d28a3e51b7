"""Decode whole topics of a recorded bag into arrays: a fast path for plain CDR, rosbags otherwise.

``littledog-mlsim import`` (``data.importer``) reads every message of a few topics. Decoding
one message at a time with ``rosbags`` is too slow for long recordings
(``benchmarks/import``). Messages of one topic almost always share one byte layout
(the same frame ids, joint names and array lengths), so the fast path walks the CDR layout of
one message, groups all messages whose *structural* bytes (string lengths and contents,
sequence lengths, padding: everything except the numbers) are identical to it, and pulls the
numbers of a whole group out with one NumPy view. Anything it does not know (big-endian CDR,
ROS 1 messages, a message type other than the five below, a layout that differs) goes through
``rosbags``' deserializer with the bag's own type definitions, field by field; the result is
the same (``test/data/test_import.py`` compares both paths). ``one_layout`` reads a topic
whose every message shares the first one's layout in one view (``data.bags.read_bag``);
``like_first`` goes the other way: the bytes of many messages laid out as one serialized
message, with their own stamps and numbers (``data.bags.write_bag``).

Decoded per message (``Decoded`` fields; NaN where a message lacks a value):

- ``sensor_msgs/msg/JointState``: header stamp, ``name`` -> ``position`` and ``velocity``;
- ``std_msgs/msg/Float64MultiArray``: no header (stamp 0), ``data`` as positions;
- ``nav_msgs/msg/Odometry``: header stamp, pose position + orientation, twist linear + angular;
- ``geometry_msgs/msg/PoseStamped``: header stamp, position + orientation;
- ``trajectory_msgs/msg/JointTrajectory``: header stamp, joint names and every point's
  positions with its ``time_from_start`` (rosbags path only: trajectories are few and small).
"""
from __future__ import annotations

import struct
from dataclasses import dataclass, field
from typing import Any, Callable, Sequence

import numpy as np

__all__ = ["Decoded", "decode_topic", "one_layout", "like_first", "SUPPORTED_TYPES",
           "DecodeError", "JOINT_STATE", "FLOAT64_ARRAY", "ODOMETRY", "POSE_STAMPED",
           "JOINT_TRAJECTORY", "ros2_name"]

JOINT_STATE = "sensor_msgs/msg/JointState"
FLOAT64_ARRAY = "std_msgs/msg/Float64MultiArray"
ODOMETRY = "nav_msgs/msg/Odometry"
POSE_STAMPED = "geometry_msgs/msg/PoseStamped"
JOINT_TRAJECTORY = "trajectory_msgs/msg/JointTrajectory"
SUPPORTED_TYPES = (JOINT_STATE, FLOAT64_ARRAY, ODOMETRY, POSE_STAMPED, JOINT_TRAJECTORY)
_CDR_LE = b"\x00\x01\x00\x00"


def ros2_name(msgtype: str) -> str:
    """ROS 1 ``pkg/Type`` -> ROS 2 ``pkg/msg/Type`` (ROS 2 names unchanged)."""
    parts = msgtype.split("/")
    return f"{parts[0]}/msg/{parts[1]}" if len(parts) == 2 else msgtype


class DecodeError(ValueError):
    """A message that cannot be decoded; ``index`` is its number within the topic."""

    def __init__(self, index: int, reason: str) -> None:
        self.index = index
        super().__init__(f"message {index}: {reason}")


@dataclass
class Decoded:
    """One topic's messages as arrays (in the order given)."""

    msgtype: str
    header_ns: np.ndarray                  # (n,) int64, 0 when the type has no header
    names: list[tuple[str, ...]] = field(default_factory=list)  # distinct name lists
    name_index: np.ndarray | None = None   # (n,) index into names (joint types)
    position: np.ndarray | None = None     # joint types: (n, k) ragged -> list; pose: (n, 3)
    velocity: np.ndarray | None = None     # joint states (n, k) or None
    orientation: np.ndarray | None = None  # pose: (n, 4) xyzw
    linear: np.ndarray | None = None       # odometry twist (n, 3)
    angular: np.ndarray | None = None
    frame_ids: tuple[str, str] = ("", "")  # first message's (header.frame_id, child_frame_id)
    points: list | None = None             # trajectories: per message [(t_from_start_ns, pos)]
    n_fast: int = 0                        # messages decoded by the fast path


# ---------------------------------------------------------------------------------------------
# the CDR layout walker (little-endian, ROS 2 XCDR1 as rmw writes it)


class _Walk:
    """Walks one CDR message, recording numeric fields and the structural byte ranges."""

    def __init__(self, raw: bytes) -> None:
        if raw[:4] != _CDR_LE:
            raise ValueError("not little-endian CDR")
        self.raw, self.pos = raw, 4
        # ranges that must match between messages: the encapsulation header first
        self.struct: list[tuple[int, int]] = [(0, 4)]
        self.pad: list[tuple[int, int]] = []      # alignment padding (in struct too)
        self.fields: dict[str, tuple[int, int]] = {}   # name -> (offset, count of float64)

    def _align(self, n: int) -> None:
        pad = (-(self.pos - 4)) % n
        if pad:
            self.struct.append((self.pos, self.pos + pad))
            self.pad.append((self.pos, self.pos + pad))
        self.pos += pad

    def u32(self) -> int:
        self._align(4)
        if self.pos + 4 > len(self.raw):
            raise ValueError("truncated")
        (v,) = struct.unpack_from("<I", self.raw, self.pos)
        self.struct.append((self.pos, self.pos + 4))
        self.pos += 4
        return v

    def string(self) -> str:
        n = self.u32()
        if self.pos + n > len(self.raw) or n == 0:
            raise ValueError("bad string")
        s = self.raw[self.pos:self.pos + n - 1].decode("utf-8")
        self.struct.append((self.pos, self.pos + n))
        self.pos += n
        return s

    def stamp(self) -> None:
        self._align(4)
        self.fields["stamp"] = (self.pos, 1)
        self.pos += 8

    def doubles(self, name: str, count: int) -> None:
        if count:
            self._align(8)
        self.fields[name] = (self.pos, count)
        self.pos += 8 * count
        if self.pos > len(self.raw):
            raise ValueError("truncated")

    def seq_doubles(self, name: str) -> None:
        self.doubles(name, self.u32())

    def done(self) -> None:
        # rmw pads a message to a multiple of 4; anything beyond is not a layout we know
        if len(self.raw) - self.pos > 3:
            raise ValueError(f"{len(self.raw) - self.pos} trailing bytes")
        if self.pos < len(self.raw):
            self.struct.append((self.pos, len(self.raw)))
            self.pad.append((self.pos, len(self.raw)))


def _walk_joint_state(w: _Walk) -> dict:
    w.stamp()
    frame = w.string()
    names = tuple(w.string() for _ in range(w.u32()))
    w.seq_doubles("position")
    w.seq_doubles("velocity")
    w.seq_doubles("effort")
    return {"names": names, "frame": frame}


def _walk_float64_array(w: _Walk) -> dict:
    for _ in range(w.u32()):      # layout.dim[]: label, size, stride
        w.string()
        w.u32()
        w.u32()
    w.u32()                       # data_offset
    w.seq_doubles("position")
    return {"names": ()}


def _walk_odometry(w: _Walk) -> dict:
    w.stamp()
    frame = w.string()
    child = w.string()
    w.doubles("pose", 7)
    w.doubles("pose_cov", 36)
    w.doubles("twist", 6)
    w.doubles("twist_cov", 36)
    return {"frame": frame, "child": child}


def _walk_pose_stamped(w: _Walk) -> dict:
    w.stamp()
    frame = w.string()
    w.doubles("pose", 7)
    return {"frame": frame, "child": ""}


_WALKERS: dict[str, Callable[[_Walk], dict]] = {
    JOINT_STATE: _walk_joint_state, FLOAT64_ARRAY: _walk_float64_array,
    ODOMETRY: _walk_odometry, POSE_STAMPED: _walk_pose_stamped,
}


@dataclass
class _Layout:
    length: int
    struct: list[tuple[int, int]]
    key: bytes
    fields: dict[str, tuple[int, int]]
    info: dict
    pad: list[tuple[int, int]]


def _layout(raw: bytes, msgtype: str) -> _Layout | None:
    try:
        w = _Walk(raw)
        info = _WALKERS[msgtype](w)
        w.done()
    except (ValueError, UnicodeDecodeError, struct.error, KeyError):
        return None
    blocks: list[tuple[int, int]] = []
    for a, b in sorted(w.struct):          # contiguous structural ranges -> a few blocks
        if blocks and blocks[-1][1] == a:
            blocks[-1] = (blocks[-1][0], b)
        else:
            blocks.append((a, b))
    key = b"".join(raw[a:b] for a, b in blocks)
    return _Layout(len(raw), blocks, key, w.fields, info, w.pad)


def _columns(buf: np.ndarray, off: int, count: int) -> np.ndarray:
    """(n, count) float64 from byte columns off..off+8*count of the (n, L) uint8 buffer."""
    if count == 0:
        return np.zeros((buf.shape[0], 0))
    return np.ascontiguousarray(buf[:, off:off + 8 * count]).view("<f8").reshape(-1, count)


def _stamps(buf: np.ndarray, off: int) -> np.ndarray:
    raw = np.ascontiguousarray(buf[:, off:off + 8])
    sec = raw[:, :4].copy().view("<i4").ravel().astype(np.int64)
    nsec = raw[:, 4:].copy().view("<u4").ravel().astype(np.int64)
    return sec * 1_000_000_000 + nsec


# ---------------------------------------------------------------------------------------------
# decoding a topic


def decode_topic(raws: Sequence[bytes], msgtype: str,
                 deserialize: Callable[[bytes, str], Any], src_msgtype: str | None = None,
                 fast: bool = True) -> Decoded:
    """Decode ``raws`` (one topic, one message type) into a :class:`Decoded`.

    ``msgtype``: the ROS 2 name (one of ``SUPPORTED_TYPES``); ``src_msgtype``: the bag's own
    name for ``deserialize`` (ROS 1 names differ); ``deserialize(raw, src_msgtype)``: the
    reader's deserializer (the bag's type definitions). ``fast=False`` forces the per-message
    path. DecodeError (naming the message) for a message neither path can read.
    """
    src = src_msgtype or msgtype
    n = len(raws)
    out = _empty(msgtype, n)
    slow: list[int] = []
    if fast and msgtype in _WALKERS:
        groups: dict[bytes, tuple[_Layout, list[int]]] = {}
        lay: _Layout | None = None
        for i, raw in enumerate(raws):
            if lay is None or len(raw) != lay.length or \
                    b"".join(raw[a:b] for a, b in lay.struct) != lay.key:
                lay = _layout(raw, msgtype)
                if lay is None:
                    slow.append(i)
                    continue
            g = groups.get(lay.key)
            if g is None or g[0].length != lay.length:
                g = groups.setdefault(lay.key + lay.length.to_bytes(8, "little"), (lay, []))
            g[1].append(i)
        for lay, idx in groups.values():
            _fill_fast(out, msgtype, lay, np.asarray(idx),
                       np.frombuffer(b"".join(raws[i] for i in idx),
                                     dtype=np.uint8).reshape(len(idx), lay.length))
        out.n_fast = n - len(slow)
    else:
        slow = list(range(n))
    for i in slow:
        try:
            msg = deserialize(raws[i], src)
        except Exception as exc:
            raise DecodeError(i, f"cannot deserialize {src}: {type(exc).__name__}: "
                                 f"{' '.join(str(exc).split())}") from None
        try:
            _fill_slow(out, msgtype, i, msg)
        except (AttributeError, TypeError, ValueError) as exc:
            raise DecodeError(i, f"unexpected {src} content: {exc}") from None
    if out.name_index is not None and isinstance(out.position, list):
        _pack_ragged(out)
    return out


def one_layout(raws: Sequence[bytes], msgtype: str
               ) -> tuple[np.ndarray, dict[str, np.ndarray], dict] | None:
    """The numbers of messages that all share the first one's layout, read with one NumPy view:
    (header stamps (n,) int64, {field: (n, count) float64}, the first message's ``names``,
    ``frame`` and ``child``), or None where a message's length or structural bytes differ from
    the first's or the first's layout is not known (then decode message by message). The
    alignment padding may differ (a serializer may leave any bytes there; no decoder reads
    them).

    Fields: JointState ``position``, ``velocity``, ``effort``; Odometry ``pose`` (position and
    xyzw orientation), ``pose_cov``, ``twist`` (linear and angular), ``twist_cov``; PoseStamped
    ``pose``; Float64MultiArray ``position``.
    """
    if not raws or msgtype not in _WALKERS:
        return None
    first = bytes(raws[0])
    lay = _layout(first, msgtype)
    if lay is None or any(len(r) != lay.length for r in raws):
        return None
    n = len(raws)
    buf = np.frombuffer(b"".join(raws), dtype=np.uint8).reshape(n, lay.length)
    fixed = np.zeros(lay.length, dtype=bool)
    for a, b in lay.struct:
        fixed[a:b] = True
    for a, b in lay.pad:
        fixed[a:b] = False
    if not np.array_equal(buf[:, fixed], np.broadcast_to(buf[0, fixed], (n, int(fixed.sum())))):
        return None
    stamps = (_stamps(buf, lay.fields["stamp"][0]) if "stamp" in lay.fields
              else np.zeros(n, dtype=np.int64))
    fields = {k: _columns(buf, off, count) for k, (off, count) in lay.fields.items()
              if k != "stamp"}
    return stamps, fields, lay.info


def like_first(first: bytes, msgtype: str, stamps_ns: np.ndarray,
               fields: dict[str, np.ndarray]) -> np.ndarray | None:
    """The CDR bytes of ``len(stamps_ns)`` messages laid out as the serialized message
    ``first``, as an (n, len(first)) uint8 array (row k: message k): every byte of ``first``
    except its header stamp and the float fields named in ``fields``, which take row k of
    ``stamps_ns`` (integer ns, from 0 to the int32 seconds' end) and of each ``fields[name]``
    ((n, count) float64, ``count`` as in ``first``). The numbers are written bit for bit, as a
    serializer writes a little-endian float64. None if ``first``'s layout is not known, a stamp
    is not such an integer or a field does not fit the layout (then serialize message by
    message). Field names as in :func:`one_layout`.
    """
    if msgtype not in _WALKERS:
        return None
    first = bytes(first)
    lay = _layout(first, msgtype)
    stamps_ns = np.asarray(stamps_ns)
    if (lay is None or stamps_ns.ndim != 1 or "stamp" not in lay.fields
            or stamps_ns.shape[0] == 0 or not np.issubdtype(stamps_ns.dtype, np.integer)):
        return None
    n = stamps_ns.shape[0]
    stamps_ns = stamps_ns.astype(np.int64)
    if np.any(stamps_ns < 0) or np.any(stamps_ns // 1_000_000_000 > np.iinfo(np.int32).max):
        return None
    buf = np.tile(np.frombuffer(first, dtype=np.uint8), (n, 1))
    off = lay.fields["stamp"][0]
    buf[:, off:off + 4] = (stamps_ns // 1_000_000_000).astype("<i4").view(np.uint8).reshape(n, 4)
    buf[:, off + 4:off + 8] = (stamps_ns % 1_000_000_000).astype("<u4").view(
        np.uint8).reshape(n, 4)
    for name, values in fields.items():
        if name == "stamp" or name not in lay.fields:
            return None
        off, count = lay.fields[name]
        values = np.ascontiguousarray(values, dtype="<f8")
        if values.shape != (n, count):
            return None
        if count:
            buf[:, off:off + 8 * count] = values.view(np.uint8).reshape(n, 8 * count)
    return buf


def _empty(msgtype: str, n: int) -> Decoded:
    d = Decoded(msgtype=msgtype, header_ns=np.zeros(n, dtype=np.int64))
    if msgtype in (JOINT_STATE, FLOAT64_ARRAY, JOINT_TRAJECTORY):
        d.name_index = np.zeros(n, dtype=np.int64)
        d.position = [None] * n          # ragged until _pack_ragged
        d.velocity = [None] * n if msgtype == JOINT_STATE else None
        if msgtype == JOINT_TRAJECTORY:
            d.points = [None] * n
    else:
        d.position = np.full((n, 3), np.nan)
        d.orientation = np.full((n, 4), np.nan)
        if msgtype == ODOMETRY:
            d.linear = np.full((n, 3), np.nan)
            d.angular = np.full((n, 3), np.nan)
    d._frames_set = False  # type: ignore[attr-defined]
    return d


def _name_id(out: Decoded, names: tuple[str, ...]) -> int:
    try:
        return out.names.index(names)
    except ValueError:
        out.names.append(names)
        return len(out.names) - 1


def _set_frames(out: Decoded, frame: str, child: str) -> None:
    if not getattr(out, "_frames_set", False):
        out.frame_ids = (frame, child)
        out._frames_set = True  # type: ignore[attr-defined]


def _fill_fast(out: Decoded, msgtype: str, lay: _Layout, idx: np.ndarray, buf: np.ndarray) -> None:
    f = lay.fields
    if "stamp" in f:
        out.header_ns[idx] = _stamps(buf, f["stamp"][0])
    if msgtype in (JOINT_STATE, FLOAT64_ARRAY):
        out.name_index[idx] = _name_id(out, lay.info["names"])
        pos = _columns(buf, *f["position"])
        vel = _columns(buf, *f["velocity"]) if msgtype == JOINT_STATE else None
        for j, i in enumerate(idx):
            out.position[i] = pos[j]
            if vel is not None:
                out.velocity[i] = vel[j]
        if msgtype == JOINT_STATE:
            _set_frames(out, lay.info["frame"], "")
        return
    pose = _columns(buf, *f["pose"])
    out.position[idx] = pose[:, :3]
    out.orientation[idx] = pose[:, 3:7]
    if msgtype == ODOMETRY:
        tw = _columns(buf, *f["twist"])
        out.linear[idx], out.angular[idx] = tw[:, :3], tw[:, 3:]
    _set_frames(out, lay.info["frame"], lay.info["child"])


def _stamp_ns(header: Any) -> int:
    st = header.stamp
    sec = getattr(st, "sec", None)
    if sec is None:                      # ROS 1 Time: secs/nsecs
        return int(st.secs) * 1_000_000_000 + int(st.nsecs)
    return int(sec) * 1_000_000_000 + int(st.nanosec)


def _duration_ns(d: Any) -> int:
    sec = getattr(d, "sec", None)
    if sec is None:
        return int(d.secs) * 1_000_000_000 + int(d.nsecs)
    return int(sec) * 1_000_000_000 + int(d.nanosec)


def _fill_slow(out: Decoded, msgtype: str, i: int, msg: Any) -> None:
    f64 = lambda a: np.asarray(a, dtype=np.float64).ravel()  # noqa: E731
    if msgtype == FLOAT64_ARRAY:
        out.name_index[i] = _name_id(out, ())
        out.position[i] = f64(msg.data)
        return
    out.header_ns[i] = _stamp_ns(msg.header)
    if msgtype == JOINT_STATE:
        out.name_index[i] = _name_id(out, tuple(msg.name))
        out.position[i], out.velocity[i] = f64(msg.position), f64(msg.velocity)
        _set_frames(out, msg.header.frame_id, "")
        return
    if msgtype == JOINT_TRAJECTORY:
        out.name_index[i] = _name_id(out, tuple(msg.joint_names))
        out.points[i] = [(_duration_ns(p.time_from_start), f64(p.positions)) for p in msg.points]
        out.position[i] = out.points[i][0][1] if out.points[i] else np.zeros(0)
        _set_frames(out, msg.header.frame_id, "")
        return
    pose = msg.pose.pose if msgtype == ODOMETRY else msg.pose
    p, o = pose.position, pose.orientation
    out.position[i] = (p.x, p.y, p.z)
    out.orientation[i] = (o.x, o.y, o.z, o.w)
    if msgtype == ODOMETRY:
        v, w = msg.twist.twist.linear, msg.twist.twist.angular
        out.linear[i], out.angular[i] = (v.x, v.y, v.z), (w.x, w.y, w.z)
        _set_frames(out, msg.header.frame_id, msg.child_frame_id)
    else:
        _set_frames(out, msg.header.frame_id, "")


def _pack_ragged(out: Decoded) -> None:
    """Joint arrays stay lists of 1-D arrays (lengths may differ per name list)."""
    out.position = list(out.position)
    if out.velocity is not None:
        out.velocity = list(out.velocity)
