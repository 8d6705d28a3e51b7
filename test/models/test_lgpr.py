"""LGPR (paper Section V): checked against the full GP, a naive nearest-centre loop, and itself
across process pools and a real Dask cluster; the blend's continuity at a cluster boundary."""
from __future__ import annotations

import numpy as np
import pytest

from littledog_mlsim.models import lgpr, parallel
from littledog_mlsim.models.gp import GPR, kernel_matrix
from littledog_mlsim.models.lgpr import LGPR, balanced_clusters
from littledog_mlsim.models.persistence import load_model, save_model


def smooth_data(n: int, d: int = 4, seed: int = 0, noise: float = 0.02):
    rng = np.random.default_rng(seed)
    X = rng.standard_normal((n, d))
    Y = np.column_stack([np.sin(1.5 * X[:, 0]) + 0.5 * X[:, 1] ** 2,
                         np.cos(X[:, 2]) * X[:, 1],
                         0.3 * X[:, 3]])
    return X, Y + noise * rng.standard_normal(Y.shape)


def ml_output_scale(X: np.ndarray, Y: np.ndarray, log_params: np.ndarray, jitter: float
                    ) -> np.ndarray:
    """c_j = y_j^T K_j^-1 y_j / m (standardised y_j, K_j with noise and jitter), by a solve."""
    Yn = (Y - Y.mean(axis=0)) / Y.std(axis=0)
    c = []
    for j in range(Y.shape[1]):
        K = kernel_matrix(X, log_params[j])
        K.flat[:: X.shape[0] + 1] += np.exp(log_params[j, -1]) + jitter
        c.append(Yn[:, j] @ np.linalg.solve(K, Yn[:, j]) / X.shape[0])
    return np.array(c)


@pytest.mark.parametrize("mode", ["shared", "per_output"])
def test_one_cluster_is_the_full_gp(mode):
    """One cluster = GPR; its std is GPR's (noisy-observation std) x sqrt(c_j), or GPR's exactly
    with output_scale=False."""
    X, Y = smooth_data(120)
    Xt, _ = smooth_data(40, seed=1)
    lg = LGPR(n_clusters=1, hyperparameters=mode, init="cold", max_iter=40).fit(X, Y)
    gp = GPR(shared_hyperparameters=(mode == "shared"), max_iter=40).fit(X, Y)
    np.testing.assert_array_equal(lg.log_params_[0], gp.log_params_)
    c = ml_output_scale(X, Y, gp.log_params_, float(lg.jitter_[0]))
    np.testing.assert_allclose(lg.output_scale_[0], c, rtol=1e-8)
    m1, s1 = lg.predict(Xt, return_std=True)
    m2, s2 = gp.predict(Xt, return_std=True)
    np.testing.assert_allclose(m1, m2, rtol=1e-10, atol=1e-12)
    np.testing.assert_allclose(s1, s2 * np.sqrt(c), rtol=1e-8, atol=1e-12)
    lg.output_scale = False
    m0, s0 = lg.predict(Xt, return_std=True)
    np.testing.assert_array_equal(m0, m1)
    np.testing.assert_allclose(s0, s2, rtol=1e-8, atol=1e-12)
    np.testing.assert_allclose(lg.predict(Xt[:1]), m2[:1], rtol=1e-10, atol=1e-12)


