"""Bag writing/reading (littledog_mlsim.data.bags) on synthetic moves.

Bad bags are built with ``rosbags`` directly (or by damaging files), never with ``write_bag``,
so the reader's checks are tested against bags that ``write_bag`` could never produce.
"""
from __future__ import annotations

import copy
from pathlib import Path

import numpy as np
import pytest
from rosbags.highlevel import AnyReader
from rosbags.rosbag2 import StoragePlugin, Writer
from rosbags.typesys import Stores, get_typestore

from littledog_mlsim.data import bags as bags_mod
from littledog_mlsim.data.bags import BagError, read_bag, write_bag
from littledog_mlsim.data.recording import MoveRecording
from synthetic import make_recording
from littledog_mlsim.layout import (
    CONTROL_DT_NS, JOINT_NAMES, TOPIC_CMD, TOPIC_JOINT_STATES, TOPIC_ODOM,
)

TS = get_typestore(Stores.ROS2_JAZZY)
FIELDS = ("stamps_ns", "cmd", "q", "dq", "position", "orientation", "linear_velocity",
          "angular_velocity")


def synthetic_recording(name: str = "FL_03", n: int = 400, t0_ns: int = 1_234_000_000_000,
                        seed: int = 0) -> MoveRecording:
    """A smooth move whose yaw crosses +pi, with non-zero roll and pitch."""
    return make_recording(name, n=n, seed=seed, t0_ns=t0_ns)


def assert_same(a: MoveRecording, b: MoveRecording) -> None:
    for f in FIELDS:
        x, y = getattr(a, f), getattr(b, f)
        assert x.shape == y.shape, f
        assert np.array_equal(x, y), f  # bit-exact


def assert_bag_error(exc: pytest.ExceptionInfo, bag: Path, topic: str | None) -> None:
    msg = str(exc.value)
    assert "\n" not in msg
    assert str(bag) in msg
    assert (f"topic {topic}" if topic else "whole bag") in msg, msg


# --- raw bags built with rosbags --------------------------------------------------------------

MSGTYPES = dict(bags_mod.EXPECTED_MSGTYPES)


