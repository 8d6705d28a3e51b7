"""Write moves as a *real-style* recording: one bag the way ``ros2 bag record`` records a live robot.

For the tests and the benchmark of ``littledog-mlsim import`` (``benchmarks/import``): the moves
(contract recordings, command k applied for step k -> k+1) are laid out one after another on a
wall clock, with a reset between them, and their messages are timed the way a simulator in timer
mode and a separate controller produce them:

- the simulator ticks every 10 ms of wall time (its sim time advances 10 ms per tick and one step
  more on every reset, as ``nodes/simulator.py`` does); measurement k of a move is true at tick
  k; joint states and pose may come at other rates (samples interpolated from the move);
- every message is received (bag time) after a delay: ``latency_ms`` plus an exponential tail
  (mean ``jitter_ms``), and with probability ``spike_prob`` a scheduling stall of a few ms;
- the controller answers measurement k within the step, ``cmd_delay_ms`` after the tick (so the
  simulator's next tick applies command k, as in the source move), stamps with its own wall
  clock (``controller_clock_offset_ms`` off the recorder's), and sends its joints in its own
  order; with probability ``duplicate_prob`` it sends a command twice (superseded);
- header stamps: ``sim`` (the simulator's sim time: another clock than the bag's), ``wall``
  (true times on the bag clock) or ``zero``; commands as ``Float64MultiArray`` carry none;
- joint-state and pose messages are dropped with probability ``drop_prob`` (never the first or
  last of a move; commands are not dropped, since the simulator would then have held the
  previous one and the source move would no longer be the truth);
- between moves the recording pauses ``reset_pause_s`` (no messages) and the pose jumps back.

``truth`` returned by :func:`write_realstyle_bag` gives the wall time of measurement 0 of each
move, so a test can compare what the importer produced against the source moves.
"""
from __future__ import annotations

import os
import shutil
import tempfile
from dataclasses import dataclass
from pathlib import Path
from typing import Sequence

import numpy as np

from ..layout import CONTROL_DT_NS, JOINT_NAMES
from .decode import FLOAT64_ARRAY, JOINT_STATE, JOINT_TRAJECTORY, ODOMETRY, POSE_STAMPED
from .recording import MoveRecording

__all__ = ["RealStyle", "write_realstyle_bag", "WALL_T0_NS"]

WALL_T0_NS = 1_795_463_600_000_000_000   # a wall-clock start (2026)


@dataclass
class RealStyle:
    js_rate_hz: float = 100.0
    pose_rate_hz: float = 100.0
    stamps: str = "sim"                 # sim | wall | zero (joint states and pose)
    cmd_type: str = JOINT_STATE         # JointState | Float64MultiArray | JointTrajectory
    pose_type: str = ODOMETRY           # Odometry | PoseStamped
    latency_ms: float = 0.3
    jitter_ms: float = 0.7
    spike_prob: float = 0.02
    spike_ms: float = 4.0
    cmd_delay_ms: tuple[float, float] = (1.0, 6.0)
    controller_clock_offset_ms: float = 3.0
    duplicate_prob: float = 0.05
    drop_prob: float = 0.0
    reset_pause_s: float = 0.3
    controller_joint_order: tuple[str, ...] = tuple(reversed(JOINT_NAMES))
    extra_joints: tuple[str, ...] = ("tail_joint",)
    storage: str = "mcap"               # mcap | sqlite3 | ros1
    seed: int = 0


def _sample(rec: MoveRecording, x: np.ndarray) -> dict[str, np.ndarray]:
    """The move's measurements at fractional step indices x (linear; orientation slerp)."""
    from .importer import _lerp, _slerp

    n = rec.stamps_ns.shape[0]
    i = np.clip(np.floor(x).astype(int), 0, n - 2)
    w = np.clip(x - i, 0.0, 1.0)
    return {"q": _lerp(rec.q, i, w), "dq": _lerp(rec.dq, i, w),
            "position": _lerp(rec.position, i, w), "orientation": _slerp(rec.orientation, i, w),
            "linear": _lerp(rec.linear_velocity, i, w), "angular": _lerp(rec.angular_velocity, i, w)}