def test_nearest_centre_and_prediction_match_a_naive_loop():
    X, Y = smooth_data(400, seed=2)
    Q, _ = smooth_data(60, seed=3)
    lg = LGPR(n_clusters=5, max_iter=15, n_hyperparameter_points=60,
              output_scale=False).fit(X, Y)
    k = lg.n_clusters_
    sizes = np.diff(lg.offsets_)
    assert sizes.sum() == 400 and sizes.max() <= 1.5 * 400 / 5
    np.testing.assert_array_equal(np.sort(lg.train_index_), np.arange(400))
    for c in range(k):  # centres are the means of the clusters' training points
        rows = lg.train_index_[lg.offsets_[c]:lg.offsets_[c + 1]]
        np.testing.assert_allclose(lg.centers_[c], X[rows].mean(axis=0), rtol=1e-12)
    want = np.array([min(range(k), key=lambda c: np.linalg.norm(q - lg.centers_[c]))
                     for q in Q])
    np.testing.assert_array_equal(lg.nearest_cluster(Q), want)
    mean, std = lg.predict(Q, return_std=True)
    for i, q in enumerate(Q):  # the cluster's own full GP with the same hyperparameters
        c = want[i]
        rows = lg.train_index_[lg.offsets_[c]:lg.offsets_[c + 1]]
        gp = GPR(optimize=False, init_log_params=lg.log_params_[c].tolist(),
                 jitter=float(lg.jitter_[c])).fit(X[rows], Y[rows])
        m, s = gp.predict(q[None], return_std=True)
        np.testing.assert_allclose(mean[i], m[0], rtol=1e-9, atol=1e-12)
        np.testing.assert_allclose(std[i], s[0], rtol=1e-7, atol=1e-12)
        np.testing.assert_allclose(lg.predict(q), m, rtol=1e-9, atol=1e-12)


def hetero_noise_data(n: int, seed: int, noise_fraction: np.ndarray, d: int = 4):
    """Smooth outputs of about unit variance with noise variance ``noise_fraction`` x theirs."""
    rng = np.random.default_rng(seed)
    X = rng.standard_normal((n, d))
    W = np.random.default_rng(123).standard_normal((d, noise_fraction.size))
    F = (np.sin(X @ W / np.sqrt(d) * 1.5)
         + 0.3 * np.cos(X[:, :1] * np.arange(1, noise_fraction.size + 1)))
    return X, F + 0.7 * np.sqrt(noise_fraction) * rng.standard_normal(F.shape)


def test_output_scale_calibrates_outputs_of_different_noise():
    """Shared hyperparameters: one noise level for outputs whose noise fractions differ 100x,
    so the plain std is far too wide for the clean output and too narrow for the noisy one
    (mean z^2 0.04 and 2.9 here). The profiled amplitude brings every output into [0.5, 2]
    (0.56-1.07) and leaves the mean bit-identical."""
    frac = np.array([1e-3, 1e-2, 1e-1])
    X, Y = hetero_noise_data(1500, 0, frac)
    Xq, Yq = hetero_noise_data(2000, 100, frac)
    on = LGPR(n_clusters=2, max_iter=30, n_global_points=300).fit(X, Y)
    off = LGPR(n_clusters=2, max_iter=30, n_global_points=300, output_scale=False).fit(X, Y)
    assert on.output_scale is True and on.get_params()["output_scale"] is True
    _same_model(on, off)  # the option only changes prediction
    mean_on, std_on = on.predict(Xq, return_std=True)
    mean_off, std_off = off.predict(Xq, return_std=True)
    np.testing.assert_array_equal(mean_on, mean_off)
    np.testing.assert_array_equal(on.predict(Xq), mean_off)
    np.testing.assert_array_equal(on.predict(Xq[0]), off.predict(Xq[0]))
    c = on.output_scale_[on.nearest_cluster(Xq)]
    np.testing.assert_allclose(std_on, std_off * np.sqrt(c), rtol=1e-12)
    z2_on = (((Yq - mean_on) / std_on) ** 2).mean(axis=0)
    z2_off = (((Yq - mean_off) / std_off) ** 2).mean(axis=0)
    assert z2_off.min() < 0.2 and z2_off.max() > 2.0  # mis-calibrated without
    assert np.all((z2_on > 0.5) & (z2_on < 2.0)), z2_on
    # the clean output's amplitude is small, the noisy one's large, in every cluster
    assert np.all(on.output_scale_[:, 0] < 0.3) and np.all(on.output_scale_[:, 2] > 1.5)


