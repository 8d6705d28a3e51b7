"""LR, SoR (with CV-separateness support selection) and model files."""
from __future__ import annotations

import json
import os
from pathlib import Path

import numpy as np
import pytest

from littledog_mlsim import fileio
from littledog_mlsim.models import persistence
from littledog_mlsim.models.base import Regressor
from littledog_mlsim.models.gp import GPR
from littledog_mlsim.models.lr import LinearRegression
from littledog_mlsim.models.persistence import (METHODS, ModelError, load_model, register,
                                                save_model)
from littledog_mlsim.models.sor import SoR, cv_separateness, sample_support

D = 5


def data(n: int, seed: int, p: int = 2) -> tuple[np.ndarray, np.ndarray]:
    rng = np.random.default_rng(seed)
    X = rng.standard_normal((n, D))
    Y = np.stack([np.sin(X[:, 0]) + 0.3 * X[:, 1] ** 2, np.cos(X[:, 2]) * X[:, 3]][:p], 1)
    return X, Y + 0.01 * rng.standard_normal(Y.shape)


FIXED = [0.0, 0.3, 0.5, 0.7, 1.0, 1.2, -6.0]  # log [sf2, l_1..l_5, sn2]

# ----------------------------------------------------------------------------- LR


def test_lr_is_exact_on_affine_data() -> None:
    rng = np.random.default_rng(0)
    X = rng.standard_normal((30, 4))
    W, b = rng.standard_normal((4, 3)), rng.standard_normal(3)
    m = LinearRegression().fit(X, X @ W + b)
    np.testing.assert_allclose(m.coef_, W, rtol=1e-10)
    np.testing.assert_allclose(m.intercept_, b, rtol=1e-10)
    Xt = rng.standard_normal((7, 4))
    np.testing.assert_allclose(m.predict(Xt), Xt @ W + b, rtol=1e-10, atol=1e-12)
    _, std = m.predict(Xt, return_std=True)
    assert std.shape == (7, 3) and np.all(std < 1e-10)


def test_lr_handles_a_constant_feature() -> None:
    rng = np.random.default_rng(1)
    X = np.c_[rng.standard_normal((20, 2)), np.full(20, 3.0)]  # constant column: rank deficient
    y = X[:, 0] - 2 * X[:, 1] + 0.5
    m = LinearRegression().fit(X, y)
    assert m.rank_ == 3
    np.testing.assert_allclose(m.predict(X)[:, 0], y, atol=1e-10)


# ----------------------------------------------------------------------------- SoR


def test_sor_with_all_points_equals_full_gp_mean() -> None:
    X, Y = data(60, seed=2)
    Xt = np.random.default_rng(3).standard_normal((25, D))
    gp = GPR(optimize=False, init_log_params=FIXED).fit(X, Y)
    sor = SoR(n_support=60, gp_params={"optimize": False, "init_log_params": FIXED},
              jitter=1e-12).fit(X, Y)
    assert sor.weights_.shape == (2, 60)
    np.testing.assert_allclose(sor.predict(Xt), gp.predict(Xt), rtol=1e-6, atol=1e-7)
    _, std = sor.predict(Xt, return_std=True)
    assert np.all(np.isfinite(std)) and np.all(std > 0)


def test_sor_is_close_to_gp_with_fewer_support_points() -> None:
    X, Y = data(200, seed=4)
    Xt = np.random.default_rng(5).standard_normal((50, D))
    gp_params = {"optimize": False, "init_log_params": FIXED}
    gp = GPR(**gp_params).fit(X, Y)
    sor = SoR(n_support=80, support="random", gp_params=gp_params).fit(X, Y)
    err_sor = np.mean((sor.predict(Xt) - gp.predict(Xt)) ** 2, 0)
    err_mean = np.mean((Y.mean(0) - gp.predict(Xt)) ** 2, 0)
    assert np.all(err_sor < 0.1 * err_mean)


