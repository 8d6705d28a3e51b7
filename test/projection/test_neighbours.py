"""Exact nearest-neighbour search (``projection.neighbours.NearestNeighbour``) against a naive
loop: every method, near ties, blocks of queries, the automatic choice, pickling and threads.
"""
from __future__ import annotations

import numpy as np
import pytest

from littledog_mlsim.layout import N_STATE
from littledog_mlsim.projection import NearestNeighbour
from synthetic import clustered_points, naive_nearest


def test_nearest_neighbour_equals_a_naive_loop():
    rng = np.random.default_rng(11)
    d = N_STATE
    P = rng.standard_normal((2000, d))
    P[1500] = P[37]                                          # exact duplicate: smallest index wins
    # near ties far from the origin, where the GEMM expansion cannot tell them apart
    centres = 5.0 + rng.standard_normal((40, d))
    for k, c in enumerate(centres):
        v1, v2 = rng.standard_normal((2, d))
        v1 /= np.linalg.norm(v1)
        v2 /= np.linalg.norm(v2)
        delta = 1e-13 * (1 if k % 2 else -1)
        P[100 + 2 * k] = c + v1 * (1 + delta)
        P[101 + 2 * k] = c + v2
    Q = np.vstack([rng.standard_normal((150, d)), P[[37, 5, 1999]], centres,
                   1e12 * rng.standard_normal((3, d))])
    ref = naive_nearest(P, Q)
    for chunk in (3000, 1 << 18):                           # many small chunks, and one
        nn = NearestNeighbour(P, chunk_elems=chunk)
        np.testing.assert_array_equal(nn.query(Q), ref)
        np.testing.assert_array_equal(np.concatenate([nn.query(Q[i:i + 1]) for i in range(9)]),
                                      ref[:9])
    assert ref[150] == 37
    ik = NearestNeighbour(P, method="kdtree").query(Q)
    np.testing.assert_array_equal(((Q - P[ik]) ** 2).sum(1), ((Q - P[ref]) ** 2).sum(1))


@pytest.mark.parametrize("compiled", [True, False], ids=["compiled", "numpy"])
@pytest.mark.parametrize("kind", ["clustered", "gaussian", "grid", "flat"])
def test_pca_nearest_neighbour_equals_a_naive_loop(kind, compiled):
    rng = np.random.default_rng(21)
    n, d = 4000, N_STATE
    if kind == "clustered":
        P = clustered_points(n, seed=22)
    elif kind == "gaussian":                  # flat spectrum: the bounds barely prune
        P = rng.standard_normal((n, d))
    elif kind == "grid":                      # half-integer grid: many exactly equal distances
        P = np.round(2 * clustered_points(n, seed=22)) / 2
    else:                                     # a 10-D grid in 33-D: the bounds are the
        P = np.zeros((n, d))                  # distances, up to rounding; many exact ties
        P[:, 3:13] = np.round(2 * clustered_points(n, seed=22, d=10)) / 2
    P[3999] = P[17]                           # duplicates in different chunks
    P[2500] = P[1200]
    sd = P.std(0)
    Q = np.vstack([P[rng.choice(n, 60)] + s * sd * rng.standard_normal((60, d))
                   for s in (0.3, 0.8, 1.5)]
                  + [P[[17, 1200, 0]],
                     np.round(2 * P[rng.choice(n, 20)] + 3 * rng.standard_normal((20, d))) / 2,
                     30.0 * rng.standard_normal((3, d)), 3e3 * rng.standard_normal((2, d)),
                     1e12 * rng.standard_normal((2, d))])          # far, very far, beyond `far`
    ref = naive_nearest(P, Q)
    nn = NearestNeighbour(P, method="pca", chunk_points=128, compiled=compiled)
    assert nn.build_index().n_chunks >= 32
    np.testing.assert_array_equal(nn.query(Q), ref)
    singles = np.concatenate([nn.query(Q[i:i + 1]) for i in range(0, 190, 7)])
    np.testing.assert_array_equal(singles, ref[0:190:7])
    first_copy = [np.flatnonzero((P == P[i]).all(axis=1))[0] for i in (17, 1200)]
    assert list(ref[180:182]) == first_copy and first_copy[0] <= 17
    if kind != "gaussian":
        # the bounds alone answer every query near the data: no fall-back to brute force (which
        # would also hide a point wrongly ruled out)
        index = nn.build_index()
        search = index.query_compiled if compiled else index.query
        np.testing.assert_array_equal(search(Q[:183], P), ref[:183])