def test_blend_uses_the_calibrated_variances():
    """The blend's weights and mixture variance are built from the variances predict reports
    for each local model alone (calibrated); "relative" weights do not depend on the option."""
    frac = np.array([1e-3, 1e-1])
    X, Y = hetero_noise_data(600, 1, frac, d=2)
    Q, _ = hetero_noise_data(50, 2, frac, d=2)
    lg = LGPR(n_clusters=4, max_iter=15, n_global_points=200, blend=True, n_blend=2).fit(X, Y)
    assert lg.n_clusters_ == 4
    D2 = ((Q[:, None, :] - lg.centers_[None]) ** 2).sum(axis=2)
    order = np.argsort(D2, axis=1)
    for weights in ("precision", "relative"):
        lg.blend_weights = weights
        mean, std = lg.predict(Q, return_std=True)
        for i, q in enumerate(Q):
            r = order[i, :2]
            g = D2[i, order[i, 2]] - D2[i, r]
            mus, vs, prior = [], [], []
            for c in r:  # model c alone: its cluster's points and the stored hyperparameters
                rows = lg.train_index_[lg.offsets_[c]:lg.offsets_[c + 1]]
                gp = GPR(optimize=False, init_log_params=lg.log_params_[c].tolist(),
                         jitter=float(lg.jitter_[c])).fit(X[rows], Y[rows])
                m, s = gp.predict(q[None], return_std=True)
                sf2 = np.exp(lg.log_params_[c][:, 0]) + np.exp(lg.log_params_[c][:, -1])
                mus.append(m[0])
                vs.append(s[0] ** 2 * lg.output_scale_[c])
                prior.append(sf2 * Y[rows].var(axis=0) * lg.output_scale_[c])
            prec = [1 / v if weights == "precision" else p / v for v, p in zip(vs, prior)]
            w = np.stack([g[j] * prec[j] for j in range(2)])
            w /= w.sum(axis=0)
            mu = np.stack(mus)
            want = (w * mu).sum(axis=0)
            var = (w * (np.stack(vs) + mu * mu)).sum(axis=0) - want ** 2
            np.testing.assert_allclose(mean[i], want, rtol=1e-7, atol=1e-10)
            np.testing.assert_allclose(std[i], np.sqrt(var), rtol=1e-6, atol=1e-10)
        lg.output_scale = False
        mean_off = lg.predict(Q)
        lg.output_scale = True
        if weights == "relative":
            np.testing.assert_allclose(mean_off, mean, rtol=1e-12, atol=1e-14)
        else:  # the calibrated precisions re-weight the models
            assert not np.allclose(mean_off, mean, rtol=1e-9, atol=0)


def test_balanced_clusters_split_and_dissolve():
    rng = np.random.default_rng(4)
    # one dense blob (k-means keeps most of it in one cluster), a few far points
    X = np.vstack([1e-3 * rng.standard_normal((300, 2)), 5 + rng.standard_normal((60, 2)),
                   [[40.0, 40.0]]])
    labels, centres = balanced_clusters(X, 4, max_cluster_factor=1.5, min_cluster_factor=0.25)
    sizes = np.bincount(labels)
    assert sizes.max() <= 1.5 * X.shape[0] / 4
    assert sizes.min() >= 0.25 * X.shape[0] / 4  # the lone far point was dissolved
    for c in range(centres.shape[0]):
        np.testing.assert_allclose(centres[c], X[labels == c].mean(axis=0))


def boundary_data():
    """A function on three separate intervals (2nd input constant), the middle one lifted by 1:
    the local GPs disagree across the gaps, where the nearest-centre rule switches model."""
    x = np.concatenate([np.linspace(-3, -1.4, 40), np.linspace(-0.6, 0.6, 40),
                        np.linspace(1.4, 3, 40)])
    X = np.column_stack([x, np.zeros_like(x)])
    lift = (np.abs(x) < 1.0).astype(float)
    Y = np.column_stack([np.sin(2 * x) + lift, np.cos(x) - 0.5 * lift])
    return X, Y


