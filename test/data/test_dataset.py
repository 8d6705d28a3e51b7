"""Dataset index, state/feature extraction (docs/interface.md §4), path integration, Normalizer.

Geometry is checked against scipy's Rotation (an independent implementation), and the frame
integration against the recorded odometry.
"""
from __future__ import annotations

import json
import warnings
from pathlib import Path

import numpy as np
import pytest
import yaml
from scipy.spatial.transform import Rotation

from littledog_mlsim.data.bags import BagError, write_bag
from littledog_mlsim.data.dataset import (
    BagEntry, DatasetError, Normalizer, SkippedBagWarning, actions_from_recording,
    dataset_entries, features_responses, initial_pose, integrate_path, load_moves, n_train,
    quat_to_matrix, quat_to_rpy, read_index, rpy_to_matrix, rpy_to_quat, split_names,
    states_from_recording, write_index,
)
from littledog_mlsim.data.recording import MoveRecording
from synthetic import make_recording
from littledog_mlsim.layout import (
    N_FEATURE, N_STATE, STATE_NAMES, S, wrap_angle,
)


def yaw_of(rec: MoveRecording) -> np.ndarray:
    return Rotation.from_quat(rec.orientation).as_euler("ZYX")[:, 0]


# --- rotations ---------------------------------------------------------------------------------

def test_rotation_helpers_match_scipy():
    rng = np.random.default_rng(1)
    rpy = np.column_stack([rng.uniform(-np.pi, np.pi, 200), rng.uniform(-1.4, 1.4, 200),
                           rng.uniform(-np.pi, np.pi, 200)])
    ref = Rotation.from_euler("ZYX", rpy[:, ::-1])
    np.testing.assert_allclose(rpy_to_matrix(rpy), ref.as_matrix(), atol=1e-14)
    q = rpy_to_quat(rpy)
    qr = ref.as_quat()
    qr *= np.sign(qr[:, 3:4])
    np.testing.assert_allclose(q, qr, atol=1e-14)
    np.testing.assert_allclose(quat_to_matrix(qr), ref.as_matrix(), atol=1e-14)
    np.testing.assert_allclose(quat_to_rpy(qr), rpy, atol=1e-12)
    np.testing.assert_allclose(quat_to_rpy(-3.0 * qr), rpy, atol=1e-12)  # sign, scale
    assert rpy_to_matrix(rpy.reshape(20, 10, 3)).shape == (20, 10, 3, 3)


# --- states ------------------------------------------------------------------------------------

@pytest.fixture(scope="module")
def rec() -> MoveRecording:
    return make_recording()


def test_states_against_independent_computation(rec):
    s = states_from_recording(rec)
    n = rec.n_steps
    assert s.shape == (n, N_STATE) == (400, 33)
    rot = Rotation.from_quat(rec.orientation)
    ypr = rot.as_euler("ZYX")
    d_b = rot[:-1].inv().apply(np.diff(rec.position, axis=0))   # body frame at t-1
    np.testing.assert_allclose(s[:, S.d_b], d_b, rtol=0, atol=1e-15)
    np.testing.assert_allclose(s[:, S.z_w], rec.position[1:, 2], rtol=0, atol=0)
    np.testing.assert_allclose(s[:, S.roll], ypr[1:, 2], atol=1e-13)
    np.testing.assert_allclose(s[:, S.pitch], ypr[1:, 1], atol=1e-13)
    d_ypr = np.diff(np.unwrap(ypr, axis=0), axis=0)              # angles are smooth here
    np.testing.assert_allclose(s[:, S.d_rpy], d_ypr[:, ::-1], atol=1e-13)
    assert np.array_equal(s[:, S.q], rec.q[1:]) and np.array_equal(s[:, S.dq], rec.dq[1:])
    assert np.all(np.abs(s[:, S.d_rpy]) < 0.1)          # no 2 pi jump where yaw crosses pi
    assert yaw_of(rec).max() > 3.0 and yaw_of(rec).min() < -3.0
    # names line up with the layout
    assert STATE_NAMES[S.z_w] == "z_w" and STATE_NAMES[S.dyaw] == "dyaw"