@pytest.mark.parametrize("compiled", [True, False], ids=["compiled", "numpy"])
def test_pca_nearest_neighbour_near_ties_and_blocks(compiled):
    rng = np.random.default_rng(23)
    d = N_STATE
    P = clustered_points(3000, seed=24)
    # near ties far from the origin: two points at distance 1 and 1 +- 1e-13 from a centre
    centres = P[rng.choice(3000, 40)] + 3.0
    for k, c in enumerate(centres):
        v1, v2 = rng.standard_normal((2, d))
        P[100 + 2 * k] = c + v1 / np.linalg.norm(v1) * (1 + 1e-13 * (1 if k % 2 else -1))
        P[2900 - 2 * k] = c + v2 / np.linalg.norm(v2)
    Q = np.vstack([centres, P[rng.choice(3000, 500)] + 0.5 * rng.standard_normal((500, d))])
    ref = naive_nearest(P, Q)
    nn = NearestNeighbour(P, method="pca", chunk_points=100, compiled=compiled)
    np.testing.assert_array_equal(nn.query(Q), ref)          # 540 rows: several query blocks
    np.testing.assert_array_equal(nn.query(Q[:200]), ref[:200])
    np.testing.assert_array_equal(nn.query(Q, method="brute"), ref)
    np.testing.assert_array_equal(nn.query(Q[:1]), ref[:1])
    assert nn.query(Q[:0]).shape == (0,)


def test_nearest_neighbour_auto_method_pickle_and_threads():
    import pickle
    import threading
    P = clustered_points(2000, seed=25, d=12)
    Q = P[::40] + 0.3
    ref = naive_nearest(P, Q)
    assert NearestNeighbour(P, chunk_points=500)._resolve("auto") == "pca"
    assert NearestNeighbour(P)._resolve("auto") == "brute"             # too few points
    assert NearestNeighbour(P[:, :4], chunk_points=100)._resolve("auto") == "brute"  # 4-D
    flat = np.random.default_rng(28).standard_normal((2000, N_STATE))  # no dominant axes
    assert NearestNeighbour(flat, chunk_points=100)._resolve("auto") == "brute"
    nn = NearestNeighbour(P, chunk_points=100).prepare()
    back = pickle.loads(pickle.dumps(nn))
    np.testing.assert_array_equal(back.query(Q), ref)
    results = [None] * 4

    def work(i):
        results[i] = [nn.query(Q) for _ in range(20)]

    threads = [threading.Thread(target=work, args=(i,)) for i in range(4)]
    for t in threads:
        t.start()
    for t in threads:
        t.join()
    for res in results:
        for r in res:
            np.testing.assert_array_equal(r, ref)
    bad = Q[:2].copy()
    bad[1, 3] = np.nan
    for compiled in (True, False):                  # one row and several, either form
        nn.compiled = compiled
        for rows in (bad[1:], bad):
            with pytest.raises(ValueError, match="NaN or inf"):
                nn.query(rows)
    with pytest.raises(ValueError, match="method"):
        NearestNeighbour(P, method="ball")
    with pytest.raises(ValueError, match="method"):
        nn.query(Q, method="ball")


def test_compiled_search_far_read_only_and_batch_size_agree_with_the_numpy_form():
    rng = np.random.default_rng(29)
    # data whose radius exceeds far / 64: rows beyond `far` must be searched as the NumPy
    # form searches them (at norm `far`, brute force), whatever the batch size
    P = rng.standard_normal((3000, 12)) * np.r_[[3e7] * 4, [1e5] * 8]
    Q = rng.standard_normal((12, 12)) * 1e8
    fast = NearestNeighbour(P, method="pca", chunk_points=100)
    slow = NearestNeighbour(P, method="pca", chunk_points=100, compiled=False)
    np.testing.assert_array_equal(fast.query(Q), slow.query(Q))
    # a read-only, non-contiguous batch across COMPILED_ROWS, and inf rows
    P = clustered_points(4000, seed=30)
    nn = NearestNeighbour(P, method="pca", chunk_points=128)
    n = NearestNeighbour.COMPILED_ROWS
    Q = np.asfortranarray(P[rng.choice(4000, n + 1)] + 0.5 * rng.standard_normal((n + 1, N_STATE)))
    Q.flags.writeable = False
    ref = naive_nearest(P, Q)
    np.testing.assert_array_equal(nn.query(Q), ref)                 # the NumPy form
    np.testing.assert_array_equal(nn.query(Q[:n]), ref[:n])         # compiled, one by one
    np.testing.assert_array_equal(nn.query(Q[:1]), ref[:1])
    bad = np.array(Q[:3])
    bad[2, 0] = -np.inf
    with pytest.raises(ValueError, match="NaN or inf"):
        nn.query(bad)