def test_blend_is_continuous_where_nearest_jumps():
    X, Y = boundary_data()
    near = LGPR(n_clusters=3, max_iter=30, init="cold").fit(X, Y)
    assert near.n_clusters_ == 3
    blend = LGPR(n_clusters=3, max_iter=30, init="cold", blend=True, n_blend=2).fit(X, Y)
    np.testing.assert_array_equal(blend.alpha_, near.alpha_)  # same local models

    def max_step(model, lo, hi, n):
        q = np.linspace(lo, hi, n)
        return np.abs(np.diff(model.predict(np.column_stack([q, np.zeros_like(q)])),
                              axis=0)).max()

    # the nearest rule jumps by ~1 (the lift) wherever it switches model; refining the grid
    # does not shrink the jump. The blend's largest step shrinks with the grid (continuous).
    coarse, fine = max_step(near, -3, 3, 601), max_step(near, -3, 3, 60001)
    assert coarse > 0.5 and fine > 0.5
    for weights in ("precision", "relative"):
        blend.blend_weights = weights
        coarse, fine = max_step(blend, -3, 3, 601), max_step(blend, -3, 3, 60001)
        assert coarse < 0.1 and fine < 0.2 * coarse  # shrinks with the grid: no jump
        q = np.linspace(-3, 3, 601)
        _, std = blend.predict(np.column_stack([q, np.zeros_like(q)]), return_std=True)
        assert np.all(np.isfinite(std)) and np.all(std > 0)
    # inside a cluster, far from the boundaries, the blend is close to the nearest model
    q = np.linspace(-0.3, 0.3, 61)
    Q = np.column_stack([q, np.zeros_like(q)])
    np.testing.assert_allclose(blend.predict(Q), near.predict(Q), atol=1e-3)
    blend.n_blend = 1  # one model: the nearest-centre rule exactly
    q = np.linspace(-3, 3, 601)
    Q = np.column_stack([q, np.zeros_like(q)])
    np.testing.assert_array_equal(blend.predict(Q), near.predict(Q))


def _same_model(a: LGPR, b: LGPR) -> None:
    sa, _ = a.get_state()
    sb, _ = b.get_state()
    for name in sa:
        if name not in ("fit_seconds", "fit_cpu_seconds"):
            np.testing.assert_array_equal(sa[name], sb[name], err_msg=name)


@pytest.fixture(scope="module")
def parallel_data():
    return smooth_data(300, seed=5)


@pytest.fixture(scope="module")
def serial_model(parallel_data):
    return LGPR(n_clusters=3, max_iter=15, n_global_points=80, n_jobs=1).fit(*parallel_data)


def test_joblib_processes_give_the_same_model(parallel_data, serial_model):
    two = LGPR(n_clusters=3, max_iter=15, n_global_points=80, n_jobs=2).fit(*parallel_data)
    _same_model(serial_model, two)


def test_dask_cluster_gives_the_same_model(parallel_data, serial_model):
    distributed = pytest.importorskip("distributed")
    with distributed.LocalCluster(host="127.0.0.1", dashboard_address=None, n_workers=2,
                                  threads_per_worker=1, processes=True) as cluster:
        remote = LGPR(n_clusters=3, max_iter=15, n_global_points=80,
                      dask_scheduler=cluster.scheduler_address).fit(*parallel_data)
    assert remote.dask_scheduler.startswith("tcp://127.0.0.1:")
    _same_model(serial_model, remote)


def test_dask_scheduler_unreachable_is_one_line(parallel_data, monkeypatch):
    monkeypatch.setattr(parallel, "DASK_CONNECT_TIMEOUT", "2s")
    with pytest.raises(ValueError, match="Dask scheduler") as e:
        LGPR(n_clusters=2, max_iter=2, dask_scheduler="tcp://127.0.0.1:9",
             init="cold").fit(*parallel_data)
    assert "\n" not in str(e.value)


