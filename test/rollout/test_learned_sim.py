"""The learned simulator's stepping object (``rollout/learned_sim.py``, what sim_node serves)
against the core rollout, without ROS.

Reference: ``rollout.simulate.rollout`` of the same model from the same state and pose (its own
batch FeatureHistory), and ``integrate_path`` for the pose. Models: LR on synthetic moves, with
the paper's 45 features and with the measured robot's features plus a command delay (what
``diagnose`` adds on delayed data), saved and loaded as sim_node loads them.
"""
from __future__ import annotations

import numpy as np
import pytest
from synthetic import make_recording

from littledog_mlsim.data.dataset import integrate_path
from littledog_mlsim.diagnose import measured_robot_features
from littledog_mlsim.layout import S
from littledog_mlsim.models.features import CommandLag, FeatureSet
from littledog_mlsim.models.lr import LinearRegression
from littledog_mlsim.models.onestep import OneStepModel
from littledog_mlsim.rollout.learned_sim import LearnedSimulator, model_has_variance
from littledog_mlsim.rollout.simulate import prepare_test_move, rollout

EFFECTS = measured_robot_features().with_augmentation(CommandLag(lag=2))


@pytest.fixture(scope="module")
def moves():
    return [make_recording(f"{t}_0{i}", n=120, yaw0=2.9 - i, yaw_rate=0.6 + 0.3 * i, seed=i)
            for i, t in enumerate(["F", "FL", "BL", "S"])]


@pytest.fixture(scope="module", params=["paper", "measured+command_lag"])
def model(request, moves, tmp_path_factory):
    fs = FeatureSet() if request.param == "paper" else EFFECTS
    X, Y, _ = fs.features_responses(moves[:3])
    path = tmp_path_factory.mktemp("model") / "m"
    OneStepModel.fit(LinearRegression(), X, Y, feature_set=fs).save(path)
    return OneStepModel.load(path)


def test_steps_equal_the_core_rollout_also_after_a_reset(model, moves):
    move = prepare_test_move(moves[3])
    pose0 = np.array([move.pose0.x0, move.pose0.y0, move.pose0.yaw0])
    proj = model.projection("bound")
    ref, ref_std = rollout(model, move.s0, move.actions, proj, return_std=True, pose0=pose0)
    assert np.all(np.isfinite(ref))
    assert model_has_variance(model)
    sim = LearnedSimulator(model, proj, move.s0, pose0, use_variance=True)
    assert (sim.feature_set is None) == model.feature_set.is_base
    # a few steps, a reset (the history starts again from s_0 and pose_0), then the whole move
    for u in move.actions[:7]:
        assert sim.step(u)
    sim.reset()
    np.testing.assert_array_equal(sim.state, move.s0)
    states, pos, var_z = [], [], []
    for u in move.actions:
        assert sim.step(u)
        states.append(sim.state)
        pos.append(sim.position)
        var_z.append(sim.pose_covariance[14])
    np.testing.assert_allclose(np.array(states), ref, rtol=0, atol=1e-12)
    np.testing.assert_allclose(np.array(var_z), ref_std[:, S.z_w] ** 2, rtol=1e-12, atol=0)
    path = integrate_path(ref, *move.pose0)
    np.testing.assert_allclose(np.array(pos)[:, :2], path[:, :2], rtol=0, atol=1e-12)
    assert sim.steps == move.n_steps


def test_a_refused_step_changes_nothing(model, moves):
    """A non-finite prediction is refused and leaves state and history as they were: the
    next steps still equal the rollout."""
    move = prepare_test_move(moves[3])
    pose0 = np.array([move.pose0.x0, move.pose0.y0, move.pose0.yaw0])
    proj = model.projection("bound")
    ref = rollout(model, move.s0, move.actions[:20], proj, pose0=pose0)
    sim = LearnedSimulator(model, proj, move.s0, pose0, use_variance=False)
    for t, u in enumerate(move.actions[:20]):
        if t in (3, 4):
            before = sim.state.copy()
            assert not sim.step(np.full(12, np.nan))
            np.testing.assert_array_equal(sim.state, before)
        assert sim.step(u)
        np.testing.assert_allclose(sim.state, ref[t], rtol=0, atol=1e-12)
    assert sim.pose_covariance is None and sim.steps == 20


