"""Projection of predicted states back towards the TrainPool (paper Section VI).

Every state the learned simulator predicts is passed through a ``Projection`` before it is fed
back as the next feature vector (``simulate.rollout``). Three kinds:

- ``none``:  no adjustment (the paper's baseline).
- ``bound``: BOUND, ``s^i := min(U^i, max(s^i, L^i))`` with ``L^i``/``U^i`` the minimum/maximum of
  element ``i`` over the TrainPool states.
- ``alpha``: alpha-PROJ, ``s := (1 - alpha) s + alpha q``, ``0 <= alpha <= 1``, with ``q`` the
  TrainPool state nearest to ``s``. Nearest is measured in the *normalised* Euclidean distance
  over all 33 state elements: each element divided by its TrainPool standard deviation (divisor 1
  where the std is below 1e-12), the distance the paper uses to pick LGPR's local model. (The
  paper's equation for q writes the plain norm; normalising keeps metres, radians and rad/s
  elements comparable.) The search is exact; see ``NearestNeighbour``.

Every kind, ``none`` included, also applies two constraints that hold for any LittleDog state
(``enforce_limits``), before and after the adjustment:

- joint angles ``q_*`` are clipped to ``layout.JOINT_LOWER``/``JOINT_UPPER``;
- the angle differences ``droll dpitch dyaw`` are wrapped to (-pi, pi]. Values already inside
  are returned bit for bit (wrapping an in-range value with ``mod`` would change its last bits).

So ``alpha = 0`` equals ``none`` exactly, and ``alpha = 1`` returns TrainPool states exactly (as
long as the TrainPool states themselves satisfy the two constraints, as recorded states do).

Non-finite predictions: a row holding any NaN or +-inf is set entirely to NaN by every kind (a
clip would otherwise turn +inf into a finite bound and hide a divergence). ``rollout`` keeps such
rows NaN and the metrics report them.

Storage: ``to_arrays()`` gives a flat dict of NumPy arrays (the kind as a 0-d unicode array), which
``numpy.savez`` stores and ``numpy.load(allow_pickle=False)`` reads back; ``Projection.from_arrays``
rebuilds the projection (the nearest-neighbour index is rebuilt from the TrainPool states; it is
not stored).
"""
from __future__ import annotations

from typing import Any, ClassVar, Mapping

import numpy as np

from ..layout import JOINT_LOWER, JOINT_UPPER, N_STATE, WRAPPED_STATE, S, wrap_angle

__all__ = [
    "PROJECTION_KINDS", "PROJECTION_FORMAT_VERSION", "Projection", "NoProjection",
    "BoundProjection", "AlphaProjection", "NearestNeighbour", "make_projection",
    "enforce_limits",
]

PROJECTION_KINDS: tuple[str, ...] = ("none", "bound", "alpha")
PROJECTION_FORMAT_VERSION = 1
_MIN_STD = 1e-12


# ---------------------------------------------------------------------------------------------
# constraints every projection keeps


def enforce_limits(states: np.ndarray) -> np.ndarray:
    """(..., 33) -> new (..., 33): joint angles clipped to the joint limits, angle deltas wrapped.

    Elements already inside their range are returned unchanged (bit for bit); NaN stays NaN.
    """
    s = np.array(states, dtype=np.float64, copy=True)
    s[..., S.q] = np.clip(s[..., S.q], JOINT_LOWER, JOINT_UPPER)
    d = s[..., WRAPPED_STATE]
    outside = (d > np.pi) | (d <= -np.pi)
    if np.any(outside):
        s[..., WRAPPED_STATE] = np.where(outside, wrap_angle(d), d)
    return s


def _check_states(states: np.ndarray, what: str) -> np.ndarray:
    s = np.asarray(states, dtype=np.float64)
    if s.ndim != 2 or s.shape[1] != N_STATE or s.shape[0] == 0:
        raise ValueError(f"{what} must be a non-empty (n, {N_STATE}) array, got {s.shape}")
    if not np.all(np.isfinite(s)):
        raise ValueError(f"{what} hold NaN or inf")
    return s


# ---------------------------------------------------------------------------------------------
# exact nearest neighbour