def test_save_load_round_trip(tmp_path, serial_model, parallel_data):
    Q, _ = smooth_data(30, seed=6)
    save_model(tmp_path / "m", serial_model)
    loaded, _ = load_model(tmp_path / "m")
    _same_model(serial_model, loaded)
    for blend in (False, True):
        serial_model.blend = loaded.blend = blend
        m1, s1 = serial_model.predict(Q, return_std=True)
        m2, s2 = loaded.predict(Q, return_std=True)
        np.testing.assert_array_equal(m1, m2)
        np.testing.assert_array_equal(s1, s2)
    serial_model.blend = loaded.blend = False
    assert "output_scale" in serial_model.get_state()[0] and loaded.output_scale is True
    serial_model.output_scale = False  # the option itself is persisted
    try:
        save_model(tmp_path / "off", serial_model)
    finally:
        serial_model.output_scale = True
    off, _ = load_model(tmp_path / "off")
    assert off.output_scale is False
    np.testing.assert_array_equal(off.output_scale_, serial_model.output_scale_)
    m_on, s_on = loaded.predict(Q, return_std=True)
    m_off, s_off = off.predict(Q, return_std=True)
    np.testing.assert_array_equal(m_on, m_off)
    assert not np.allclose(s_on, s_off)


def test_older_model_files_load_with_unit_output_scale(serial_model):
    """A model saved before output_scale existed (no array, no parameter) predicts the plain
    std, as it did."""
    Q, _ = smooth_data(30, seed=6)
    arrays, meta = serial_model.get_state()
    params = serial_model.get_params()
    old_arrays = {k: v for k, v in arrays.items() if k != "output_scale"}
    old_params = {k: v for k, v in params.items() if k != "output_scale"}
    old = LGPR.from_state(old_params, old_arrays, meta)
    assert old.output_scale is True
    np.testing.assert_array_equal(old.output_scale_, np.ones_like(serial_model.output_scale_))
    assert not np.allclose(serial_model.output_scale_, 1.0)
    serial_model.output_scale = False
    try:
        m1, s1 = serial_model.predict(Q, return_std=True)
    finally:
        serial_model.output_scale = True
    m2, s2 = old.predict(Q, return_std=True)
    np.testing.assert_array_equal(m1, m2)
    np.testing.assert_array_equal(s1, s2)
    with pytest.raises(ValueError, match="output_scale"):
        LGPR.from_state(params, {**arrays, "output_scale": arrays["output_scale"][:, :1]}, meta)


def test_variance_cache_budget(serial_model):
    Q, _ = smooth_data(20, seed=7)
    _, want = serial_model.predict(Q, return_std=True)
    tiny = LGPR(**{**serial_model.get_params(), "variance_cache_mb": 0.0})
    arrays, meta = serial_model.get_state()
    tiny = LGPR.from_state(tiny.get_params(), arrays, meta)
    assert tiny.prepare_variance() == 0
    np.testing.assert_array_equal(tiny.predict(Q, return_std=True)[1], want)
    assert serial_model.prepare_variance() == serial_model.n_clusters_


@pytest.mark.parametrize("kw", [{"hyperparameters": "both"}, {"init": "hot"},
                                {"n_blend": 0}, {"blend_weights": "x"}])
def test_bad_parameters(kw, parallel_data):
    with pytest.raises(ValueError):
        LGPR(n_clusters=2, **kw).fit(*parallel_data)


def friction_like_data(n_slide: int = 450, n_free: int = 350, seed: int = 0):
    """Raw features as in the diagnosis' friction set: two regimes k-means separates. In
    the "sliding" one the smoothed-sign (tanh) column is constant up to 1e-15 noise, another is
    exactly constant and 40 rows are duplicated; in the other regime both columns vary."""
    rng = np.random.default_rng(seed)
    A = rng.standard_normal((n_slide, 6))
    A[:, :4] = 0.5 * A[:, :4] + 3.0
    A[:, 4] = 1.0 + 1e-15 * rng.standard_normal(n_slide)  # tanh(v / eps), saturated
    A[:, 5] = -1.3
    A[-40:] = A[:40]
    B = rng.standard_normal((n_free, 6))
    B[:, 4] = np.tanh(3.0 * B[:, 4])
    X = np.vstack([A, B])
    Y = np.column_stack([np.sin(X[:, 1]) + 0.3 * X[:, 4] * X[:, 2], np.cos(X[:, 3]) - 0.2 * X[:, 5],
                         0.5 * X[:, 2] * X[:, 1]])
    Y += 0.01 * rng.standard_normal(Y.shape)
    return X, Y


