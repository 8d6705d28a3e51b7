"""OneStepModel (normalisation, delta/next targets, files) and the ``train`` verb."""
from __future__ import annotations

import json
import shutil
from pathlib import Path

import numpy as np
import pytest

from littledog_mlsim import cli
from littledog_mlsim.data.bags import write_bag
from littledog_mlsim.data.dataset import (dataset_entries, features_responses, load_moves,
                                          write_index)
from littledog_mlsim.layout import FEATURE_NAMES, N_FEATURE, N_STATE
from littledog_mlsim.models.features import CommandLag, FeatureSet
from littledog_mlsim.models.gp import GPR
from littledog_mlsim.models.lgpr import LGPR
from littledog_mlsim.models.lr import LinearRegression
from littledog_mlsim.models.onestep import OneStepModel
from littledog_mlsim.models.persistence import ModelError, fingerprint_arrays, save_model
from littledog_mlsim.models.train import train_from_dataset
from littledog_mlsim.projection import make_projection
from synthetic import make_recording


def linear_system(n: int = 300, seed: int = 0):
    """s_{t+1} = s_t + X W + c exactly (one fixed system), features of very different scales."""
    sys_rng = np.random.default_rng(12345)
    scale = np.exp(sys_rng.uniform(-6, 1, N_FEATURE))
    offset = sys_rng.standard_normal(N_FEATURE)
    W = sys_rng.standard_normal((N_FEATURE, N_STATE)) / scale[:, None] * 0.1
    X = np.random.default_rng(seed).standard_normal((n, N_FEATURE)) * scale + offset
    Y = X[:, :N_STATE] + X @ W + 0.01
    return X, Y


@pytest.mark.parametrize("target", ["delta", "next"])
def test_targets_reproduce_a_linear_system(target):
    X, Y = linear_system()
    m = OneStepModel.fit(LinearRegression(), X, Y, target=target)
    Xt, Yt = linear_system(20, seed=1)
    np.testing.assert_allclose(m.predict(Xt), Yt, rtol=1e-7, atol=1e-9)
    one = m.predict(Xt[0])
    assert one.shape == (N_STATE,)
    np.testing.assert_allclose(one, Yt[0], rtol=1e-7, atol=1e-9)
    # the estimator saw unit-variance features and targets
    Xn = (X - m.feature_normalizer.mean_) / m.feature_normalizer.std_
    np.testing.assert_allclose(Xn.std(axis=0), 1.0, rtol=1e-9)
    R = Y - X[:, :N_STATE] if target == "delta" else Y
    np.testing.assert_allclose(m.response_normalizer.mean_, R.mean(axis=0), rtol=1e-9)


def test_delta_and_next_gp_std():
    X, Y = linear_system(150)
    for target in ("delta", "next"):
        m = OneStepModel.fit(GPR(shared_hyperparameters=True, max_iter=20), X, Y,
                             target=target)
        mean, std = m.predict(X[:5], return_std=True)
        assert mean.shape == std.shape == (5, N_STATE) and np.all(std > 0)
        np.testing.assert_allclose(mean, Y[:5], atol=0.05 * Y.std(axis=0).max())
    with pytest.raises(ValueError):
        OneStepModel.fit(LinearRegression(), X, Y, target="velocity")


@pytest.fixture(scope="module")
def lgpr_model():
    X, Y = linear_system(240, seed=3)
    Y = Y + 0.05 * np.sin(X[:, :N_STATE])
    return OneStepModel.fit(LGPR(n_clusters=2, max_iter=10, n_global_points=60), X, Y,
                            info={"note": "test"}), X


def test_save_load_round_trip_is_bit_exact(tmp_path, lgpr_model):
    model, X = lgpr_model
    model.save(tmp_path / "m")
    back = OneStepModel.load(tmp_path / "m")
    assert back.method == "lgpr" and back.target == model.target
    assert back.data_fingerprint == model.data_fingerprint != ""
    assert back.info["note"] == "test" and back.info["n_train"] == 240
    np.testing.assert_array_equal(back.train_states, model.train_states)
    for rs in (False, True):
        a, b = model.predict(X[:7], return_std=rs), back.predict(X[:7], return_std=rs)
        for u, v in zip(a if rs else [a], b if rs else [b]):
            np.testing.assert_array_equal(u, v)
    S = model.train_states[:9] * 1.01
    for kind in ("alpha", "bound"):
        np.testing.assert_array_equal(back.projection(kind, alpha=0.3)(S),
                                      make_projection(kind, model.train_states, alpha=0.3)(S))
    back.prepare(return_std=True)


