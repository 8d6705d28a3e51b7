"""Every registered regressor follows the one contract of models/base.py (scikit-learn's shape).

Parametrised over the registry (``models.METHODS``), so a new method is checked as soon as it
is registered: constructor = keyword-only hyperparameters read back by ``get_params``, a
``random_state``, fit/predict shapes, the declared predictive std, NotFittedError, bad input as
a one-line ValueError, bit-exact save/load through the model files, and determinism.
"""
from __future__ import annotations

import inspect
import json
from functools import lru_cache

import numpy as np
import pytest

from littledog_mlsim.models import (METHOD_NAMES, METHODS, ModelError, NotFittedError,
                                    StdNotSupportedError, get_method, load_model,
                                    make_estimator, save_model)
from littledog_mlsim.models.base import standardise_targets

# small settings so that every method fits in well under a second on 60 points
FAST: dict[str, dict] = {
    "lr": {},
    "lwpr": {"init_D": 2.0, "n_epochs": 2},
    "gpr": {"max_iter": 15},
    "sor": {"n_support": 20, "n_folds": 3, "n_hyperparameter_points": 40,
            "gp_params": {"max_iter": 15}},
    "lgpr": {"n_clusters": 2, "max_iter": 15, "n_hyperparameter_points": 30,
             "n_global_points": 40},
}
N, D, P = 60, 3, 2
REGISTERED = tuple(sorted(METHODS))      # every registered method (the paper's five and more)


def data(n: int = N, seed: int = 0) -> tuple[np.ndarray, np.ndarray]:
    rng = np.random.default_rng(seed)
    X = rng.uniform(-1.0, 1.0, (n, D))
    Y = np.c_[np.sin(2.0 * X[:, 0]) + X[:, 1], X[:, 2] ** 2 - 0.5 * X[:, 0]]
    return X, Y + 0.01 * rng.standard_normal((n, P))


def build(method: str, **extra):
    return make_estimator(method, {**FAST[method], **extra}, random_state=0)


@lru_cache(maxsize=None)
def fitted(method: str):
    X, Y = data()
    return build(method).fit(X, Y)


def test_the_registry_holds_the_paper_methods():
    assert set(METHOD_NAMES) <= set(METHODS)
    for name in METHOD_NAMES:
        assert get_method(name).method == name
    assert set(FAST) == set(REGISTERED), "give every registered method fast test settings"


@pytest.mark.parametrize("method", REGISTERED)
def test_get_params_is_the_keyword_only_constructor_signature(method):
    cls = get_method(method)
    sig = inspect.signature(cls.__init__)
    named = [n for n, p in sig.parameters.items() if n != "self"]
    assert all(sig.parameters[n].kind is inspect.Parameter.KEYWORD_ONLY for n in named)
    est = build(method)
    params = est.get_params()
    assert list(params) == [n for n in named if n not in cls._renamed_params]
    assert "seed" not in params
    if method != "lr":                                   # everything random is seeded by it
        assert "random_state" in params
    # JSON round trip rebuilds an estimator with the same parameters
    again = cls(**json.loads(json.dumps(params)))
    assert again.get_params() == params
    with pytest.raises(TypeError):
        cls(*[0])                                        # hyperparameters are keyword-only


@pytest.mark.parametrize("method", REGISTERED)
def test_fit_returns_self_and_predict_has_the_shapes(method):
    X, Y = data()
    est = build(method)
    assert est.fit(X, Y) is est
    assert est.n_features_in_ == D and est.n_outputs_ == P
    Xq, Yq = data(17, seed=1)
    pred = est.predict(Xq)
    assert pred.shape == (17, P) and np.all(np.isfinite(pred))
    assert est.predict(Xq[0]).shape == (1, P)
    # it learned something: better than predicting the training mean
    assert np.mean((pred - Yq) ** 2) < 0.8 * np.mean((Yq - Y.mean(axis=0)) ** 2)
    one = build(method).fit(X, Y[:, 0])
    assert one.predict(Xq).shape == (17, 1)


@pytest.mark.parametrize("method", REGISTERED)
def test_predictive_std_is_declared(method):
    est = fitted(method)
    Xq, _ = data(9, seed=2)
    if est.supports_std:
        mean, std = est.predict(Xq, return_std=True)
        assert mean.shape == std.shape == (9, P)
        assert np.all(np.isfinite(std)) and np.all(std > 0)
        np.testing.assert_allclose(mean, est.predict(Xq), rtol=1e-12, atol=1e-12)
    else:
        with pytest.raises(StdNotSupportedError):
            est.predict(Xq, return_std=True)


