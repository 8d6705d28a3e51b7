"""Import recorded bags (``ros2 bag record``, ROS 1 ``rosbag record``) as a dataset of moves.

``littledog-mlsim import BAG [BAG ...] --out DATASET`` (``docs/import.md``). The project's own
bags are one move each, on one exact 100 Hz clock (``data.bags``); a recording of a robot or of a
simulator driven by a separate controller is not: topics come at their own rates with jitter,
stamped on different clocks (a simulator's sim time, a controller's wall clock, zeros), with
dropped messages, pauses and resets between moves. This module turns such recordings into the
contract format (one bag per move + ``dataset.yaml``) that every other verb reads unchanged.

Per bag (a rosbag2 directory, a single ``.mcap``/``.db3`` file or a ROS 1 ``.bag``, read with
``rosbags.highlevel.AnyReader`` and the bag's own type definitions):

1. Read the command, joint-state and pose topics (``ImportOptions`` maps them; the defaults are
   the contract's names) and decode them (``data.decode``). Joints are matched by name (extra
   joints ignored, missing ones an error); ``Float64MultiArray`` commands carry no names and use
   ``cmd_joint_order``; a ``JointTrajectory`` becomes its points at ``stamp + time_from_start``,
   each message superseding the rest of the previous one (as a trajectory controller does).
   Messages holding NaN/inf or a degenerate quaternion are dropped and counted.
2. Give every message a time on the bag's (receive) clock (``time_source``): header stamps when
   they are on that clock (median of receive - stamp within ``clock_tolerance_s``); stamps of
   another clock (a simulator's sim time) shifted onto it piecewise (``aligned``: one offset per
   stretch without a time jump or pause, the 5th percentile of receive - stamp, i.e. the
   least-delayed messages), which keeps the stamps' regular spacing; receive time when the
   stamps are zero, absent (``Float64MultiArray``) or unusable.
3. Cut the recording where it is not one continuous motion: gaps longer than ``gap_s`` in the
   joint states or the pose (a pause, lost messages), time jumps, and resets (the pose or a
   joint jumps further between two samples than the robot can move). A segment starts once its
   first command has arrived.
4. Resample each segment onto the 10 ms grid starting at a joint-state sample: joint states and
   position linearly, orientation by slerp, twist linearly (or from the poses), and the command
   of step k -> k+1 is the newest command received more than ``cmd_cutoff_s`` before measurement
   k+1, i.e. the command the simulator's tick that produced measurement k+1 applied (zero-order
   hold; commands that never were the newest at a tick are counted as superseded).
5. Label each segment (``move_type`` per bag, else inferred from its motion with
   ``summary.infer_move_type``, else ``U`` = unknown), split long segments into moves of at most
   ``max_move_s``, and split moves per type into TrainPool and TestPool: in recording order, the
   last ``test_fraction`` of each type (rounded as ``dataset.n_train``) is the TestPool.

The dataset appears atomically (``fileio.atomic_directory``) with ``import_report.json``, ``.md``
and ``.png`` beside ``dataset.yaml`` (``data.import_report``). A bad bag is one ``BagError`` line
naming bag, topic and message, and nothing is written, unless ``skip_bad_bags`` leaves it out
(reported).
"""
from __future__ import annotations

import logging
import os
import tempfile
import time
from dataclasses import asdict, dataclass, field
from functools import lru_cache
from pathlib import Path
from typing import Any, Sequence

import numpy as np

from ..layout import (
    CONTROL_DT,
    CONTROL_DT_NS,
    DATASET_MOVE_TYPES,
    JOINT_NAMES,
    N_JOINTS,
    TOPIC_CMD,
    TOPIC_JOINT_STATES,
    TOPIC_ODOM,
    UNKNOWN_MOVE_TYPE,
)
from ..rotations import quat_conjugate, quat_multiply, rotvec_from_quat
from .bags import BagError
from .decode import (
    FLOAT64_ARRAY,
    JOINT_STATE,
    JOINT_TRAJECTORY,
    ODOMETRY,
    POSE_STAMPED,
    DecodeError,
    decode_topic,
    ros2_name,
)
from .recording import MoveRecording

__all__ = ["ImportOptions", "ImportResult", "import_bags", "expand_bag_paths", "read_recording", "segment_recording",
           "RecordingStreams", "Segment", "TIME_SOURCES", "ROLE_TYPES"]

log = logging.getLogger(__name__)

TIME_SOURCES = ("auto", "header", "receive")
TWIST_SOURCES = ("auto", "message", "pose")
ROLE_TYPES: dict[str, tuple[str, ...]] = {
    "cmd": (JOINT_STATE, FLOAT64_ARRAY, JOINT_TRAJECTORY),
    "joint_states": (JOINT_STATE,),
    "pose": (ODOMETRY, POSE_STAMPED),
}
MAX_SPEED_M_S = 2.0        # fastest plausible body speed, for reset detection
MAX_RATE_RAD_S = 10.0      # fastest plausible body rotation
MAX_JOINT_RATE_RAD_S = 30.0
#: the largest command excitation an import records (``record --excitation``'s limit)
MAX_EXCITATION_RAD = 0.2
_NS = 1_000_000_000