@pytest.mark.parametrize("before,after", [(np.pi - 0.004, -np.pi + 0.006),
                                          (-np.pi + 0.004, np.pi - 0.006)])
def test_dyaw_at_the_pi_crossing(before, after):
    r = make_recording("L_00", n=2, tilt=0.0)
    r.orientation = Rotation.from_euler("ZYX", [[before, 0, 0], [after, 0, 0], [after, 0, 0]]
                                        ).as_quat()
    s = states_from_recording(r)
    expected = np.sign(before) * 0.01    # the short way round, not ~ -2 pi + 0.01
    assert s[0, S.dyaw] == pytest.approx(expected, abs=1e-12)
    assert s[1, S.dyaw] == pytest.approx(0.0, abs=1e-12)


def test_actions_and_features(rec):
    recs = [rec, make_recording("F_00", n=50, seed=3)]
    X, Y, idx = features_responses(recs)
    assert X.shape == (399 + 49, N_FEATURE) and Y.shape == (399 + 49, N_STATE)
    assert np.array_equal(idx, np.r_[np.zeros(399, int), np.ones(49, int)])
    assert np.array_equal(actions_from_recording(rec), rec.cmd)
    # sample j of a move: features (s_{j+1}, u_{j+1}), response s_{j+2} -- raw fields
    for j in (0, 17, 398):
        assert np.array_equal(X[j, S.q], rec.q[j + 1]) and np.array_equal(X[j, 33:], rec.cmd[j + 1])
        assert np.array_equal(Y[j, S.q], rec.q[j + 2]) and np.array_equal(Y[j, S.dq], rec.dq[j + 2])
        assert X[j, S.z_w] == rec.position[j + 1, 2] and Y[j, S.z_w] == rec.position[j + 2, 2]
    s = states_from_recording(recs[1])
    assert np.array_equal(X[399:, :33], s[:-1]) and np.array_equal(Y[399:], s[1:])
    with pytest.raises(ValueError):
        features_responses([])


# --- path integration --------------------------------------------------------------------------

@pytest.mark.parametrize("yaw0,yaw_rate,tilt", [(2.9, 0.6, 1.0),      # crosses +pi, tilted
                                                (-2.9, -0.6, 1.0),    # crosses -pi the other way
                                                (0.3, 0.2, 0.0)])     # flat
def test_integration_reproduces_odometry(yaw0, yaw_rate, tilt):
    r = make_recording(yaw0=yaw0, yaw_rate=yaw_rate, tilt=tilt)
    path = integrate_path(states_from_recording(r), *initial_pose(r))
    assert path.shape == (400, 3)
    np.testing.assert_allclose(path[:, :2], r.position[1:, :2], rtol=0, atol=1e-9)
    yaw_err = wrap_angle(path[:, 2] - yaw_of(r)[1:])
    assert np.max(np.abs(yaw_err)) < 1e-9
    assert np.all(np.abs(path[:, 2]) <= np.pi)
    # starting later in the move
    later = integrate_path(states_from_recording(r)[100:], *initial_pose(r, 100))
    np.testing.assert_allclose(later[:, :2], r.position[101:, :2], rtol=0, atol=1e-9)


def test_initial_roll_pitch_matters():
    r = make_recording(tilt=3.0)
    s = states_from_recording(r)
    x0, y0, yaw0, rp0 = initial_pose(r)
    good = integrate_path(s, x0, y0, yaw0, rp0)
    flat = integrate_path(s, x0, y0, yaw0, (0.0, 0.0))
    assert np.abs(flat[0, :2] - r.position[1, :2]).max() > 1e-6
    assert np.abs(good[0, :2] - r.position[1, :2]).max() < 1e-12


def test_integration_batched():
    recs = [make_recording(seed=i, yaw0=y, yaw_rate=w) for i, (y, w) in
            enumerate([(2.9, 0.6), (-2.9, -0.6), (0.0, 0.1)])]
    states = np.stack([states_from_recording(r) for r in recs])
    poses = [initial_pose(r) for r in recs]
    x0, y0, yaw0 = (np.array([p[i] for p in poses]) for i in range(3))
    rp0 = np.stack([p.roll_pitch0 for p in poses])
    batch = integrate_path(states, x0, y0, yaw0, rp0)
    assert batch.shape == (3, 400, 3)
    for b, r in enumerate(recs):
        np.testing.assert_array_equal(batch[b], integrate_path(states[b], *poses[b]))
    with pytest.raises(ValueError):
        integrate_path(states[..., :30], x0, y0, yaw0, rp0)