def write_realstyle_bag(path: str | os.PathLike, moves: Sequence[MoveRecording],
                        style: RealStyle | None = None, topics: dict[str, str] | None = None
                        ) -> dict:
    """Write ``moves`` as one real-style recording at ``path`` (see the module docstring).

    ``path``: a directory (rosbag2), or a file ending in ``.mcap``/``.db3`` (the storage file
    alone, without metadata.yaml) or ``.bag`` (ROS 1). ``topics``: role -> topic name (cmd,
    joint_states, pose). Returns ``{"move_t0_ns": [...], "n_messages": n}``.
    """
    st = style or RealStyle()
    rng = np.random.default_rng(st.seed)
    topics = {"cmd": "/littledog/cmd", "joint_states": "/littledog/joint_states",
              "pose": "/littledog/odom", **(topics or {})}
    msgs: list[tuple[int, str, object]] = []   # (receive time, role, message)

    def delay(n: int) -> np.ndarray:
        d = st.latency_ms + rng.exponential(st.jitter_ms, n)
        d += np.where(rng.random(n) < st.spike_prob, rng.uniform(0, st.spike_ms, n), 0.0)
        return (d * 1e6).astype(np.int64)

    def kept(n: int) -> np.ndarray:
        keep = rng.random(n) >= st.drop_prob
        keep[[0, -1]] = True
        return keep

    wall = WALL_T0_NS
    sim = 0
    move_t0 = []
    for rec in moves:
        n = rec.n_steps
        move_t0.append(wall)
        dur_ns = n * CONTROL_DT_NS
        for role, rate in (("joint_states", st.js_rate_hz), ("pose", st.pose_rate_hz)):
            period = int(round(1e9 / rate))
            t_true = wall + np.arange(0, dur_ns + 1, period, dtype=np.int64)
            vals = _sample(rec, (t_true - wall) / CONTROL_DT_NS)
            recv = t_true + delay(t_true.size)
            stamp = {"sim": t_true - wall + sim, "wall": t_true,
                     "zero": np.zeros_like(t_true)}[st.stamps]
            for j in np.flatnonzero(kept(t_true.size)):
                msgs.append((int(recv[j]), role, (int(stamp[j]), {k: v[j] for k, v in vals.items()})))
        # commands: command k sent cmd_delay after tick k, received before tick k+1
        lo, hi = st.cmd_delay_ms
        send = wall + np.arange(n, dtype=np.int64) * CONTROL_DT_NS + \
            (rng.uniform(lo, hi, n) * 1e6).astype(np.int64)
        recv = np.minimum(send + delay(n), wall + (np.arange(n) + 1) * CONTROL_DT_NS - 1_500_000)
        own = send + int(st.controller_clock_offset_ms * 1e6)
        if st.cmd_type == JOINT_TRAJECTORY:     # every 2nd step: points for k and k+1
            for k in range(0, n, 2):
                pts = [(0, rec.cmd[k])] + ([(CONTROL_DT_NS, rec.cmd[k + 1])] if k + 1 < n else [])
                msgs.append((int(recv[k]), "cmd", (int(own[k]), pts)))
        else:
            for k in range(n):
                msgs.append((int(recv[k]), "cmd", (int(own[k]), rec.cmd[k])))
                if rng.random() < st.duplicate_prob:   # sent twice: the first one superseded
                    msgs.append((int(recv[k]) + 200_000, "cmd", (int(own[k]) + 200_000, rec.cmd[k])))
        wall += dur_ns + CONTROL_DT_NS + int(st.reset_pause_s * 1e9)
        sim += dur_ns + CONTROL_DT_NS + (int(st.reset_pause_s * 1e9) // CONTROL_DT_NS) * CONTROL_DT_NS
    msgs.sort(key=lambda m: m[0])
    _write(Path(path), msgs, st, topics)
    return {"move_t0_ns": move_t0, "n_messages": len(msgs)}


def _write(path: Path, msgs: list, st: RealStyle, topics: dict[str, str]) -> None:
    from rosbags.typesys import Stores, get_typestore

    ros1 = path.suffix == ".bag"
    ts = get_typestore(Stores.ROS1_NOETIC if ros1 else Stores.ROS2_JAZZY)
    T = ts.types
    types = {"cmd": st.cmd_type, "joint_states": JOINT_STATE, "pose": st.pose_type}
    has_seq = any(f[0] == "seq" for f in ts.fielddefs["std_msgs/msg/Header"][1])

    def header(t: int, frame: str = ""):
        kw = {"seq": 0} if has_seq else {}
        return T["std_msgs/msg/Header"](stamp=T["builtin_interfaces/msg/Time"](
            sec=t // 1_000_000_000, nanosec=t % 1_000_000_000), frame_id=frame, **kw)

    order_cmd = list(st.controller_joint_order)
    perm_cmd = np.array([JOINT_NAMES.index(j) for j in order_cmd])
    js_names = list(JOINT_NAMES[6:]) + list(st.extra_joints) + list(JOINT_NAMES[:6])
    empty = np.zeros(0)

    def build(role: str, payload):
        stamp, v = payload
        typ = types[role]
        if role == "joint_states":
            q = np.concatenate([v["q"][6:], np.zeros(len(st.extra_joints)), v["q"][:6]])
            dq = np.concatenate([v["dq"][6:], np.zeros(len(st.extra_joints)), v["dq"][:6]])
            return T[JOINT_STATE](header=header(stamp), name=js_names, position=q,
                                  velocity=dq, effort=empty)
        if role == "pose":
            P = T["geometry_msgs/msg/Pose"](
                position=T["geometry_msgs/msg/Point"](x=v["position"][0], y=v["position"][1],
                                                      z=v["position"][2]),
                orientation=T["geometry_msgs/msg/Quaternion"](
                    x=v["orientation"][0], y=v["orientation"][1], z=v["orientation"][2],
                    w=v["orientation"][3]))
            if typ == POSE_STAMPED:
                return T[POSE_STAMPED](header=header(stamp, "mocap"), pose=P)
            V3 = T["geometry_msgs/msg/Vector3"]
            cov = np.zeros(36)
            return T[ODOMETRY](
                header=header(stamp, "odom"), child_frame_id="base_link",
                pose=T["geometry_msgs/msg/PoseWithCovariance"](pose=P, covariance=cov),
                twist=T["geometry_msgs/msg/TwistWithCovariance"](
                    twist=T["geometry_msgs/msg/Twist"](linear=V3(*v["linear"]),
                                                       angular=V3(*v["angular"])),
                    covariance=cov))
        if typ == FLOAT64_ARRAY:
            layout = T["std_msgs/msg/MultiArrayLayout"](dim=[T["std_msgs/msg/MultiArrayDimension"](
                label="joints", size=12, stride=12)], data_offset=0)
            return T[FLOAT64_ARRAY](layout=layout, data=np.asarray(v)[perm_cmd].copy())
        if typ == JOINT_TRAJECTORY:
            Dur = T["builtin_interfaces/msg/Duration"]
            pts = [T["trajectory_msgs/msg/JointTrajectoryPoint"](
                positions=np.asarray(p)[perm_cmd].copy(), velocities=empty, accelerations=empty,
                effort=empty, time_from_start=Dur(sec=0, nanosec=int(off))) for off, p in v]
            return T[JOINT_TRAJECTORY](header=header(stamp), joint_names=order_cmd, points=pts)
        return T[JOINT_STATE](header=header(stamp), name=order_cmd,
                              position=np.asarray(v)[perm_cmd].copy(), velocity=empty,
                              effort=empty)

    if ros1:
        from rosbags.rosbag1 import Writer as Writer1

        with Writer1(path) as w:
            conns = {r: w.add_connection(topics[r], types[r], typestore=ts) for r in topics}
            for t, role, payload in msgs:
                w.write(conns[role], t, ts.serialize_ros1(build(role, payload), types[role]))
        return
    from rosbags.rosbag2 import StoragePlugin, Writer

    single = path.suffix in (".mcap", ".db3")
    storage = "sqlite3" if path.suffix == ".db3" else ("mcap" if single else st.storage)
    plugin = StoragePlugin.MCAP if storage == "mcap" else StoragePlugin.SQLITE3
    tmp = Path(tempfile.mkdtemp(prefix=".realstyle.", dir=path.parent))
    try:
        bag_dir = tmp / (path.stem if single else path.name)
        with Writer(bag_dir, version=9, storage_plugin=plugin) as w:
            conns = {r: w.add_connection(topics[r], types[r], typestore=ts) for r in topics}
            for t, role, payload in msgs:
                w.write(conns[role], t, ts.serialize_cdr(build(role, payload), types[role]))
        if single:
            (f,) = [p for p in bag_dir.iterdir() if p.suffix == path.suffix]
            os.rename(f, path)
        else:
            os.rename(bag_dir, path)
    finally:
        shutil.rmtree(tmp, ignore_errors=True)