def test_load_refuses_wrong_features_and_corrupt_files(tmp_path, lgpr_model):
    model, _ = lgpr_model
    path = model.save(tmp_path / "m")
    with pytest.raises(ModelError, match="features"):
        OneStepModel.load(path, feature_names=list(FEATURE_NAMES[:-1]) + ["u_extra"])
    with pytest.raises(ModelError, match="order"):
        OneStepModel.load(path, feature_names=list(reversed(FEATURE_NAMES)))
    OneStepModel.load(path, feature_names=None)

    bad = tmp_path / "truncated"
    shutil.copytree(path, bad)
    blob = (bad / "arrays.npz").read_bytes()
    (bad / "arrays.npz").write_bytes(blob[: len(blob) // 2])
    with pytest.raises(ModelError, match="corrupt"):
        OneStepModel.load(bad)

    garbled = tmp_path / "garbled"
    shutil.copytree(path, garbled)
    (garbled / "model.json").write_text('{"format": "littledog_mlsim-model", ')
    with pytest.raises(ModelError, match="JSON"):
        OneStepModel.load(garbled)

    edited = tmp_path / "edited"
    shutil.copytree(path, edited)
    doc = json.loads((edited / "model.json").read_text())
    doc["meta"]["onestep"]["format_version"] = 99
    (edited / "model.json").write_text(json.dumps(doc))
    with pytest.raises(ModelError, match="format_version"):
        OneStepModel.load(edited)

    doc["meta"]["onestep"]["format_version"] = 1
    doc["meta"]["normalisation"]["features"]["std"][0] = -1.0
    (edited / "model.json").write_text(json.dumps(doc))
    with pytest.raises(ModelError, match="normaliser|Normalizer"):
        OneStepModel.load(edited)

    plain = tmp_path / "plain"  # an estimator saved without the one-step wrapper
    save_model(plain, model.estimator, {"feature_names": list(FEATURE_NAMES)})
    with pytest.raises(ModelError, match="one-step"):
        OneStepModel.load(plain)


# ----------------------------------------------------------------------------- train verb

@pytest.fixture(scope="module")
def tiny_dataset(tmp_path_factory) -> Path:
    d = tmp_path_factory.mktemp("tiny")
    entries = dataset_entries(3, types=["F", "S"])  # 2 train + 1 test per type
    for i, e in enumerate(entries):
        write_bag(d / e.name, make_recording(e.name, n=50, seed=i, yaw_rate=0.1 * i))
    write_index(d, entries, {"robot": "nominal", "seed": 0})
    return d


def test_train_from_dataset(tiny_dataset):
    X, Y, _ = features_responses(load_moves(tiny_dataset, "train"))
    m = train_from_dataset(tiny_dataset, "lgpr", options={"n_clusters": 2, "max_iter": 5},
                           progress=False, target="next")
    assert m.target == "next" and m.info["n_train"] == X.shape[0] == 4 * 49
    assert m.data_fingerprint == fingerprint_arrays(X, Y)
    np.testing.assert_array_equal(m.train_states, Y)
    sub = train_from_dataset(tiny_dataset, "gpr", options={"max_iter": 3, "target": "delta"},
                             max_train_samples=50, progress=False)
    assert sub.info["n_train"] == 50 and sub.target == "delta"
    assert sub.data_fingerprint == m.data_fingerprint
    fs = FeatureSet((CommandLag(lag=1),))  # an augmented feature set goes through as well
    aug = train_from_dataset(tiny_dataset, "lr", options={}, progress=False, feature_set=fs)
    Xa, _, _ = fs.features_responses(load_moves(tiny_dataset, "train"))
    assert aug.feature_names == fs.names and Xa.shape[1] > X.shape[1]
    assert aug.predict(Xa).shape == Y.shape
    with pytest.raises(ValueError, match="no option"):
        train_from_dataset(tiny_dataset, "lr", options={"n_clusters": 3}, progress=False)
    with pytest.raises(ValueError, match="unknown method"):
        train_from_dataset(tiny_dataset, "knn", options={}, progress=False)


def run_cli(*args: str) -> int:
    return cli.main(["train", *map(str, args)])


def test_train_cli(tiny_dataset, tmp_path, capsys):
    out = tmp_path / "model"
    assert run_cli("--data", tiny_dataset, "--method", "lgpr", "--clusters", "2", "--jobs", "1",
                   "--option", "max_iter=5", "--option", 'init="cold"', "--out", out,
                   "--quiet") == 0
    assert "wrote" in capsys.readouterr().out
    m = OneStepModel.load(out)
    assert m.method == "lgpr" and m.estimator.n_clusters_ == 2 and m.estimator.init == "cold"
    X, Y, _ = features_responses(load_moves(tiny_dataset, "test"))
    assert m.predict(X).shape == Y.shape
    before = (out / "model.json").read_bytes()

    # a failed training leaves the existing model alone; errors are one line, exit 2
    for bad in (["--method", "lr", "--clusters", "2"],
                ["--method", "lgpr", "--option", "no_such_option=1"],
                ["--method", "lgpr", "--dask-scheduler", "not-an-address"]):
        assert run_cli("--data", tiny_dataset, "--out", out, "--quiet", *bad) == 2
        err = capsys.readouterr().err.strip()
        assert err.startswith("littledog-mlsim train: error:") and "\n" not in err
    assert "not an address (tcp://HOST:PORT)" in err     # refused before a Client is made
    assert (out / "model.json").read_bytes() == before

    assert run_cli("--data", tmp_path / "nope", "--method", "lr", "--out", tmp_path / "m2",
                   "--quiet") == 2
    notes = tmp_path / "notes.txt"
    notes.write_text("keep me")
    assert run_cli("--data", tiny_dataset, "--method", "lr", "--out", notes, "--quiet") == 2
    assert notes.read_text() == "keep me"
    capsys.readouterr()

    # retraining replaces the model atomically
    assert run_cli("--data", tiny_dataset, "--method", "lr", "--target", "next", "--out", out,
                   "--quiet") == 0
    assert OneStepModel.load(out).method == "lr"
