"""The GP core against scikit-learn's GaussianProcessRegressor and against finite differences."""
from __future__ import annotations

import numpy as np
import pytest
from sklearn.gaussian_process import GaussianProcessRegressor
from sklearn.gaussian_process.kernels import RBF, ConstantKernel, WhiteKernel

from littledog_mlsim.models.gp import (DEFAULT_LENGTH_SCALE_BOUNDS, GPR,
                                       NotPositiveDefiniteError, _prior_variance, cross_kernel,
                                       default_bounds, default_init, degenerate_columns,
                                       fit_gp_hyperparameters, gp_posterior_stable, jitter_schedule,
                                       kernel_cross, kernel_matrix, lml_and_grad,
                                       log_marginal_likelihood)

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


def test_non_positive_definite_start_escalates_the_jitter() -> None:
    """Duplicates, noise variance e^-50 and no jitter: K is singular at the start; the fit
    raises the jitter along jitter_schedule instead of giving up, and records it."""
    X = np.repeat(np.random.default_rng(14).standard_normal((10, 3)), 3, axis=0)  # duplicates
    y = np.sin(X[:, 0])
    bounds = np.array([[-3, 3], [-3, 5], [-3, 5], [-3, 5], [-60, 0]], float)
    init = [0, 0, 0, 0, -50.0]
    assert not np.isfinite(lml_and_grad(np.array(init), X, y, jitter=0.0)[0])
    res = fit_gp_hyperparameters(X, y, init=init, bounds=bounds, jitter=0.0)
    assert res.jitter > 0 and np.isfinite(res.lml[0])
    assert res.jitter in jitter_schedule(0.0, _prior_variance(np.array(init)))
    m = GPR(optimize=False, init_log_params=init, jitter=0.0, normalize_y=False).fit(X, y)
    assert m.jitter_ > 0 and np.all(np.isfinite(m.alpha_))
    _, std = m.predict(X[:4], return_std=True)
    assert np.all(np.isfinite(std))


@pytest.mark.filterwarnings("ignore::RuntimeWarning")  # exp overflow: the point of the test
def test_unfittable_hyperparameters_fail_in_one_line() -> None:
    """Only non-finite kernels cannot be fixed by jitter: a one-line error with the reason."""
    X, Y = smooth_data(20, 3, seed=14)
    bounds = np.array([[800, 800], [-3, 5], [-3, 5], [-3, 5], [-6, 0]], float)  # sf2 = inf
    with pytest.raises(NotPositiveDefiniteError, match="non-finite hyperparameters") as e:
        fit_gp_hyperparameters(X, Y[:, 0], init=[800, 0, 0, 0, -3.0], bounds=bounds)
    assert "\n" not in str(e.value)
    with pytest.raises(NotPositiveDefiniteError, match="non-finite") as e:
        gp_posterior_stable(X, Y, np.array([800, 0, 0, 0, -3.0]))


def degenerate_cluster(n: int = 559, seed: int = 0) -> tuple[np.ndarray, np.ndarray]:
    """A cluster of the friction features: one column constant up to 1e-15 noise (a saturated
    tanh), one exactly constant (at n = 559, np.std of 1.3 gives 8e-15: rounding of the mean),
    one constant column of zeros, and 40 duplicated rows."""
    rng = np.random.default_rng(seed)
    X = rng.standard_normal((n, 7))
    X[:, 4] = 0.8 + 1e-15 * rng.standard_normal(n)
    X[:, 5] = 1.3
    X[:, 6] = 0.0
    X[-40:] = X[:40]
    Y = np.column_stack([np.sin(X[:, 0]) + 0.5 * X[:, 1] ** 2, np.cos(X[:, 2]) * X[:, 3]])
    return X, Y + 0.01 * rng.standard_normal(Y.shape)


def test_near_constant_columns_get_the_unit_scale() -> None:
    X, Y = degenerate_cluster()
    sx = X.std(axis=0)  # the column-wise reduction accumulates rounding: 1.3 has std 8e-15
    assert 0 < sx[4] < 1e-14 and 0 < sx[5] < 1e-14 and np.ptp(X[:, 5]) == 0
    np.testing.assert_array_equal(degenerate_columns(X), [0, 0, 0, 0, 1, 1, 1])
    b = default_bounds(X, Y)
    np.testing.assert_allclose(np.exp(b[0, 5:8]), [DEFAULT_LENGTH_SCALE_BOUNDS] * 3)
    np.testing.assert_allclose(np.exp(b[0, 1, :]), X[:, 0].std() * np.array([1e-2, 1e3]))
    assert np.all(np.isfinite(default_init(X, Y)))
    # a column that varies (even tiny next to its offset, as far as rounding allows) keeps its std
    Z = X.copy()
    Z[:, 4] = 1e3 + 1e-4 * np.arange(X.shape[0])
    assert not degenerate_columns(Z)[4]