# --- Normalizer --------------------------------------------------------------------------------

def test_normalizer_round_trip():
    rng = np.random.default_rng(0)
    X = rng.normal(3.0, 5.0, (500, 4)) * [1, 1e-3, 1e3, 1]
    X[:, 3] = 0.146                                   # constant column
    norm = Normalizer().fit(X)
    Z = norm.transform(X)
    np.testing.assert_allclose(Z[:, :3].mean(0), 0, atol=1e-12)
    np.testing.assert_allclose(Z[:, :3].std(0), 1, atol=1e-12)
    assert norm.std_[3] == 1.0 and np.allclose(Z[:, 3], 0)
    np.testing.assert_allclose(norm.inverse_transform(Z), X, rtol=1e-14, atol=1e-12)
    np.testing.assert_allclose(norm.inverse_transform_std(np.ones(4)), norm.std_)
    back = Normalizer.from_dict(json.loads(json.dumps(norm.to_dict())))
    assert np.array_equal(back.mean_, norm.mean_) and np.array_equal(back.std_, norm.std_)
    assert np.array_equal(back.transform(X), Z)
    with pytest.raises(ValueError):
        norm.transform(X[:, :3])
    with pytest.raises(ValueError):
        Normalizer.from_dict({"mean": [0.0, 1.0], "std": [1.0, 0.0]})
    with pytest.raises(RuntimeError):
        Normalizer().transform(X)


# --- splits and index --------------------------------------------------------------------------

def test_split_rule():
    assert [n_train(n) for n in (0, 1, 2, 5, 10, 15, 20)] == [0, 1, 1, 4, 7, 11, 14]
    assert split_names(20) == (list(range(14)), list(range(14, 20)))
    assert split_names(5) == ([0, 1, 2, 3], [4])
    entries = dataset_entries(20)
    assert len(entries) == 20 * 11 and sum(e.split == "train" for e in entries) == 14 * 11
    assert [e.name for e in entries[:20] if e.split == "train"] == [
        f"F_{i:02d}" for i in range(14)]
    assert [e.name for e in entries[:20] if e.split == "test"] == [
        f"F_{i:02d}" for i in range(14, 20)]
    assert entries[-1] == BagEntry("S_19", "S", "test")
    with pytest.raises(ValueError):
        dataset_entries(3, types=["F", "XX"])


def test_index_round_trip(tmp_path):
    entries = dataset_entries(3, types=["F", "BL"])
    info = {"robot": "measured", "seed": np.int64(4), "storage": "mcap", "moves_per_type": 3}
    path = write_index(tmp_path, entries, info)
    assert path == tmp_path / "dataset.yaml"
    doc = yaml.safe_load(path.read_text())
    assert doc["format_version"] == 1 and doc["counts"] == {"total": 6, "train": 4, "test": 2}
    assert doc["bags"][0] == {"name": "F_00", "move_type": "F", "split": "train"}
    idx = read_index(tmp_path)
    assert idx.entries == entries and idx.info["seed"] == 4
    assert idx.names("test") == ["F_02", "BL_02"] and idx.names("all", ["BL"])[0] == "BL_00"
    assert [p.name for p in tmp_path.iterdir()] == ["dataset.yaml"]   # no temporary left


@pytest.mark.parametrize("info,entries", [
    ({"effects": ["x"]}, None),
    ({"recording": {"active_effect_classes": "a:B"}}, None),
    (None, [BagEntry("F_00", "FL", "train")]),
    (None, [BagEntry("F_00", "F", "validation")]),
    (None, [BagEntry("F_00", "F", "train"), BagEntry("F_00", "F", "test")]),
    (None, [BagEntry("../F_00", "F", "train")]),
    (None, [{"name": "F_00", "move_type": "F", "split": "train", "effect": "wind"}]),
    ({"when": object()}, None),
])
def test_write_index_refuses(tmp_path, info, entries):
    with pytest.raises(ValueError):
        write_index(tmp_path, entries or dataset_entries(1), info)
    assert list(tmp_path.iterdir()) == []


