"""Compiled candidate search of ``NearestNeighbour``'s ``"pca"`` method (numba).

The NumPy form of the search (``neighbours._PCAIndex._query``) makes about a hundred NumPy
calls per query, whose fixed cost, not the arithmetic, sets the time of one query (the learned
simulator's step asks one at a time). :func:`pca_candidates` runs the same bounds in one
compiled loop per query and returns the points the bounds cannot rule out; the caller scores
them with the naive formula in NumPy, as the NumPy form does, so the answer is the naive
loop's, bit for bit.

The bounds are those of ``_PCAIndex`` (its docstring gives the margins) with these changes, all
on the safe side:

- the lower bounds ``||f_p||^2 - 2 f_x . f_p`` are summed point by point in float32, in any
  order and with fused multiply-adds (the float32 GEMM's margin covers any order), and
  compared with the float64 threshold (the NumPy form rounds it up to float32);
- inside each chunk the points lie in leaves of ``BLOCK`` slots, and a leaf whose feature box
  cannot hold a point within the bound is skipped, by the chunk's own test;
- the chunks are visited in order of their box bound, and each chunk's best point, when its
  bound is under the threshold, is scored at once, so that the bound ``U`` tightens before the
  next chunk is considered; a point scored here (a compiled sum, not NumPy's) counts at
  ``(1 + 4 (d + 4) u64)`` times its value, which covers the two summations' rounding.

A return of -1 means "search this query by brute force" (far outside the data, bounds that
select most of the home chunk's sample, or more than ``max_candidates`` candidates), -2 that
the query holds NaN or inf.
"""
from __future__ import annotations

import math

import numpy as np
from numba import njit

from .neighbours import _U32, _U64  # noqa: E402  (the NumPy form's unit roundoffs)

#: slots per leaf: ``_PCAIndex.BLOCK`` (a compile-time constant here)
BLOCK = 32


@njit(cache=True, nogil=True)
def _sq_dist(x, P, i):
    s = 0.0
    for j in range(x.shape[0]):
        t = x[j] - P[i, j]
        s += t * t
    return s


@njit(cache=True, nogil=True)
def _threshold(U, qq, ez, fn32, rfc, orth, d, nf):
    """``_PCAIndex._threshold`` for one (chunk, query) pair, in float64 (numba cannot call
    the NumPy form; keep the two formulas the same)."""
    Uz = (math.sqrt(U * ((1.0 + orth) * (1.0 + (d + 4) * _U64))) + 2.0 * ez) ** 2
    base = Uz - qq * (1.0 - 4.0 * (nf + 2) * _U64) + 16.0 * _U64 * (Uz + qq)
    return base + 2.0 * (nf + 4) * _U32 * (fn32 + rfc) ** 2


@njit(cache=True, nogil=True, fastmath={"contract", "reassoc"})
def _bounds_of_leaf(af, points, s0, row):
    """row[s] = points[s, nf] + sum_f af[f] points[s, f] (float32, in any order of the sum)
    for the BLOCK slots s of one leaf from ``s0``; ``points`` (cs, nf + 1): a chunk's
    ``[-2 f_p, ||f_p||^2]`` point by point."""
    nf = af.shape[0]
    for t in range(BLOCK):
        p = points[s0 + t]
        v = p[nf]
        for f in range(nf):
            v += af[f] * p[f]
        row[s0 + t] = v