def test_sor_without_variance_declares_no_std():
    X, Y = data()
    est = build("sor", predict_variance=False).fit(X, Y)
    assert not est.supports_std
    with pytest.raises(StdNotSupportedError):
        est.predict(X[:2], return_std=True)


@pytest.mark.parametrize("method", REGISTERED)
def test_use_before_fit_raises_not_fitted(method, tmp_path):
    est = build(method)
    with pytest.raises(NotFittedError, match="not fitted"):
        est.predict(np.zeros((2, D)))
    with pytest.raises(NotFittedError):
        est.get_state()
    with pytest.raises(ModelError, match="not fitted"):
        save_model(tmp_path / "m", est)
    assert not (tmp_path / "m").exists()


@pytest.mark.parametrize("method", REGISTERED)
def test_bad_input_is_a_one_line_value_error(method):
    X, Y = data()
    for bad_X, bad_Y in ((np.where(np.arange(N)[:, None] == 5, np.nan, X), Y),
                         (X, np.where(np.arange(N)[:, None] == 7, np.inf, Y)),
                         (X[:-1], Y), (X[:, :, None], Y), (X[:0], Y[:0])):
        with pytest.raises(ValueError) as e:
            build(method).fit(bad_X, bad_Y)
        assert "\n" not in str(e.value)
    est = fitted(method)
    with pytest.raises(ValueError, match=f"\\(n, {D}\\)"):
        est.predict(np.zeros((3, D + 1)))
    # a non-finite query (a diverged rollout) gives a non-finite row, the others stay exact
    Xq, _ = data(5, seed=3)
    Xq_nan = Xq.copy()
    Xq_nan[2] = np.nan
    out = est.predict(Xq_nan)
    assert not np.all(np.isfinite(out[2]))
    rows = [0, 1, 3, 4]
    np.testing.assert_allclose(out[rows], est.predict(Xq[rows]), rtol=1e-9, atol=1e-12)


@pytest.mark.parametrize("method", REGISTERED)
def test_save_load_is_bit_exact(method, tmp_path):
    est = fitted(method)
    save_model(tmp_path / method, est)
    loaded, _ = load_model(tmp_path / method)
    assert type(loaded) is type(est) and loaded.get_params() == est.get_params()
    Xq, _ = data(25, seed=4)
    np.testing.assert_array_equal(loaded.predict(Xq), est.predict(Xq))
    if est.supports_std:
        for a, b in zip(loaded.predict(Xq, return_std=True), est.predict(Xq, return_std=True)):
            np.testing.assert_array_equal(a, b)
    arrays, meta = loaded.get_state()
    arrays0, meta0 = est.get_state()
    assert sorted(arrays) == sorted(arrays0)
    for k in arrays:
        np.testing.assert_array_equal(arrays[k], arrays0[k])


@pytest.mark.parametrize("method", REGISTERED)
def test_same_random_state_same_model(method):
    X, Y = data()
    Xq, _ = data(11, seed=5)
    a = build(method).fit(X, Y).predict(Xq)
    np.testing.assert_array_equal(a, fitted(method).predict(Xq))


def test_old_parameter_names_still_load():
    """LWPR's seed was renamed random_state: old files and option lists keep working."""
    lwpr = get_method("lwpr")
    assert lwpr(seed=3).random_state == 3
    assert lwpr.from_params({"seed": 4}).get_params()["random_state"] == 4
    assert make_estimator("lwpr", {"seed": 5}).random_state == 5
    with pytest.raises(ValueError, match="no option"):
        make_estimator("lwpr", {"sead": 5})
    with pytest.raises(ValueError, match="unknown method"):
        make_estimator("nope")


def test_standardise_targets_against_numpy():
    Y = np.c_[np.arange(5.0), np.full(5, 3.0)]
    Yn, mean, sd = standardise_targets(Y)
    np.testing.assert_allclose(mean, [2.0, 3.0])
    np.testing.assert_allclose(sd, [np.sqrt(2.0), 1.0])    # a constant column keeps std 1
    np.testing.assert_allclose(Yn[:, 0], (np.arange(5.0) - 2.0) / np.sqrt(2.0))
    assert np.all(Yn[:, 1] == 0.0)
    Yr, mean, sd = standardise_targets(Y, enabled=False)
    assert np.array_equal(Yr, Y) and np.all(mean == 0) and np.all(sd == 1)