def test_nn_distance_flag_and_covariance_inflation(moves):
    """nn_distance is the prediction's normalised distance to its nearest TrainPool state (a
    brute-force search here); beyond trust_radius the step is flagged and its variances are
    multiplied by (d / r)^2."""
    X, Y, _ = FeatureSet().features_responses(moves[:3])
    model = OneStepModel.fit(LinearRegression(), X, Y)
    move = prepare_test_move(moves[3])
    pose0 = np.array([move.pose0.x0, move.pose0.y0, move.pose0.yaw0])
    proj = model.projection("none")
    monitor = model.projection("alpha", 0.0)
    plain = LearnedSimulator(model, proj, move.s0, pose0, use_variance=True, monitor=monitor)
    P = model.train_states / monitor.scale
    ds = []
    for u in move.actions[:30]:
        x = np.r_[plain.state, u][None]
        pred = model.predict(x)[0]
        assert plain.step(u)
        ds.append(plain.nn_distance)
        brute = np.sqrt(((pred / monitor.scale - P) ** 2).sum(axis=1)).min()
        assert plain.nn_distance == pytest.approx(brute, rel=1e-9)
        assert not plain.extrapolating                     # trust_radius 0: never flagged
    r = float(np.median(ds))
    sim = LearnedSimulator(model, proj, move.s0, pose0, use_variance=True, trust_radius=r,
                           monitor=monitor)
    ref = LearnedSimulator(model, proj, move.s0, pose0, use_variance=True)
    for u, d in zip(move.actions[:30], ds):
        _, std = model.predict(np.r_[sim.state, u][None], return_std=True)
        assert sim.step(u) and ref.step(u)
        np.testing.assert_array_equal(sim.state, ref.state)   # the flag changes no state
        assert sim.extrapolating == (d > r)
        f = (d / r) ** 2 if d > r else 1.0
        assert sim.pose_covariance[14] == pytest.approx(std[0, S.z_w] ** 2 * f, rel=1e-12)
    st = sim.stats()
    assert st["extrapolating_steps"] == sum(d > r for d in ds)
    assert float(st["nn_distance_max"]) == pytest.approx(max(ds), abs=1e-3)
    assert sim.pose_covariance[0] > ref.pose_covariance[0]      # x variance grew faster
    assert sim.stats()["nn_distance_max"] == "nan"              # a new window, no step yet


def test_gated_projection_distance_is_the_search_distance(moves):
    """With alpha-PROJ the distance comes from the projection's own search: the same as a
    separate one, and the state is that of the plain rollout step."""
    X, Y, _ = FeatureSet().features_responses(moves[:3])
    model = OneStepModel.fit(LinearRegression(), X, Y)
    move = prepare_test_move(moves[3])
    gated = model.projection("alpha", 0.5, radius=0.5)
    ref = rollout(model, move.s0, move.actions[:20], gated)
    sim = LearnedSimulator(model, gated, move.s0, use_variance=False)
    for t, u in enumerate(move.actions[:20]):
        pred = model.predict(np.r_[sim.state, u][None])
        assert sim.step(u)
        np.testing.assert_array_equal(sim.state, ref[t])
        assert sim.nn_distance == pytest.approx(float(gated.distance(pred)[0]), rel=1e-12)


def test_single_pose_rotations_equal_the_vectorised_ones():
    from littledog_mlsim.rotations import rpy_to_matrix, rpy_to_matrix1, rpy_to_quat, rpy_to_quat1
    rpy = np.random.default_rng(0).uniform(-np.pi, np.pi, (200, 3))
    np.testing.assert_allclose(np.array([rpy_to_matrix1(*r) for r in rpy]), rpy_to_matrix(rpy),
                               rtol=0, atol=1e-15)
    np.testing.assert_allclose(np.array([rpy_to_quat1(*r) for r in rpy]), rpy_to_quat(rpy),
                               rtol=0, atol=1e-15)