@njit(cache=True, nogil=True)
def pca_candidates(x, upper, P, mean, V, k, group_bounds, lo, hi, sub_lo, sub_hi, rf,
                   aug_points, aug_sample, perm, perm_sample, R, orth, max_candidates, out, work,
                   leaves):
    """Candidates of one query ``x`` (d,) among ``P`` (n, d): their count in ``out``, or -1.

    ``upper``: a known point's NumPy naive squared distance (``inf`` if none). The index
    arrays are ``_PCAIndex``'s: ``V`` its axes, ``k`` leading coordinates and the residual
    groups ``group_bounds`` (G, 2) as features, ``lo``/``hi`` (nf, nc) the chunks' feature
    boxes, ``sub_lo``/``sub_hi`` (nc, nf, leaves) those of the chunks' leaves (a leaf whose
    box cannot hold a point within the bound is skipped), ``rf`` (nc,) their largest
    float32 feature norms, ``aug_points`` (nc, cs, nf + 1) point by point and ``aug_sample``
    (nc, nf + 1, cs / SAMPLE) the float32 ``[-2 f_p, ||f_p||^2]``, ``perm``/``perm_sample``
    slot -> point. ``out`` (>= max_candidates + 1,) int64 receives the candidates; ``work`` (nc, cs)
    float32 and ``leaves`` (nc, cs // BLOCK) int64 are scratch.
    """
    d = x.shape[0]
    nc = lo.shape[1]
    nf = lo.shape[0]
    cs = aug_points.shape[1]
    css = aug_sample.shape[2]
    ng = group_bounds.shape[0]
    for i in range(d):
        if not math.isfinite(x[i]):
            return -2
    # rotated query and its features
    z = np.empty(d)
    zn2 = 0.0
    for j in range(d):
        s = 0.0
        for i in range(d):
            s += (x[i] - mean[i]) * V[i, j]
        z[j] = s
        zn2 += s * s
    zn = math.sqrt(zn2)
    if zn > 64.0 * R:
        return -1
    fx = np.empty(nf)
    for j in range(k):
        fx[j] = z[j]
    for g in range(ng):
        s = 0.0
        for j in range(group_bounds[g, 0], group_bounds[g, 1]):
            s += z[j] * z[j]
        fx[k + g] = math.sqrt(s)
    qq = 0.0
    af = np.empty(nf, dtype=np.float32)
    fn2 = 0.0
    for j in range(nf):
        qq += fx[j] * fx[j]
        af[j] = np.float32(fx[j])
        fn2 += float(af[j]) * float(af[j])
    fn32 = math.sqrt(fn2)
    ez = 8.0 * (d + 2) * math.sqrt(d) * _U64 * (zn + R) + 1e-300
    inflate = 1.0 + 4.0 * (d + 4) * _U64
    # 1. box bound per chunk; the home chunk has the smallest
    box = np.empty(nc)
    for c in range(nc):
        s = 0.0
        for f in range(nf):
            g = lo[f, c] - fx[f]
            h = fx[f] - hi[f, c]
            if h > g:
                g = h
            if g > 0.0:
                s += g * g
        box[c] = s
    home = 0
    for c in range(1, nc):
        if box[c] < box[home]:
            home = c
    # 2. the first upper bound: the home chunk's sample point with the smallest lower bound
    g1 = np.empty(css, dtype=np.float32)
    sample = aug_sample[home]
    for s in range(css):
        g1[s] = sample[nf, s]
    for f in range(nf):
        a = af[f]
        col = sample[f]
        for s in range(css):
            g1[s] += a * col[s]
    best = 0
    for s in range(1, css):
        if g1[s] < g1[best]:
            best = s
    U = upper
    p = perm_sample[home * css + best]
    if p >= 0:
        u = _sq_dist(x, P, p) * inflate
        if u < U:
            U = u
    t1 = _threshold(U, qq, ez, fn32, rf[home], orth, d, nf)
    hits = 0
    real = 0
    for s in range(css):
        if perm_sample[home * css + s] >= 0:
            real += 1
            if g1[s] <= t1:
                hits += 1
    if hits > 0.75 * real:
        return -1
    # 3. chunks in order of their box bound while the box can hold a point within U; in each,
    #    the leaves whose feature box can; each chunk's best point, if under the threshold,
    #    is scored and may lower U
    order = np.argsort(box, kind="mergesort")
    shrink = 1.0 - 4.0 * (nf + 2) * _U64
    nb = sub_lo.shape[2]
    visited = np.empty(nc, dtype=np.int64)
    n_leaves = np.zeros(nc, dtype=np.int64)
    q = np.empty(nb)
    nvis = 0
    for oc in range(nc):
        c = order[oc]
        lim = math.sqrt(U * ((1.0 + orth) * (1.0 + (d + 4) * _U64))) + 2.0 * ez
        if c != home and math.sqrt(box[c] * shrink) > lim:
            break
        for b in range(nb):
            q[b] = 0.0
        for f in range(nf):
            xf = fx[f]
            lof = sub_lo[c, f]
            hif = sub_hi[c, f]
            for b in range(nb):
                g = max(lof[b] - xf, xf - hif[b], 0.0)
                q[b] += g * g
        row = work[nvis]
        mine = leaves[nvis]
        nl = 0
        bmin = np.inf
        am = -1
        for b in range(nb):
            if math.sqrt(q[b] * shrink) > lim:
                continue
            mine[nl] = b
            nl += 1
            s0 = b * BLOCK
            _bounds_of_leaf(af, aug_points[c], s0, row)
            for t in range(BLOCK):
                if row[s0 + t] < bmin:
                    bmin = row[s0 + t]
                    am = s0 + t
        visited[nvis] = c
        n_leaves[nvis] = nl
        nvis += 1
        if am >= 0 and bmin <= _threshold(U, qq, ez, fn32, rf[c], orth, d, nf):
            p = perm[c * cs + am]
            if p >= 0:
                u = _sq_dist(x, P, p) * inflate
                if u < U:
                    U = u
    # 4. every point of a visited leaf whose bound is under the final threshold
    n_out = 0
    for i in range(nvis):
        c = visited[i]
        thr = _threshold(U, qq, ez, fn32, rf[c], orth, d, nf)
        row = work[i]
        for j in range(n_leaves[i]):
            s0 = leaves[i, j] * BLOCK
            for t in range(BLOCK):
                if row[s0 + t] <= thr:
                    p = perm[c * cs + s0 + t]
                    if p >= 0:
                        if n_out >= max_candidates:
                            return -1
                        out[n_out] = p
                        n_out += 1
    return n_out