def _stamp(t: int):
    return TS.types["builtin_interfaces/msg/Time"](sec=t // 10**9, nanosec=t % 10**9)


def raw_items(rec: MoveRecording, cmd_names=JOINT_NAMES, n_cmd: int | None = None) -> list:
    """[(topic, bag_time, msg)] of a valid bag; tests damage this list before writing it."""
    T = TS.types
    H, JS = T["std_msgs/msg/Header"], T["sensor_msgs/msg/JointState"]
    Odo = T["nav_msgs/msg/Odometry"]
    g = lambda s: T[f"geometry_msgs/msg/{s}"]  # noqa: E731
    cov = np.zeros(36)
    cov[0] = -1
    empty = np.zeros(0)
    perm = [JOINT_NAMES.index(nm) for nm in cmd_names]
    n = rec.n_steps
    n_cmd = n if n_cmd is None else n_cmd
    cmd = np.vstack([rec.cmd, rec.cmd[-1:]])  # an N+1-th command, if asked for
    items = []
    for k, t in enumerate(int(x) for x in rec.stamps_ns):
        p, o = rec.position[k], rec.orientation[k]
        v, w = rec.linear_velocity[k], rec.angular_velocity[k]
        items.append((TOPIC_JOINT_STATES, t, JS(
            header=H(stamp=_stamp(t), frame_id=""), name=list(JOINT_NAMES),
            position=rec.q[k].copy(), velocity=rec.dq[k].copy(), effort=empty)))
        items.append((TOPIC_ODOM, t, Odo(
            header=H(stamp=_stamp(t), frame_id="odom"), child_frame_id="base_link",
            pose=g("PoseWithCovariance")(
                pose=g("Pose")(position=g("Point")(x=p[0], y=p[1], z=p[2]),
                               orientation=g("Quaternion")(x=o[0], y=o[1], z=o[2], w=o[3])),
                covariance=cov),
            twist=g("TwistWithCovariance")(
                twist=g("Twist")(linear=g("Vector3")(x=v[0], y=v[1], z=v[2]),
                                 angular=g("Vector3")(x=w[0], y=w[1], z=w[2])),
                covariance=cov))))
        if k < n_cmd:
            items.append((TOPIC_CMD, t, JS(
                header=H(stamp=_stamp(t), frame_id=""), name=list(cmd_names),
                position=cmd[k][perm].copy(), velocity=empty, effort=empty)))
    return items


def write_raw(path: Path, items: list, msgtypes: dict | None = None,
              storage: StoragePlugin = StoragePlugin.MCAP) -> Path:
    msgtypes = {**MSGTYPES, **(msgtypes or {})}
    with Writer(path, version=9, storage_plugin=storage) as w:
        conns = {tp: w.add_connection(tp, mt, typestore=TS) for tp, mt in msgtypes.items()
                 if any(it[0] == tp for it in items)}
        for topic, t, msg in items:
            data = msg if isinstance(msg, bytes) else TS.serialize_cdr(msg, msgtypes[topic])
            w.write(conns[topic], t, data)
    return path


def nth(items: list, topic: str, k: int) -> int:
    """Index into ``items`` of the k-th message of ``topic``."""
    return [i for i, it in enumerate(items) if it[0] == topic][k]


@pytest.fixture(scope="module")
def short_rec() -> MoveRecording:
    return synthetic_recording("F_01", n=20)


# --- round trip and interoperability ----------------------------------------------------------

@pytest.mark.parametrize("storage", ["mcap", "sqlite3"])
def test_round_trip_bit_exact(tmp_path, storage):
    rec = synthetic_recording("FL_03")
    write_bag(tmp_path / "FL_03", rec, storage=storage)
    back = read_bag(tmp_path / "FL_03")
    assert back.name == "FL_03" and back.move_type == "FL"
    assert back.stamps_ns.dtype == np.int64
    assert_same(rec, back)
    back.validate()
    # only the bag directory, no leftovers of the atomic write
    assert sorted(p.name for p in tmp_path.iterdir()) == ["FL_03"]
    suffix = {"mcap": ".mcap", "sqlite3": ".db3"}[storage]
    assert sorted(p.name for p in (tmp_path / "FL_03").iterdir()) == [
        "FL_03" + suffix, "metadata.yaml"]


def test_move_type_parameter_and_name(tmp_path, short_rec):
    write_bag(tmp_path / "anything", short_rec)
    with pytest.raises(BagError) as exc:
        read_bag(tmp_path / "anything")
    assert_bag_error(exc, tmp_path / "anything", None)
    assert read_bag(tmp_path / "anything", move_type="DL").move_type == "DL"
    with pytest.raises(BagError):
        read_bag(tmp_path / "anything", move_type="XX")


@pytest.mark.parametrize("storage", ["mcap", "sqlite3"])
def test_plain_anyreader_sees_contract(tmp_path, storage):
    rec = synthetic_recording("BR_11", n=30)
    write_bag(tmp_path / "BR_11", rec, storage=storage)
    meta = (tmp_path / "BR_11" / "metadata.yaml").read_text()
    assert "version: 9" in meta and f"storage_identifier: {storage}" in meta
    n = rec.n_steps
    got: dict[str, list] = {TOPIC_CMD: [], TOPIC_JOINT_STATES: [], TOPIC_ODOM: []}
    with AnyReader([tmp_path / "BR_11"], default_typestore=TS) as reader:
        types = {c.topic: c.msgtype for c in reader.connections}
        assert types == {TOPIC_CMD: "sensor_msgs/msg/JointState",
                         TOPIC_JOINT_STATES: "sensor_msgs/msg/JointState",
                         TOPIC_ODOM: "nav_msgs/msg/Odometry"}
        for conn, t, raw in reader.messages():
            msg = reader.deserialize(raw, conn.msgtype)
            assert msg.header.stamp.sec * 10**9 + msg.header.stamp.nanosec == t
            got[conn.topic].append((t, msg))
    assert len(got[TOPIC_CMD]) == n and len(got[TOPIC_JOINT_STATES]) == n + 1
    assert len(got[TOPIC_ODOM]) == n + 1
    for k, (t, m) in enumerate(got[TOPIC_CMD]):
        assert t == rec.stamps_ns[k] and list(m.name) == list(JOINT_NAMES)
        assert np.array_equal(m.position, rec.cmd[k]) and len(m.velocity) == len(m.effort) == 0
    for k, (t, m) in enumerate(got[TOPIC_JOINT_STATES]):
        assert t == rec.stamps_ns[k] and list(m.name) == list(JOINT_NAMES)
        assert np.array_equal(m.position, rec.q[k]) and np.array_equal(m.velocity, rec.dq[k])
    for k, (t, m) in enumerate(got[TOPIC_ODOM]):
        assert m.header.frame_id == "odom" and m.child_frame_id == "base_link"
        o = m.pose.pose.orientation
        assert np.array_equal([o.x, o.y, o.z, o.w], rec.orientation[k])
        assert m.pose.pose.position.z == rec.position[k, 2]
        assert m.twist.twist.angular.y == rec.angular_velocity[k, 1]
        assert m.pose.covariance[0] == -1 and m.twist.covariance[0] == -1


# --- writer refusals and atomicity -------------------------------------------------------------

def test_write_refuses_existing_directory(tmp_path, short_rec):
    (tmp_path / "F_01").mkdir()
    (tmp_path / "F_01" / "keep.txt").write_text("x")
    with pytest.raises(FileExistsError):
        write_bag(tmp_path / "F_01", short_rec)
    assert [p.name for p in (tmp_path / "F_01").iterdir()] == ["keep.txt"]
    assert [p.name for p in tmp_path.iterdir()] == ["F_01"]


def test_write_leaves_nothing_on_bad_input(tmp_path, short_rec):
    bad = copy.deepcopy(short_rec)
    bad.q[3, 2] = np.nan
    gappy = copy.deepcopy(short_rec)
    gappy.stamps_ns[5:] += CONTROL_DT_NS
    unnormed = copy.deepcopy(short_rec)
    unnormed.orientation[2] *= 1.01
    for rec in (bad, gappy, unnormed):
        with pytest.raises(ValueError):
            write_bag(tmp_path / "F_01", rec)
    with pytest.raises(ValueError):
        write_bag(tmp_path / "F_01", short_rec, storage="rosbag1")
    assert list(tmp_path.iterdir()) == []


@pytest.mark.parametrize("storage", ["mcap", "sqlite3"])
def test_write_leaves_nothing_on_failure_midway(tmp_path, short_rec, monkeypatch, storage):
    real_write = Writer.write
    calls = {"n": 0}

    def failing(self, *args, **kw):
        calls["n"] += 1
        if calls["n"] > 25:
            raise RuntimeError("disk full (simulated)")
        return real_write(self, *args, **kw)

    monkeypatch.setattr(Writer, "write", failing)
    with pytest.raises(RuntimeError, match="simulated"):
        write_bag(tmp_path / "F_01", short_rec, storage=storage)
    assert calls["n"] > 25
    assert list(tmp_path.iterdir()) == []


def test_write_leaves_nothing_when_serializing_fails_midway(tmp_path, short_rec, monkeypatch):
    real_serialize = bags_mod._typestore().serialize_cdr
    calls = {"n": 0}

    def failing(msg, typename, **kw):
        calls["n"] += 1
        if calls["n"] > 3:     # in the odometry's first block, a joint state written before it
            raise RuntimeError("serializer failed (simulated)")
        return real_serialize(msg, typename, **kw)

    monkeypatch.setattr(bags_mod._typestore(), "serialize_cdr", failing)
    with pytest.raises(RuntimeError, match="simulated"):
        write_bag(tmp_path / "F_01", short_rec)
    assert list(tmp_path.iterdir()) == []


# --- reader leniency the contract allows -------------------------------------------------------

def test_cmd_names_any_order_and_n_plus_one(tmp_path, short_rec):
    names = tuple(reversed(JOINT_NAMES[6:])) + JOINT_NAMES[:6]
    bag = write_raw(tmp_path / "F_01", raw_items(short_rec, cmd_names=names,
                                                 n_cmd=short_rec.n_steps + 1))
    assert_same(short_rec, read_bag(bag))


def test_extra_topics_ignored(tmp_path, short_rec):
    items = raw_items(short_rec)
    Clock = TS.types["rosgraph_msgs/msg/Clock"]
    items += [("/clock", int(t), Clock(clock=_stamp(int(t)))) for t in short_rec.stamps_ns]
    bag = write_raw(tmp_path / "F_01", items, {"/clock": "rosgraph_msgs/msg/Clock"})
    assert_same(short_rec, read_bag(bag))


def _spy_layout(monkeypatch) -> dict:
    """Record, per topic, whether ``read_bag`` read it as arrays (the same-layout path)."""
    seen: dict = {}
    real = bags_mod._same_layout_columns

    def spy(raws, topic, *args):
        out = real(raws, topic, *args)
        seen[topic] = out is not None
        return out
    monkeypatch.setattr(bags_mod, "_same_layout_columns", spy)
    return seen


@pytest.mark.parametrize("storage", ["mcap", "sqlite3"])
def test_messages_of_one_layout_read_as_arrays_equal_the_per_message_decode(
        tmp_path, storage, monkeypatch):
    rec = synthetic_recording("FL_03")
    bag = tmp_path / "FL_03"
    write_bag(bag, rec, storage=storage)
    seen = _spy_layout(monkeypatch)
    fast = read_bag(bag)
    assert seen == {TOPIC_JOINT_STATES: True, TOPIC_ODOM: True, TOPIC_CMD: True}
    monkeypatch.setattr(bags_mod, "_same_layout_columns", lambda *a: None)
    slow = read_bag(bag)
    assert_same(slow, fast)
    assert_same(rec, fast)
    for f in FIELDS:   # bit for bit (-0.0 is not 0.0) and the same memory layout: BLAS may
        a, b = getattr(fast, f), getattr(slow, f)    # round C and Fortran order apart
        assert a.strides == b.strides and a.tobytes() == b.tobytes(), f


def _stored(bag: Path) -> list:
    """[(topic, bag_time, raw CDR bytes)] of ``bag`` in storage order."""
    from rosbags.rosbag2 import Reader
    with Reader(bag) as r:
        return [(c.topic, t, bytes(raw)) for c, t, raw in r.messages()]


def _awkward_recording() -> MoveRecording:
    """A move whose numbers a byte-level writer could get wrong: -0.0, subnormals, huge and
    tiny magnitudes, and stamps that cross whole seconds late in the int32 range."""
    rec = synthetic_recording("FL_03", n=250, t0_ns=2_000_000_000 * 10**9 + 995_000_000)
    rec.q[3, 2], rec.dq[7, 0], rec.cmd[9, 11] = -0.0, 5e-324, -1.7976931348623157e308
    rec.linear_velocity[4, 1], rec.angular_velocity[2, 2] = -0.0, 2.2250738585072014e-308
    rec.position[5, 0] = -1e-300
    return rec


@pytest.mark.parametrize("storage", ["mcap", "sqlite3"])
def test_written_messages_equal_each_message_serialized_on_its_own(tmp_path, storage,
                                                                   monkeypatch):
    """``write_bag`` lays every message out as the first one serialized (``like_first``):
    the bytes stored are those of each message built and serialized on its own
    (``raw_items``), in the same order; without the layout the bag is the same."""
    rec = _awkward_recording()
    ts, calls = bags_mod._typestore(), []
    real = ts.serialize_cdr
    monkeypatch.setattr(ts, "serialize_cdr", lambda *a, **k: calls.append(1) or real(*a, **k))
    write_bag(tmp_path / "FL_03", rec, storage=storage)
    assert len(calls) == 6          # the first and last message of each topic: laid out
    monkeypatch.undo()
    want = [(topic, t, bytes(TS.serialize_cdr(msg, MSGTYPES[topic])))
            for topic, t, msg in raw_items(rec)]
    assert _stored(tmp_path / "FL_03") == want
    monkeypatch.setattr(bags_mod, "like_first", lambda *a: None)
    write_bag(tmp_path / "FL_04", rec, storage=storage)
    assert _stored(tmp_path / "FL_04") == want
    assert_same(rec, read_bag(tmp_path / "FL_03"))


def test_a_long_bag_is_laid_out_a_block_at_a_time(tmp_path, monkeypatch):
    """Blocks of ``LAYOUT_BLOCK`` messages (a long bag's write holds one block per topic):
    each block's first and last messages are serialized on their own, and the bag is the same."""
    rec = _awkward_recording()
    monkeypatch.setattr(bags_mod, "LAYOUT_BLOCK", 16)
    ts, calls = bags_mod._typestore(), []
    real = ts.serialize_cdr
    monkeypatch.setattr(ts, "serialize_cdr", lambda *a, **k: calls.append(1) or real(*a, **k))
    write_bag(tmp_path / "FL_03", rec)
    blocks = -(-(rec.n_steps + 1) // 16) * 2 + -(-rec.n_steps // 16)
    assert len(calls) == 2 * blocks
    monkeypatch.undo()
    want = [(topic, t, bytes(TS.serialize_cdr(msg, MSGTYPES[topic])))
            for topic, t, msg in raw_items(rec)]
    assert _stored(tmp_path / "FL_03") == want


@pytest.mark.parametrize("row", [0, -1])
def test_a_layout_whose_first_or_last_message_disagrees_is_not_used(tmp_path, short_rec,
                                                                     monkeypatch, row):
    """The laid-out messages are kept only where the first and last equal those messages
    serialized on their own: a layout that gets a byte wrong falls back to serializing each
    message."""
    real = bags_mod.like_first

    def wrong(*args):
        buf = real(*args)
        buf[row, -1] ^= 0x01
        return buf
    monkeypatch.setattr(bags_mod, "like_first", wrong)
    write_bag(tmp_path / "F_01", short_rec)
    want = [(topic, t, bytes(TS.serialize_cdr(msg, MSGTYPES[topic])))
            for topic, t, msg in raw_items(short_rec)]
    assert _stored(tmp_path / "F_01") == want


def test_like_first_refuses_what_does_not_fit_the_first_message():
    from littledog_mlsim.data.decode import JOINT_STATE, like_first
    items = raw_items(synthetic_recording("F_01", n=3))
    first = TS.serialize_cdr(items[0][2], MSGTYPES[TOPIC_JOINT_STATES])
    stamps = np.array([0, 10**7, 2 * 10**7])
    assert like_first(first, JOINT_STATE, stamps, {"position": np.zeros((3, 12))}) is not None
    assert like_first(first, JOINT_STATE, stamps, {"position": np.zeros((3, 11))}) is None
    assert like_first(first, JOINT_STATE, stamps, {"twist": np.zeros((3, 6))}) is None
    assert like_first(first, JOINT_STATE, -stamps, {}) is None
    assert like_first(first, JOINT_STATE, stamps + 2**31 * 10**9, {}) is None   # int32 seconds
    assert like_first(first, JOINT_STATE, stamps.astype(float), {}) is None
    assert like_first(first, JOINT_STATE, stamps, {"position": np.zeros((2, 12))}) is None
    assert like_first(first, "std_msgs/msg/String", stamps, {}) is None
    assert like_first(first[:-8], JOINT_STATE, stamps, {}) is None


def test_a_message_of_another_encoding_within_a_bag_is_decoded_on_its_own(tmp_path, short_rec):
    """Only the first message's CDR header is walked; a later one that says big-endian is not
    read with the others (it is garbage read as big-endian: refused as before)."""
    items = raw_items(short_rec)
    i = nth(items, TOPIC_JOINT_STATES, 5)
    raw = bytearray(TS.serialize_cdr(items[i][2], MSGTYPES[TOPIC_JOINT_STATES]))
    raw[1] = 0x00
    items[i] = (*items[i][:2], bytes(raw))
    bag = write_raw(tmp_path / "F_01", items)
    with pytest.raises(BagError) as exc:
        read_bag(bag)
    assert_bag_error(exc, bag, TOPIC_JOINT_STATES)


def test_messages_that_differ_only_in_their_padding_are_read_as_arrays(tmp_path, short_rec,
                                                                     monkeypatch):
    """A serializer may leave any bytes in the alignment padding (rclpy does): no decoder reads
    them, so they do not split a topic's layout."""
    items = raw_items(short_rec)
    i = nth(items, TOPIC_JOINT_STATES, 5)
    raw = bytearray(TS.serialize_cdr(items[i][2], MSGTYPES[TOPIC_JOINT_STATES]))
    assert raw[12:17] == b"\x01\x00\x00\x00\x00"   # frame_id "": its length, its NUL, padding
    raw[17:20] = b"\xab\xcd\xef"
    items[i] = (*items[i][:2], bytes(raw))
    bag = write_raw(tmp_path / "F_01", items)
    seen = _spy_layout(monkeypatch)
    assert_same(short_rec, read_bag(bag))
    assert seen[TOPIC_JOINT_STATES]


def test_a_damaged_message_is_named_by_its_own_number(tmp_path, short_rec):
    items = raw_items(short_rec)
    for k in (3, 15):
        i = nth(items, TOPIC_JOINT_STATES, k)
        items[i] = (*items[i][:2], b"\x00\x01\x00\x00\x05\x00")
    bag = write_raw(tmp_path / "F_01", items)
    with pytest.raises(BagError, match="after 3 messages"):
        read_bag(bag)


def test_names_reordered_within_a_bag_are_decoded_message_by_message(tmp_path, short_rec,
                                                                    monkeypatch):
    items = raw_items(short_rec)
    names = JOINT_NAMES[6:] + JOINT_NAMES[:6]       # same bytes in all, another order
    perm = [JOINT_NAMES.index(nm) for nm in names]
    i = nth(items, TOPIC_CMD, 5)
    msg = copy.deepcopy(items[i][2])
    msg.name, msg.position = list(names), msg.position[perm].copy()
    items[i] = (*items[i][:2], msg)
    bag = write_raw(tmp_path / "F_01", items)
    seen = _spy_layout(monkeypatch)
    assert_same(short_rec, read_bag(bag))
    assert seen == {TOPIC_JOINT_STATES: True, TOPIC_ODOM: True, TOPIC_CMD: False}


# --- every bad input: one-line BagError naming bag and topic -------------------------------------

def _set(items, topic, k, fn):
    i = nth(items, topic, k)
    msg = copy.deepcopy(items[i][2])
    fn(msg)
    items[i] = (items[i][0], items[i][1], msg)
    return items


def _shift_time(items, topic, k, dt_ns, header_too=True):
    i = nth(items, topic, k)
    tp, t, msg = items[i]
    msg = copy.deepcopy(msg)
    if header_too:
        msg.header.stamp = _stamp(t + dt_ns)
    items[i] = (tp, t + dt_ns, msg)
    return items


def _swap_headers(items, topic, k):
    i, j = nth(items, topic, k), nth(items, topic, k + 1)
    a, b = copy.deepcopy(items[i][2]), copy.deepcopy(items[j][2])
    a.header.stamp, b.header.stamp = b.header.stamp, a.header.stamp
    items[i], items[j] = (*items[i][:2], a), (*items[j][:2], b)
    return items


def _drop_time(items, k_stamp):
    return [it for it in items if it[1] != k_stamp]


def _nan_position(m):
    m.position[4] = np.nan


def _inf_twist(m):
    m.twist.twist.linear.x = np.inf


def _js_name(names):
    def fn(m):
        m.name = list(names)
    return fn


_JS = TOPIC_JOINT_STATES
_R = synthetic_recording("F_01", n=20)
_T5 = int(_R.stamps_ns[5])
BAD_CASES = {
    "missing odom": (lambda it: [x for x in it if x[0] != TOPIC_ODOM], {}, TOPIC_ODOM, "missing"),
    "missing cmd": (lambda it: [x for x in it if x[0] != TOPIC_CMD], {}, TOPIC_CMD, "missing"),
    "odom as JointState": (
        lambda it: [x for x in it if x[0] != TOPIC_ODOM]
        + [(TOPIC_ODOM, t, m) for tp, t, m in it if tp == _JS],
        {TOPIC_ODOM: "sensor_msgs/msg/JointState"}, TOPIC_ODOM, "message type"),
    "NaN joint position": (lambda it: _set(it, _JS, 7, _nan_position), {}, _JS, "NaN"),
    "NaN cmd": (lambda it: _set(it, TOPIC_CMD, 3, _nan_position), {}, TOPIC_CMD, "NaN"),
    "inf twist": (lambda it: _set(it, TOPIC_ODOM, 2, _inf_twist), {}, TOPIC_ODOM, "NaN or inf"),
    "duplicated stamp": (lambda it: _shift_time(it, TOPIC_ODOM, 6, -CONTROL_DT_NS), {},
                         TOPIC_ODOM, "duplicated"),
    "out-of-order header stamps": (lambda it: _swap_headers(it, _JS, 4), {}, _JS, "header"),
    "header differs from bag time": (
        lambda it: _set(it, TOPIC_CMD, 9, lambda m: setattr(m.header.stamp, "nanosec",
                                                            m.header.stamp.nanosec + 1)),
        {}, TOPIC_CMD, "header"),
    "gap in clock (all topics)": (lambda it: _drop_time(it, _T5), {}, _JS, "gap"),
    "gap in odom only": (lambda it: [x for x in it if not (x[0] == TOPIC_ODOM and x[1] == _T5)],
                         {}, TOPIC_ODOM, "gap"),
    "jitter": (lambda it: _shift_time(it, TOPIC_ODOM, 8, 1000), {}, TOPIC_ODOM, "clock"),
    "odom on another clock": (
        lambda it: [(tp, t + CONTROL_DT_NS, m) if tp == TOPIC_ODOM else (tp, t, m)
                    for tp, t, m in _shift_all_headers(it, TOPIC_ODOM)],
        {}, TOPIC_ODOM, "one clock"),
    "cmd too short": (lambda it: it[:nth(it, TOPIC_CMD, 19)] + it[nth(it, TOPIC_CMD, 19) + 1:],
                      {}, TOPIC_CMD, "messages"),
    "11 joint names": (lambda it: _set(it, _JS, 2, lambda m: (
        setattr(m, "name", m.name[:11]), setattr(m, "position", m.position[:11]),
        setattr(m, "velocity", m.velocity[:11]))), {}, _JS, "11 joint names"),
    "unknown joint name": (lambda it: _set(it, TOPIC_CMD, 2, _js_name(
        ("front_left_ankle",) + JOINT_NAMES[1:])), {}, TOPIC_CMD, "front_left_ankle"),
    "duplicated joint name": (lambda it: _set(it, _JS, 0, _js_name(
        JOINT_NAMES[:11] + JOINT_NAMES[:1])), {}, _JS, "duplicated"),
    "positions vs names": (lambda it: _set(it, _JS, 3, lambda m: setattr(
        m, "position", m.position[:10])), {}, _JS, "positions"),
    "wrong odom frame": (lambda it: _set(it, TOPIC_ODOM, 1, lambda m: setattr(
        m.header, "frame_id", "map")), {}, TOPIC_ODOM, "frames"),
    "non-unit quaternion": (lambda it: _set(it, TOPIC_ODOM, 1, lambda m: setattr(
        m.pose.pose.orientation, "w", m.pose.pose.orientation.w * 1.1)), {}, TOPIC_ODOM,
        "unit quaternion"),
    "garbage CDR": (lambda it: [(tp, t, b"\x00\x01\x00\x00\x05\x00") if (tp == _JS and t == _T5)
                                else (tp, t, m) for tp, t, m in it], {}, _JS, "corrupt"),
}


def _shift_all_headers(items, topic):
    out = []
    for tp, t, m in items:
        if tp == topic:
            m = copy.deepcopy(m)
            m.header.stamp = _stamp(t + CONTROL_DT_NS)
        out.append((tp, t, m))
    return out


@pytest.mark.parametrize("case", list(BAD_CASES))
def test_bad_bag_raises_one_line_error(tmp_path, case):
    damage, msgtypes, topic, words = BAD_CASES[case]
    bag = write_raw(tmp_path / "F_01", damage(raw_items(_R)), msgtypes)
    with pytest.raises(BagError) as exc:
        read_bag(bag)
    assert_bag_error(exc, bag, topic)
    assert words in str(exc.value), str(exc.value)
    assert isinstance(exc.value, ValueError)


def test_bad_bag_sqlite3(tmp_path):
    damage, msgtypes, topic, words = BAD_CASES["NaN joint position"]
    bag = write_raw(tmp_path / "F_01", damage(raw_items(_R)), msgtypes, StoragePlugin.SQLITE3)
    with pytest.raises(BagError) as exc:
        read_bag(bag)
    assert_bag_error(exc, bag, topic)


@pytest.mark.parametrize("storage,frac", [("mcap", 0.0), ("mcap", 0.5), ("mcap", 0.99),
                                          ("sqlite3", 0.0), ("sqlite3", 0.5)])
def test_truncated_storage(tmp_path, short_rec, storage, frac):
    bag = tmp_path / "F_01"
    write_bag(bag, short_rec, storage=storage)
    f = next(p for p in bag.iterdir() if p.name != "metadata.yaml")
    data = f.read_bytes()
    f.write_bytes(data[: int(len(data) * frac)])
    with pytest.raises(BagError) as exc:
        read_bag(bag)
    assert "\n" not in str(exc.value) and str(bag) in str(exc.value)


def test_sqlite3_rows_missing(tmp_path, short_rec):
    import sqlite3
    bag = tmp_path / "F_01"
    write_bag(bag, short_rec, storage="sqlite3")
    con = sqlite3.connect(bag / "F_01.db3")
    con.execute("DELETE FROM messages WHERE id IN (SELECT id FROM messages ORDER BY id DESC "
                "LIMIT 5)")  # the tail: a recording cut short
    con.commit()
    con.close()
    with pytest.raises(BagError) as exc:
        read_bag(bag)
    assert "\n" not in str(exc.value) and str(bag) in str(exc.value)
    assert "topic /littledog/" in str(exc.value)


@pytest.mark.parametrize("damage", ["delete", "garble", "empty"])
def test_bad_metadata(tmp_path, short_rec, damage):
    bag = tmp_path / "F_01"
    write_bag(bag, short_rec)
    meta = bag / "metadata.yaml"
    if damage == "delete":
        meta.unlink()
    elif damage == "garble":
        meta.write_text("rosbag2_bagfile_information: [unclosed\n")
    else:
        meta.write_text("")
    with pytest.raises(BagError) as exc:
        read_bag(bag)
    assert_bag_error(exc, bag, None)


def test_missing_bag_directory(tmp_path):
    with pytest.raises(BagError) as exc:
        read_bag(tmp_path / "F_09")
    assert_bag_error(exc, tmp_path / "F_09", None)


def test_bag_error_pickles():  # errors cross process pools (record/load with --jobs)
    import pickle
    err = pickle.loads(pickle.dumps(BagError("/d/F_01", TOPIC_ODOM, "missing\ntopic")))
    assert str(err) == "bag /d/F_01 (topic /littledog/odom): missing topic"
    assert err.topic == TOPIC_ODOM and err.bag == "/d/F_01"
