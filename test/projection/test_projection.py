"""The projections (none, BOUND, alpha-PROJ): the limits every kind keeps, the kinds against
hand-computed references and a naive nearest-neighbour loop, their array storage and refusals.
"""
from __future__ import annotations

import numpy as np
import pytest

from littledog_mlsim.layout import JOINT_LOWER, JOINT_UPPER, N_STATE, S
from littledog_mlsim.projection import NoProjection, Projection, enforce_limits, make_projection
from synthetic import clustered_points, naive_nearest, random_states


def test_enforce_limits_clips_joints_and_wraps_deltas_only_when_needed():
    rng = np.random.default_rng(5)
    s = 0.1 * rng.standard_normal((6, N_STATE))
    s[0, S.q] = JOINT_UPPER + 1.0
    s[1, S.q] = JOINT_LOWER - 1.0
    s[2, S.d_rpy] = [3.5, -np.pi, -4.0]
    s[3, S.d_rpy] = [np.pi, 2 * np.pi + 0.25, -7.0]
    out = enforce_limits(s)
    np.testing.assert_array_equal(out[0, S.q], JOINT_UPPER)
    np.testing.assert_array_equal(out[1, S.q], JOINT_LOWER)
    np.testing.assert_allclose(out[2, S.d_rpy], [3.5 - 2 * np.pi, np.pi, -4.0 + 2 * np.pi],
                               atol=1e-15)
    np.testing.assert_allclose(out[3, S.d_rpy], [np.pi, 0.25, -7.0 + 2 * np.pi], atol=1e-14)
    np.testing.assert_array_equal(out[4:], s[4:])          # in range: bit for bit
    assert out[3, S.d_rpy][0] == np.pi                        # pi itself stays pi


def test_alpha_zero_equals_none_and_alpha_one_gives_the_nearest_trainpool_state():
    rng = np.random.default_rng(6)
    train = random_states(400, seed=7)
    train[:, S.z_w] *= 0.01                       # unequal scales: the normalisation matters
    s = train[rng.choice(400, 50)] + 0.2 * rng.standard_normal((50, N_STATE))
    s[0, S.q] = JOINT_UPPER + 0.5                             # out-of-range values, too
    s[1, S.d_rpy] = 4.0
    none = NoProjection()(s)
    np.testing.assert_array_equal(make_projection("alpha", train, alpha=0.0)(s), none)
    sd = train.std(0)
    nearest = naive_nearest(train / sd, none / sd)
    one = make_projection("alpha", train, alpha=1.0)(s)
    np.testing.assert_array_equal(one, train[nearest])      # exactly TrainPool states
    half = make_projection("alpha", train, alpha=0.5)(s)
    np.testing.assert_allclose(half, 0.5 * none + 0.5 * train[nearest], rtol=0, atol=1e-15)
    # the normalised distance, not the raw one, chooses q (z_w has a 100x smaller scale)
    assert not np.array_equal(nearest, naive_nearest(train, none))


def test_bound_clips_to_the_trainpool_range():
    rng = np.random.default_rng(8)
    train = random_states(300, seed=9)
    lo = np.array([min(r[i] for r in train) for i in range(N_STATE)])   # by a loop
    hi = np.array([max(r[i] for r in train) for i in range(N_STATE)])
    s = 0.6 * rng.standard_normal((40, N_STATE))
    out = make_projection("bound", train)(s)
    expect = np.minimum(hi, np.maximum(s, lo))
    np.testing.assert_array_equal(out, expect)
    inside = (s >= lo) & (s <= hi)
    assert inside.any() and (~inside).any()
    np.testing.assert_array_equal(out[inside], s[inside])


def test_nonfinite_rows_become_nan_and_others_are_untouched():
    train = random_states(100, seed=10)
    s = train[:4] + 0.01
    s[1, 3] = np.inf
    s[2, 20] = np.nan
    for proj in (NoProjection(), make_projection("bound", train),
                 make_projection("alpha", train, 0.5)):
        out = proj(s)
        assert np.all(np.isnan(out[1])) and np.all(np.isnan(out[2]))
        np.testing.assert_array_equal(out[[0, 3]], proj(s[[0, 3]]))


def test_alpha_projection_default_search_equals_brute_force():
    train = clustered_points(9000, seed=26)
    train[:, S.q] = np.clip(train[:, S.q], JOINT_LOWER + 0.05, JOINT_UPPER - 0.05)
    train[:, S.d_rpy] = np.clip(train[:, S.d_rpy], -3.0, 3.0)
    rng = np.random.default_rng(27)
    s = train[rng.choice(9000, 66)] + 0.8 * train.std(0) * rng.standard_normal((66, N_STATE))
    auto = make_projection("alpha", train, alpha=0.5)
    assert auto.nn._resolve(auto.nn.method) == "pca"
    brute = make_projection("alpha", train, alpha=0.5, nn_method="brute")
    np.testing.assert_array_equal(auto.nearest(s), brute.nearest(s))
    np.testing.assert_array_equal(auto(s), brute(s))


def test_projection_round_trips_through_npz(tmp_path):
    train = random_states(200, seed=12)
    s = train[:10] + 0.3
    for proj in (NoProjection(), make_projection("bound", train),
                 make_projection("alpha", train, alpha=0.3)):
        path = tmp_path / f"{proj.kind}.npz"
        np.savez(path, other=np.arange(3), **proj.to_arrays(prefix="projection_"))
        with np.load(path, allow_pickle=False) as z:
            back = Projection.from_arrays(z, prefix="projection_")
        assert type(back) is type(proj) and back.describe() == proj.describe()
        np.testing.assert_array_equal(back(s), proj(s))
    arrays = make_projection("alpha", train).to_arrays()
    for broken, msg in [({**arrays, "kind": np.array("magic")}, "unknown kind"),
                        ({**arrays, "format_version": np.array(2)}, "format_version"),
                        ({k: v for k, v in arrays.items() if k != "train_states"}, "missing"),
                        ({**arrays, "scale": np.ones(5)}, "shape"),
                        ({**arrays, "alpha": np.array(1.5)}, "alpha")]:
        with pytest.raises(ValueError, match=msg):
            Projection.from_arrays(broken)


def test_make_projection_refuses_bad_arguments():
    train = random_states(20, seed=13)
    with pytest.raises(ValueError, match="alpha"):
        make_projection("alpha", train, alpha=1.5)
    with pytest.raises(ValueError, match="TrainPool"):
        make_projection("bound")
    with pytest.raises(ValueError, match="projection must be"):
        make_projection("clip", train)
    bad = train.copy()
    bad[3, 3] = np.nan
    with pytest.raises(ValueError, match="NaN"):
        make_projection("alpha", bad)