@dataclass
class ImportOptions:
    """How to read recordings; every field is a CLI option of ``littledog-mlsim import``."""

    cmd_topic: str = TOPIC_CMD
    joint_states_topic: str = TOPIC_JOINT_STATES
    pose_topic: str = TOPIC_ODOM
    cmd_joint_order: tuple[str, ...] = JOINT_NAMES   # Float64MultiArray commands
    time_source: str = "auto"          # auto | header | receive
    clock_tolerance_s: float = 0.5     # header stamps within this of receive time: same clock
    gap_s: float = 0.05                # a longer gap between samples splits a segment
    reset_jump_m: float = 0.05         # pose jump beyond MAX_SPEED_M_S * dt: a reset
    reset_jump_rad: float = 0.3        # orientation jump beyond MAX_RATE_RAD_S * dt: a reset
    joint_jump_rad: float = 0.5        # joint jump beyond MAX_JOINT_RATE_RAD_S * dt: a reset
    min_segment_s: float = 1.0         # shorter segments are dropped (reported)
    max_move_s: float = 0.0            # longer segments are split into equal moves (0: never)
    cmd_cutoff_s: float = 0.001        # command must arrive this long before the measurement
    twist: str = "auto"                # auto (message if it has one) | message | pose
    dejitter: bool = True              # receive-time measurements: fit their sending clock
    move_types: tuple[str | None, ...] = ()   # per bag (one value: all bags); None/"": infer
    infer_types: bool = True           # False: segments without move_types are U
    test_fraction: float = 0.3
    storage: str = "mcap"
    skip_bad_bags: bool = False
    command_excitation_rad: float = 0.0   # std of the noise the robot's commands carried

    def check(self) -> None:
        """ValueError (one line) for an invalid option."""
        if self.time_source not in TIME_SOURCES:
            raise ValueError(f"time source must be one of {', '.join(TIME_SOURCES)}")
        if self.twist not in TWIST_SOURCES:
            raise ValueError(f"twist must be one of {', '.join(TWIST_SOURCES)}")
        order = tuple(self.cmd_joint_order)
        missing = [j for j in JOINT_NAMES if j not in order]
        if missing:
            raise ValueError(f"cmd joint order lacks joint(s) {', '.join(missing)}")
        if len(set(order)) != len(order):
            raise ValueError("cmd joint order names a joint twice")
        for name in ("clock_tolerance_s", "gap_s", "reset_jump_m", "reset_jump_rad",
                     "joint_jump_rad", "min_segment_s", "max_move_s", "cmd_cutoff_s"):
            v = getattr(self, name)
            if not (np.isfinite(v) and v >= 0):
                raise ValueError(f"{name} must be finite and >= 0, got {v}")
        if self.gap_s < 1.5 * CONTROL_DT:
            raise ValueError(f"gap_s must be at least {1.5 * CONTROL_DT} s")
        if 0 < self.max_move_s < 2 * CONTROL_DT:
            raise ValueError("max_move_s must be 0 or at least 0.02 s")
        if not 0.0 <= self.test_fraction < 1.0:
            raise ValueError(f"test fraction must be in [0, 1), got {self.test_fraction}")
        for t in self.move_types:
            if t not in (None, "") and t not in DATASET_MOVE_TYPES:
                raise ValueError(f"unknown move type {t!r}; choose from "
                                 f"{', '.join(DATASET_MOVE_TYPES)}")
        if self.storage not in ("mcap", "sqlite3"):
            raise ValueError(f"storage must be mcap or sqlite3, got {self.storage!r}")
        e = self.command_excitation_rad
        if isinstance(e, bool) or not isinstance(e, (int, float)) or not (
                np.isfinite(e) and 0.0 <= e <= MAX_EXCITATION_RAD):
            raise ValueError(f"command excitation must be between 0 and {MAX_EXCITATION_RAD} "
                             f"rad, got {e!r}")

    def topic(self, role: str) -> str:
        return {"cmd": self.cmd_topic, "joint_states": self.joint_states_topic,
                "pose": self.pose_topic}[role]


# ---------------------------------------------------------------------------------------------
# reading one bag


@dataclass
class Stream:
    """One topic on the bag clock: times [ns] (sorted) and values, plus what happened to it."""

    role: str
    topic: str
    msgtype: str
    recv_ns: np.ndarray                # receive (bag) time of every message read
    header_ns: np.ndarray = field(default_factory=lambda: np.zeros(0, np.int64))
    t_ns: np.ndarray = field(default_factory=lambda: np.zeros(0, np.int64))  # assigned time
    values: dict[str, np.ndarray] = field(default_factory=dict)
    report: dict[str, Any] = field(default_factory=dict)
    breaks: list[tuple[int, int, str]] = field(default_factory=list)  # (from, to, why) in ns


@dataclass
class RecordingStreams:
    bag: str
    kind: str
    streams: dict[str, Stream]
    n_messages: int                    # messages read (the three topics)
    n_messages_bag: int                # messages in the bag (all topics)
    recovered: str = ""                # what was salvaged of a cut-short bag and what dropped


@lru_cache(maxsize=1)
def _default_typestore():
    from rosbags.typesys import Stores, get_typestore

    return get_typestore(Stores.ROS2_JAZZY)


def _bag_kind(path: Path) -> str:
    if path.is_dir():
        return "rosbag2 directory"
    return {".mcap": "rosbag2 mcap file", ".db3": "rosbag2 sqlite3 file",
            ".bag": "ROS 1 bag"}.get(path.suffix, "unknown")


def read_recording(path: str | os.PathLike, opts: ImportOptions) -> RecordingStreams:
    """Read and decode the three topics of one bag onto the bag clock (steps 1 and 2).

    BagError (one line naming bag, topic and message) for anything unusable. A bare MCAP file
    cut short (a killed recorder) is read as far as its records are whole; what was dropped and
    why is in ``RecordingStreams.recovered`` and logged as a warning.
    """
    path = Path(path)
    bag = str(path)
    kind = _bag_kind(path)
    if not path.exists():
        raise BagError(bag, None, "no such bag")
    if kind == "unknown":
        raise BagError(bag, None, "not a bag: expected a rosbag2 directory or a .mcap, .db3 "
                                  "or ROS 1 .bag file")
    scratch = tempfile.TemporaryDirectory(prefix="littledog-salvage-")
    try:
        reader, recovered = _open_reader(path, bag, kind, Path(scratch.name))
        rs = _read_streams(reader, path, bag, kind, opts)
    finally:
        scratch.cleanup()
    rs.recovered = recovered
    return rs


def _open_reader(path: Path, bag: str, kind: str, scratch: Path):
    """An open AnyReader of the bag, and what was salvaged ("" if the bag opened as it is).

    A bare MCAP file that rosbags cannot open (a recorder killed before it wrote the summary)
    is read through a copy of its whole records in ``scratch`` (``data.salvage``)."""
    from rosbags.highlevel import AnyReader

    from .salvage import SalvageError, salvage_mcap

    try:
        reader = AnyReader([path], default_typestore=_default_typestore())
        reader.open()
        return reader, ""
    except Exception as exc:
        why = f"cannot open: {type(exc).__name__}: {str(exc).rstrip('.')}"
        if kind != "rosbag2 mcap file":
            raise BagError(bag, None, why) from None
    try:
        s = salvage_mcap(path, scratch / path.name)
        reader = AnyReader([s.out], default_typestore=_default_typestore())
        reader.open()
    except (SalvageError, OSError) as exc:
        raise BagError(bag, None, f"{why}; nothing to salvage: {exc}") from None
    except Exception as exc:
        raise BagError(bag, None, f"{why}; its salvaged records do not read either: "
                                  f"{type(exc).__name__}: {exc}") from None
    recovered = (f"read {s.messages} whole messages of {s.size} bytes; {s.dropped}")
    log.warning("%s: %s", bag, recovered)
    return reader, recovered


