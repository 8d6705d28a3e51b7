"""``littledog-mlsim import``: recorded bags (real-style timing, other types, rates, clocks,
storages, ROS 1) become a dataset whose moves match the source moves.

The source moves are recorded with pybullet into a contract dataset (4 moves); the real-style
recordings are written from them by ``data.realstyle`` (rates, jitter, clocks, drops, resets),
so every imported number can be checked against the contract bag it came from.
"""
from __future__ import annotations

import json
import sqlite3
from pathlib import Path

import numpy as np
import pytest
from inprocess import cli
import yaml

from littledog_mlsim.data import decode as D
from littledog_mlsim.data.bags import BagError, read_bag
from littledog_mlsim.data.dataset import load_moves, read_index
from littledog_mlsim.data.importer import ImportOptions, import_bags
from littledog_mlsim.data.realstyle import RealStyle, write_realstyle_bag
from littledog_mlsim.layout import JOINT_NAMES

TYPES = ["F", "BL", "L", "S"]


@pytest.fixture(scope="module")
def contract(tmp_path_factory) -> Path:
    from littledog_mlsim.apps.record import record_dataset

    out = tmp_path_factory.mktemp("contract") / "data"
    record_dataset(out, moves_per_type=1, types=TYPES, jobs=1, progress=False)
    return out


@pytest.fixture(scope="module")
def sources(contract):
    return [read_bag(contract / f"{t}_00") for t in TYPES]


def _match(moves, sources, info):
    """Each imported move with its source move and the source step it starts at."""
    out = []
    for m in moves:
        j = int(np.argmin([abs(int(m.stamps_ns[0]) - t) for t in info["move_t0_ns"]]))
        k0 = int(round((int(m.stamps_ns[0]) - info["move_t0_ns"][j]) / 1e7))
        out.append((m, sources[j], k0))
    return out


def _compare(m, o, k0, tol):
    n = m.n_steps
    sl = slice(k0, k0 + n + 1)
    err = {"q": np.abs(m.q - o.q[sl]).max(), "dq": np.abs(m.dq - o.dq[sl]).max(),
           "cmd": np.abs(m.cmd - o.cmd[k0:k0 + n]).max(),
           "position": np.abs(m.position - o.position[sl]).max(),
           "orientation": np.abs(m.orientation - o.orientation[sl]).max()}
    bad = {k: v for k, v in err.items() if v > tol[k]}
    assert not bad, f"{m.name} vs {o.name} from step {k0}: {bad}"


def test_reimport_contract_bags_exactly(contract, sources, tmp_path):
    out = tmp_path / "re"
    r = import_bags([contract / f"{t}_00" for t in TYPES], out, ImportOptions(test_fraction=0))
    moves = load_moves(out, "all")
    assert [m.name for m in moves] == [f"{t}_00" for t in TYPES]     # types inferred
    for m, o in zip(moves, sources):
        for f in ("stamps_ns", "cmd", "q", "dq", "position", "orientation", "linear_velocity",
                  "angular_velocity"):
            assert np.array_equal(getattr(m, f), getattr(o, f)), (m.name, f)
    assert r.n_messages == sum(3 * o.n_steps + 2 for o in sources)
    rep = json.loads((out / "import_report.json").read_text())
    assert rep["bags"][0]["topics"]["joint_states"]["time_source"] == "header"
    assert (out / "import_report.md").is_file() and (out / "import_report.png").stat().st_size > 0


# Joint states on the grid exactly; the pose stream's clock offset is estimated on its own (5th
# percentile of its receive delays), a fraction of a ms off the joint states': 1e-4 m/rad.
EXACT = dict(q=0, dq=0, cmd=0, position=1e-4, orientation=1e-4)
# receive times with jitter, 500 Hz / 120 Hz: interpolation errors of ~1 ms of motion
JITTERY = dict(q=0.035, dq=2.5, cmd=0, position=2e-3, orientation=6e-3)