@pytest.mark.parametrize("init", ["warm", "cold"])
def test_cluster_with_constant_columns_fits(init):
    """Regression (benchmarks/diagnose/diagnose.md, "LGPR as the report model"): a cluster where a
    column is constant up to rounding (std ~1e-15) got length-scale bounds ~1e-14 and a garbage kernel
    matrix ("not positive definite at any start point" from the warm start, "even with jitter
    0.0001" at paper scale). Now the constant columns are harmless and no jitter is added."""
    X, Y = friction_like_data()
    Xq, Yq = friction_like_data(200, 200, seed=1)
    mu, sd = X.mean(axis=0), X.std(axis=0)  # normalised features, as LGPR expects
    X, Xq = (X - mu) / sd, (Xq - mu) / sd
    lg = LGPR(n_clusters=2, init=init, max_iter=30, n_hyperparameter_points=300,
              n_global_points=300).fit(X, Y)
    assert lg.n_clusters_ == 2
    np.testing.assert_array_equal(lg.jitter_, lg.jitter)  # no escalation needed
    slide = int(np.argmax(lg.centers_[:, 0]))
    rows = slice(lg.offsets_[slide], lg.offsets_[slide + 1])
    sx = lg.X_train_[rows].std(axis=0)
    assert sx[4] < 1e-13 and sx[5] < 1e-13  # the cluster really holds the constant columns
    ls = np.exp(lg.log_params_[slide][:, 5:7])
    assert np.all(ls > 0.1)  # unit scale, not 1e-14: a query off by rounding is not "far"
    mean, std = lg.predict(Xq, return_std=True)
    assert np.all(np.isfinite(mean)) and np.all(std > 0)
    assert np.all(((mean - Yq) ** 2).mean(0) / Yq.var(0) < 0.01)


def test_cluster_failure_is_one_line_naming_the_cluster(monkeypatch):
    from littledog_mlsim.models.gp import NotPositiveDefiniteError

    def broken(*a, **k):
        raise NotPositiveDefiniteError("GP kernel matrix (300 points): reason\nsecond line")

    X, Y = friction_like_data()
    monkeypatch.setattr(lgpr, "fit_gp_hyperparameters", broken)
    with pytest.raises(NotPositiveDefiniteError, match=r"LGPR cluster \d \(\d+ points, "
                       r"hyperparameters on 300, cold start\): GP kernel matrix .*reason") as e:
        LGPR(n_clusters=2, init="cold", n_hyperparameter_points=300).fit(X, Y)
    assert "\n" not in str(e.value)
    with pytest.raises(NotPositiveDefiniteError, match="LGPR global GP of the warm start") as e:
        LGPR(n_clusters=2, init="warm", n_global_points=100).fit(X, Y)
    assert "\n" not in str(e.value)