def separated_data() -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """A dense cluster on a smooth function plus 10 isolated points with unpredictable values.

    With unit length scales, each isolated point is > 4 length scales from any other point, so a
    GP that has not seen it predicts about 0 there (error ~2), while every cluster point has
    dozens of close neighbours in any other fold (error ~0).
    """
    rng = np.random.default_rng(6)
    cluster = 0.3 * rng.standard_normal((150, 2))
    angles = np.linspace(0, 2 * np.pi, 10, endpoint=False)
    isolated = 6.0 * np.c_[np.cos(angles), np.sin(angles)]  # 3.7 apart on a circle
    X = np.vstack([cluster, isolated])
    y = np.r_[np.sin(cluster[:, 0]) + cluster[:, 1], 2.0 * (-1.0) ** np.arange(10)]
    return X, y[:, None], np.r_[np.zeros(150, bool), np.ones(10, bool)]


def test_cv_separateness_prefers_points_that_are_hard_to_predict() -> None:
    X, Y, isolated = separated_data()
    lp = np.log([1.0, 1.0, 1.0, 1e-4])
    prob = cv_separateness(X, Y, lp, n_folds=5, random_state=0)
    assert prob.shape == (160, 1)
    np.testing.assert_allclose(prob.sum(0), 1.0)
    assert prob[isolated].min() > 10 * prob[~isolated].max()
    # sampling 20 of 160: uniform would pick 10 * 20/160 = 1.25 isolated points on average
    sor = SoR(n_support=20, support="cv", n_folds=5, normalize_y=False,
              gp_params={"optimize": False, "init_log_params": lp.tolist()}).fit(X, Y)
    assert np.isin(np.flatnonzero(isolated), sor.support_index_[0]).sum() >= 9
    rnd = SoR(n_support=20, support="random", normalize_y=False,
              gp_params={"optimize": False, "init_log_params": lp.tolist()}).fit(X, Y)
    assert np.isin(np.flatnonzero(isolated), rnd.support_index_[0]).sum() <= 5


def test_cv_support_is_per_output() -> None:
    X, Y = data(120, seed=7)
    sor = SoR(n_support=30, support="cv", n_folds=4, n_hyperparameter_points=60,
              gp_params={"max_iter": 30}).fit(X, Y)
    assert sor.support_index_.shape == (2, 30)
    assert not np.array_equal(sor.support_index_[0], sor.support_index_[1])
    assert sor.separateness_.shape == (120, 2)
    assert not np.allclose(sor.log_params_[0], sor.log_params_[1])


def test_sample_support_with_too_few_nonzero_probabilities() -> None:
    prob = np.zeros(10)
    prob[[2, 5]] = 0.5
    idx = sample_support(prob, 4, np.random.default_rng(0))
    assert len(set(idx)) == 4 and {2, 5} <= set(idx)


# ----------------------------------------------------------------------------- persistence


def fitted(method: str) -> Regressor:
    X, Y = data(70, seed=8)
    if method == "lr":
        return LinearRegression().fit(X, Y)
    if method == "gpr":
        return GPR(max_iter=20).fit(X, Y)
    return SoR(n_support=25, n_folds=3, n_hyperparameter_points=40,
               gp_params={"max_iter": 20}).fit(X, Y)


@pytest.mark.parametrize("method", ["lr", "gpr", "sor"])
def test_save_load_round_trip_is_bit_exact(tmp_path: Path, method: str) -> None:
    model = fitted(method)
    assert METHODS[method] is type(model)
    Xt = np.random.default_rng(9).standard_normal((12, D))
    mean, std = model.predict(Xt, return_std=True)
    meta = {"feature_names": [f"x{i}" for i in range(D)], "x_mean": np.zeros(D),
            "fingerprint": "abc"}
    save_model(tmp_path / "m", model, meta)
    loaded, meta2 = load_model(tmp_path / "m", feature_names=meta["feature_names"])
    assert type(loaded) is type(model)
    assert meta2 == {"feature_names": meta["feature_names"], "x_mean": [0.0] * D,
                     "fingerprint": "abc"}
    assert loaded.get_params() == model.get_params()
    m2, s2 = loaded.predict(Xt, return_std=True)
    np.testing.assert_array_equal(m2, mean)
    np.testing.assert_array_equal(s2, std)
    with np.load(tmp_path / "m" / "arrays.npz", allow_pickle=False) as z:
        assert set(z.files) == set(json.loads((tmp_path / "m" / "model.json").read_text())
                                   ["arrays"])