def test_continue_from_swaps_the_model_and_keeps_the_robot(moves, tmp_path):
    """A swap (sim_node's ~/load_model): the new model's simulator takes over the robot where
    the old one left it, and from there steps exactly as the core's rollout of the new model
    started at that state and pose."""
    move = prepare_test_move(moves[3])
    pose0 = np.array([move.pose0.x0, move.pose0.y0, move.pose0.yaw0])
    models = []
    for k, n in enumerate((2, 3)):
        X, Y, _ = FeatureSet().features_responses(moves[:n])
        OneStepModel.fit(LinearRegression(), X, Y).save(tmp_path / f"m{k}")
        models.append(OneStepModel.load(tmp_path / f"m{k}"))
    old = LearnedSimulator(models[0], models[0].projection("bound"), move.s0, pose0)
    for u in move.actions[:10]:
        assert old.step(u)
    new = LearnedSimulator(models[1], models[1].projection("bound"), move.s0, [0.0, 0.0, 0.0])
    new.continue_from(old)
    for a in ("state", "position", "orientation", "linear_velocity", "angular_velocity",
              "pose_covariance"):
        np.testing.assert_array_equal(getattr(new, a), getattr(old, a), err_msg=a)
    assert new.steps == 10
    x, y, yaw = old._xy_yaw
    ref = rollout(models[1], old.state, move.actions[10:], models[1].projection("bound"),
                  pose0=np.array([x, y, yaw]))
    path = integrate_path(ref, x, y, yaw, old.state[S.roll_pitch])
    states, pos = [], []
    for u in move.actions[10:]:
        assert new.step(u)
        states.append(new.state)
        pos.append(new.position)
    np.testing.assert_allclose(np.array(states), ref, rtol=0, atol=1e-12)
    np.testing.assert_allclose(np.array(pos)[:, :2], path[:, :2], rtol=0, atol=1e-12)
    # a reset goes to the new simulator's own initial state and pose
    new.reset()
    np.testing.assert_array_equal(new.state, move.s0)
    np.testing.assert_array_equal(new.position[:2], [0.0, 0.0])


class _VaryingStd:
    """A model whose std changes with its input (LR's is constant) and that counts the calls
    asking for it: the wrapped LR's mean, std = 0.01 (1 + |first feature|)."""

    def __init__(self, model):
        self.model, self.std_calls = model, 0
        self.supports_std = True

    def __getattr__(self, name):
        return getattr(self.model, name)

    def predict(self, X, return_std=False):
        mean = self.model.predict(X)
        if not return_std:
            return mean
        self.std_calls += 1
        return mean, 0.01 * (1.0 + np.abs(X[:, :1])) * np.ones_like(mean)


def test_covariance_every_k_steps_holds_the_std_and_keeps_the_mean(moves):
    """covariance_every k: the states are bit for bit those of every step's std; the std is
    asked for on the first step and every k-th step after it (and again after a reset); a step
    between publishes the last computed variance, and the summed x variance grows by it."""
    X, Y, _ = FeatureSet().features_responses(moves[:3])
    base = OneStepModel.fit(LinearRegression(), X, Y)
    move = prepare_test_move(moves[3])
    pose0 = np.array([move.pose0.x0, move.pose0.y0, move.pose0.yaw0])
    proj = base.projection("bound")
    every, held = _VaryingStd(base), _VaryingStd(base)
    ref = LearnedSimulator(every, proj, move.s0, pose0, use_variance=True)
    sim = LearnedSimulator(held, proj, move.s0, pose0, use_variance=True, covariance_every=4)
    last = None
    for t, u in enumerate(move.actions[:30]):
        assert ref.step(u) and sim.step(u)
        np.testing.assert_array_equal(sim.state, ref.state)
        np.testing.assert_array_equal(sim.position, ref.position)
        if t % 4 == 0:
            np.testing.assert_array_equal(sim.twist_covariance, ref.twist_covariance)
            last = ref.twist_covariance.copy()
        else:
            np.testing.assert_array_equal(sim.twist_covariance, last)
            assert not np.array_equal(sim.twist_covariance, ref.twist_covariance)
    assert every.std_calls == 30 and held.std_calls == 8          # steps 0, 4, ..., 28
    assert sim.pose_covariance[0] > 0 and sim.pose_covariance[0] != ref.pose_covariance[0]
    sim.reset()
    held.std_calls = 0
    assert sim.step(move.actions[0]) and held.std_calls == 1       # a fresh std after a reset
    for bad in (0, 101, 2.5, True):
        with pytest.raises(ValueError, match="covariance_every"):
            LearnedSimulator(base, proj, move.s0, pose0, covariance_every=bad)
