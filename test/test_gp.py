"""The GP core against scikit-learn's GaussianProcessRegressor and against finite differences."""
from __future__ import annotations

import numpy as np
import pytest
from sklearn.gaussian_process import GaussianProcessRegressor
from sklearn.gaussian_process.kernels import RBF, ConstantKernel, WhiteKernel

from littledog_mlsim.models.gp import (GPR, cross_kernel, default_bounds, default_init,
                                       fit_gp_hyperparameters, kernel_cross, kernel_matrix,
                                       lml_and_grad, log_marginal_likelihood)

JITTER = 1e-10


def sk_kernel(log_params: np.ndarray, bounds: np.ndarray | None = None):
    """scikit-learn's ConstantKernel * RBF(ARD) + WhiteKernel at our log_params (d + 2,)."""
    p = np.exp(log_params)
    if bounds is None:  # wide but not "fixed", so that theta holds every hyperparameter
        bounds = np.tile(np.log([1e-12, 1e12]), (p.size, 1))
    b = np.exp(bounds)
    return (ConstantKernel(p[0], tuple(b[0])) * RBF(p[1:-1], [tuple(r) for r in b[1:-1]])
            + WhiteKernel(p[-1], tuple(b[-1])))


def smooth_data(n: int, d: int, seed: int, p: int = 1) -> tuple[np.ndarray, np.ndarray]:
    rng = np.random.default_rng(seed)
    X = rng.standard_normal((n, d))
    W = rng.standard_normal((d, p))
    Y = np.sin(X @ W / np.sqrt(d)) + 0.3 * (X[:, :1] ** 2) + 0.05 * rng.standard_normal((n, p))
    return X, Y


def random_log_params(d: int, rng: np.random.Generator) -> np.ndarray:
    return np.concatenate([[rng.uniform(-1, 1)], rng.uniform(-0.5, 1.5, d),
                           [rng.uniform(-6, -1)]])


@pytest.mark.parametrize("p", [1, 3])
def test_lml_and_grad_equal_sklearn(p: int) -> None:
    rng = np.random.default_rng(0)
    X, Y = smooth_data(50, 6, seed=1, p=p)
    y = Y[:, 0] if p == 1 else Y
    for _ in range(3):
        lp = random_log_params(X.shape[1], rng)
        ours, g = lml_and_grad(lp, X, y, jitter=JITTER)
        sk = GaussianProcessRegressor(sk_kernel(lp), alpha=JITTER, optimizer=None).fit(X, y)
        # sklearn's theta is [log constant, log length scales..., log noise]: our order
        ref, gref = sk.log_marginal_likelihood(sk.kernel_.theta, eval_gradient=True)
        np.testing.assert_allclose(sk.kernel_.theta, lp, rtol=1e-14)
        np.testing.assert_allclose(ours, ref, rtol=1e-6)
        np.testing.assert_allclose(g, gref, rtol=1e-6, atol=1e-9 * np.abs(gref).max())
        np.testing.assert_allclose(log_marginal_likelihood(lp, X, y, JITTER).sum(), ref,
                                   rtol=1e-6)


def test_gradient_matches_finite_differences() -> None:
    rng = np.random.default_rng(2)
    X, Y = smooth_data(40, 4, seed=3, p=2)
    lp = random_log_params(X.shape[1], rng)
    _, g = lml_and_grad(lp, X, Y)
    h = 1e-5
    fd = np.empty_like(lp)
    for i in range(lp.size):
        e = np.zeros_like(lp)
        e[i] = h
        fd[i] = (lml_and_grad(lp + e, X, Y)[0] - lml_and_grad(lp - e, X, Y)[0]) / (2 * h)
    np.testing.assert_allclose(g, fd, rtol=1e-5, atol=1e-6 * np.abs(fd).max())


def test_shared_lml_is_sum_over_outputs() -> None:
    X, Y = smooth_data(30, 3, seed=4, p=3)
    lp = random_log_params(3, np.random.default_rng(5))
    f_all, g_all = lml_and_grad(lp, X, Y)
    parts = [lml_and_grad(lp, X, Y[:, j]) for j in range(3)]
    np.testing.assert_allclose(f_all, sum(f for f, _ in parts), rtol=1e-12)
    np.testing.assert_allclose(g_all, sum(g for _, g in parts), rtol=1e-9, atol=1e-12)


def test_kernels_agree_with_each_other_and_sklearn() -> None:
    rng = np.random.default_rng(6)
    X, _ = smooth_data(20, 5, seed=7)
    Xs = rng.standard_normal((4, 5))
    lps = np.stack([random_log_params(5, rng) for _ in range(3)])
    many = cross_kernel(Xs, X, lps)
    for q in range(3):
        ref = sk_kernel(lps[q]).k1(Xs, X)  # the noise-free part
        np.testing.assert_allclose(many[:, :, q], ref, rtol=1e-12, atol=1e-14)
        np.testing.assert_allclose(kernel_cross(Xs, X, lps[q]), ref, rtol=1e-10, atol=1e-14)
    np.testing.assert_allclose(kernel_matrix(X, lps[0]), sk_kernel(lps[0]).k1(X), rtol=1e-10,
                               atol=1e-14)