def _read_streams(reader, path: Path, bag: str, kind: str,
                  opts: ImportOptions) -> RecordingStreams:
    """Read, decode and time the three topics from the open ``reader`` (closes it)."""
    try:
        conns: dict[str, list] = {}
        for role in ("cmd", "joint_states", "pose"):
            topic = opts.topic(role)
            cs = [c for c in reader.connections if c.topic == topic]
            if not cs:
                have = sorted({c.topic for c in reader.connections})
                raise BagError(bag, topic, f"missing topic (the bag has {', '.join(have) or 'none'}"
                                           f"); map it with --{role.replace('_', '-')}-topic")
            types = {ros2_name(c.msgtype) for c in cs}
            if len(types) > 1 or types.pop() not in ROLE_TYPES[role]:
                raise BagError(bag, topic, f"message type {cs[0].msgtype} cannot be the "
                                           f"{role.replace('_', ' ')} topic (expected one of "
                                           f"{', '.join(ROLE_TYPES[role])})")
            conns[role] = cs
        by_conn = {id(c): role for role, cs in conns.items() for c in cs}
        raw: dict[str, list] = {r: [] for r in conns}
        times: dict[str, list] = {r: [] for r in conns}
        n_read = 0
        try:
            fast = _mcap_raw(reader, {opts.topic(r): r for r in conns})
            if fast is not None:
                for role, (t, data) in fast.items():
                    times[role], raw[role] = t, data
                    n_read += len(data)
            else:
                for c, t, data in reader.messages(
                        connections=[c for cs in conns.values() for c in cs]):
                    role = by_conn[id(c)]
                    raw[role].append(bytes(data))
                    times[role].append(t)
                    n_read += 1
        except Exception as exc:
            raise BagError(bag, None, f"corrupt or truncated after {n_read} messages: "
                                      f"{type(exc).__name__}: {exc}") from None
        n_bag = int(getattr(reader, "message_count", 0) or 0)
        streams: dict[str, Stream] = {}
        for role, cs in conns.items():
            topic = opts.topic(role)
            src_type = cs[0].msgtype
            msgtype = ros2_name(src_type)
            if not raw[role]:
                raise BagError(bag, topic, "no messages")
            t0 = time.perf_counter()
            try:
                dec = decode_topic(raw[role], msgtype, reader.deserialize, src_type)
            except DecodeError as exc:
                raise BagError(bag, topic, str(exc)) from None
            s = Stream(role, topic, msgtype, np.asarray(times[role], dtype=np.int64))
            s.report.update(topic=topic, msgtype=msgtype, count=len(raw[role]),
                            fast_decoded=dec.n_fast,
                            decode_s=round(time.perf_counter() - t0, 4),
                            frames=list(dec.frame_ids))
            _fill_values(s, dec, opts, bag)
            streams[role] = s
    finally:
        try:
            reader.close()
        except Exception:
            pass
    for s in streams.values():
        _assign_time(s, opts)
    return RecordingStreams(bag, kind, streams, n_read, n_bag or n_read)


def _mcap_raw(reader, roles: dict[str, str]) -> dict[str, tuple[list, list]] | None:
    """All messages of the topics in ``roles`` (topic -> role) straight from the MCAP chunks.

    rosbags' reader yields messages one by one through several generator layers; this walks
    each chunk's records with ``struct.unpack_from`` instead (much faster:
    ``benchmarks/import``), then sorts each topic by log time (stable). None (use rosbags' reader) for
    anything but indexed, chunked MCAP files without file or message compression.
    """
    import struct as _struct

    from rosbags.rosbag2.storage_mcap import McapReader, decompress

    storages = []
    for r2 in getattr(reader, "readers", []):
        st = getattr(r2, "storage", None)
        if isinstance(st, McapReader):
            storages.append(st)
        elif st is not None and hasattr(st, "storages"):
            if getattr(getattr(st, "metadata", None), "compression_mode", None):
                return None
            if not all(isinstance(x, McapReader) for x in st.storages):
                return None
            storages += list(st.storages)
        else:
            return None
    if not storages or any(not st.chunks or st.bio is None for st in storages):
        return None
    out: dict[str, tuple[list, list]] = {r: ([], []) for r in roles.values()}
    unpack = _struct.Struct("<HIQ").unpack_from
    length_of = _struct.Struct("<Q").unpack_from
    for st in storages:
        chan = {cid: roles[c.topic] for cid, c in st.channels.items() if c.topic in roles}
        for ch in st.chunks:
            if not any(ch.channel_count.get(cid, 0) for cid in chan):
                continue
            st.bio.seek(ch.chunk_start_offset + 9 + 24)
            (crc,) = _struct.unpack("<I", st.bio.read(4))
            st.bio.seek(ch.chunk_start_offset + 9 + 40 + len(ch.compression))
            buf = decompress(st.bio.read(ch.compressed_size), ch.compression,
                             ch.uncompressed_size, crc)
            pos, end = 0, len(buf)
            while pos < end:
                op = buf[pos]
                (n,) = length_of(buf, pos + 1)
                if op == 0x05:
                    cid, _, t = unpack(buf, pos + 9)
                    role = chan.get(cid)
                    if role is not None:
                        o = out[role]
                        o[0].append(t)
                        o[1].append(buf[pos + 31:pos + 9 + n])
                pos += 9 + n
    for role, (t, data) in out.items():
        order = np.argsort(np.asarray(t, dtype=np.int64), kind="stable")
        if np.any(np.diff(order) != 1):
            out[role] = ([t[i] for i in order], [data[i] for i in order])
    return out


def _joint_matrix(dec, names_for_empty: tuple[str, ...], bag: str, topic: str,
                  which: str) -> np.ndarray:
    """(n, 12) contract-order values of a joint topic; NaN rows where a message lacks them."""
    rows = dec.position if which == "position" else dec.velocity
    n = len(rows)
    out = np.full((n, N_JOINTS), np.nan)
    for g, names in enumerate(dec.names):
        idx = np.flatnonzero(dec.name_index == g)
        names = names or names_for_empty
        where = {nm: i for i, nm in enumerate(names)}
        missing = [j for j in JOINT_NAMES if j not in where]
        if missing:
            raise BagError(bag, topic, f"message {int(idx[0])}: missing joint(s) "
                                       f"{', '.join(missing)}")
        perm = np.array([where[j] for j in JOINT_NAMES])
        lens = {len(rows[i]) for i in idx}
        if lens == {len(names)}:
            out[idx] = np.stack([rows[i] for i in idx])[:, perm]
            continue
        for i in idx:
            r = rows[i]
            if len(r) == len(names):
                out[i] = r[perm]
            elif which == "position" or len(r):
                raise BagError(bag, topic, f"message {int(i)}: {len(r)} {which} values for "
                                           f"{len(names)} joint names")
    return out


