"""The gate's shortcut: ``CandidateGroups`` and ``AlphaProjection.project_distance`` with
``candidates``, and the exact search started from a known point (``NearestNeighbour.query``'s
``upper``), against the exact search and naive loops.

The shortcut must not change a projected state, whatever the groups: random groups, groups
that miss the nearest state, and states placed on the gate's edge (within rounding of the
radius) are all checked bit for bit against the projection without it.
"""
from __future__ import annotations

import numpy as np
import pytest

from littledog_mlsim.layout import WRAPPED_STATE, S
from littledog_mlsim.projection import (AlphaProjection, CandidateGroups, NearestNeighbour,
                                        enforce_limits)
from synthetic import clustered_points, naive_nearest, random_states


def test_candidate_groups_bound_is_a_real_points_naive_distance():
    P = clustered_points(3000, seed=3)
    rng = np.random.default_rng(4)
    groups = np.array_split(rng.permutation(P.shape[0]), 7)
    cg = CandidateGroups(P, groups)
    Q = P[rng.integers(0, 3000, 50)] + 0.3 * rng.standard_normal((50, P.shape[1]))
    labels = rng.integers(0, 7, 50)
    idx, sq = cg.upper_bound(Q, labels)
    for k in range(50):
        assert idx[k] in set(groups[labels[k]].tolist())
        assert sq[k] == ((Q[k] - P[idx[k]]) ** 2).sum()
        exact_in_group = ((P[groups[labels[k]]] - Q[k]) ** 2).sum(axis=1).min()
        assert sq[k] == pytest.approx(exact_in_group, rel=1e-9)
    one = CandidateGroups(P, [np.arange(P.shape[0])])
    i1, _ = one.upper_bound(Q, np.zeros(50, dtype=int))
    np.testing.assert_array_equal(i1, naive_nearest(P, Q))      # one group = the exact search
    i2, _ = cg.upper_bound(Q[:1], labels[:1])                    # the single-query path
    assert i2[0] == idx[0]
    with pytest.raises(ValueError):
        cg.upper_bound(Q, np.full(50, 7))
    with pytest.raises(ValueError):
        CandidateGroups(P, [np.array([], dtype=int)])


def test_exact_search_from_a_known_point_is_the_same_search():
    P = clustered_points(9000, seed=5)
    nn = NearestNeighbour(P, method="pca").prepare()
    rng = np.random.default_rng(6)
    Q = P[rng.integers(0, 9000, 80)] + 0.5 * rng.standard_normal((80, P.shape[1]))
    some = rng.integers(0, 9000, 80)
    upper = ((Q - P[some]) ** 2).sum(axis=1)
    np.testing.assert_array_equal(nn.query(Q, upper=upper), naive_nearest(P, Q))


@pytest.fixture(scope="module")
def pool():
    train = random_states(600, seed=12)
    rng = np.random.default_rng(13)
    return train, rng


@pytest.mark.parametrize("alpha", [0.5, 1.0, 0.0])
def test_states_bit_for_bit_with_any_groups_and_on_the_gate_edge(pool, alpha):
    train, rng = pool
    r = 1.2
    proj = AlphaProjection(train, alpha=alpha, radius=r)
    P = proj.nn.points
    # queries: near the data, far from it, and on the gate's edge (distance r to the exact
    # nearest state, up to rounding), plus a non-finite row
    near = train[rng.integers(0, 600, 40)] + 0.05 * rng.standard_normal((40, 33))
    far = train[rng.integers(0, 600, 20)] + 1.0 * rng.standard_normal((20, 33))
    base = train[rng.integers(0, 600, 20)]
    direction = rng.standard_normal((20, 33))
    direction[:, S.q] = 0.0                # stay inside the joint limits: exactly on the edge
    direction[:, WRAPPED_STATE] = 0.0
    direction /= np.linalg.norm(direction / proj.scale, axis=1)[:, None]
    edge = base + r * direction * (1 + rng.uniform(-1e-12, 1e-12, (20, 1)))
    S_ = enforce_limits(np.vstack([near, far, edge, np.full((1, 33), np.nan)]))
    exact_d = np.sqrt(((S_[:-1, None] / proj.scale - P[None]) ** 2).sum(-1).min(axis=1))
    ref, ref_d = proj.project_distance(S_)
    np.testing.assert_allclose(ref_d[:-1], exact_d, rtol=1e-12)
    for groups in (np.array_split(np.arange(600), 6),                   # in order
                   np.array_split(rng.permutation(600), 6),              # random
                   [np.arange(600)],                                     # everything
                   [np.arange(0, 600, 50)]):                             # a poor few
        cg = proj.candidate_groups(groups)
        labels = rng.integers(0, len(groups), S_.shape[0])
        first = rng.integers(-1, 600, S_.shape[0])
        window = np.stack([first, rng.integers(-1, 600, S_.shape[0])], axis=1)
        for cand in ((cg, labels), (cg, labels, first), (cg, labels, window)):
            index = np.empty(S_.shape[0], dtype=np.int64)
            out, d = proj.project_distance(S_, cand, index)
            np.testing.assert_array_equal(out, ref)                      # the states
            assert np.isnan(d[-1]) and index[-1] == -1
            dd, di = d[:-1], index[:-1]
            # every distance is one to the state named, at least the exact one; beyond the
            # gate it is the exact one
            np.testing.assert_allclose(dd, np.sqrt(((S_[:-1] / proj.scale - P[di]) ** 2)
                                                   .sum(axis=1)), rtol=1e-12)
            assert np.all(dd >= exact_d * (1 - 1e-12))
            outside = dd > r
            np.testing.assert_array_equal(dd[outside], ref_d[:-1][outside])
            np.testing.assert_array_equal(dd > r, ref_d[:-1] > r)        # the same flag
        on_edge = np.abs(exact_d[60:] - r) < 1e-9 * r
        assert on_edge.sum() >= 10                                        # really on the edge
    # without a radius the candidates are ignored (plain alpha-PROJ: exact everywhere)
    plain = AlphaProjection(train, alpha=0.5)
    cg = plain.candidate_groups([np.arange(0, 600, 50)])
    a, da = plain.project_distance(S_, (cg, np.zeros(S_.shape[0], dtype=int)))
    b, db = plain.project_distance(S_)
    np.testing.assert_array_equal(a, b)
    np.testing.assert_array_equal(da, db)
