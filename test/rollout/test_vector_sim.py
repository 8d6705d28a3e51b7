"""The batched learned simulator (``rollout/vector_sim.py``) and the gate's shortcut.

References, each independent of the code under test: the rollout loop as it was before it ran
on the batched simulator (copied below, frozen), ``LearnedSimulator`` (sim_node's step) with the
shortcut off, a robot stepped alone, and ``integrate_path`` for the pose. Models: LGPR (the
clustered model the shortcut needs) and LR on synthetic moves, a model with a command delay
(a FeatureHistory), and a gate radius at the median of the predictions' distances so that both
the shortcut and the exact search run.
"""
from __future__ import annotations

import numpy as np
import pytest
from synthetic import make_recording

from littledog_mlsim.data.dataset import integrate_path
from littledog_mlsim.diagnose import measured_robot_features
from littledog_mlsim.layout import N_FEATURE, N_STATE
from littledog_mlsim.models.features import CommandLag, FeatureSet
from littledog_mlsim.models.lgpr import LGPR
from littledog_mlsim.models.lr import LinearRegression
from littledog_mlsim.models.onestep import OneStepModel
from littledog_mlsim.projection import NoProjection
from littledog_mlsim.rollout.learned_sim import LearnedSimulator
from littledog_mlsim.rollout.simulate import _predict, model_feature_set, prepare_test_move, rollout
from littledog_mlsim.rollout.vector_sim import VectorLearnedSimulator


def rollout_before(model, s0, actions, projection=None, return_std=False, pose0=None):
    """``rollout.simulate.rollout`` as it was before it ran on VectorLearnedSimulator (frozen
    copy of its loop: the reference for "outputs unchanged")."""
    projection = NoProjection() if projection is None else projection
    s = np.asarray(s0, dtype=np.float64)
    u = np.asarray(actions, dtype=np.float64)
    single = s.ndim == 1
    if single:
        s, u = s[None], u[None]
    B, T = u.shape[:2]
    out = np.full((B, T, N_STATE), np.nan)
    std_out = np.full((B, T, N_STATE), np.nan) if return_std else None
    fs = model_feature_set(model)
    history = None
    if fs is not None:
        if pose0 is not None:
            pose0 = np.asarray(pose0, dtype=np.float64).reshape(-1, 3)
        history = fs.history(s, pose0)
    X = np.empty((B, N_FEATURE))
    X[:, :N_STATE] = s
    alive = np.isfinite(s).all(axis=1)
    with np.errstate(over="ignore", invalid="ignore"):
        for t in range(T):
            idx = np.flatnonzero(alive)
            if idx.size == 0:
                break
            if history is None:
                X[:, N_STATE:] = u[:, t]
                Xa = X if idx.size == B else X[idx]
            else:
                Xh = history.features(u[:, t])
                Xa = Xh if idx.size == B else Xh[idx]
            mean, std = _predict(model, Xa, return_std)
            nxt = projection(mean)
            out[idx, t] = nxt
            if return_std:
                std_out[idx, t] = std
            X[idx, :N_STATE] = nxt
            alive[idx] = np.isfinite(nxt).all(axis=1)
            if history is not None:
                s_next = np.full((B, N_STATE), np.nan)
                s_next[idx] = nxt
                history.push(s_next)
    if single:
        out = out[0]
        std_out = std_out[0] if return_std else None
    return (out, std_out) if return_std else out


@pytest.fixture(scope="module")
def moves():
    return [make_recording(f"{t}_0{i}", n=120, yaw0=2.9 - i, yaw_rate=0.6 + 0.3 * i, seed=i)
            for i, t in enumerate(["F", "FL", "BL", "S", "F"])]


@pytest.fixture(scope="module")
def lgpr(moves):
    X, Y, _ = FeatureSet().features_responses(moves[:3])
    return OneStepModel.fit(LGPR(n_clusters=4, max_iter=8, n_global_points=150,
                                 n_hyperparameter_points=60), X, Y)


@pytest.fixture(scope="module")
def tests(moves):
    return [prepare_test_move(m) for m in moves[3:]]


def _batch(tests, n):
    pick = [tests[i % len(tests)] for i in range(n)]
    T = min(m.n_steps for m in pick)
    s0 = np.stack([m.s0 for m in pick])
    u = np.stack([m.actions[:T] for m in pick])
    pose0 = np.array([[m.pose0.x0, m.pose0.y0, m.pose0.yaw0] for m in pick])
    return s0, u, pose0