CASES = {
    # sim-time stamps (another clock): aligned, exact; commands in the controller's order
    "sim_clock": ("rec", RealStyle(), {}, EXACT, "aligned"),
    # 500 Hz joint states, 120 Hz mocap PoseStamped, zero stamps, drops, Float64MultiArray
    "rates_zero_stamps": ("rec.db3", RealStyle(js_rate_hz=500, pose_rate_hz=120, stamps="zero",
                                               cmd_type=D.FLOAT64_ARRAY, pose_type=D.POSE_STAMPED,
                                               drop_prob=0.05, seed=1),
                          {"cmd_joint_order": tuple(reversed(JOINT_NAMES)), "twist": "pose"},
                          JITTERY, "receive"),
    "trajectory_mcap_file": ("rec.mcap", RealStyle(cmd_type=D.JOINT_TRAJECTORY, seed=2), {},
                             EXACT, "aligned"),
    # ROS 1 bag, no pause between moves: the resets are found by the pose jumps
    "ros1_resets": ("rec.bag", RealStyle(reset_pause_s=0.0, stamps="wall", seed=3), {}, EXACT,
                    "header"),
}


@pytest.mark.parametrize("case", list(CASES))
def test_realstyle_recordings_match_the_source(case, sources, tmp_path):
    fname, style, opts, tol, source = CASES[case]
    bag = tmp_path / fname
    info = write_realstyle_bag(bag, sources, style)
    out = tmp_path / "ds"
    r = import_bags([bag], out, ImportOptions(test_fraction=0, **opts))
    moves = load_moves(out, "all")
    assert len(moves) == len(sources), [m.name for m in moves]
    assert [m.move_type for m in moves] == TYPES
    assert all(m.n_steps >= sources[0].n_steps - 2 for m in moves)
    for m, o, k0 in _match(moves, sources, info):
        assert 0 <= k0 <= 2
        _compare(m, o, k0, tol)
    topics = r.report["bags"][0]["topics"]
    assert topics["joint_states"]["time_source"].startswith(source)   # receive: maybe dejittered
    if style.cmd_type != D.JOINT_TRAJECTORY:
        assert r.report["bags"][0]["commands"]["superseded"] > 0     # duplicates were sent
    if style.drop_prob:
        assert topics["joint_states"]["count"] < 0.97 * 4 * 401 * 5


def test_long_bag_with_resets_pauses_and_a_gap(sources, tmp_path):
    """8 moves in one bag, resets with and without pauses, and a lost stretch in one move."""
    moves8 = [sources[i % 3] for i in range(8)]        # F, BL, L: all move, so resets show
    bag = tmp_path / "long"
    write_realstyle_bag(bag, moves8, RealStyle(reset_pause_s=0.0, seed=4))
    # cut 100 ms out of the 3rd move: every message received in that window is lost
    from rosbags.rosbag2 import Reader, Writer

    with Reader(bag) as rd:
        t_start = rd.start_time + 2 * 4_010_000_000 + 2_000_000_000
        lost = (t_start, t_start + 100_000_000)
        cut = tmp_path / "long_cut"
        with Writer(cut, version=9, storage_plugin=__import__("rosbags.rosbag2", fromlist=["x"])
                    .StoragePlugin.MCAP) as w:
            conns = {c.id: w.add_connection(c.topic, c.msgtype, typestore=_jazzy())
                     for c in rd.connections}
            for c, t, raw in rd.messages():
                if not lost[0] <= t < lost[1]:
                    w.write(conns[c.id], t, raw)
    out = tmp_path / "ds"
    r = import_bags([cut], out, ImportOptions(test_fraction=0.3))
    b = r.report["bags"][0]
    assert len(b["segments"]) == 9, b["breaks"]
    whys = " ".join(x["why"] for x in b["breaks"])
    assert "reset" in whys and "gap" in whys
    idx = read_index(out)
    assert idx.info["import_options"]["test_fraction"] == 0.3
    # split per type in recording order, 0.7 rounded half up of each type's count
    by_type = {}
    for e in idx.entries:
        by_type.setdefault(e.move_type, []).append(e.split)
    for t, splits in by_type.items():
        k = int(np.floor(0.7 * len(splits) + 0.5))
        assert splits == ["train"] * k + ["test"] * (len(splits) - k), (t, splits)
    # reproducible: the same import gives the same index
    r2 = import_bags([cut], tmp_path / "ds2", ImportOptions(test_fraction=0.3), figure=False)
    assert (out / "dataset.yaml").read_text() == (tmp_path / "ds2" / "dataset.yaml").read_text()
    assert r2.n_moves == r.n_moves


def _jazzy():
    from rosbags.typesys import Stores, get_typestore

    return get_typestore(Stores.ROS2_JAZZY)


