"""Sequential rollout and its metrics (the projections themselves: ``test/projection/``).

References are independent of the code under test: an exact model that looks up the recorded
s_{t+1} (so a rollout must reproduce the recording and its odometry), a linear system stepped by a
plain loop, and small cases computed by hand.
"""
from __future__ import annotations

import json

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from littledog_mlsim.data.dataset import (
    InitialPose, actions_from_recording, features_responses, integrate_path, states_from_recording,
)
from littledog_mlsim.data.recording import MoveRecording
from littledog_mlsim.layout import (
    CONTROL_DT_NS, HOME_POSE, JOINT_LOWER, JOINT_UPPER, N_STATE, STATE_NAMES, S,
)
from littledog_mlsim.rollout.metrics import (
    element_abs_error, element_error_sum, nmse, nmse_at_horizons, rollout_metrics, xy_error,
)
from littledog_mlsim.projection import NoProjection, Projection, make_projection
from littledog_mlsim.rollout.simulate import (
    TestMove, prepare_test_move, prepare_test_moves, rollout, rollout_moves, step,
)
from synthetic import random_states

# ----------------------------------------------------------------------------- helpers


def make_recording(name: str, n: int, seed: int) -> MoveRecording:
    """A smooth synthetic move whose yaw crosses +-pi (orientation built with scipy)."""
    rng = np.random.default_rng(seed)
    t = np.arange(n + 1) * 0.01
    yaw = 3.0 + 0.9 * t + 0.05 * np.sin(3 * t)
    roll = 0.08 * np.sin(2 * np.pi * 1.3 * t + seed) + 0.03
    pitch = 0.06 * np.cos(2 * np.pi * 0.9 * t) - 0.02
    quat = Rotation.from_euler("ZYX", np.column_stack([yaw, pitch, roll])).as_quat()
    phase = rng.uniform(0, 2 * np.pi, 12)
    q = HOME_POSE + 0.2 * np.sin(2 * np.pi * 2.5 * t[:, None] + phase)
    dq = 0.2 * 2 * np.pi * 2.5 * np.cos(2 * np.pi * 2.5 * t[:, None] + phase)
    heading = yaw[:-1]
    step_xy = 0.003 * np.column_stack([np.cos(heading), np.sin(heading)])
    xy = np.vstack([[0.4 * seed, -0.2], [0.4 * seed, -0.2] + np.cumsum(step_xy, axis=0)])
    pos = np.column_stack([xy, 0.146 + 0.005 * np.sin(7 * t)])
    return MoveRecording(
        name=name, move_type=name.split("_")[0],
        stamps_ns=np.arange(n + 1, dtype=np.int64) * CONTROL_DT_NS,
        cmd=q[1:] + 0.01 * rng.standard_normal((n, 12)), q=q, dq=dq, position=pos,
        orientation=quat, linear_velocity=np.zeros((n + 1, 3)),
        angular_velocity=np.zeros((n + 1, 3)))


class LookupModel:
    """The exact one-step model of given recordings: returns the recorded s_{t+1} for (s_t, u_t).

    Rows it does not know raise KeyError; every call is logged.
    """

    def __init__(self, X: np.ndarray, Y: np.ndarray) -> None:
        self.table = {x.tobytes(): y for x, y in zip(X, Y)}
        self.calls: list[np.ndarray] = []

    def predict(self, X: np.ndarray, return_std: bool = False):
        X = np.asarray(X, dtype=np.float64)
        self.calls.append(X.copy())
        Y = np.array([self.table[x.tobytes()] for x in X])
        return (Y, np.full(Y.shape, 0.25)) if return_std else Y


class Affine:
    """s_{t+1} = [s_t, u_t] @ W + b, with a call log."""

    def __init__(self, W: np.ndarray, b: np.ndarray) -> None:
        self.W, self.b, self.calls = W, b, []

    def predict(self, X: np.ndarray, return_std: bool = False):
        X = np.asarray(X, dtype=np.float64)
        self.calls.append(X.copy())
        Y = X @ self.W + self.b
        return (Y, np.full(Y.shape, 0.1)) if return_std else Y


@pytest.fixture(scope="module")
def recordings() -> list[MoveRecording]:
    # two lengths: rollout_moves must batch moves of equal length together
    return [make_recording(f"F_{i:02d}", n=60 if i < 2 else 45, seed=i) for i in range(3)]


# ----------------------------------------------------------------------------- test moves