@pytest.fixture()
def saved(tmp_path: Path) -> Path:
    path = tmp_path / "model"
    save_model(path, fitted("lr"), {"feature_names": [f"x{i}" for i in range(D)]})
    return path


def rewrite_json(path: Path, **changes) -> None:
    doc = json.loads((path / "model.json").read_text())
    doc.update(changes)
    (path / "model.json").write_text(json.dumps(doc))


def rewrite_arrays(path: Path, arrays: dict[str, np.ndarray]) -> None:
    """Replace arrays.npz and make model.json consistent with it (checksum, listing)."""
    import hashlib
    import io
    buf = io.BytesIO()
    np.savez(buf, **arrays)
    (path / "arrays.npz").write_bytes(buf.getvalue())
    rewrite_json(path, arrays_sha256=hashlib.sha256(buf.getvalue()).hexdigest(),
                 arrays={k: {"shape": list(v.shape), "dtype": v.dtype.str}
                         for k, v in arrays.items()})


def one_line_error(path: Path, match: str, **kw) -> None:
    with pytest.raises(ModelError, match=match) as e:
        load_model(path, **kw)
    assert "\n" not in str(e.value)


def test_truncated_or_corrupt_files_fail_clearly(saved: Path) -> None:
    blob = (saved / "arrays.npz").read_bytes()
    (saved / "arrays.npz").write_bytes(blob[: len(blob) // 2])
    one_line_error(saved, "checksum")
    (saved / "arrays.npz").write_bytes(b"")
    one_line_error(saved, "checksum")
    text = (saved / "model.json").read_text()
    (saved / "model.json").write_text(text[: len(text) // 2])
    one_line_error(saved, "not valid JSON")
    (saved / "model.json").unlink()
    one_line_error(saved, "not a model")


def test_npz_that_is_not_a_zip_fails_clearly(saved: Path) -> None:
    import hashlib
    junk = b"this is not a zip archive"
    (saved / "arrays.npz").write_bytes(junk)
    rewrite_json(saved, arrays_sha256=hashlib.sha256(junk).hexdigest())
    one_line_error(saved, "unreadable")


def test_unknown_version_or_method_fails_clearly(saved: Path) -> None:
    rewrite_json(saved, format_version=99)
    one_line_error(saved, "unsupported format_version 99")
    rewrite_json(saved, format_version=1, method="nonexistent_method")
    one_line_error(saved, "unknown model method 'nonexistent_method'")
    rewrite_json(saved, method="../../etc")
    one_line_error(saved, "unknown model method")


def test_missing_arrays_or_wrong_shapes_fail_clearly(saved: Path) -> None:
    model, _ = load_model(saved)
    arrays, _ = model.get_state()
    rewrite_arrays(saved, {k: v for k, v in arrays.items() if k != "coef"})
    one_line_error(saved, "missing array 'coef'")
    rewrite_arrays(saved, {**arrays, "coef": arrays["coef"][:, :1]})
    one_line_error(saved, "array 'coef' has shape")
    rewrite_arrays(saved, arrays)
    load_model(saved)  # consistent again
    rewrite_json(saved, arrays={**json.loads((saved / "model.json").read_text())["arrays"],
                                "extra": {"shape": [1], "dtype": "<f8"}})
    one_line_error(saved, "missing array 'extra'")


def test_feature_set_the_caller_cannot_supply(saved: Path) -> None:
    names = [f"x{i}" for i in range(D)]
    load_model(saved, feature_names=names)
    one_line_error(saved, "cannot supply: x4", feature_names=names[:4])
    one_line_error(saved, "order", feature_names=names[::-1])


def test_failed_save_leaves_the_old_model_untouched(saved: Path, monkeypatch) -> None:
    before = {f: (saved / f).read_bytes() for f in ("arrays.npz", "model.json")}
    with pytest.raises(ModelError, match="JSON"):
        save_model(saved, fitted("gpr"), {"bad": object()})

    def explode(*a, **k):
        raise OSError("disk full")
    monkeypatch.setattr(persistence.np, "savez", explode)
    with pytest.raises(OSError, match="disk full"):
        save_model(saved, fitted("gpr"))
    monkeypatch.undo()
    assert {f: (saved / f).read_bytes() for f in before} == before
    assert sorted(os.listdir(saved.parent)) == [saved.name]  # no temporary leftovers
    assert type(load_model(saved)[0]) is LinearRegression


@pytest.mark.parametrize("exchange", [True, False])
def test_save_replaces_an_existing_model(saved: Path, monkeypatch, exchange: bool) -> None:
    if not exchange:  # the fallback for kernels/file systems without renameat2
        monkeypatch.setattr(fileio, "_exchange", lambda a, b: False)
    save_model(saved, fitted("gpr"), {"run": 2})
    model, meta = load_model(saved)
    assert type(model) is GPR and meta == {"run": 2}
    assert sorted(os.listdir(saved.parent)) == [saved.name]


def test_refuses_to_replace_something_that_is_not_a_model(tmp_path: Path) -> None:
    (tmp_path / "notes").mkdir()
    (tmp_path / "notes" / "keep.txt").write_text("important")
    with pytest.raises(ModelError, match="not a model directory"):
        save_model(tmp_path / "notes", fitted("lr"))
    assert (tmp_path / "notes" / "keep.txt").read_text() == "important"
    with pytest.raises(ModelError, match="not fitted"):
        save_model(tmp_path / "m", LinearRegression())
    assert not (tmp_path / "m").exists()


def test_registry_accepts_new_methods(tmp_path: Path) -> None:
    class Const(Regressor):
        method = "test_const"

        def __init__(self, value: float = 0.0) -> None:
            self.value = value

        def fit(self, X, Y):
            self.p_ = np.asarray(Y).reshape(len(Y), -1).shape[1]
            return self

        def predict(self, X, return_std=False):
            return np.full((len(X), self.p_), self.value)

        def get_params(self):
            return {"value": self.value}

        def get_state(self):
            return {"p": np.array([self.p_])}, {}

        @classmethod
        def from_state(cls, params, arrays, meta):
            m = cls(**params)
            m.p_ = int(arrays["p"][0])
            return m

    with pytest.raises(ModelError, match="not registered"):
        save_model(tmp_path / "c", Const(1.5).fit(np.zeros((3, 2)), np.zeros((3, 4))))
    register(Const)
    try:
        save_model(tmp_path / "c", Const(1.5).fit(np.zeros((3, 2)), np.zeros((3, 4))))
        m, _ = load_model(tmp_path / "c")
        np.testing.assert_array_equal(m.predict(np.zeros((2, 2))), np.full((2, 4), 1.5))
        with pytest.raises(ValueError, match="already registered"):
            register(type("Other", (Const,), {}))
    finally:
        METHODS.pop("test_const")


def test_fingerprint_changes_with_the_data() -> None:
    X, Y = data(20, seed=10)
    f = persistence.fingerprint_arrays(X, Y)
    assert f == persistence.fingerprint_arrays(X.copy(), Y.copy())
    X2 = X.copy()
    X2[3, 1] += 1e-12
    assert f != persistence.fingerprint_arrays(X2, Y)
    assert f != persistence.fingerprint_arrays(X.astype(np.float32), Y)


def test_model_directory_follows_the_umask(tmp_path: Path) -> None:
    old = os.umask(0o022)
    try:
        save_model(tmp_path / "m", fitted("lr"))
    finally:
        os.umask(old)
    assert (tmp_path / "m").stat().st_mode & 0o777 == 0o755
    assert (tmp_path / "m" / "model.json").stat().st_mode & 0o777 == 0o644
    with pytest.raises(ModelError, match="no such model"):
        load_model(tmp_path / "missing")


def test_unregistered_method_is_found_in_its_module(saved: Path, monkeypatch) -> None:
    import sys
    import types
    mod = types.ModuleType("littledog_mlsim.models.test_fake")

    class Fake(LinearRegression):
        method = "test_fake"
    mod.Fake = Fake
    monkeypatch.setitem(sys.modules, "littledog_mlsim.models.test_fake", mod)
    rewrite_json(saved, method="test_fake")
    try:
        model, _ = load_model(saved)
        assert type(model) is Fake
    finally:
        METHODS.pop("test_fake", None)