def test_float32_variance_factors_keep_the_mean_and_bound_the_std_change():
    """``prepare_variance(dtype="float32")``: packed factors (half the square's bytes); the mean
    bit for bit, the std within the float32 solve's rounding (relative to the prior variance),
    for one query and for many; back to float64: the std as before.
    ``cluster_rows`` partitions fit's rows."""
    X, Y = smooth_data(400, seed=6)
    Q, _ = smooth_data(50, seed=7)
    lg = LGPR(n_clusters=4, max_iter=10, n_hyperparameter_points=60).fit(X, Y)
    rows = lg.cluster_rows()
    np.testing.assert_array_equal(np.sort(np.concatenate(rows)), np.arange(400))
    assert all(np.all(lg.nearest_cluster(X[r]) >= 0) for r in rows)
    m64, s64 = lg.predict(Q, return_std=True)
    m1, s1 = lg.predict(Q[:1], return_std=True)
    assert lg.prepare_variance(dtype="float32") == lg.n_clusters_
    assert all(f[0].dtype == np.float32 and f[0].ndim == 1 for f in lg._chol.values())
    assert lg._chol_bytes == sum(4 * len(r) * (len(r) + 1) // 2 for r in rows)   # packed
    m32, s32 = lg.predict(Q, return_std=True)
    np.testing.assert_array_equal(m32, m64)
    np.testing.assert_array_equal(lg.predict(Q[:1], return_std=True)[0], m1)
    np.testing.assert_array_equal(lg.predict(Q[:1], return_std=True)[1], s32[:1])
    prior = lg._prior_var[lg.nearest_cluster(Q)] * lg._variance_units(lg.nearest_cluster(Q))
    assert np.all(np.abs(s32 ** 2 - s64 ** 2) <= 1e-4 * prior)
    assert not np.array_equal(s32, s64)
    lg.prepare_variance()
    np.testing.assert_array_equal(lg.predict(Q, return_std=True)[1], s64)
    with pytest.raises(ValueError):
        lg.prepare_variance(dtype="float16")


def test_batch_mean_is_the_per_cluster_loop_bit_for_bit():
    """The batched mean (``LGPR._batch_mean``: the queries' scaling and output units over the
    whole batch, the kernel rows' elementwise steps compiled, one exp) equals the per-cluster
    loop bit for bit: on batches of 2 to 300 rows over every cluster, with repeated rows, a row
    far outside the data and a NaN row (NaN out, as before); the mean with the std (the loop)
    is the same; one row takes the single-cluster path, equal to rounding."""
    rng = np.random.default_rng(11)
    d = 45
    X = rng.standard_normal((600, d))
    Y = np.column_stack([np.sin(X[:, 0]) + 0.3 * X[:, 1] * X[:, 2], np.cos(X[:, 3]),
                         0.2 * X[:, 4] ** 2, X[:, 5] - X[:, 6]])
    lg = LGPR(n_clusters=6, max_iter=3, n_hyperparameter_points=40).fit(X, Y)
    assert lg._stacked is not None
    Q = rng.standard_normal((300, d))
    Q[7] = Q[3]
    Q[11] = 40.0
    Q[20, 5] = np.nan
    assert len(np.unique(lg.nearest_cluster(np.nan_to_num(Q)))) == lg.n_clusters_
    stacked = lg._stacked
    means = {}
    for n in (2, 3, 17, 64, 300):
        got = lg.predict(Q[:n])
        lg._stacked = None                       # the per-cluster loop
        want = lg.predict(Q[:n])
        lg._stacked = stacked
        np.testing.assert_array_equal(got, want)
        np.testing.assert_array_equal(got, lg.predict(Q[:n], return_std=True)[0])
        means[n] = got
    assert np.isnan(got[20]).all() and np.isfinite(np.delete(got, 20, axis=0)).all()
    # one row is the single-cluster path: a GEMM over one row may round its last bits
    # differently from one over several (as before)
    np.testing.assert_allclose(lg.predict(Q[:1]), got[:1], rtol=1e-9, atol=1e-12)
    # a batch above the cap takes the loop (the batched mean holds all its kernel rows)
    cap = lgpr.BATCH_MEAN_MAX_ROWS
    try:
        lgpr.BATCH_MEAN_MAX_ROWS = 16

        def refuse(*args):
            raise AssertionError("the batched mean ran above the cap")
        lg._batch_mean = refuse
        np.testing.assert_array_equal(lg.predict(Q[:64]), means[64])
    finally:
        lgpr.BATCH_MEAN_MAX_ROWS = cap
        del lg._batch_mean