def _index_doc(tmp_path):
    write_index(tmp_path, dataset_entries(2, types=["F"]), {"robot": "measured"})
    return yaml.safe_load((tmp_path / "dataset.yaml").read_text())


@pytest.mark.parametrize("edit", [
    lambda d: d.update(format_version=2),
    lambda d: d.update(format="something"),
    lambda d: d["info"].update(effect_params={"k": 1}),
    lambda d: d["counts"].update(train=5),
    lambda d: d["bags"][1].update(split="holdout"),
    lambda d: d["bags"].append(dict(d["bags"][0])),
    lambda d: d.update(bags=[]),
])
def test_read_index_refuses(tmp_path, edit):
    doc = _index_doc(tmp_path)
    edit(doc)
    (tmp_path / "dataset.yaml").write_text(yaml.safe_dump(doc))
    with pytest.raises(DatasetError) as exc:
        read_index(tmp_path)
    assert str(tmp_path / "dataset.yaml") in str(exc.value) and "\n" not in str(exc.value)


def test_read_index_missing_or_garbled(tmp_path):
    with pytest.raises(DatasetError):
        read_index(tmp_path)
    (tmp_path / "dataset.yaml").write_text("bags: [unclosed\n")
    with pytest.raises(DatasetError):
        read_index(tmp_path)


# --- loading moves -----------------------------------------------------------------------------

@pytest.fixture(scope="module")
def dataset_dir(tmp_path_factory) -> Path:
    d = tmp_path_factory.mktemp("ds")
    entries = dataset_entries(3, types=["F", "DR"])       # 2 train + 1 test per type
    for i, e in enumerate(entries):
        write_bag(d / e.name, make_recording(e.name, n=30, seed=i),
                  storage="sqlite3" if i % 2 else "mcap")
    write_index(d, entries, {"robot": "nominal", "seed": 0, "storage": "mixed"})
    return d


def test_load_moves(dataset_dir):
    train = load_moves(dataset_dir)
    assert [r.name for r in train] == ["F_00", "F_01", "DR_00", "DR_01"]
    assert [r.move_type for r in train] == ["F", "F", "DR", "DR"]
    assert np.array_equal(train[2].q, make_recording("DR_00", n=30, seed=3).q)
    assert [r.name for r in load_moves(dataset_dir, "test")] == ["F_02", "DR_02"]
    assert [r.name for r in load_moves(dataset_dir, "all", types=["DR"])] == [
        "DR_00", "DR_01", "DR_02"]
    X, Y, idx = features_responses(train)
    assert X.shape == (4 * 29, 45) and idx.max() == 3
    with pytest.raises(DatasetError):
        load_moves(dataset_dir, "test", types=["S"])
    with pytest.raises(ValueError):
        load_moves(dataset_dir, "validation")
    with pytest.raises(ValueError):
        load_moves(dataset_dir, on_error="ignore")


def test_load_moves_bad_bag_policy(tmp_path, dataset_dir):
    import shutil
    d = tmp_path / "ds"
    shutil.copytree(dataset_dir, d)
    shutil.rmtree(d / "F_01")                                       # missing bag
    (d / "DR_00" / "metadata.yaml").write_text("")                   # corrupt bag
    with pytest.raises(BagError) as exc:
        load_moves(d)
    assert "F_01" in str(exc.value)
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        moves = load_moves(d, on_error="skip")
    assert [r.name for r in moves] == ["F_00", "DR_01"]
    msgs = [str(w.message) for w in caught if issubclass(w.category, SkippedBagWarning)]
    assert len(msgs) == 2 and "F_01" in msgs[0] and "DR_00" in msgs[1]
    shutil.rmtree(d / "F_00")
    shutil.rmtree(d / "DR_01")
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        with pytest.raises(DatasetError, match="all 4 selected bags are bad"):
            load_moves(d, on_error="skip")