def _fill_values(s: Stream, dec, opts: ImportOptions, bag: str) -> None:
    """Values in contract order; drops non-finite messages (counted)."""
    s.header_ns = dec.header_ns
    dropped = {}
    if s.msgtype == JOINT_TRAJECTORY:
        _fill_trajectory(s, dec, opts, bag)
        return
    if s.role in ("cmd", "joint_states"):
        s.values["q"] = _joint_matrix(dec, tuple(opts.cmd_joint_order), bag, s.topic, "position")
        if s.role == "joint_states":
            s.values["dq"] = _joint_matrix(dec, (), bag, s.topic, "velocity")
            no_vel = np.all(np.isnan(s.values["dq"]), axis=1)
            s.report["velocity_from_positions"] = bool(no_vel.all())
            if no_vel.all():
                s.values["dq"] = np.zeros_like(s.values["q"])
        bad = ~np.all(np.isfinite(s.values["q"]), axis=1)
        if "dq" in s.values:
            bad |= ~np.all(np.isfinite(s.values["dq"]), axis=1)
        dropped["nonfinite"] = int(bad.sum())
    else:
        s.values["position"] = np.asarray(dec.position, dtype=np.float64)
        quat = np.asarray(dec.orientation, dtype=np.float64)
        norm = np.linalg.norm(quat, axis=1)
        bad = ~np.all(np.isfinite(s.values["position"]), axis=1) | ~np.isfinite(norm)
        degenerate = np.isfinite(norm) & (np.abs(norm - 1.0) > 0.01)
        dropped["nonfinite"] = int(bad.sum())
        dropped["not_unit_quaternion"] = int((degenerate & ~bad).sum())
        bad |= degenerate
        with np.errstate(invalid="ignore", divide="ignore"):   # unit to 1e-6 (bags.py): kept
            s.values["orientation"] = np.where(np.abs(norm - 1.0)[:, None] > 1e-7,
                                               quat / norm[:, None], quat)
        s.report["has_twist"] = dec.linear is not None
        if dec.linear is not None:
            s.values["linear"] = np.asarray(dec.linear)
            s.values["angular"] = np.asarray(dec.angular)
            tw_bad = ~np.all(np.isfinite(np.hstack([dec.linear, dec.angular])), axis=1)
            dropped["nonfinite"] += int((tw_bad & ~bad).sum())
            bad |= tw_bad
    keep = ~bad
    s.recv_ns, s.header_ns = s.recv_ns[keep], s.header_ns[keep]
    s.values = {k: v[keep] for k, v in s.values.items()}
    s.report["dropped"] = {k: v for k, v in dropped.items() if v}
    if not keep.any():
        raise BagError(bag, s.topic, "no usable message (all hold NaN/inf)")


def _fill_trajectory(s: Stream, dec, opts: ImportOptions, bag: str) -> None:
    """Every trajectory point as one command sample at message time + time_from_start.

    ``header_ns`` of the points is the message stamp + offset (0 stays 0: starts on receipt);
    ``recv_ns`` the receive time + offset. Points of a message at or after the next message's
    start are superseded (dropped, counted).
    """
    recv, hdr, q, src = [], [], [], []
    n_nonfinite = 0
    for i, pts in enumerate(dec.points):
        names = dec.names[dec.name_index[i]]
        where = {nm: k for k, nm in enumerate(names)}
        missing = [j for j in JOINT_NAMES if j not in where]
        if missing:
            raise BagError(bag, s.topic, f"message {i}: missing joint(s) {', '.join(missing)}")
        perm = np.array([where[j] for j in JOINT_NAMES])
        for off, pos in pts:
            if pos.shape[0] != len(names):
                raise BagError(bag, s.topic, f"message {i}: a point has {pos.shape[0]} positions "
                                             f"for {len(names)} joint names")
            if not np.all(np.isfinite(pos)):
                n_nonfinite += 1
                continue
            recv.append(s.recv_ns[i] + off)
            hdr.append(dec.header_ns[i] + off if dec.header_ns[i] else 0)
            q.append(pos[perm])
            src.append(i)
    if not q:
        raise BagError(bag, s.topic, "no usable trajectory point")
    recv, hdr, src = (np.asarray(x, dtype=np.int64) for x in (recv, hdr, src))
    start_recv = s.recv_ns[src]   # superseded: a later message started before this point
    nxt = np.searchsorted(s.recv_ns, start_recv, side="right")
    next_start = np.where(nxt < s.recv_ns.shape[0], s.recv_ns[np.minimum(nxt, len(s.recv_ns) - 1)],
                          np.iinfo(np.int64).max)
    keep = recv < next_start
    keep[np.r_[True, src[1:] != src[:-1]]] = True   # a message's first point always counts
    s.report["trajectory_points"] = int(len(q))
    s.report["dropped"] = {k: v for k, v in {"nonfinite": n_nonfinite,
                                             "superseded_points": int((~keep).sum())}.items() if v}
    order = np.argsort(recv[keep], kind="stable")
    s.recv_ns, s.header_ns = recv[keep][order], hdr[keep][order]
    s.values = {"q": np.asarray(q)[keep][order]}


# ---------------------------------------------------------------------------------------------
# time