@pytest.mark.parametrize("n_query", [3, 40])  # both prediction paths (few queries / GEMM loop)
@pytest.mark.parametrize("normalize_y", [False, True])
def test_gpr_predictions_equal_sklearn_with_fixed_hyperparameters(n_query: int,
                                                                  normalize_y: bool) -> None:
    rng = np.random.default_rng(8)
    X, Y = smooth_data(60, 5, seed=9, p=2)
    Xs = rng.standard_normal((n_query, 5))
    lps = np.stack([random_log_params(5, rng) for _ in range(2)])
    ours = GPR(optimize=False, init_log_params=lps.tolist(), normalize_y=normalize_y,
               jitter=JITTER).fit(X, Y)
    mean, std = ours.predict(Xs, return_std=True)
    assert mean.shape == std.shape == (n_query, 2)
    np.testing.assert_array_equal(ours.predict(Xs), mean)
    for j in range(2):
        sk = GaussianProcessRegressor(sk_kernel(lps[j]), alpha=JITTER, optimizer=None,
                                      normalize_y=normalize_y).fit(X, Y[:, j])
        m_ref, s_ref = sk.predict(Xs, return_std=True)
        np.testing.assert_allclose(mean[:, j], m_ref, rtol=1e-7, atol=1e-9)
        np.testing.assert_allclose(std[:, j], s_ref, rtol=1e-6, atol=1e-9)


@pytest.mark.filterwarnings("ignore::sklearn.exceptions.ConvergenceWarning")
def test_fit_improves_lml_and_reaches_sklearns_optimum() -> None:
    X, Y = smooth_data(80, 4, seed=10)
    y = Y[:, 0]
    init = default_init(X, y)[0]
    bounds = default_bounds(X, y)[0]
    res = fit_gp_hyperparameters(X, y, init=init, bounds=bounds, max_iter=500)
    start = log_marginal_likelihood(init, X, y)[0]
    assert res.lml[0] > start + 1.0
    np.testing.assert_allclose(res.lml[0], log_marginal_likelihood(res.log_params[0], X, y)[0])
    sk = GaussianProcessRegressor(sk_kernel(init, bounds), alpha=JITTER,
                                  n_restarts_optimizer=0).fit(X, y)
    # same start, same bounds, same objective: same optimum (to optimiser tolerance)
    assert res.lml[0] >= sk.log_marginal_likelihood_value_ - 1e-3


def test_gpr_fit_per_output_shared_and_threads() -> None:
    X, Y = smooth_data(50, 3, seed=11, p=3)
    per = GPR(max_iter=50).fit(X, Y)
    assert per.log_params_.shape == (3, 5)
    assert not np.allclose(per.log_params_[0], per.log_params_[1])
    assert np.all(per.lml_ > log_marginal_likelihood(default_init(X, Y)[0], X,
                                                     (Y - Y.mean(0)) / Y.std(0)).min())
    threaded = GPR(max_iter=50, n_jobs=2).fit(X, Y)
    np.testing.assert_array_equal(threaded.log_params_, per.log_params_)
    shared = GPR(max_iter=50, shared_hyperparameters=True).fit(X, Y)
    assert np.all(shared.log_params_ == shared.log_params_[:1])
    mean, std = shared.predict(X[:5], return_std=True)
    assert mean.shape == std.shape == (5, 3) and np.all(std > 0)


def test_restarts_never_worse() -> None:
    X, Y = smooth_data(40, 3, seed=12)
    one = fit_gp_hyperparameters(X, Y, max_iter=100)
    more = fit_gp_hyperparameters(X, Y, max_iter=100, n_restarts=2, random_state=0)
    assert more.lml[0] >= one.lml[0] - 1e-9
    assert more.n_fev[0] > one.n_fev[0]


def test_bad_inputs_fail_clearly() -> None:
    X, Y = smooth_data(10, 3, seed=13)
    with pytest.raises(ValueError, match="rows"):
        GPR().fit(X, Y[:5])
    with pytest.raises(ValueError, match="NaN"):
        GPR().fit(np.where(X > 1, np.nan, X), Y)
    with pytest.raises(ValueError, match="init_log_params"):
        GPR(optimize=False).fit(X, Y)
    m = GPR(optimize=False, init_log_params=[0.0] * 5).fit(X, Y)
    with pytest.raises(ValueError, match=r"\(n, 3\)"):
        m.predict(np.zeros((2, 4)))


def test_non_positive_definite_start_fails_clearly() -> None:
    X = np.repeat(np.random.default_rng(14).standard_normal((10, 3)), 3, axis=0)  # duplicates
    y = np.sin(X[:, 0])
    bounds = np.array([[-3, 3], [-3, 5], [-3, 5], [-3, 5], [-60, 0]], float)
    with pytest.raises(ValueError, match="not positive definite"):
        fit_gp_hyperparameters(X, y, init=[0, 0, 0, 0, -50.0], bounds=bounds, jitter=0.0)


def test_default_init_avoids_the_all_noise_basin() -> None:
    """A response of 3 of 30 inputs: from the plain median heuristic (factor 1) L-BFGS-B stops
    in the "everything is noise" optimum; the default candidate factors pick a shorter start
    (by LML) from which the fit explains the data."""
    rng = np.random.default_rng(0)
    X = rng.standard_normal((150, 30))
    y = np.sin(X[:, 3]) + X[:, 4] * X[:, 5] + 0.01 * rng.standard_normal(150)
    y = (y - y.mean()) / y.std()
    plain = default_init(X, y, length_scale_factors=(1.0,))
    chosen = default_init(X, y)
    assert chosen[0, 1] < plain[0, 1]
    stuck = fit_gp_hyperparameters(X, y, init=plain)
    fitted = fit_gp_hyperparameters(X, y, init=chosen)
    assert np.exp(stuck.log_params[0, -1]) > 0.05  # large noise variance: little explained
    assert np.exp(fitted.log_params[0, -1]) < 1e-2
    assert fitted.lml[0] > stuck.lml[0] + 100
