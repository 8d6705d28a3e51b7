"""Exact Euclidean nearest-neighbour search over a fixed set of points (:class:`NearestNeighbour`).

alpha-PROJ (:mod:`.kinds`) pulls each predicted state towards its nearest TrainPool state, so
the learned simulator searches all TrainPool states (33 dimensions) at every step: the search
has to be exact (the same answer as a naive loop) and fast enough for a 10 ms step. It is
NumPy, with the bounds of up to a few hundred queries compiled by numba (``compiled.py``) and
SciPy only for the optional k-d tree, and knows nothing about states or projections.
Timings of the methods: ``benchmarks/projection_nn/``.
"""
from __future__ import annotations

import threading
from typing import ClassVar

import numpy as np

__all__ = ["NearestNeighbour", "CandidateGroups"]


class NearestNeighbour:
    """Exact Euclidean nearest neighbour of query rows among ``points`` (n, d), float64.

    Every method returns the answer of a naive loop, ``argmin(((points - x) ** 2).sum(axis=1))``
    per query ``x``: the smallest such distance, and on exact ties the smallest index
    (``"kdtree"`` excepted, see below). Methods (``benchmarks/projection_nn/projection_nn.md``
    has the timings):

    - ``"auto"`` (default): ``"pca"`` for at least ``4 * chunk_points`` points in at least 8
      dimensions whose first ``n_components`` principal axes carry at least 95% of the
      variance (the TrainPool: 99%), else ``"brute"``.
    - ``"pca"``: lower bounds first, exact distances only for the few points they cannot rule
      out. The points are rotated once into their principal axes (``z = (p - mean) V``) and
      split into chunks of at most ``chunk_points`` points by median cuts along the first two
      principal coordinates. Features ``f(z)``: the first ``k = n_components`` coordinates
      plus the norms of two groups of the remaining ones; ``||f(z_x) - f(z_p)||`` is a lower
      bound on the distance (triangle inequality within each group), tight near the data and
      still useful far from it. On alpha-PROJ's data it leaves a few of the 61k TrainPool
      states per query. For a batch of queries:

      1. per (chunk, query) the box bound: squared distance from ``f(z_x)`` to the chunk's
         bounding box of features;
      2. a first upper bound ``U``: in the chunk with the smallest box bound ("home"), the
         lower bounds of every 4th point (float32 GEMM ``[f_x, 1] @ [-2 f_p, ||f_p||^2]^T``,
         one per chunk); the point with the smallest one, scored exactly;
      3. the lower bounds of every point of each chunk whose box bound does not exceed ``U``
         (on the real data about 1/5 of the (chunk, query) pairs); the best point of each,
         if its bound is below ``U``, is scored and may lower ``U``;
      4. every point whose lower bound does not exceed ``U`` (plus the margin below) is scored
         with the naive loop's formula ``((x - p) ** 2).sum()`` in the original coordinates;
         the smallest distance wins, then the smallest index.

      The margins cover the float32 GEMM's rounding error (bounded from the features' norms
      per chunk) and that of the float64 rotation and norms, so a point is skipped only if it
      is provably further than a point already scored: the answer is exactly the naive
      loop's. Queries the bounds do not help (far outside the data, most of the home chunk's
      sample or more than ``n / 32`` points left as candidates) go to ``"brute"``. On the
      TrainPool about 1/4 of ``"brute"``'s time for alpha-PROJ's 66 queries of a rollout step,
      1/2 for one query (``benchmarks/projection_nn/projection_nn.md``).

      With ``compiled=True`` (the default) up to ``COMPILED_ROWS`` queries are searched one by
      one in compiled code (``compiled.pca_candidates``), with the same features, boxes and
      margins, plus one more level: within a chunk the points lie in leaves of ``BLOCK``
      points cut along the first ``LEAF_DIMS`` features, and a leaf whose feature box cannot
      hold a point within ``U`` is skipped. The candidates are scored with the naive formula
      in NumPy, so the answer is the same as the NumPy form's. One query is several times
      faster that way (``benchmarks/sim_node_20x``): the NumPy form's time for one query is
      mostly the fixed cost of its calls.
    - ``"brute"``: one GEMM per chunk of points, ``[a, 1] @ [-2 b_j, ||b_j||^2]^T``
      = ``||a - b_j||^2 - ||a||^2`` (the row constant ``||a||^2`` dropped); every point within a
      rounding-error bound of the row minimum is then re-scored with the direct
      ``((a - b_j) ** 2).sum()``, smallest index first on exact ties: the same answer as a naive
      loop over the points. Cost proportional to n for every query.
    - ``"kdtree"``: ``scipy.spatial.cKDTree`` (``eps=0``, exact; ties may pick another of the
      equidistant points), built on first use. Faster than brute only for queries very close to
      the points; much slower for queries as far from them as real predictions are.

    Queries further than ``far`` from the origin (a diverging rollout) are searched at norm
    ``far`` along their direction (which keeps the GEMM finite); they always use brute force.
    """

    METHODS: ClassVar[tuple[str, ...]] = ("auto", "pca", "brute", "kdtree")
    #: ``"pca"`` searches up to this many rows one by one in compiled code (``compiled=True``),
    #: more in the NumPy form, whose GEMMs share each chunk between the rows
    COMPILED_ROWS: ClassVar[int] = 256

    def __init__(self, points: np.ndarray, method: str = "auto",
                 chunk_elems: int = 1 << 18, far: float = 1e8, n_components: int = 24,
                 chunk_points: int = 2048, compiled: bool = True) -> None:
        if method not in self.METHODS:
            raise ValueError(f"method must be one of {self.METHODS}, got {method!r}")
        P = np.array(points, dtype=np.float64, order="C", copy=True)
        if P.ndim != 2 or P.shape[0] == 0:
            raise ValueError(f"points must be a non-empty (n, d) array, got {P.shape}")
        if not np.all(np.isfinite(P)):
            raise ValueError("points hold NaN or inf")
        if int(n_components) < 1 or int(chunk_points) < 1:
            raise ValueError("n_components and chunk_points must be positive")
        self.method = method
        self.compiled = bool(compiled)
        self.chunk_elems = int(chunk_elems)
        self.far = float(far)
        self.n_components = int(n_components)
        self.chunk_points = int(chunk_points)
        n, d = P.shape
        self._P = P
        sq = np.einsum("ij,ij->i", P, P)
        # [-2 P, ||P||^2]^T, (d + 1, n); stored transposed: a single query is then an
        # axpy-friendly (1, d+1) GEMM.
        self._augT = np.empty((d + 1, n))
        self._augT[:d] = -2.0 * P.T
        self._augT[d] = sq
        self._max_norm = float(np.sqrt(sq.max()))
        self._tree = None
        self._pca: _PCAIndex | None = None
        self._auto: str | None = None     # what "auto" means here, settled on first use

    @property
    def n_points(self) -> int:
        return self._P.shape[0]

    @property
    def dim(self) -> int:
        return self._P.shape[1]

    @property
    def points(self) -> np.ndarray:
        """(n, d) the points (a new array)."""
        return self._P.copy()

    def _resolve(self, method: str) -> str:
        if method != "auto":
            return method
        if self._auto is None:
            auto = "brute"
            if self.n_points >= 4 * self.chunk_points and self.dim >= 8:
                had = self._pca is not None
                if self.build_index().residual_fraction <= 0.05:
                    auto = "pca"
                elif not had:
                    self._pca = None
            self._auto = auto
        return self._auto

    def build_tree(self):
        """The cKDTree over the points (built once; build early to keep it out of a 10 ms step)."""
        if self._tree is None:
            from scipy.spatial import cKDTree
            self._tree = cKDTree(self._P)
        return self._tree

    def prepare(self) -> "NearestNeighbour":
        """Build what the search method needs now (on first use otherwise: ~0.2 s for the
        TrainPool, and for the compiled search its machine code, compiled or loaded from
        numba's cache: to be kept out of a 10 ms step); returns self."""
        method = self._resolve(self.method)
        if method == "pca":
            self.build_index()
            if self.compiled:
                self.query(self._P[:1])
        elif method == "kdtree":
            self.build_tree()
        return self

    def build_index(self) -> "_PCAIndex":
        """The principal-axes index of ``"pca"`` (built once, on first use)."""
        if self._pca is None:
            self._pca = _PCAIndex(self._P, self.n_components, self.chunk_points)
        return self._pca

    def query(self, X: np.ndarray, method: str | None = None,
              upper: np.ndarray | None = None) -> np.ndarray:
        """Index (m,) int64 of the nearest point to each row of ``X`` (m, d) (finite values).

        ``upper`` (m,), optional: for each row the naive squared distance
        ``((x - p) ** 2).sum()`` of some point p (``CandidateGroups.upper_bound``); ``"pca"``
        starts from it where it is smaller than its own first bound (fewer chunks to visit).
        The answer is the same with or without it."""
        A = np.asarray(X, dtype=np.float64)
        if A.ndim != 2 or A.shape[1] != self.dim:
            raise ValueError(f"queries must be (m, {self.dim}), got {A.shape}")
        method = method or self.method
        if method not in self.METHODS:
            raise ValueError(f"method must be one of {self.METHODS}, got {method!r}")
        method = self._resolve(method)
        if method == "pca" and self.compiled and 0 < A.shape[0] <= self.COMPILED_ROWS:
            # the compiled bounds check the rows for NaN and inf themselves; a writeable
            # C-order copy where needed (a read-only array would compile another version)
            if not (A.flags.c_contiguous and A.flags.writeable):
                A = np.array(A, order="C")
            up = None if upper is None else np.asarray(upper, dtype=np.float64)
            res = self.build_index().query_compiled(A, self._P, up)
            if np.any(res == _NOT_FINITE):
                raise ValueError("queries hold NaN or inf")
            # rows beyond `far` go to brute force at norm `far`, as in the NumPy form
            res[np.sqrt(np.einsum("ij,ij->i", A, A)) > self.far] = -1
            todo = res < 0                               # left to brute force
            if np.any(todo):
                res[todo] = self.query(A[todo], method="brute")
            return res
        if not np.all(np.isfinite(A)):
            raise ValueError("queries hold NaN or inf")
        if A.shape[0] == 0:
            return np.empty(0, dtype=np.int64)
        norm = np.sqrt(np.einsum("ij,ij->i", A, A))
        far = norm > self.far
        if np.any(far):
            A = A.copy()
            A[far] *= (self.far / norm[far])[:, None]
        if method == "brute" or np.all(far):
            return self._brute(A, norm)
        out = np.empty(A.shape[0], dtype=np.int64)
        near = ~far
        if method == "kdtree":
            out[near] = self.build_tree().query(A[near], k=1, eps=0.0, p=2.0)[1]
        else:
            An = A if not np.any(far) else A[near]
            up = None if upper is None else np.asarray(upper, dtype=np.float64)
            if up is not None and np.any(far):
                up = up[near]
            res = self.build_index().query(An, self._P, up)
            todo = res < 0                               # left to brute force
            if np.any(todo):
                res[todo] = self._brute(An[todo], norm[near][todo] if np.any(far)
                                        else norm[todo])
            out[near] = res
        if np.any(far):
            out[far] = self._brute(A[far], np.minimum(norm[far], self.far))
        return out

    def _brute(self, A: np.ndarray, anorm: np.ndarray) -> np.ndarray:
        m, d = A.shape
        n = self.n_points
        Aa = np.empty((m, d + 1))
        Aa[:, :d] = A
        Aa[:, d] = 1.0
        # Rounding error of the (d + 1)-term dot product (plus that of ||b||^2) is below
        # (d + 3) eps (||b||^2 + 2 |a| |b|); a factor 4 margin on top.
        eps = np.finfo(np.float64).eps
        anorm = np.minimum(anorm, self.far)
        tol = 4.0 * (d + 3) * eps * (self._max_norm ** 2 + 2.0 * anorm * self._max_norm)
        rows = np.arange(m)
        best = np.full(m, np.inf)       # smallest value so far
        second = np.full(m, np.inf)     # smallest value at any other point
        best_idx = np.zeros(m, dtype=np.int64)
        step = max(1, self.chunk_elems // m)
        for j0 in range(0, n, step):
            V = Aa @ self._augT[:, j0:j0 + step]                         # (m, c)
            i = V.argmin(axis=1)
            v = V[rows, i]
            if V.shape[1] > 1:
                V[rows, i] = np.inf
                v2 = V.min(axis=1)
            else:
                v2 = np.full(m, np.inf)
            better = v < best
            second = np.where(better, np.minimum(best, v2), np.minimum(second, v))
            best = np.where(better, v, best)
            best_idx = np.where(better, i + j0, best_idx)
        # Rows where another point is within the rounding bound: re-score all such points with
        # the direct formula (rare; one GEMV per such row).
        for r in np.flatnonzero(second <= best + tol):
            c = np.flatnonzero(Aa[r] @ self._augT <= best[r] + tol[r])
            exact = ((A[r] - self._P[c]) ** 2).sum(axis=1)
            best_idx[r] = c[np.argmin(exact)]   # first of equal minima = smallest index
        return best_idx


class CandidateGroups:
    """A cheap upper bound on the nearest-neighbour distance: the nearest of a few candidates.

    ``points`` (n, d) as given to :class:`NearestNeighbour`; ``groups``: index arrays into them
    (any subsets, e.g. the TrainPool states an LGPR cluster's training rows lead to). For
    queries X (m, d) with a group label each, :meth:`upper_bound` returns, per query, one point
    of its group and that point's naive squared distance ``((x - p) ** 2).sum()``: the exact
    search's smallest naive value is at most this, whichever group a query is given (the
    groups only decide how tight the bound is, never whether it holds). Used by the gated
    alpha-PROJ (``AlphaProjection.project_distance``): a state whose bound is inside the gate
    is left alone without the exact search, which could only confirm it.
    """

    def __init__(self, points: np.ndarray, groups) -> None:
        P = np.asarray(points, dtype=np.float64)
        if P.ndim != 2:
            raise ValueError(f"points must be (n, d), got {P.shape}")
        self.groups = [np.asarray(g, dtype=np.int64).reshape(-1) for g in groups]
        if not self.groups or any(g.size == 0 or g.min() < 0 or g.max() >= P.shape[0]
                                  for g in self.groups):
            raise ValueError("groups must be non-empty index arrays into points")
        self.dim = P.shape[1]
        # per group: its points contiguous, and [-2 p, ||p||^2]^T for one GEMM per group
        self._pts = [np.ascontiguousarray(P[g]) for g in self.groups]
        self._aug = []
        for B in self._pts:
            a = np.empty((self.dim + 1, B.shape[0]))
            a[:self.dim] = -2.0 * B.T
            a[self.dim] = np.einsum("ij,ij->i", B, B)
            self._aug.append(a)

    @property
    def n_groups(self) -> int:
        return len(self.groups)

    def upper_bound(self, X: np.ndarray, labels: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """(index (m,) int64 into ``points``, naive squared distance (m,)) of the candidate of
        each finite query row ``X`` (m, d) in group ``labels`` (m,): the group's point with the
        smallest ``||x||^2``-free GEMM value, scored with the naive formula (so the bound is
        the naive distance of a real point, whatever the GEMM's rounding)."""
        A = np.asarray(X, dtype=np.float64)
        lab = np.asarray(labels, dtype=np.int64).reshape(-1)
        m = A.shape[0]
        if A.ndim != 2 or A.shape[1] != self.dim or lab.shape != (m,):
            raise ValueError(f"queries must be (m, {self.dim}) with m labels")
        if m and (lab.min() < 0 or lab.max() >= self.n_groups):
            raise ValueError("labels out of range")
        idx = np.empty(m, dtype=np.int64)
        sq = np.empty(m)
        Aa = np.empty((m, self.dim + 1))
        Aa[:, :self.dim] = A
        Aa[:, self.dim] = 1.0
        if m == 1:
            groups = [(int(lab[0]), slice(None))]
        else:
            order = np.argsort(lab, kind="stable")
            cut = np.flatnonzero(np.diff(lab[order])) + 1
            groups = [(int(lab[r[0]]), r) for r in np.split(order, cut)]
        for g, rows in groups:
            a = (Aa[rows] @ self._aug[g]).argmin(axis=1)
            B = self._pts[g][a]
            idx[rows] = self.groups[g][a]
            diff = A[rows] - B
            sq[rows] = (diff * diff).sum(axis=1)
        return idx, sq


_U32 = float(np.finfo(np.float32).eps) / 2      # unit roundoff of float32
_U64 = float(np.finfo(np.float64).eps) / 2
_PAD = np.float32(1e38)                         # lower bound of the padding slots of a chunk
_NOT_FINITE = -2                                # query_compiled: a row holds NaN or inf


def _median_split(Z: np.ndarray, idx: np.ndarray, size: int) -> list[np.ndarray]:
    """Split ``idx`` by medians along the widest column of ``Z`` into parts of <= size."""
    parts, out = [idx], []
    while parts:
        ix = parts.pop()
        if ix.size <= size:
            out.append(ix)
            continue
        X = Z[ix]
        col = X[:, int(np.argmax(X.max(axis=0) - X.min(axis=0)))]
        order = np.argsort(col, kind="stable")
        h = ix.size // 2
        parts += [ix[order[h:]], ix[order[:h]]]
    return out


class _PCAIndex:
    """The data of ``NearestNeighbour``'s ``"pca"`` method (see there): float32 GEMMs for the
    bounds, float64 for the answer. ``query`` returns -1 for rows it leaves to brute force.

    Features: ``f(z) = [z_0 .. z_k-1, ||z_g1||, .., ||z_gG||]``, the first ``k`` rotated
    coordinates and the norms of ``G = RESIDUAL_GROUPS`` groups of the remaining ones. By the
    triangle inequality in each group, ``||f(z_x) - f(z_p)|| <= ||z_x - z_p||``: a lower bound on
    the distance that is tight near the data (the residual coordinates carry little variance)
    and still useful far from it (the residual norms then dominate the distance).

    Rounding: the bounds are compared with margins that cover every rounding error on the way,
    so a point is skipped only if its exact distance exceeds the naive distance of a point
    already scored: the float64 rotation and feature norms (``_err_z``, ``orth``), the float32
    GEMM (relative ``(k + G + 4) u32`` of the sums of magnitudes, doubled) and the float64
    arithmetic of the margins themselves.
    """

    SPLIT_DIMS = 2            # chunks are cells of median cuts along this many principal axes
    RESIDUAL_GROUPS = 2
    SAMPLE = 4                # the first upper bound comes from every 4th point of a chunk
    BLOCK = 32                # leaf size: a chunk's slots come in blocks of BLOCK (padded)
    LEAF_DIMS = 8             # leaves are cut along the first LEAF_DIMS features

    def __init__(self, P: np.ndarray, n_components: int, chunk_points: int,
                 residual_groups: int | None = None) -> None:
        n, d = P.shape
        k = min(n_components, d)
        self.k = k
        groups = self.RESIDUAL_GROUPS if residual_groups is None else residual_groups
        self.groups = [g for g in np.array_split(np.arange(k, d), max(1, groups)) if g.size]
        nf = k + len(self.groups)                               # features per point
        self.mean = P.mean(axis=0)
        C = P - self.mean
        w, V = np.linalg.eigh(C.T @ C)
        self.V = np.ascontiguousarray(V[:, ::-1])               # descending variance
        # share of the variance outside the first k coordinates
        self.residual_fraction = float(max(0.0, w[:d - k].sum()) / max(w.sum(), 1e-300))
        Z = C @ self.V                                          # (n, d) rotated points
        F = self._features(Z)
        self.R = float(np.sqrt(np.einsum("ij,ij->i", Z, Z).max()))
        # how far V is from orthonormal: |V^T y|^2 = (1 + t) |y|^2 with |t| <= orth
        self.orth = float(np.abs(self.V.T @ self.V - np.eye(d)).sum(axis=1).max()) + 8 * _U64
        # float32 must hold the coordinates, and the padding stay above every threshold
        self.usable = self.R < 1e15 and self.orth < 1e-6
        chunks = _median_split(Z[:, :min(self.SPLIT_DIMS, d)], np.arange(n), chunk_points)
        chunks.sort(key=lambda ix: int(ix[0]))
        # within a chunk, leaves of at most BLOCK points by median cuts along the first
        # LEAF_DIMS features, each leaf in its own block of BLOCK slots (padded): the compiled
        # search skips a leaf whose feature box is beyond the bound
        leaves = [_median_split(F[ix, :min(self.LEAF_DIMS, nf)], np.arange(ix.size),
                                self.BLOCK) for ix in chunks]
        nc = len(chunks)
        cs = self.BLOCK * max(len(lv) for lv in leaves)
        self.n_chunks, self.cs = nc, cs
        self.perm = np.full((nc, cs), -1, dtype=np.int64)      # chunk slot -> point index
        self.aug = np.zeros((nc, nf + 1, cs), dtype=np.float32)  # [-2 f, ||f||^2] per chunk
        self.aug[:, nf] = _PAD
        lo = np.empty((nf, nc))
        hi = np.empty((nf, nc))
        self.rf = np.empty(nc)                                  # max ||f|| in float32
        for j, (ix, lv) in enumerate(zip(chunks, leaves)):
            slots = np.concatenate([b * self.BLOCK + np.arange(leaf.size)
                                    for b, leaf in enumerate(lv)])
            ix = ix[np.concatenate(lv)]
            f = F[ix]
            f32 = f.astype(np.float32)
            self.perm[j, slots] = ix
            self.aug[j, :nf, slots] = -2 * f32
            self.aug[j, nf, slots] = np.einsum("ij,ij->i", f, f)
            lo[:, j] = f.min(axis=0)
            hi[:, j] = f.max(axis=0)
            self.rf[j] = np.sqrt(np.einsum("ij,ij->i", f32, f32, dtype=np.float64).max())
        self.lo, self.hi = lo[:, :, None], hi[:, :, None]      # (features, chunks, 1)
        # every SAMPLE-th slot of each chunk (the first slot of every leaf among them)
        self.aug_sample = np.ascontiguousarray(self.aug[:, :, ::self.SAMPLE])
        self.perm_sample = np.ascontiguousarray(self.perm[:, ::self.SAMPLE]).ravel()
        self.cs_sample = self.aug_sample.shape[2]
        self.n_sample = (self.perm_sample.reshape(nc, -1) >= 0).sum(axis=1)  # real, per chunk
        self.perm = self.perm.ravel()
        self._lock = threading.Lock()
        self._work = np.empty(0, dtype=np.float32)
        self._cwork: tuple[np.ndarray, np.ndarray, np.ndarray] | None = None
        self._flat: tuple | None = None

    def query_compiled(self, A: np.ndarray, P: np.ndarray, upper: np.ndarray | None = None
                       ) -> np.ndarray:
        """``query``'s answer, the bounds in one compiled loop per query (``compiled.py``):
        the same indices (-1: left to brute force; -2: the row holds NaN or inf), with a
        handful of NumPy calls per query instead of about a hundred."""
        m = A.shape[0]
        out = np.full(m, -1, dtype=np.int64)
        if not self.usable:
            return out
        if self._flat is None:
            self._flat = self._compiled_arrays(P)
        pca_candidates, bounds, lo, hi, sub_lo, sub_hi, aug_points = self._flat
        most = max(256, P.shape[0] // 32)
        mine = self._lock.acquire(blocking=False)
        try:
            if mine and self._cwork is not None:
                cand, work, leaves = self._cwork
            else:
                cand = np.empty(most + 1, dtype=np.int64)
                work = np.empty((self.n_chunks, self.cs), dtype=np.float32)
                leaves = np.empty((self.n_chunks, self.cs // self.BLOCK), dtype=np.int64)
                if mine:
                    self._cwork = (cand, work, leaves)
            for i in range(m):
                u = np.inf if upper is None else float(upper[i])
                n = pca_candidates(A[i], u, P, self.mean, self.V, self.k, bounds, lo, hi,
                                   sub_lo, sub_hi, self.rf, aug_points, self.aug_sample, self.perm,
                                   self.perm_sample, self.R, self.orth, most, cand, work,
                                   leaves)
                if n < 0:                   # brute force (-1) or not finite (-2)
                    out[i] = n
                elif n == 1:                # the nearest point is always a candidate
                    out[i] = cand[0]
                elif n > 1:
                    c = cand[:n]
                    dd = ((A[i] - P[c]) ** 2).sum(axis=1)
                    out[i] = c[dd == dd.min()].min()
        finally:
            if mine:
                self._lock.release()
        return out

    def _compiled_arrays(self, P: np.ndarray) -> tuple:
        """The compiled search's views: the residual groups as [start, end), the chunks'
        boxes as (nf, nc), and the feature boxes of blocks of ``BLOCK`` consecutive slots
        (nc, nf, blocks; +-inf for padding), from the points' features in float64; first
        the compiled kernel itself (numba is imported here, on first use)."""
        from .compiled import BLOCK, pca_candidates
        if BLOCK != self.BLOCK:
            raise RuntimeError("compiled.BLOCK and _PCAIndex.BLOCK differ")
        nf, nc, cs = self.lo.shape[0], self.n_chunks, self.cs
        bounds = np.array([[g[0], g[-1] + 1] for g in self.groups], dtype=np.int64)
        F = self._features((P - self.mean) @ self.V)
        width = self.BLOCK
        nb = cs // width
        sub_lo = np.full((nc, nf, nb), np.inf)
        sub_hi = np.full((nc, nf, nb), -np.inf)
        slots = self.perm.reshape(nc, cs)
        for c in range(nc):
            for b in range(nb):
                ix = slots[c, b * width:(b + 1) * width]
                ix = ix[ix >= 0]
                if ix.size:
                    sub_lo[c, :, b] = F[ix].min(axis=0)
                    sub_hi[c, :, b] = F[ix].max(axis=0)
        return (pca_candidates, bounds.reshape(-1, 2), np.ascontiguousarray(self.lo[:, :, 0]),
                np.ascontiguousarray(self.hi[:, :, 0]), sub_lo, sub_hi,
                np.ascontiguousarray(self.aug.transpose(0, 2, 1)))

    def _features(self, Z: np.ndarray) -> np.ndarray:
        F = np.empty((Z.shape[0], self.k + len(self.groups)))
        F[:, :self.k] = Z[:, :self.k]
        for i, g in enumerate(self.groups):
            F[:, self.k + i] = np.sqrt(np.einsum("ij,ij->i", Z[:, g], Z[:, g]))
        return F

    def __getstate__(self) -> dict:
        state = self.__dict__.copy()
        for name in ("_lock", "_work", "_cwork", "_flat"):
            state.pop(name, None)
        return state

    def __setstate__(self, state: dict) -> None:
        self.__dict__.update(state)
        self._lock = threading.Lock()
        self._work = np.empty(0, dtype=np.float32)
        self._cwork = None
        self._flat = None

    def _err_z(self, zn: np.ndarray) -> np.ndarray:
        """Bound on |error| of the computed ``||f(z_x) - f(z_p)||`` and ``||z_x - z_p||`` from
        the float64 rotations and feature norms, each of z_x and z_p."""
        d = self.V.shape[0]
        return 8 * (d + 2) * np.sqrt(d) * _U64 * (zn + self.R) + 1e-300

    def _lower_bounds(self, G: np.ndarray, Af: np.ndarray, pj: np.ndarray, pq: np.ndarray,
                      aug: np.ndarray) -> None:
        """``G[i] = ||f_p||^2 - 2 f_x . f_p`` (float32) over the points of chunk pj[i] of
        ``aug`` for query pq[i]; pairs sorted by chunk, one GEMM per chunk."""
        ends = np.cumsum(np.bincount(pj, minlength=self.n_chunks))
        start = 0
        for j in np.unique(pj):
            end = ends[j]
            np.matmul(Af[pq[start:end]], aug[j], out=G[start:end])
            start = end

    def _threshold(self, U: np.ndarray, qq: np.ndarray, ez: np.ndarray, fn32: np.ndarray,
                   pj: np.ndarray, pq: np.ndarray) -> np.ndarray:
        """float32 per pair: every point with naive squared distance <= U[q] has its G below.

        With t the exact squared distance, ``||f_x - f_p|| <= sqrt((1 + orth) t) + 2 ez`` and
        the naive value is >= t / (1 + (d + 4) u64); G's float32 error is at most
        2 (nf + 4) u32 (||f_x|| + ||f_p||)^2 (nf features).
        """
        nf, d = self.lo.shape[0], self.V.shape[0]
        Uz = (np.sqrt(U * ((1 + self.orth) * (1 + (d + 4) * _U64))) + 2 * ez) ** 2
        base = Uz - qq * (1 - 4 * (nf + 2) * _U64) + 16 * _U64 * (Uz + qq)
        rf = self.rf[pj]
        thr = base[pq] + 2 * (nf + 4) * _U32 * (fn32[pq] + rf) ** 2
        thr32 = thr.astype(np.float32)
        low = thr32.astype(np.float64) < thr
        thr32[low] = np.nextafter(thr32[low], np.float32(np.inf))
        return thr32

    def query(self, A: np.ndarray, P: np.ndarray, upper: np.ndarray | None = None
              ) -> np.ndarray:
        m = A.shape[0]
        if not self.usable:
            return np.full(m, -1, dtype=np.int64)
        # blocks of queries bound the (pairs, cs) float32 work array (<= 32 MB)
        step = max(16, (1 << 23) // (self.n_chunks * self.cs))
        if m > step:
            return np.concatenate([self.query(A[i:i + step], P,
                                              None if upper is None else upper[i:i + step])
                                   for i in range(0, m, step)])
        Zx = (A - self.mean) @ self.V                                       # (m, d)
        zn = np.sqrt(np.einsum("ij,ij->i", Zx, Zx))
        far = zn > 64.0 * self.R          # far outside the data: bounds useless, brute force
        if np.any(far):
            out = np.full(m, -1, dtype=np.int64)
            sub = np.flatnonzero(~far)
            if sub.size:
                out[sub] = self.query(A[sub], P, None if upper is None else upper[sub])
            return out
        # the work array is reused between calls (fresh multi-MB arrays cost page faults);
        # a concurrent call allocates its own
        mine = self._lock.acquire(blocking=False)
        try:
            return self._query(A, P, Zx, zn, self._work if mine else None, mine, upper)
        finally:
            if mine:
                self._lock.release()

    def _query(self, A: np.ndarray, P: np.ndarray, Zx: np.ndarray, zn: np.ndarray,
               work: np.ndarray | None, keep: bool, upper: np.ndarray | None = None
               ) -> np.ndarray:
        m = A.shape[0]
        nf, cs, d, nc = self.lo.shape[0], self.cs, self.V.shape[0], self.n_chunks
        ez = self._err_z(zn)
        fx = self._features(Zx)
        qq = np.einsum("ij,ij->i", fx, fx)
        Af = np.empty((m, nf + 1), dtype=np.float32)
        Af[:, :nf] = fx
        Af[:, nf] = 1.0
        fn32 = np.sqrt(np.einsum("ij,ij->i", Af[:, :nf], Af[:, :nf], dtype=np.float64))
        # 1. box bound per (chunk, query): squared distance from f_x to the chunk's box
        g = np.maximum(self.lo - fx.T[:, None, :], fx.T[:, None, :] - self.hi)
        np.maximum(g, 0.0, out=g)
        box = np.einsum("fcm,fcm->cm", g, g)                                # (chunks, m)
        # 2. a first upper bound U: in each query's home chunk (smallest box bound), the
        #    sample point (every SAMPLE-th) with the smallest lower bound, scored exactly
        home = box.argmin(axis=0)
        q1 = np.argsort(home, kind="stable")
        j1 = home[q1]
        G1 = np.empty((m, self.cs_sample), dtype=np.float32)
        self._lower_bounds(G1, Af, j1, q1, self.aug_sample)
        a1 = G1.argmin(axis=1)
        U = np.empty(m)
        U[q1] = ((A[q1] - P[self.perm_sample[j1 * self.cs_sample + a1]]) ** 2).sum(axis=1)
        if upper is not None:         # a known point's naive distance: also a valid U
            np.minimum(U, upper, out=U)
        # queries whose bounds select most of the sample (points spread evenly in all
        # dimensions, or queries far from them) go to brute force right away
        t1 = self._threshold(U, qq, ez, fn32, j1, q1)
        brute = np.zeros(m, dtype=bool)
        brute[q1] = np.count_nonzero(G1 <= t1[:, None], axis=1) > 0.75 * self.n_sample[j1]
        # 3. every chunk whose box bound does not exceed U (float64 box from features within
        #    ez of the exact ones; the home chunk always): lower bounds of all its points;
        #    the smallest of each (chunk, query) pair, scored exactly, may lower U
        lim = np.sqrt(U * ((1 + self.orth) * (1 + (d + 4) * _U64))) + 2 * ez
        need = np.sqrt(box * (1 - 4 * (nf + 2) * _U64)) <= lim
        need[home, np.arange(m)] = True
        need[:, brute] = False
        pj, pq = np.nonzero(need)
        tot = pq.size
        if work is None or work.size < tot * cs:
            work = np.empty(max(tot, m * nc // 4) * cs, dtype=np.float32)
            if keep:
                self._work = work
        G = work[:tot * cs].reshape(tot, cs)
        self._lower_bounds(G, Af, pj, pq, self.aug)
        am = G.argmin(axis=1)
        gmin = G[np.arange(tot), am]
        thr = self._threshold(U, qq, ez, fn32, pj, pq)
        r = np.flatnonzero(gmin <= thr)
        if r.size:
            pts = self.perm[pj[r] * cs + am[r]]
            np.minimum.at(U, pq[r], ((A[pq[r]] - P[pts]) ** 2).sum(axis=1))
            thr = self._threshold(U, qq, ez, fn32, pj, pq)
        # 4. every point whose lower bound does not exceed the threshold of the final U is
        #    scored with the naive formula: smallest distance, then smallest index, wins
        rows = np.flatnonzero(gmin <= thr)
        hit = np.flatnonzero((G[rows] <= thr[rows, None]).ravel())
        rr, c = np.divmod(hit, cs)
        rr = rows[rr]
        cq = pq[rr]
        cp = self.perm[pj[rr] * cs + c]
        # ... and so do queries left with too many candidates
        many = np.bincount(cq, minlength=m) > max(256, P.shape[0] // 32)
        if np.any(many):
            brute |= many
            keep_c = ~many[cq]
            cq, cp = cq[keep_c], cp[keep_c]
        dd = np.empty(cq.size)
        for s in range(0, cq.size, 256):            # small temporaries (no page faults)
            dd[s:s + 256] = ((A[cq[s:s + 256]] - P[cp[s:s + 256]]) ** 2).sum(axis=1)
        dmin = np.full(m, np.inf)
        np.minimum.at(dmin, cq, dd)
        tie = dd == dmin[cq]
        best = np.full(m, np.iinfo(np.int64).max)
        np.minimum.at(best, cq[tie], cp[tie])
        out = np.full(m, -1, dtype=np.int64)
        found = np.isfinite(dmin) & ~brute
        out[found] = best[found]
        return out