def _assign_time(s: Stream, opts: ImportOptions) -> None:
    """Choose the time base of a stream (step 2) and record why in ``s.report``."""
    r, h = s.recv_ns, s.header_ns
    rep = s.report
    no_header = s.msgtype == FLOAT64_ARRAY
    # one message at stamp 0 is a clock starting at 0 (sim time); more are unset stamps
    zero = int((h == 0).sum())
    zero = zero if zero > 1 else 0
    d = (r - h).astype(np.float64)
    rep["clock_offset_s"] = None if no_header or zero == len(h) else float(np.median(d) / _NS)
    mode, why = "receive", ""
    if opts.time_source == "receive":
        why = "forced by --time-source receive"
    elif no_header:
        why = "the message type has no header"
    elif zero:
        why = f"{zero} of {len(h)} header stamps are zero"
    elif opts.time_source == "header":
        mode, why = "header", "forced by --time-source header"
    elif abs(np.median(d)) <= opts.clock_tolerance_s * _NS:
        mode, why = "header", (f"header stamps on the bag clock (median offset "
                               f"{np.median(d) / 1e6:+.3f} ms)")
    else:
        mode, why = "aligned", (f"header stamps on another clock (median offset "
                                f"{np.median(d) / _NS:+.3f} s), shifted onto the receive clock")
    if mode == "aligned":
        t, pieces = _align(h, r, opts.gap_s)
        if t is None:
            mode, why = "receive", why + "; the stamps jump too often to align, receive time used"
        else:
            s.t_ns = t
            resid = (r - t) / 1e6
            rep["aligned_pieces"] = pieces
            rep["receive_minus_aligned_ms"] = {"p50": float(np.percentile(resid, 50)),
                                               "p99": float(np.percentile(resid, 99))}
    if mode == "header":
        s.t_ns = h.copy()
    elif mode == "receive":
        s.t_ns = r.copy()
        if opts.dejitter and s.role != "cmd":
            t, note = _dejitter(r, opts.gap_s)
            if t is not None:
                s.t_ns, mode = t, "receive-dejittered"
            why += f"; {note}"
    rep["time_source"], rep["time_source_reason"] = mode, why
    # sort by the assigned time; equal times keep the last message (the newest)
    order = np.argsort(s.t_ns, kind="stable")
    backwards = int((np.diff(s.t_ns) < 0).sum())
    s.t_ns, s.recv_ns, s.header_ns = s.t_ns[order], s.recv_ns[order], s.header_ns[order]
    s.values = {k: v[order] for k, v in s.values.items()}
    dup = np.r_[s.t_ns[1:] == s.t_ns[:-1], False]
    if dup.any():
        keep = ~dup
        s.t_ns, s.recv_ns, s.header_ns = s.t_ns[keep], s.recv_ns[keep], s.header_ns[keep]
        s.values = {k: v[keep] for k, v in s.values.items()}
        rep.setdefault("dropped", {})["duplicate_time"] = int(dup.sum())
    if backwards:
        rep["out_of_order"] = backwards
    dt = np.diff(s.t_ns) / 1e6
    if dt.size:
        rep["rate_hz"] = float(1e3 * dt.size / max((s.t_ns[-1] - s.t_ns[0]) / 1e6, 1e-9))
        rep["interval_ms"] = {k: float(np.percentile(dt, p)) for k, p in
                              (("p1", 1), ("p50", 50), ("p99", 99))} | {"max": float(dt.max())}
        rep["jitter_ms"] = float(np.std(dt))
    rep["interval_series"] = (s.t_ns, dt)


def _sample_numbers(x: np.ndarray, a: float, b: float) -> np.ndarray:
    """Sample numbers of receive times ``x`` on the clock ``a + b * k`` (centred on the typical
    delay). A message delayed by more than half a period rounds onto the next sample's number:
    where two share one, the later (relative to the clock) moves back one, a few passes."""
    idx = np.round((x - a) / b)
    for _ in range(4):
        late = x - (a + b * idx)
        order = np.lexsort((late, idx))
        dup = idx[order][1:] == idx[order][:-1]
        if not dup.any():
            break
        idx[order[1:][dup]] -= 1
    return idx


def _dejitter(r: np.ndarray, gap_s: float) -> tuple[np.ndarray | None, str]:
    """Receive times of a regularly sampled stream mapped onto the sender's clock.

    A sensor samples on its own regular clock; the receive times add a varying delay. Per
    stretch without a gap, each message gets its sample number (the nominal period counted
    over lost messages) and the sending clock is fitted as a line through the least-delayed
    messages (least squares on those at or below the median residual, twice), shifted to the
    5th percentile of the delays. Not applied (None) when the stream is not regular: the bulk of
    the residuals (p1 to p75; a few long stalls are normal) spread over 3/4 of a period, or too
    few messages.
    """
    dt = np.diff(r)
    if dt.size < 20:
        return None, "too few messages to fit the sending clock"
    period = float(np.median(dt))
    if period <= 0:
        return None, "no regular period"
    out = np.empty_like(r)
    cut = np.flatnonzero(dt > gap_s * _NS) + 1
    spread: list[float] = []
    fitted: list[float] = []
    for a, b in zip(np.r_[0, cut], np.r_[cut, len(r)]):
        x = r[a:b].astype(np.float64) - float(r[a])
        if b - a < 10:
            out[a:b] = r[a:b]
            continue
        a0, b0, med = 0.0, period, 0.0
        n = b - a
        # growing windows, so that an error of the period cannot pile up to a whole sample
        for w in [k for k in (30, 100, 300, 1000, 3000, 10000) if k < n] + [n, n]:
            xw = x[:w]
            # sample numbers on the current clock estimate, centred on the typical delay, and
            # strictly increasing (the messages of one connection arrive in order)
            idx = _sample_numbers(xw, a0 + med, b0)
            keep = np.ones(w, bool)
            for _k in range(2):   # the line through the least-delayed half
                A = np.column_stack([np.ones(keep.sum()), idx[keep]])
                coef, *_r = np.linalg.lstsq(A, xw[keep], rcond=None)
                res = xw - (coef[0] + coef[1] * idx)
                keep = res <= np.median(res)
            a0, b0 = float(coef[0]), float(coef[1])
            med = float(np.median(xw - (a0 + b0 * idx)))
        fit = coef[0] + coef[1] * idx
        res = x - fit
        spread.append(float(np.percentile(res, 75) - np.percentile(res, 1)))
        fitted.append(b0)
        out[a:b] = r[a] + np.round(fit + np.percentile(res, 5)).astype(np.int64)
    worst = max(spread) if spread else 0.0
    if worst > 0.75 * period:
        return None, (f"receive delays spread {worst / 1e6:.1f} ms (p1-p75), over 3/4 period: "
                      "not regular, receive times used")
    if np.unique(out).size != out.size:
        return None, "two messages on one sample of the fitted clock, receive times used"
    period = float(np.median(fitted)) if fitted else period
    return out, (f"sending clock fitted (period {period / 1e6:.4f} ms, delays spread p1-p75 "
                 f"{worst / 1e6:.2f} ms)")