def test_fast_decoder_equals_rosbags(sources, tmp_path):
    from rosbags.highlevel import AnyReader

    bag = tmp_path / "rec"
    write_realstyle_bag(bag, sources[:1], RealStyle(pose_type=D.ODOMETRY, seed=5))
    fl = tmp_path / "f.mcap"
    write_realstyle_bag(fl, sources[:1], RealStyle(cmd_type=D.FLOAT64_ARRAY,
                                                   pose_type=D.POSE_STAMPED, seed=5))
    for path in (bag, fl):
        with AnyReader([path]) as rd:
            for c in rd.connections:
                raws = [bytes(r) for _, _, r in rd.messages(connections=[c])]
                fast = D.decode_topic(raws, c.msgtype, rd.deserialize)
                slow = D.decode_topic(raws, c.msgtype, rd.deserialize, fast=False)
                assert fast.n_fast == len(raws) and slow.n_fast == 0
                assert np.array_equal(fast.header_ns, slow.header_ns)
                assert fast.names == slow.names and fast.frame_ids == slow.frame_ids
                for f in ("position", "velocity", "orientation", "linear", "angular"):
                    a, b = getattr(fast, f), getattr(slow, f)
                    if a is None:
                        assert b is None
                        continue
                    assert np.array_equal(np.asarray(a), np.asarray(b)), (c.topic, f)


def test_mcap_chunk_reader_equals_rosbags(sources, tmp_path):
    """The direct MCAP chunk walk yields what rosbags' reader yields, in the same order."""
    from rosbags.highlevel import AnyReader

    from littledog_mlsim.data.importer import _mcap_raw

    for path in (tmp_path / "d", tmp_path / "f.mcap"):
        write_realstyle_bag(path, sources[:2], RealStyle(seed=13))
        with AnyReader([path]) as rd:
            topics = {c.topic: c.topic for c in rd.connections}
            fast = _mcap_raw(rd, topics)
            assert fast is not None
            for c in rd.connections:
                ref = [(t, bytes(r)) for _, t, r in rd.messages(connections=[c])]
                got = list(zip(*fast[c.topic]))
                assert [(t, bytes(r)) for t, r in got] == ref, c.topic


def test_humble_metadata_and_no_type_definitions(sources, tmp_path):
    """rosbag2 metadata version 5 (Humble) with sqlite3 storage and no stored definitions."""
    bag = tmp_path / "humble"
    write_realstyle_bag(bag, sources[:2], RealStyle(storage="sqlite3", seed=6))
    meta = bag / "metadata.yaml"
    doc = yaml.safe_load(meta.read_text())
    info = doc["rosbag2_bagfile_information"]
    info["version"] = 5
    for k in ("ros_distro", "custom_data"):
        info.pop(k, None)
    for t in info["topics_with_message_count"]:
        t["topic_metadata"].pop("type_description_hash", None)
    meta.write_text(yaml.safe_dump(doc))
    (db,) = bag.glob("*.db3")
    with sqlite3.connect(db) as con:
        con.execute("DELETE FROM message_definitions")   # no stored types
    import_bags([bag], tmp_path / "ds", ImportOptions(test_fraction=0))
    assert [m.name for m in load_moves(tmp_path / "ds", "all")] == ["F_00", "BL_00"]


def test_bad_input_is_one_line_and_writes_nothing(sources, tmp_path):
    good = tmp_path / "good"
    write_realstyle_bag(good, sources[:1], RealStyle(seed=7))
    out = tmp_path / "ds"

    def fails(bags, match, **opts):
        with pytest.raises((BagError, ValueError)) as e:
            import_bags(bags, out, ImportOptions(**opts))
        msg = str(e.value)
        assert "\n" not in msg and match in msg, msg
        assert not out.exists() and not list(tmp_path.glob(".ds*"))
        return msg

    msg = fails([good], "missing topic", pose_topic="/mocap/pose")
    assert str(good) in msg and "/mocap/pose" in msg
    no_tail = tuple(j for j in JOINT_NAMES if j != "back_left_knee")
    # a command stream lacking a joint: written with a controller that leaves one out
    bad = tmp_path / "nojoint"
    write_realstyle_bag(bad, sources[:1], RealStyle(controller_joint_order=no_tail, seed=8))
    msg = fails([good, bad], "missing joint(s) back_left_knee")
    assert str(bad) in msg and "/littledog/cmd" in msg and "message 0" in msg
    # wrong type for a role
    msg = fails([good], "cannot be the pose topic", pose_topic="/littledog/joint_states")
    # a command excitation that is no number of radians record could have used
    for bad_e in (float("nan"), -0.01, 0.5, True):
        fails([good], "command excitation must be between 0 and 0.2", command_excitation_rad=bad_e)
    # corrupt storage: cut inside its header, nothing to salvage (a file cut later is read as
    # far as it is whole: test/test_faults.py)
    broken = tmp_path / "broken.mcap"
    write_realstyle_bag(broken, sources[:1], RealStyle(seed=9))
    data = broken.read_bytes()
    broken.write_bytes(data[:20])
    msg = fails([good, broken], str(broken))
    # skip: the good bag alone is imported, the bad one reported
    r = import_bags([good, broken], out, ImportOptions(skip_bad_bags=True, test_fraction=0))
    assert r.n_moves == 1 and str(broken) in r.report["bags"][1]["skipped"]
    # an existing dataset is not replaced without overwrite
    with pytest.raises(FileExistsError):
        import_bags([good], out, ImportOptions())