class NearestNeighbour:
    """Exact Euclidean nearest neighbour of query rows among ``points`` (n, d), float64.

    Every method returns the answer of a naive loop, ``argmin(((points - x) ** 2).sum(axis=1))``
    per query ``x``: the smallest such distance, and on exact ties the smallest index
    (``"kdtree"`` excepted, see below). Methods (``benchmarks/projection_nn.md`` has the timings):

    - ``"auto"`` (default): ``"pca"`` for at least ``4 * chunk_points`` points in at least 8
      dimensions, else ``"brute"``.
    - ``"pca"``: lower bounds first, exact distances only for the few points they cannot rule
      out. The points are rotated once into their principal axes (``z = (p - mean) V``) and
      split into chunks of about ``chunk_points`` points by median cuts along the first two
      principal coordinates. For a batch of queries:

      1. an upper bound ``U0`` on each query's nearest distance from ~1024 pivot points (one
         small float32 GEMM over all coordinates);
      2. per (query, chunk) the box bound: squared distance from the query's first ``k``
         principal coordinates (``n_components``, default 16) to the chunk's bounding box in
         them; chunks with a bound above ``U0`` are skipped (about 3/4 of them for alpha-PROJ's
         queries);
      3. for the remaining pairs one float32 GEMM per chunk gives every point's distance in
         the first ``k`` principal coordinates, a lower bound on its full distance; the point
         with the smallest bound in each pair is scored exactly, giving ``U1``;
      4. every point whose lower bound is below ``U1`` plus a rounding margin (a few tens of
         points per query on the real TrainPool) is scored with the naive loop's formula
         ``((x - p) ** 2).sum()`` in the original coordinates, and the minimum taken.

      The margin covers the float32 GEMM's rounding error (bounded from the coordinates'
      norms per chunk) and the float64 rotation's, so no point that could be the nearest is
      ever skipped; the answer is exactly the naive loop's. Queries the bounds would not help
      (far outside the data, or with too many candidates) go to ``"brute"``.
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

    def __init__(self, points: np.ndarray, method: str = "auto",
                 chunk_elems: int = 1 << 18, far: float = 1e8, n_components: int = 16,
                 chunk_points: int = 2048) -> None:
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
        if self._resolve(method) == "pca":
            self.build_index()

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
        return "pca" if self.n_points >= 4 * self.chunk_points and self.dim >= 8 else "brute"

    def build_tree(self):
        """The cKDTree over the points (built once; build early to keep it out of a 10 ms step)."""
        if self._tree is None:
            from scipy.spatial import cKDTree
            self._tree = cKDTree(self._P)
        return self._tree

    def build_index(self) -> "_PCAIndex":
        """The principal-axes index of ``"pca"`` (built once, in the constructor if used)."""
        if self._pca is None:
            self._pca = _PCAIndex(self._P, self.n_components, self.chunk_points)
        return self._pca

    def query(self, X: np.ndarray, method: str | None = None) -> np.ndarray:
        """Index (m,) int64 of the nearest point to each row of ``X`` (m, d) (finite values)."""
        A = np.asarray(X, dtype=np.float64)
        if A.ndim != 2 or A.shape[1] != self.dim:
            raise ValueError(f"queries must be (m, {self.dim}), got {A.shape}")
        if not np.all(np.isfinite(A)):
            raise ValueError("queries hold NaN or inf")
        method = method or self.method
        if method not in self.METHODS:
            raise ValueError(f"method must be one of {self.METHODS}, got {method!r}")
        method = self._resolve(method)
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
            res = self.build_index().query(An, self._P)
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


_U32 = float(np.finfo(np.float32).eps) / 2      # unit roundoff of float32
_U64 = float(np.finfo(np.float64).eps) / 2
_PAD = np.float32(1e38)                         # lower bound of the padding slots of a chunk


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
    """The data of ``NearestNeighbour``'s ``"pca"`` method (see there); float32 GEMMs, exact
    answers. ``query`` returns -1 for rows it leaves to brute force."""

    N_PIVOTS = 1024
    SPLIT_DIMS = 2

    def __init__(self, P: np.ndarray, n_components: int, chunk_points: int) -> None:
        n, d = P.shape
        k = min(n_components, d)
        self.k = k
        self.mean = P.mean(axis=0)
        C = P - self.mean
        w, V = np.linalg.eigh(C.T @ C)
        self.V = np.ascontiguousarray(V[:, ::-1])               # descending variance
        Z = C @ self.V                                          # (n, d) rotated points
        znorm = np.sqrt(np.einsum("ij,ij->i", Z, Z))
        self.R = float(znorm.max())
        # How far V is from orthonormal: |V^T y|^2 <= (1 + orth) |y|^2.
        self.orth = float(np.abs(self.V.T @ self.V - np.eye(d)).sum(axis=1).max()) + 4 * _U64
        chunks = _median_split(Z[:, :min(self.SPLIT_DIMS, d)], np.arange(n), chunk_points)
        chunks.sort(key=lambda ix: int(ix[0]))
        nc = len(chunks)
        cs = max(ix.size for ix in chunks)
        self.cs = cs
        self.perm = np.full((nc, cs), -1, dtype=np.int64)
        self.aug = np.zeros((nc, k + 1, cs), dtype=np.float32)  # [-2 z_k, ||z_k||^2] per chunk
        self.aug[:, k] = _PAD
        self.lo = np.empty((k, nc))
        self.hi = np.empty((k, nc))
        self.rk = np.empty(nc)                                  # max ||z_k|| (float32 input)
        for j, ix in enumerate(chunks):
            zk = Z[ix, :k]
            zk32 = zk.astype(np.float32)
            self.perm[j, :ix.size] = ix
            self.aug[j, :k, :ix.size] = -2 * zk32.T
            self.aug[j, k, :ix.size] = np.einsum("ij,ij->i", zk, zk)
            self.lo[:, j] = zk.min(axis=0)
            self.hi[:, j] = zk.max(axis=0)
            self.rk[j] = np.sqrt(np.einsum("ij,ij->i", zk32, zk32, dtype=np.float64).max())
        self.perm = self.perm.ravel()
        # pivots, spread over the chunks: exact rotated coordinates for the upper bound U0
        valid = self.perm[self.perm >= 0]
        piv = valid[np.unique(np.linspace(0, n - 1, min(n, self.N_PIVOTS)).astype(np.int64))]
        zp = Z[piv].astype(np.float32)
        self.piv_aug = np.empty((d + 1, piv.size), dtype=np.float32)
        self.piv_aug[:d] = -2 * zp.T
        self.piv_aug[d] = np.einsum("ij,ij->i", Z[piv], Z[piv])
        self.piv_r = float(np.sqrt(np.einsum("ij,ij->i", zp, zp, dtype=np.float64).max()))
        self._buf = np.empty(0, dtype=np.float32)
        # float32 holds the coordinates and the padding stays above every threshold
        self.usable = self.R < 1e15

    def _err_z(self, zn: np.ndarray) -> np.ndarray:
        """Bound on the error of ||z_x - z_p|| from computing z in float64 (per query)."""
        d = self.V.shape[0]
        return 4 * (d + 2) * np.sqrt(d) * _U64 * (zn + self.R + 1e-300)

    def query(self, A: np.ndarray, P: np.ndarray) -> np.ndarray:
        m = A.shape[0]
        if not self.usable:
            return np.full(m, -1, dtype=np.int64)
        # Blocks of queries keep the (pairs, chunk) buffer below ~32 MB.
        step = max(16, (1 << 23) // max(1, self.perm.size))
        if m > step:
            return np.concatenate([self.query(A[i:i + step], P) for i in range(0, m, step)])
        k, cs, d = self.k, self.cs, self.V.shape[0]
        Zx = (A - self.mean) @ self.V                                       # (m, d)
        zn = np.sqrt(np.einsum("ij,ij->i", Zx, Zx))
        out = np.full(m, -1, dtype=np.int64)
        ok = zn <= 64.0 * (self.R + 1e-300)         # far outside the data: brute force
        if not np.all(ok):
            sub = np.flatnonzero(ok)
            if sub.size:
                out[sub] = self.query(A[sub], P)
            return out
        # Any computed squared distance D' of the true squared distance D (rotated, float32 GEMM
        # or direct float64) satisfies |D' - D| <= slack(D), with slack growing with the norms;
        # the margins below add it wherever a bound is compared.
        ez = self._err_z(zn)
        zx32 = Zx.astype(np.float32)
        zxn32 = np.sqrt(np.einsum("ij,ij->i", zx32, zx32, dtype=np.float64))
        # 1. U0 >= the smallest naive squared distance, from the pivots
        Aq = np.empty((m, d + 1), dtype=np.float32)
        Aq[:, :d] = zx32
        Aq[:, d] = 1.0
        g32 = 2 * (d + 4) * _U32 * (zxn32 + self.piv_r) ** 2
        rot = (Aq @ self.piv_aug).min(axis=1).astype(np.float64) + zn * zn + g32
        rot *= 1 + 4 * _U64
        U0 = (np.sqrt(rot) + 2 * ez) ** 2 / (1 - self.orth) * (1 + (d + 8) * _U64)
        # 2. box bound per (chunk, query) over the first k rotated coordinates
        box = np.zeros((self.lo.shape[1], m))
        for i in range(k):
            x = Zx[:, i]
            g = np.maximum(self.lo[i][:, None] - x, x - self.hi[i][:, None])
            np.maximum(g, 0.0, out=g)
            g *= g
            box += g
        # chunk j may hold the nearest point only if its box bound (float64, from z's within
        # ez of the exact ones) is at most the rotated U0
        lim = np.sqrt(U0 * (1 + self.orth) * (1 + (d + 4) * _U64)) + 2 * ez
        need = np.sqrt(box * (1 - 4 * (k + 2) * _U64)) <= lim
        pj, pq = np.nonzero(need)
        tot = pq.size
        # 3. lower bounds of every point of the needed chunks (float32 GEMM per chunk)
        if self._buf.size < tot * cs:
            self._buf = np.empty(tot * cs, dtype=np.float32)
        G = self._buf[:tot * cs].reshape(tot, cs)
        Ak = np.empty((m, k + 1), dtype=np.float32)
        Ak[:, :k] = zx32[:, :k]
        Ak[:, k] = 1.0
        ends = np.cumsum(np.bincount(pj, minlength=self.lo.shape[1]))
        start = 0
        for j in np.unique(pj):
            end = ends[j]
            np.matmul(Ak[pq[start:end]], self.aug[j], out=G[start:end])
            start = end
        am = G.argmin(axis=1)
        gm = G[np.arange(tot), am]
        best_pt = self.perm[pj * cs + am]
        dd = ((A[pq] - P[best_pt]) ** 2).sum(axis=1)                     # naive formula
        U1 = np.full(m, np.inf)
        np.minimum.at(U1, pq, dd)
        # 4. threshold on G: a point p with naive squared distance <= U1 has
        #    G(p) <= U1 (1 + orth + ...) + slack - ||z_x,k||^2
        zk = Zx[:, :k]
        qq = np.einsum("ij,ij->i", zk, zk)
        Uq = (np.sqrt(U1 * (1 + self.orth) * (1 + (d + 4) * _U64)) + 2 * ez) ** 2
        base = (Uq - qq * (1 - 4 * (k + 2) * _U64)) + 8 * _U64 * (Uq + qq)
        zkn32 = np.sqrt(np.einsum("ij,ij->i", zx32[:, :k], zx32[:, :k], dtype=np.float64))
        rk = self.rk[pj]
        thr = base[pq] + 2 * (k + 4) * _U32 * (zkn32[pq] + rk) ** 2
        thr32 = thr.astype(np.float32)
        low = thr32.astype(np.float64) < thr
        thr32[low] = np.nextafter(thr32[low], np.float32(np.inf))
        rows = np.flatnonzero(gm <= thr32)
        hit = np.flatnonzero((G[rows] <= thr32[rows, None]).ravel())
        r, c = np.divmod(hit, cs)
        r = rows[r]
        cq = pq[r]
        cp = self.perm[pj[r] * cs + c]
        # too many candidates (points spread evenly in all dimensions): brute force is cheaper
        counts = np.bincount(cq, minlength=m)
        many = counts > max(256, P.shape[0] // 32)
        if np.any(many):
            keep = ~many[cq]
            cq, cp = cq[keep], cp[keep]
        dd = ((A[cq] - P[cp]) ** 2).sum(axis=1)                          # naive formula
        order = np.lexsort((cp, dd, cq))            # by query, then distance, then index
        cq, cp = cq[order], cp[order]
        first = np.flatnonzero(np.r_[True, cq[1:] != cq[:-1]])
        out[cq[first]] = cp[first]
        out[many] = -1
        return out


# ---------------------------------------------------------------------------------------------
# projections


class Projection:
    """Base class: ``projection(states)`` maps (B, 33) or (33,) predicted states to projected ones.

    Subclasses implement ``_project`` on finite (B, 33) rows that already satisfy the joint
    limits and angle wrapping, and the ``_arrays``/``_from`` storage pair.
    """

    kind: ClassVar[str] = ""

    def __call__(self, states: np.ndarray) -> np.ndarray:
        s = np.asarray(states, dtype=np.float64)
        single = s.ndim == 1
        if single:
            s = s[None, :]
        if s.ndim != 2 or s.shape[1] != N_STATE:
            raise ValueError(f"states must be (B, {N_STATE}) or ({N_STATE},), got {s.shape}")
        finite = np.isfinite(s).all(axis=1)
        out = enforce_limits(s)
        if not finite.all():
            out[~finite] = np.nan
            if finite.any():
                out[finite] = enforce_limits(self._project(out[finite]))
        elif out.shape[0]:
            out = enforce_limits(self._project(out))
        return out[0] if single else out

    def _project(self, s: np.ndarray) -> np.ndarray:
        raise NotImplementedError

    def describe(self) -> dict[str, Any]:
        """JSON-ready summary (kind and parameters, not the TrainPool)."""
        return {"kind": self.kind}

    # storage -------------------------------------------------------------------------------

    def to_arrays(self, prefix: str = "") -> dict[str, np.ndarray]:
        """Flat dict of arrays for ``numpy.savez`` (no objects; loads with allow_pickle=False)."""
        arrays = {"kind": np.array(self.kind),
                  "format_version": np.array(PROJECTION_FORMAT_VERSION)}
        arrays.update(self._arrays())
        return {prefix + k: v for k, v in arrays.items()}

    def _arrays(self) -> dict[str, np.ndarray]:
        return {}

    @staticmethod
    def from_arrays(arrays: Mapping[str, np.ndarray], prefix: str = "") -> "Projection":
        """Rebuild from ``to_arrays`` output (or an ``NpzFile``); ValueError on anything invalid."""
        def get(name: str) -> np.ndarray:
            key = prefix + name
            if key not in arrays:
                raise ValueError(f"projection arrays: missing {key!r}")
            return np.asarray(arrays[key])

        kind_arr = get("kind")
        if kind_arr.dtype.kind != "U" or kind_arr.shape != ():
            raise ValueError("projection arrays: 'kind' must be a 0-d string array")
        kind = str(kind_arr[()])
        version = get("format_version")
        if version.shape != () or version.dtype.kind not in "iu":
            raise ValueError("projection arrays: 'format_version' must be a 0-d integer")
        if int(version) != PROJECTION_FORMAT_VERSION:
            raise ValueError(f"projection arrays: format_version {int(version)} unknown "
                             f"(this code reads {PROJECTION_FORMAT_VERSION})")
        cls = _KINDS.get(kind)
        if cls is None:
            raise ValueError(f"projection arrays: unknown kind {kind!r}; known {PROJECTION_KINDS}")
        return cls._from(get)

    @classmethod
    def _from(cls, get) -> "Projection":
        return cls()


def _float_array(a: np.ndarray, shape: tuple[int | None, ...], name: str) -> np.ndarray:
    if a.dtype.kind not in "fiu":
        raise ValueError(f"projection arrays: {name!r} must be numeric, got dtype {a.dtype}")
    if a.ndim != len(shape) or any(s is not None and s != t for s, t in zip(shape, a.shape)):
        raise ValueError(f"projection arrays: {name!r} has shape {a.shape}, expected {shape}")
    a = np.array(a, dtype=np.float64)
    if not np.all(np.isfinite(a)):
        raise ValueError(f"projection arrays: {name!r} holds NaN or inf")
    return a


class NoProjection(Projection):
    """``none``: only the joint limits and angle wrapping."""

    kind = "none"

    def _project(self, s: np.ndarray) -> np.ndarray:
        return s


class BoundProjection(Projection):
    """BOUND: clip each element to [lower, upper], its range over the TrainPool states."""

    kind = "bound"

    def __init__(self, lower: np.ndarray, upper: np.ndarray) -> None:
        self.lower = _float_array(np.asarray(lower), (N_STATE,), "lower")
        self.upper = _float_array(np.asarray(upper), (N_STATE,), "upper")
        if np.any(self.lower > self.upper):
            raise ValueError("bound projection: lower > upper for some element")

    @classmethod
    def from_train_states(cls, train_states: np.ndarray) -> "BoundProjection":
        s = _check_states(train_states, "TrainPool states")
        return cls(s.min(axis=0), s.max(axis=0))

    def _project(self, s: np.ndarray) -> np.ndarray:
        return np.clip(s, self.lower, self.upper)

    def _arrays(self) -> dict[str, np.ndarray]:
        return {"lower": self.lower, "upper": self.upper}

    @classmethod
    def _from(cls, get) -> "BoundProjection":
        return cls(_float_array(get("lower"), (N_STATE,), "lower"),
                   _float_array(get("upper"), (N_STATE,), "upper"))


class AlphaProjection(Projection):
    """alpha-PROJ: ``s := (1 - alpha) s + alpha q``, q the nearest TrainPool state (normalised).

    ``train_states`` (n, 33) raw TrainPool states; ``scale`` (33,) the per-element divisor of the
    distance (default: their std, 1 where std < 1e-12); ``nn_method`` see ``NearestNeighbour``.
    """

    kind = "alpha"

    def __init__(self, train_states: np.ndarray, alpha: float = 0.5,
                 scale: np.ndarray | None = None, nn_method: str = "auto") -> None:
        alpha = float(alpha)
        if not 0.0 <= alpha <= 1.0:
            raise ValueError(f"alpha must be in [0, 1], got {alpha}")
        self.alpha = alpha
        self.train_states = np.ascontiguousarray(_check_states(train_states, "TrainPool states"))
        if scale is None:
            std = self.train_states.std(axis=0)
            scale = np.where(std < _MIN_STD, 1.0, std)
        self.scale = _float_array(np.asarray(scale), (N_STATE,), "scale")
        if np.any(self.scale <= 0):
            raise ValueError("alpha projection: scale must be positive")
        self.nn = NearestNeighbour(self.train_states / self.scale, method=nn_method)

    def nearest(self, states: np.ndarray) -> np.ndarray:
        """Index into ``train_states`` (B,) of the nearest TrainPool state of each finite row."""
        return self.nn.query(np.asarray(states, dtype=np.float64) / self.scale)

    def _project(self, s: np.ndarray) -> np.ndarray:
        if self.alpha == 0.0:
            return s
        q = self.train_states[self.nearest(s)]
        if self.alpha == 1.0:
            return q.copy()
        return (1.0 - self.alpha) * s + self.alpha * q

    def describe(self) -> dict[str, Any]:
        return {"kind": self.kind, "alpha": self.alpha,
                "n_train_states": int(self.train_states.shape[0])}

    def _arrays(self) -> dict[str, np.ndarray]:
        return {"alpha": np.array(self.alpha), "train_states": self.train_states,
                "scale": self.scale}

    @classmethod
    def _from(cls, get) -> "AlphaProjection":
        return cls(_float_array(get("train_states"), (None, N_STATE), "train_states"),
                   alpha=float(_float_array(get("alpha"), (), "alpha")),
                   scale=_float_array(get("scale"), (N_STATE,), "scale"))


_KINDS: dict[str, type[Projection]] = {
    "none": NoProjection, "bound": BoundProjection, "alpha": AlphaProjection,
}


def make_projection(kind: str, train_states: np.ndarray | None = None,
                    alpha: float = 0.5, nn_method: str = "auto") -> Projection:
    """The projection ``kind`` (``none``/``bound``/``alpha``) built from TrainPool states (n, 33).

    ``train_states`` are the states of the TrainPool (e.g. the responses ``Y`` of
    ``features_responses`` on the TrainPool); not needed for ``none``.
    """
    if kind not in _KINDS:
        raise ValueError(f"projection must be one of {PROJECTION_KINDS}, got {kind!r}")
    if kind == "none":
        return NoProjection()
    if train_states is None:
        raise ValueError(f"projection {kind!r} needs the TrainPool states")
    if kind == "bound":
        return BoundProjection.from_train_states(train_states)
    return AlphaProjection(train_states, alpha=alpha, nn_method=nn_method)