def _align(h: np.ndarray, r: np.ndarray, gap_s: float) -> tuple[np.ndarray | None, int]:
    """Header stamps of another clock shifted onto the receive clock, one offset per piece.

    A new piece starts where the stamps go backwards or jump forward by more than ``gap_s``
    (a reset of that clock, or lost messages). Within a piece the stamps are the time base:
    their spacing is the truth of the clock that made them, and receive delays that vary (a
    simulator falling behind real time and catching up in bursts) do not cut the recording;
    ``receive_minus_aligned_ms`` in the report shows how much they varied.
    """
    d = r - h
    gap = int(gap_s * _NS)
    dh = np.diff(h)
    cut = np.flatnonzero((dh <= 0) | (dh > gap)) + 1
    if cut.size > max(10, len(h) // 50):
        return None, 0
    t = np.empty_like(h)
    for a, b in zip(np.r_[0, cut], np.r_[cut, len(h)]):
        t[a:b] = h[a:b] + int(np.percentile(d[a:b], 5))
    return t, int(cut.size + 1)


# ---------------------------------------------------------------------------------------------
# segments and resampling


@dataclass
class Segment:
    """A stretch of the recording resampled onto the 10 ms grid, as a move."""

    bag: str
    index: int                   # within the bag
    rec: MoveRecording
    start_ns: int
    ended_by: str
    label_source: str = ""
    superseded_cmds: int = 0
    held_steps: int = 0


def _breaks(s: Stream, opts: ImportOptions) -> list[tuple[int, int, str]]:
    """Intervals (a, b) of a stream that no segment may span, with the reason."""
    t = s.t_ns
    dt = np.diff(t)
    out: list[tuple[int, int, str]] = []
    gap = opts.gap_s * _NS
    for k in np.flatnonzero(dt > gap):
        out.append((int(t[k]), int(t[k + 1]), f"gap of {dt[k] / 1e6:.0f} ms in {s.topic}"))
    dts = np.maximum(dt, 1) / _NS
    if s.role == "pose":
        dp = np.linalg.norm(np.diff(s.values["position"], axis=0), axis=1)
        q = s.values["orientation"]
        dang = 2 * np.arccos(np.clip(np.abs(np.sum(q[1:] * q[:-1], axis=1)), 0, 1))
        jump = (dp > opts.reset_jump_m + MAX_SPEED_M_S * dts) | \
               (dang > opts.reset_jump_rad + MAX_RATE_RAD_S * dts)
        for k in np.flatnonzero(jump & (dt <= gap)):
            out.append((int(t[k]), int(t[k + 1]), f"reset: pose jumped {dp[k]:.3f} m, "
                                                  f"{dang[k]:.2f} rad in {s.topic}"))
    elif s.role == "joint_states":
        dq = np.abs(np.diff(s.values["q"], axis=0)).max(axis=1)
        jump = dq > opts.joint_jump_rad + MAX_JOINT_RATE_RAD_S * dts
        for k in np.flatnonzero(jump & (dt <= gap)):
            out.append((int(t[k]), int(t[k + 1]), f"reset: a joint jumped {dq[k]:.2f} rad in "
                                                  f"{s.topic}"))
    if s.report.get("time_source") == "aligned":
        # a piece boundary of an aligned clock (time jump or pause) is a break as well
        off = s.t_ns - s.header_ns
        for k in np.flatnonzero(np.diff(off) != 0):
            if dt[k] <= gap:
                out.append((int(t[k]), int(t[k + 1]), f"time jump in {s.topic}"))
    return out


def _interp_index(t: np.ndarray, grid: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Left sample index and weight of each grid time (t sorted, grid within [t0, t-1])."""
    i = np.clip(np.searchsorted(t, grid, side="right") - 1, 0, len(t) - 2)
    w = (grid - t[i]) / np.maximum(t[i + 1] - t[i], 1)
    return i, np.clip(w, 0.0, 1.0)


def _lerp(v: np.ndarray, i: np.ndarray, w: np.ndarray) -> np.ndarray:
    return v[i] * (1.0 - w[:, None]) + v[i + 1] * w[:, None]


def _slerp(q: np.ndarray, i: np.ndarray, w: np.ndarray) -> np.ndarray:
    a, b = q[i], q[i + 1]
    dot = np.sum(a * b, axis=1)
    b = np.where(dot[:, None] < 0, -b, b)
    dot = np.abs(dot)
    theta = np.arccos(np.clip(dot, -1.0, 1.0))
    small = theta < 1e-6
    st = np.where(small, 1.0, np.sin(theta))
    wa = np.where(small, 1.0 - w, np.sin((1.0 - w) * theta) / st)
    wb = np.where(small, w, np.sin(w * theta) / st)
    out = a * wa[:, None] + b * wb[:, None]
    out /= np.linalg.norm(out, axis=1, keepdims=True)
    out[w == 0.0] = a[w == 0.0]                 # on a sample: the sample itself, bit for bit
    out[w == 1.0] = q[i + 1][w == 1.0]
    return out


def _twist_from_poses(p: np.ndarray, q: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Body twist at each grid pose by a backward difference (the first by a forward one)."""
    from ..rotations import quat_to_matrix

    v_world = np.diff(p, axis=0) / CONTROL_DT
    R1 = quat_to_matrix(q[1:])
    lin = np.einsum("nji,nj->ni", R1, v_world)
    ang = rotvec_from_quat(quat_multiply(quat_conjugate(q[:-1]), q[1:])) / CONTROL_DT
    return np.vstack([lin[:1], lin]), np.vstack([ang[:1], ang])


def segment_recording(rs: RecordingStreams, opts: ImportOptions) -> tuple[list[Segment], dict]:
    """Cut a bag's streams into segments and resample each onto the 10 ms grid (steps 3, 4).

    Returns the segments and a report dict (breaks, dropped segments, command statistics).
    """
    js, pose, cmd = (rs.streams[r] for r in ("joint_states", "pose", "cmd"))
    cut = _breaks(js, opts) + _breaks(pose, opts)
    cut.sort()
    lo = max(js.t_ns[0], pose.t_ns[0])
    hi = min(js.t_ns[-1], pose.t_ns[-1])
    # free stretches: [lo, hi] minus the break intervals
    stretches: list[tuple[int, int, str]] = []
    cur = lo
    for a, b, why in cut:
        if a > cur:
            stretches.append((cur, min(a, hi), why))
        cur = max(cur, b)
        if cur >= hi:
            break
    if cur < hi:
        stretches.append((cur, hi, "end of the recording"))
    report = {"breaks": [{"from_s": a / _NS, "to_s": b / _NS, "why": w} for a, b, w in cut],
              "dropped_segments": []}
    min_steps = max(2, int(round(opts.min_segment_s / CONTROL_DT)))
    phase = _grid_phase(js, cmd, report)
    cutoff = int(opts.cmd_cutoff_s * _NS)
    segs: list[Segment] = []
    for a, b, why in stretches:
        # first command inside the stretch; the grid starts at a joint-state sample such that
        # that command came before measurement 1 (minus the cutoff)
        c0 = np.searchsorted(cmd.t_ns, a, side="left")
        if c0 >= len(cmd.t_ns) or cmd.t_ns[c0] > b:
            report["dropped_segments"].append({"from_s": a / _NS, "to_s": b / _NS,
                                               "why": "no command in it"})
            continue
        start_min = max(a, int(cmd.t_ns[c0]) + cutoff - CONTROL_DT_NS + 1)
        k0 = np.searchsorted(js.t_ns, start_min, side="left")
        if k0 >= len(js.t_ns):
            continue
        t0 = int(js.t_ns[k0])
        if phase is not None:   # joint states not at 100 Hz: the grid avoids the commands
            t0 = start_min + (phase - start_min) % CONTROL_DT_NS
        n = (b - t0) // CONTROL_DT_NS if b > t0 else -1
        if n < min_steps:
            report["dropped_segments"].append({
                "from_s": a / _NS, "to_s": b / _NS,
                "why": f"{max(n, 0)} steps, fewer than --min-segment-s {opts.min_segment_s} s"})
            continue
        grid = t0 + CONTROL_DT_NS * np.arange(n + 1, dtype=np.int64)
        segs.append(_resample(rs, opts, len(segs), grid, why, c0))
    # commands used per step vs received in the segments: the rest were superseded
    report["commands"] = {"superseded": int(sum(s.superseded_cmds for s in segs)),
                          "held_steps": int(sum(s.held_steps for s in segs))}
    return segs, report


def _grid_phase(js: Stream, cmd: Stream, report: dict) -> int | None:
    """Phase (ns mod 10 ms) of the grid, or None to start it at a joint-state sample.

    With joint states at 100 Hz (a simulator's or robot's control clock) the grid is their
    clock. Otherwise (e.g. 500 Hz encoders) the grid points go in the middle of the largest gap
    between the arrival phases of the commands, so that which command a step gets does not
    depend on jitter.
    """
    dt = np.diff(js.t_ns)
    if dt.size and abs(np.median(dt) - CONTROL_DT_NS) <= 0.1 * CONTROL_DT_NS:
        report["grid"] = "on the joint-state samples (100 Hz)"
        return None
    ph = np.sort(cmd.t_ns % CONTROL_DT_NS)
    gaps = np.diff(np.r_[ph, ph[0] + CONTROL_DT_NS])
    k = int(np.argmax(gaps))
    phase = int((ph[k] + gaps[k] // 2) % CONTROL_DT_NS)
    report["grid"] = (f"phase {phase / 1e6:.2f} ms (mod 10 ms): in the middle of the largest "
                      f"gap ({gaps[k] / 1e6:.2f} ms) between command arrival phases")
    return phase


def _resample(rs: RecordingStreams, opts: ImportOptions, index: int, grid: np.ndarray,
              ended_by: str, c0: int) -> Segment:
    js, pose, cmd = (rs.streams[r] for r in ("joint_states", "pose", "cmd"))
    i, w = _interp_index(js.t_ns, grid)
    q, dq = _lerp(js.values["q"], i, w), _lerp(js.values["dq"], i, w)
    if js.report.get("velocity_from_positions"):
        dq = np.gradient(q, CONTROL_DT, axis=0)
    i, w = _interp_index(pose.t_ns, grid)
    pos = _lerp(pose.values["position"], i, w)
    ori = _slerp(pose.values["orientation"], i, w)
    use_msg = "linear" in pose.values and opts.twist in ("auto", "message")
    if opts.twist == "message" and "linear" not in pose.values:
        raise BagError(rs.bag, pose.topic, f"{pose.msgtype} has no twist; use --twist pose")
    if use_msg:
        lin, ang = _lerp(pose.values["linear"], i, w), _lerp(pose.values["angular"], i, w)
    else:
        lin, ang = _twist_from_poses(pos, ori)
    # command of step k -> k+1: newest command (from c0 on) before grid[k+1] - cutoff
    cutoff = int(opts.cmd_cutoff_s * _NS)
    ci = np.searchsorted(cmd.t_ns, grid[1:] - cutoff, side="left") - 1
    ci = np.maximum(ci, c0)
    u = cmd.values["q"][ci]
    used = np.unique(ci)
    received = np.searchsorted(cmd.t_ns, grid[-1] - cutoff, side="left") - c0
    rec = MoveRecording(name="", move_type=UNKNOWN_MOVE_TYPE, stamps_ns=grid, cmd=u, q=q, dq=dq,
                        position=pos, orientation=ori, linear_velocity=lin, angular_velocity=ang)
    return Segment(rs.bag, index, rec, int(grid[0]), ended_by,
                   superseded_cmds=int(max(received - used.size, 0)),
                   held_steps=int((np.diff(ci) == 0).sum()))


def _split_long(seg: Segment, max_steps: int) -> list[Segment]:
    n = seg.rec.n_steps
    if max_steps <= 0 or n <= max_steps:
        return [seg]
    parts = -(-n // max_steps)
    bounds = np.linspace(0, n, parts + 1).round().astype(int)
    out = []
    r = seg.rec
    for a, b in zip(bounds[:-1], bounds[1:]):
        sub = MoveRecording(name="", move_type=r.move_type, stamps_ns=r.stamps_ns[a:b + 1],
                            cmd=r.cmd[a:b], q=r.q[a:b + 1], dq=r.dq[a:b + 1],
                            position=r.position[a:b + 1], orientation=r.orientation[a:b + 1],
                            linear_velocity=r.linear_velocity[a:b + 1],
                            angular_velocity=r.angular_velocity[a:b + 1])
        out.append(Segment(seg.bag, seg.index, sub, int(sub.stamps_ns[0]),
                           seg.ended_by if b == n else f"split at --max-move-s {max_steps / 100} s"))
    out[0].superseded_cmds, out[0].held_steps = seg.superseded_cmds, seg.held_steps
    return out


# ---------------------------------------------------------------------------------------------
# the whole import


def expand_bag_paths(paths: Sequence[str | os.PathLike]) -> list[Path]:
    """The bags named by ``paths``: a bag itself, or a plain folder of bags (a directory without
    ``metadata.yaml``: its rosbag2 directories and .mcap/.db3/.bag files, sorted by name)."""
    out: list[Path] = []
    for p in map(Path, paths):
        if p.is_dir() and not (p / "metadata.yaml").is_file():
            found = sorted(c for c in p.iterdir() if not c.name.startswith(".") and (
                (c.is_dir() and (c / "metadata.yaml").is_file())
                or (c.is_file() and c.suffix in (".mcap", ".db3", ".bag"))))
            if not found:
                raise BagError(p, None, "neither a bag nor a folder of bags")
            out += found
        else:
            out.append(p)
    return out


@dataclass
class ImportResult:
    out: Path
    n_moves: int
    n_train: int
    n_test: int
    n_messages: int
    wall_s: float
    read_s: float          # wall time of reading, decoding, segmenting, resampling
    report: dict


def import_bags(bags: Sequence[str | os.PathLike], out: str | os.PathLike,
                opts: ImportOptions | None = None, overwrite: bool = False,
                figure: bool = True, robot: str | os.PathLike | None = None) -> ImportResult:
    """Import ``bags`` into a new dataset directory ``out`` (atomically) with its report.

    ``robot``: what the data came from, a robot name or a twin file (``robot.twin``), recorded
    in ``dataset.yaml`` as ``record`` records it (``robot.twin.robot_source``); None: unknown.
    ValueError/BagError (one line) for a bad option, robot or bag; nothing is written then.
    """
    from .. import __version__
    from ..fileio import atomic_directory
    from .bags import write_bag
    from .dataset import BagEntry, n_train, write_index
    from .import_report import write_report
    from .summary import infer_move_type

    opts = opts or ImportOptions()
    opts.check()
    source = {}
    if robot is not None:
        from ..robot.twin import robot_source
        source = robot_source(robot)
    bags = expand_bag_paths(bags)
    if not bags:
        raise ValueError("no bags given")
    if len(opts.move_types) not in (0, 1, len(bags)):
        raise ValueError(f"{len(opts.move_types)} move types for {len(bags)} bags: give one, "
                         "or one per bag")
    out = Path(out)
    if out.exists() and not overwrite:
        raise FileExistsError(f"{out} already exists; pass --overwrite to replace it")
    t_start = time.perf_counter()
    moves: list[Segment] = []
    bag_reports: list[dict] = []
    n_msgs = 0
    read_s = read_cpu_s = 0.0   # reading, decoding, timing, segmenting, resampling
    for bi, path in enumerate(bags):
        given = opts.move_types[0 if len(opts.move_types) == 1 else bi] \
            if opts.move_types else None
        t0, c0 = time.perf_counter(), time.process_time()
        try:
            rs = read_recording(path, opts)
            segs, seg_report = segment_recording(rs, opts)
            read_s += time.perf_counter() - t0
            read_cpu_s += time.process_time() - c0
        except BagError as exc:
            if not opts.skip_bad_bags:
                raise
            log.warning("skipped %s", exc)
            bag_reports.append({"path": str(path), "skipped": str(exc)})
            continue
        n_msgs += rs.n_messages
        if not segs:
            log.warning("%s: no segment of at least %s s", path, opts.min_segment_s)
        seg_rows = []
        for seg in segs:
            if given:
                seg.rec.move_type, seg.label_source = given, "--move-type"
            for part in _split_long(seg, int(round(opts.max_move_s / CONTROL_DT))):
                if given:
                    part.rec.move_type, part.label_source = given, "--move-type"
                elif opts.infer_types:
                    t = infer_move_type(part.rec)
                    part.rec.move_type = t or UNKNOWN_MOVE_TYPE
                    part.label_source = "inferred" if t else "fits no type"
                else:
                    part.label_source = "not inferred"
                moves.append(part)
                seg_rows.append(part)
        bag_reports.append({"path": str(path), "kind": rs.kind, "messages": rs.n_messages,
                            "messages_in_bag": rs.n_messages_bag,
                            **({"recovered": rs.recovered} if rs.recovered else {}),
                            "topics": {r: s.report for r, s in rs.streams.items()},
                            "_segments": seg_rows, **seg_report})
    if not moves:
        raise ValueError("no usable segment in " + ", ".join(str(b) for b in bags)
                         + (" (see the warnings)" if opts.skip_bad_bags else ""))
    # names per type in recording order, then the split per type
    counters: dict[str, int] = {}
    by_type: dict[str, list[Segment]] = {}
    for m in moves:
        k = counters.get(m.rec.move_type, 0)
        counters[m.rec.move_type] = k + 1
        m.rec.name = f"{m.rec.move_type}_{k:02d}"
        by_type.setdefault(m.rec.move_type, []).append(m)
    split: dict[str, str] = {}
    for t, ms in by_type.items():
        k = n_train(len(ms), 1.0 - opts.test_fraction)
        for j, m in enumerate(ms):
            split[m.rec.name] = "train" if j < k else "test"
    entries = [BagEntry(m.rec.name, m.rec.move_type, split[m.rec.name]) for m in moves]
    wall_read = time.perf_counter() - t_start
    opt_dict = {k: (list(v) if isinstance(v, tuple) else v) for k, v in asdict(opts).items()}
    info = {"imported_from": [str(b) for b in bags], "import_options": opt_dict,
            "storage": opts.storage, "control_dt_ns": CONTROL_DT_NS,
            "types": sorted(by_type, key=DATASET_MOVE_TYPES.index),
            "recorded_by": f"littledog_mlsim {__version__} import", **source}
    if opts.command_excitation_rad:
        # the key record writes: diagnose --reference compares it (diagnose.conditions)
        info["command_excitation_rad"] = float(opts.command_excitation_rad)
    with atomic_directory(out, replace=overwrite) as tmp:
        for m in moves:
            write_bag(tmp / m.rec.name, m.rec, storage=opts.storage)
        write_index(tmp, entries, info)
        report = write_report(tmp, bags=bag_reports, entries=entries, opts=opt_dict,
                              n_messages=n_msgs, read_s=read_s, read_cpu_s=read_cpu_s,
                              wall_s=wall_read,
                              figure=figure)
    n_tr = sum(e.split == "train" for e in entries)
    return ImportResult(out, len(entries), n_tr, len(entries) - n_tr, n_msgs,
                        time.perf_counter() - t_start, read_s, report)