def test_kernel_is_translation_invariant_despite_large_offsets() -> None:
    """Column offsets 1e8 times the length scale: (x / l)^2 ~ 1e16 would leave O(1) errors in
    |a|^2 + |b|^2 - 2 a.b; the kernel builds distances from centred inputs."""
    rng = np.random.default_rng(15)
    X, Y = smooth_data(40, 3, seed=16)
    Xs = rng.standard_normal((50, 3))
    lp = random_log_params(3, rng)
    shift = np.array([1e8, -3e7, 0.0])
    np.testing.assert_allclose(kernel_matrix(X + shift, lp), kernel_matrix(X, lp), atol=1e-12)
    np.testing.assert_allclose(kernel_cross(Xs + shift, X + shift, lp), kernel_cross(Xs, X, lp),
                               atol=1e-9)
    f, g = lml_and_grad(lp, X, Y[:, 0])
    f2, g2 = lml_and_grad(lp, X + shift, Y[:, 0])
    np.testing.assert_allclose([f2, *g2], [f, *g], rtol=1e-8, atol=1e-8)


@pytest.mark.parametrize("shared", [False, True])
def test_gpr_fits_a_cluster_with_constant_and_duplicated_columns(shared: bool) -> None:
    """Regression (benchmarks/diagnose/diagnose.md, "LGPR as the report model"): the std-relative
    bounds of a std-3e-15 column made K garbage at every start ("not positive definite at any start
    point"). The constant columns must be harmless: same fit as without them."""
    X, Y = degenerate_cluster()
    Xq, Yq = degenerate_cluster(200, seed=1)
    m = GPR(max_iter=50, shared_hyperparameters=shared).fit(X, Y)
    assert m.jitter_ == m.jitter  # no escalation needed
    mean, std = m.predict(Xq, return_std=True)
    assert np.all(np.isfinite(mean)) and np.all(std > 0)
    ref = GPR(max_iter=50, shared_hyperparameters=shared).fit(X[:, :4], Y)
    err = ((mean - Yq) ** 2).mean(0) / Yq.var(0)
    err_ref = ((ref.predict(Xq[:, :4]) - Yq) ** 2).mean(0) / Yq.var(0)
    assert np.all(err < 0.01)
    np.testing.assert_allclose(err, err_ref, rtol=0.05, atol=1e-4)


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


def test_a_packed_float32_factor_gives_the_variance_of_the_square_one() -> None:
    """``noisy_variance`` from a packed float32 factor (``pack_lower``) against the variance by
    a float64 dense solve of K: equal within float32 rounding, for one query and for several;
    the packed array holds the lower triangle row by row."""
    import scipy.linalg as sla

    from littledog_mlsim.models.gp import noisy_variance, pack_lower

    rng = np.random.default_rng(3)
    X = rng.normal(size=(120, 4))
    sf2, sn2 = 1.3, 0.01
    K = sf2 * np.exp(-0.5 * ((X[:, None, :] - X[None, :, :]) ** 2).sum(-1))
    L = np.linalg.cholesky(K + sn2 * np.eye(120))
    packed = pack_lower(L)
    assert packed.dtype == np.float32 and packed.shape == (120 * 121 // 2,)
    np.testing.assert_array_equal(packed[:3], np.float32([L[0, 0], L[1, 0], L[1, 1]]))
    Q = rng.normal(size=(5, 4))
    Kq = sf2 * np.exp(-0.5 * ((Q[:, None, :] - X[None, :, :]) ** 2).sum(-1))
    want = sf2 + sn2 - np.einsum("ij,ji->i", Kq, sla.solve(K + sn2 * np.eye(120), Kq.T))
    got = noisy_variance(packed, Kq, sf2, sn2)
    np.testing.assert_allclose(got, want, atol=1e-4 * (sf2 + sn2))
    np.testing.assert_array_equal(noisy_variance(packed, Kq[2:3], sf2, sn2), got[2:3])