def test_cli_import_and_unknown_types_through_the_pipeline(sources, tmp_path, capsys):
    """U moves: train, evaluate, rollout and info accept them (no inference, no --move-type)."""
    bag = tmp_path / "rec.mcap"
    write_realstyle_bag(bag, sources, RealStyle(seed=10))
    data = tmp_path / "ds"
    p = cli(capsys, "import", str(bag), "--out", str(data), "--no-infer", "--test-fraction", "0.5",
            "--max-move", "2.0")
    assert p.returncode == 0, p.stderr
    assert p.stdout.startswith("imported 8 moves (4 TrainPool / 4 TestPool; U 8)"), p.stdout
    idx = read_index(data)
    assert {e.move_type for e in idx.entries} == {"U"}
    assert [e.name for e in idx.entries] == [f"U_{i:02d}" for i in range(8)]
    p = cli(capsys, "info", "--data", str(data))
    assert p.returncode == 0 and "  U " in p.stdout, p.stdout + p.stderr
    model = tmp_path / "model"
    p = cli(capsys, "train", "--data", str(data), "--method", "lr", "--out", str(model), "--quiet")
    assert p.returncode == 0, p.stderr
    p = cli(capsys, "evaluate", "--model", str(model), "--data", str(data), "--out", str(tmp_path / "ev"),
            "--projections", "none")
    assert p.returncode == 0, p.stderr
    metrics = json.loads((tmp_path / "ev" / "metrics.json").read_text())
    assert np.isfinite(metrics["nmse_mean"])
    p = cli(capsys, "rollout", "--model", str(model), "--data", str(data), "--out", str(tmp_path / "ro"),
            "--projection", "none")
    assert p.returncode == 0, p.stderr
    # a plain folder of bags: its bags in name order; --move-type once per bag
    folder = tmp_path / "folder"
    folder.mkdir()
    write_realstyle_bag(folder / "a.mcap", sources[:1], RealStyle(seed=11))
    write_realstyle_bag(folder / "b.mcap", sources[2:3], RealStyle(seed=12))
    p = cli(capsys, "import", str(folder), "--out", str(tmp_path / "f"), "--move-type", "F",
            "--move-type", "unknown", "--test-fraction", "0", "--excitation", "0.05")
    assert p.returncode == 0, p.stderr
    f_index = read_index(tmp_path / "f")
    assert f_index.names() == ["F_00", "U_00"]
    # --excitation is written as record writes it, and diagnose --reference reads it
    from littledog_mlsim.diagnose.conditions import conditions_of
    assert f_index.info["command_excitation_rad"] == 0.05
    assert "command_excitation_rad" not in read_index(data).info
    c = conditions_of(f_index.info, read_index(data).info)
    assert (c.data_excitation_rad, c.reference_excitation_rad, c.comparable) == (0.05, 0.0, False)
    # --move-type per bag and a bad option are one line
    p = cli(capsys, "import", str(bag), "--out", str(tmp_path / "x"), "--move-type", "Q")
    assert p.returncode == 2 and p.stderr.count("\n") == 1 and "unknown move type" in p.stderr
    assert not (tmp_path / "x").exists()
    p = cli(capsys, "import", str(bag), "--out", str(tmp_path / "x"), "--excitation", "nan")
    assert p.returncode == 2 and p.stderr.count("\n") == 1 and "command excitation" in p.stderr
    assert not (tmp_path / "x").exists()