def _median_radius(model, tests) -> float:
    """A gate radius at the median distance of the plain rollout's predictions: half the steps
    inside the gate (the shortcut), half outside (the exact search)."""
    s0, u, _ = _batch(tests, 2)
    probe = model.projection("alpha", 0.5)
    states = rollout(model, s0, u[:, :60], probe)
    X = np.concatenate([states[:, :-1], u[:, 1:60]], axis=2).reshape(-1, N_FEATURE)
    return float(np.median(probe.distance(model.predict(X))))


def test_lgpr_has_state_clusters_lr_and_subsets_have_none(lgpr, moves):
    groups, label = lgpr.state_clusters()
    assert np.array_equal(np.sort(np.concatenate(groups)), np.arange(lgpr.train_states.shape[0]))
    X, Y, _ = FeatureSet().features_responses(moves[:3])
    assert np.mean(label(X) == lgpr.estimator.nearest_cluster(
        lgpr.feature_normalizer.transform(X))) > 0.99
    assert OneStepModel.fit(LinearRegression(), X, Y).state_clusters() is None
    sub = OneStepModel.fit(LGPR(n_clusters=2, max_iter=3, n_global_points=100,
                                n_hyperparameter_points=40), X[::2], Y[::2], train_states=Y)
    assert sub.state_clusters() is None            # fitted rows are not the TrainPool states


@pytest.mark.parametrize("return_std", [False, True])
def test_rollout_is_unchanged_lgpr_gated(lgpr, tests, return_std):
    r = _median_radius(lgpr, tests)
    proj = lgpr.projection("alpha", 0.5, radius=r)
    s0, u, pose0 = _batch(tests, 5)
    new = rollout(lgpr, s0, u, proj, return_std=return_std, pose0=pose0)
    old = rollout_before(lgpr, s0, u, proj, return_std=return_std, pose0=pose0)
    for a, b in zip(new if return_std else [new], old if return_std else [old]):
        np.testing.assert_array_equal(a, b)


class Diverging:
    """The model, except that its 30th prediction of the last row is infinite."""

    supports_std = True

    def __init__(self, model) -> None:
        self.model, self.feature_set, self.calls = model, model.feature_set, 0

    def predict(self, X, return_std=False):
        self.calls += 1
        mean, std = self.model.predict(X, return_std=True)
        if self.calls == 30:
            mean[-1, 3] = np.inf
        return (mean, std) if return_std else mean


@pytest.mark.parametrize("kind", ["none", "bound", "alpha"])
def test_rollout_is_unchanged_lr_with_a_command_lag_and_divergence(moves, tests, kind):
    fs = measured_robot_features().with_augmentation(CommandLag(lag=2))
    X, Y, _ = fs.features_responses(moves[:3])
    model = OneStepModel.fit(LinearRegression(), X, Y, feature_set=fs)
    s0, u, pose0 = _batch(tests, 3)
    s0[1, 0] = np.nan                               # one robot never runs
    proj = model.projection(kind, 0.5) if kind != "none" else None
    new, new_std = rollout(Diverging(model), s0, u, proj, return_std=True, pose0=pose0)
    old, old_std = rollout_before(Diverging(model), s0, u, proj, return_std=True, pose0=pose0)
    np.testing.assert_array_equal(new, old)
    np.testing.assert_array_equal(new_std, old_std)
    assert np.isnan(new[1]).all() and np.isnan(new[2, 29:]).all() and np.isfinite(new[2, :29]).all()
    assert np.isfinite(new[0]).all()


def test_one_robot_is_sim_nodes_step_bit_for_bit(lgpr, tests):
    """N = 1: the states (and std) of LearnedSimulator, whose shortcut is off here; the pose as
    integrate_path gives it."""
    r = _median_radius(lgpr, tests)
    proj = lgpr.projection("alpha", 0.5, radius=r)
    m = tests[0]
    pose0 = np.array([m.pose0.x0, m.pose0.y0, m.pose0.yaw0])
    ref = LearnedSimulator(lgpr, proj, m.s0, pose0, use_variance=True, trust_radius=r,
                           gate_shortcut=False)
    vec = VectorLearnedSimulator(lgpr, proj, m.s0, pose0, use_variance=True, trust_radius=r,
                                 num_envs=1)
    assert vec._candidates is not None and ref._candidates is None
    states, flags = [], []
    for u in m.actions:
        assert ref.step(u)
        vec.step(u[None])
        np.testing.assert_array_equal(vec.states[0], ref.state)
        np.testing.assert_allclose(vec.pose[0, :2], ref.position[:2], rtol=0, atol=1e-12)
        assert vec.extrapolating[0] == ref.extrapolating
        assert vec.nn_distance[0] >= ref.nn_distance * (1 - 1e-12)   # an upper bound ...
        if not ref.extrapolating:
            assert vec.nn_distance[0] <= r                              # ... inside the gate
        else:
            assert vec.nn_distance[0] == ref.nn_distance                # exact outside
        states.append(ref.state)
        flags.append(ref.extrapolating)
    assert 0 < np.mean(flags) < 1                   # both paths ran
    path = integrate_path(np.array(states), *m.pose0)
    np.testing.assert_allclose(vec.pose[0], path[-1], rtol=0, atol=1e-12)