def test_prepare_test_move_slices_the_recording(recordings):
    rec = recordings[0]
    m = prepare_test_move(rec)
    s, u = states_from_recording(rec), actions_from_recording(rec)
    assert m.n_steps == 59 and m.name == "F_00" and m.move_type == "F"
    np.testing.assert_array_equal(m.s0, s[0])
    np.testing.assert_array_equal(m.actions, u[1:])
    np.testing.assert_array_equal(m.states, s[1:])
    np.testing.assert_array_equal(m.xy, rec.position[2:, :2])
    # the pose at measurement 1 integrates the true states to the recorded odometry
    path = integrate_path(m.states, *m.pose0)
    np.testing.assert_allclose(path[:, :2], m.xy, atol=1e-12)


# ----------------------------------------------------------------------------- rollout


@pytest.mark.parametrize("kind", ["none", "bound", "alpha1", "alpha05"])
def test_exact_model_reproduces_the_recording(recordings, kind):
    X, Y, _ = features_responses(recordings)
    model = LookupModel(X, Y)
    moves = prepare_test_moves(recordings)
    train = np.vstack([m.states for m in moves] + [m.s0[None] for m in moves])
    proj = {"none": NoProjection(), "bound": make_projection("bound", train),
            "alpha1": make_projection("alpha", train, alpha=1.0),
            "alpha05": make_projection("alpha", train, alpha=0.5)}[kind]
    preds = rollout_moves(model, moves, proj)
    for m, p in zip(moves, preds):
        np.testing.assert_array_equal(p, m.states)   # bit for bit: states are TrainPool states
    # one predict call per step for all moves of a length: 59 steps (2 moves) + 44 steps (1 move)
    assert [c.shape[0] for c in model.calls] == [2] * 59 + [1] * 44
    res = rollout_metrics(moves, preds, projection=proj)
    assert res["final_xy_error_m"] < 1e-9
    assert max(res["xy_error_vs_time"]["p90"]) < 1e-9
    assert res["n_nan_moves"] == 0 and res["nan_moves"] == []
    assert all(v == 0.0 for v in res["element_error_sum_mean"].values())
    for h in res["nmse_at_horizon"].values():
        assert all(v == 0.0 for v in h["nmse"].values())
    json.dumps(res, allow_nan=False)


def test_rollout_matches_a_plain_loop_of_a_fitted_linear_system():
    rng = np.random.default_rng(3)
    Q, _ = np.linalg.qr(rng.standard_normal((N_STATE, N_STATE)))
    A = 0.8 * Q                                     # stable
    Bu = 0.05 * rng.standard_normal((12, N_STATE))
    c = 0.01 * rng.standard_normal(N_STATE)
    Xtr = np.hstack([0.05 * rng.standard_normal((200, N_STATE)), rng.standard_normal((200, 12))])
    Ytr = Xtr[:, :N_STATE] @ A.T + Xtr[:, N_STATE:] @ Bu + c
    W, *_ = np.linalg.lstsq(np.c_[Xtr, np.ones(200)], Ytr, rcond=None)   # LR by lstsq
    model = Affine(W[:-1], W[-1])
    s0 = 0.05 * rng.standard_normal((3, N_STATE))
    u = 0.1 * rng.standard_normal((3, 40, 12))
    out, std = rollout(model, s0, u, NoProjection(), return_std=True)
    ref = np.empty_like(out)
    for b in range(3):
        s = s0[b]
        for t in range(40):
            s = A @ s + u[b, t] @ Bu + c
            ref[b, t] = s
    np.testing.assert_allclose(out, ref, atol=1e-10)
    assert np.all(std == 0.1)
    assert len(model.calls) == 40 and all(c.shape == (3, 45) for c in model.calls)
    # single move and single step agree with the batch (up to BLAS rounding of other shapes)
    np.testing.assert_allclose(rollout(model, s0[1], u[1]), out[1], rtol=1e-12, atol=1e-16)
    np.testing.assert_allclose(step(model, s0[1], u[1, 0]), out[1, 0], rtol=1e-12, atol=1e-16)
    nxt, sd = step(model, s0[:2], u[:2, 0], return_std=True)
    np.testing.assert_allclose(nxt, out[:2, 0], rtol=1e-12, atol=1e-16)
    assert sd.shape == (2, N_STATE)


