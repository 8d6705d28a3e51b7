"""Gated alpha-PROJ (``radius``) and the leave-move-out radius, against plain loops.

References are computed independently of the code under test: a naive nearest-neighbour loop in
the normalised metric, the gate written out per row, a naive leave-move-out loop.
"""
from __future__ import annotations

import numpy as np
import pytest

from littledog_mlsim.layout import JOINT_LOWER, JOINT_UPPER, N_STATE, S
from littledog_mlsim.projection import (
    AlphaProjection, NoProjection, Projection, leave_move_out_distances, make_projection,
    radius_from_quantile,
)
from synthetic import random_states


def naive_distances(train: np.ndarray, s: np.ndarray) -> np.ndarray:
    sd = train.std(0)
    return np.array([np.sqrt(min((((x - p) / sd) ** 2).sum() for p in train)) for x in s])


def naive_gated(train: np.ndarray, s: np.ndarray, alpha: float, r: float) -> np.ndarray:
    sd = train.std(0)
    out = s.copy()
    for k, x in enumerate(s):
        d2 = [(((x - p) / sd) ** 2).sum() for p in train]
        q = train[int(np.argmin(d2))]
        d = float(np.sqrt(min(d2)))
        if d > r:
            # distance to q shrinks from d to r + (1 - alpha) (d - r), along s - q
            out[k] = q + (x - q) * (r + (1 - alpha) * (d - r)) / d
    return out


@pytest.fixture(scope="module")
def data():
    rng = np.random.default_rng(31)
    train = random_states(300, seed=32)
    train[:, S.z_w] *= 0.01                        # unequal scales: the normalisation matters
    s = train[rng.choice(300, 80)] + 0.1 * train.std(0) * rng.standard_normal((80, N_STATE))
    s[:, S.q] = np.clip(s[:, S.q], JOINT_LOWER + 0.01, JOINT_UPPER - 0.01)
    return train, NoProjection()(s)


def test_radius_zero_is_plain_alpha_bit_for_bit(data):
    train, s = data
    for alpha in (0.0, 0.3, 0.5, 1.0):
        plain = make_projection("alpha", train, alpha=alpha)
        gated0 = make_projection("alpha", train, alpha=alpha, radius=0.0)
        np.testing.assert_array_equal(gated0(s), plain(s))
        assert gated0.describe() == plain.describe()      # no radius entry at 0


@pytest.mark.parametrize("alpha", [0.25, 0.5, 1.0])
def test_gated_projection_equals_a_per_row_loop(data, alpha):
    train, s = data
    r = float(np.median(naive_distances(train, s)))      # half the rows inside, half outside
    proj = make_projection("alpha", train, alpha=alpha, radius=r)
    d = proj.distance(s)
    np.testing.assert_allclose(d, naive_distances(train, s), rtol=1e-12)
    inside = d <= r
    assert 30 < inside.sum() < 50                          # both branches exercised
    out = proj(s)
    ref = naive_gated(train, s, alpha, r)
    np.testing.assert_allclose(out, ref, rtol=0, atol=1e-13)
    np.testing.assert_array_equal(out[inside], s[inside])  # untouched, bit for bit
    # distance after the projection: r + (1 - alpha) (d - r) outside, to the same q
    i = proj.nearest(s)
    after = proj.distance(out, i)
    expect = np.where(inside, d, r + (1 - alpha) * (d - r))
    np.testing.assert_allclose(after, expect, rtol=1e-12, atol=1e-13)
    np.testing.assert_array_equal(proj.nearest(out[~inside]), i[~inside])


def test_gated_limits_small_and_large_radius(data):
    train, s = data
    none = s
    huge = make_projection("alpha", train, alpha=0.7, radius=1e6)
    np.testing.assert_array_equal(huge(s), none)          # nothing beyond a huge radius
    tiny = make_projection("alpha", train, alpha=0.7, radius=1e-9)
    plain = make_projection("alpha", train, alpha=0.7)
    np.testing.assert_allclose(tiny(s), plain(s), rtol=0, atol=1e-9)


def test_gated_projection_round_trips_and_refuses_bad_radii(tmp_path, data):
    train, s = data
    proj = make_projection("alpha", train, alpha=0.4, radius=0.8)
    path = tmp_path / "p.npz"
    np.savez(path, **proj.to_arrays(prefix="projection_"))
    with np.load(path, allow_pickle=False) as z:
        back = Projection.from_arrays(z, prefix="projection_")
    assert isinstance(back, AlphaProjection) and back.radius == 0.8
    assert back.describe() == proj.describe()
    np.testing.assert_array_equal(back(s), proj(s))
    # plain alpha-PROJ writes no radius (files as before the option) and reads back radius 0
    plain = make_projection("alpha", train, alpha=0.4).to_arrays()
    assert "radius" not in plain and Projection.from_arrays(plain).radius == 0.0
    with pytest.raises(ValueError, match="radius"):
        Projection.from_arrays({**proj.to_arrays(), "radius": np.array(-1.0)})
    for bad in (-0.1, np.inf, np.nan):
        with pytest.raises(ValueError, match="radius"):
            make_projection("alpha", train, radius=bad)
    with pytest.raises(ValueError, match="alpha projection only"):
        make_projection("bound", train, radius=1.0)


def test_nonfinite_rows_stay_nan_with_a_radius(data):
    train, s = data
    x = s[:4].copy()
    x[1, 5] = np.inf
    out = make_projection("alpha", train, alpha=0.5, radius=0.5)(x)
    assert np.all(np.isnan(out[1])) and np.all(np.isfinite(out[[0, 2, 3]]))


def test_leave_move_out_distances_equal_a_naive_loop():
    rng = np.random.default_rng(41)
    train = random_states(240, seed=42)
    train[:, S.z_w] *= 0.01
    groups = np.repeat(rng.permutation(6), 40)             # 6 moves, not in order
    sd = train.std(0)
    P = train / sd
    ref = np.array([min(np.sqrt(((P[i] - P[j]) ** 2).sum())
                        for j in range(240) if groups[j] != groups[i]) for i in range(240)])
    got = leave_move_out_distances(train, groups, block=17)
    np.testing.assert_allclose(got, ref, rtol=1e-12)
    # every 3rd state of each move, in the order of the states
    sub = np.sort(np.concatenate([np.flatnonzero(groups == m)[::3] for m in range(6)]))
    np.testing.assert_allclose(leave_move_out_distances(train, groups, every=3), ref[sub],
                               rtol=1e-12)
    assert radius_from_quantile(train, groups, 0.9, every=1) == pytest.approx(
        np.quantile(ref, 0.9), rel=1e-12)
    with pytest.raises(ValueError, match="two moves"):
        leave_move_out_distances(train, np.zeros(240, dtype=int))
    with pytest.raises(ValueError, match="quantile"):
        radius_from_quantile(train, groups, 1.5)