def test_a_robot_in_a_batch_gets_its_own_states(lgpr, tests):
    """Each of N robots against itself stepped alone: equal up to the model's GEMM rounding
    (not bit for bit: a product over N rows may round differently from one over one row)."""
    r = _median_radius(lgpr, tests)
    proj = lgpr.projection("alpha", 0.5, radius=r)
    s0, u, pose0 = _batch(tests, 6)
    vec = VectorLearnedSimulator(lgpr, proj, s0, pose0, use_variance=True)
    out = np.stack([vec.step(u[:, t]) for t in range(u.shape[1])], axis=1)
    for i in range(3):
        alone = rollout(lgpr, s0[i], u[i], proj)
        np.testing.assert_allclose(out[i], alone, rtol=1e-9, atol=1e-9)


def test_reset_some_robots_and_the_shortcut_changes_no_state(lgpr, tests):
    r = _median_radius(lgpr, tests)
    proj = lgpr.projection("alpha", 0.5, radius=r)
    s0, u, pose0 = _batch(tests, 4)
    fast = VectorLearnedSimulator(lgpr, proj, s0, pose0, trust_radius=r)
    slow = VectorLearnedSimulator(lgpr, proj, s0, pose0, trust_radius=r, gate_shortcut=False)
    for t in range(40):
        if t == 25:
            mask = np.array([True, False, True, False])
            np.testing.assert_array_equal(fast.reset(mask)[mask], s0[mask])
            slow.reset(mask)
            assert list(fast.steps) == [0, 25, 0, 25]
            np.testing.assert_array_equal(fast.pose[mask], pose0[mask])
        np.testing.assert_array_equal(fast.step(u[:, t]), slow.step(u[:, t]))
        np.testing.assert_array_equal(fast.extrapolating, slow.extrapolating)
        np.testing.assert_array_equal(fast.pose, slow.pose)
    again = VectorLearnedSimulator(lgpr, proj, s0[0], pose0[0], num_envs=1)
    for t in range(15):
        again.step(u[:1, 25 + t])
    fresh_then = fast.states[0]
    np.testing.assert_allclose(fresh_then, again.states[0], rtol=1e-9, atol=1e-9)


def test_bad_inputs(lgpr, tests):
    s0, u, _ = _batch(tests, 2)
    sim = VectorLearnedSimulator(lgpr, None, s0)
    with pytest.raises(ValueError):
        sim.step(u[0, :1])
    with pytest.raises(ValueError):
        sim.step(np.full((2, 12), np.nan))
    with pytest.raises(ValueError):
        sim.reset(np.ones(3, dtype=bool))
    with pytest.raises(ValueError):
        VectorLearnedSimulator(lgpr, None, np.zeros((2, 5)))


def test_sim_nodes_step_mean_is_bit_for_bit_the_exact_search_and_float64_std(lgpr, tests):
    """sim_node's step as it is now (gate shortcut, float32 std factors) against the step as it
    was (exact search, float64 factors): the same states and extrapolation flags bit for bit;
    the covariances equal up to the float32 solve's rounding, which is relative to the prior
    variance: a few % of a variance 1e-4 of the prior, as here (docs/simulator.md)."""
    import copy
    r = _median_radius(lgpr, tests)
    fast_model, exact_model = copy.deepcopy(lgpr), copy.deepcopy(lgpr)
    fast_model.prepare(return_std=True, variance_dtype="float32")
    exact_model.prepare(return_std=True)
    m = tests[1]
    pose0 = np.array([m.pose0.x0, m.pose0.y0, m.pose0.yaw0])
    fast = LearnedSimulator(fast_model, fast_model.projection("alpha", 0.5, radius=r), m.s0,
                            pose0, use_variance=True, trust_radius=r)
    exact = LearnedSimulator(exact_model, exact_model.projection("alpha", 0.5, radius=r), m.s0,
                             pose0, use_variance=True, trust_radius=r, gate_shortcut=False)
    assert fast._candidates is not None
    flags = []
    for u in m.actions:
        assert fast.step(u) and exact.step(u)
        np.testing.assert_array_equal(fast.state, exact.state)
        np.testing.assert_array_equal(fast.position, exact.position)
        assert fast.extrapolating == exact.extrapolating
        np.testing.assert_allclose(fast.twist_covariance, exact.twist_covariance, rtol=0.1,
                                   atol=0)
        flags.append(exact.extrapolating)
    assert 0 < np.mean(flags) < 1