def test_diverging_model_blows_up_without_projection_only():
    train = random_states(500, seed=4)
    W = np.vstack([1.1 * np.eye(N_STATE), np.zeros((12, N_STATE))])
    model = Affine(W, np.zeros(N_STATE))
    s0 = train[:4] + 0.05
    u = np.zeros((4, 300, 12))
    free = rollout(model, s0, u, make_projection("none"))
    assert np.all(np.isfinite(free)) and np.abs(free[:, -1, S.z_w]).max() > 1e6
    # even `none` keeps the joint limits and wrapped angle deltas
    assert np.all(free[..., S.q] >= JOINT_LOWER) and np.all(free[..., S.q] <= JOINT_UPPER)
    assert np.all(np.abs(free[..., S.d_rpy]) <= np.pi)
    bound = rollout(model, s0, u, make_projection("bound", train))
    assert np.all(bound >= train.min(0)) and np.all(bound <= train.max(0))
    alpha = rollout(model, s0, u, make_projection("alpha", train, alpha=0.5))
    # |s'| <= 0.55 |s| + 0.5 |q|  =>  |s| <= max(|s0|, |q| / 0.9)
    lim = max(np.abs(s0).max(), np.abs(train).max() / 0.9)
    assert np.abs(alpha).max() <= lim + 1e-12


# ----------------------------------------------------------------------------- metrics


def test_one_step_nmse_by_hand():
    Yt = np.tile(np.array([[0.0], [2.0], [0.0], [2.0]]), (1, N_STATE)) + np.arange(N_STATE)
    Yt[:, 5] = 7.0                                           # constant: zero variance
    Yp = Yt.copy()
    Yp[:, 0] += [1.0, 0.0, 0.0, -1.0]                        # MSE 0.5, variance 1
    Yp[:, 9] += 2.0                                          # MSE 4
    out = nmse(Yt, Yp)
    assert list(out) == list(STATE_NAMES)
    assert out["z_w"] == 0.5 and out[STATE_NAMES[9]] == 4.0 and out["dx_b"] == 0.0
    assert np.isnan(out["pitch"])
    assert nmse(Yt, Yp, var=np.full(N_STATE, 2.0))["z_w"] == 0.25


def _straight_move(name: str, xy_pred_body: tuple[float, float]) -> tuple[TestMove, np.ndarray]:
    """Three steps heading +y (yaw pi/2) at 0.1 m/step; the prediction uses body d_b given."""
    states = np.zeros((3, N_STATE))
    states[:, S.d_b] = [0.1, 0.0, 0.0]
    states[:, S.z_w] = 0.15
    pred = states.copy()
    pred[:, 1:3] = xy_pred_body
    move = TestMove(name=name, move_type=name[:1], s0=states[0], actions=np.zeros((3, 12)),
                    states=states, pose0=InitialPose(1.0, 2.0, np.pi / 2, np.zeros(2)),
                    xy=np.array([[1.0, 2.1], [1.0, 2.2], [1.0, 2.3]]))
    return move, pred


def test_sequential_metrics_by_hand():
    a, pa = _straight_move("F_00", (0.1, 0.05))   # body y = world -x: (-0.05, +0.1) per step
    b, pb = _straight_move("B_00", (0.13, 0.0))   # 0.03 m/step too far along +y
    np.testing.assert_allclose(xy_error(integrate_path(pa, *a.pose0), a.xy), [0.05, 0.1, 0.15],
                               atol=1e-12)
    np.testing.assert_allclose(element_abs_error(a.states, pa)[:, 2], [0.05] * 3, atol=1e-15)
    assert element_error_sum(b.states, pb)[1] == pytest.approx(0.09, abs=1e-12)
    res = rollout_metrics([a, b], [pa, pb])
    assert res["final_xy_error_m"] == pytest.approx(0.12, abs=1e-12)
    assert res["final_xy_error_m_median"] == pytest.approx(0.12, abs=1e-12)
    assert res["final_xy_error_m_p90"] == pytest.approx(0.09 + 0.9 * 0.06, abs=1e-12)
    vt = res["xy_error_vs_time"]
    assert vt["step"] == [1, 2, 3] and vt["time_s"] == [0.01, 0.02, 0.03]
    np.testing.assert_allclose(vt["mean"], [0.04, 0.08, 0.12], atol=1e-12)
    assert vt["n_moves"] == [2, 2, 2] and vt["n_nan"] == [0, 0, 0]
    pm = {m["name"]: m for m in res["per_move"]}
    assert pm["F_00"]["final_xy_error_m"] == pytest.approx(0.15, abs=1e-12)
    assert pm["F_00"]["element_error_sum"]["dy_b"] == pytest.approx(0.15, abs=1e-12)
    assert pm["B_00"]["element_error_sum"]["dx_b"] == pytest.approx(0.09, abs=1e-12)
    assert pm["F_00"]["move_type"] == "F" and not pm["F_00"]["nan"]
    assert res["element_error_sum_mean"]["dx_b"] == pytest.approx(0.045, abs=1e-12)
    assert res["by_move_type"]["B"]["final_xy_error_m"] == pytest.approx(0.09, abs=1e-12)
    # horizons: 1 and 2 steps, and 4 s clipped to the 3 steps there are
    h = nmse_at_horizons([a, b], [pa, pb], horizons_s=(0.01, 0.02, 4.0),
                         state_var=np.ones(N_STATE))
    assert list(h) == ["0.01", "0.02", "4"]
    assert h["0.01"]["steps"] == 1 and h["4"]["steps"] == 3 and h["4"]["time_s"] == 0.03
    assert h["0.01"]["nmse"]["dx_b"] == pytest.approx(0.03 ** 2 / 2, abs=1e-15)
    assert h["0.02"]["nmse"]["dy_b"] == pytest.approx(0.05 ** 2 / 2, abs=1e-15)
    # the TestPool variance of dx_b is zero (always 0.1): nMSE undefined -> None
    assert res["nmse_variance"] == "TestPool"
    assert res["nmse_at_horizon"]["0.1"]["nmse"]["dx_b"] is None
    json.dumps(res, allow_nan=False)


def test_nan_in_a_rollout_is_detected_and_never_averaged(recordings):
    X, Y, idx = features_responses(recordings)
    Y = Y.copy()
    first = np.flatnonzero(idx == 1)[0]
    Y[first + 4] = np.nan                         # move 1 predicts NaN at its 5th step
    model = LookupModel(X, Y)
    moves = prepare_test_moves(recordings)
    bound = make_projection("bound", np.vstack([m.states for m in moves]))
    preds = rollout_moves(model, moves, bound)
    assert np.all(np.isnan(preds[1][4:])) and np.all(np.isfinite(preds[1][:4]))
    np.testing.assert_array_equal(preds[0], moves[0].states)
    assert all(np.all(np.isfinite(c)) for c in model.calls)   # NaN rows are not fed back
    res = rollout_metrics(moves, preds)
    assert res["n_nan_moves"] == 1 and res["nan_moves"] == ["F_01"]
    pm = res["per_move"][1]
    assert pm["nan"] and pm["first_nan_step"] == 5 and pm["final_xy_error_m"] is None
    assert pm["element_error_sum"]["z_w"] is None
    assert res["final_xy_error_m"] is None                    # not averaged over the others
    assert res["final_xy_error_m_finite"] < 1e-9
    vt = res["xy_error_vs_time"]
    assert vt["n_nan"][3] == 0 and vt["n_nan"][4] == 1
    assert vt["mean"][3] is not None and vt["mean"][4] is None
    assert vt["median"][4] is not None and vt["median"][4] < 1e-9   # 2 of 3 moves exact
    assert vt["p90"][4] is None
    assert res["nmse_at_horizon"]["0.1"]["n_nan_moves"] == 1
    assert res["nmse_at_horizon"]["0.1"]["nmse"]["z_w"] is None
    assert res["element_error_sum_mean"]["z_w"] is None
    json.dumps(res, allow_nan=False)


def test_overflowing_model_turns_nan_not_inf():
    W = np.vstack([1e100 * np.eye(N_STATE), np.zeros((12, N_STATE))])
    model = Affine(W, np.zeros(N_STATE))
    train = random_states(50, seed=14)
    out = rollout(model, train[:2] + 0.5, np.zeros((2, 10, 12)), NoProjection())
    bad = ~np.isfinite(out).all(axis=2)
    assert bad[:, -1].all() and not bad[:, 0].any() and np.all(np.isnan(out[bad]))
    assert len(model.calls) == int((~bad).all(axis=0).sum()) + 1   # stops once all are NaN
    bounded = rollout(model, train[:2] + 0.5, np.zeros((2, 10, 12)),
                      make_projection("bound", train))
    assert np.all(np.isfinite(bounded))
