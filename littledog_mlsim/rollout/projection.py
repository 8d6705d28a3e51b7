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
rebuilds the projection (the KD-tree, if used, is rebuilt on first use; it is not stored).
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

    Methods (``benchmarks/projection_nn.md`` has the timings that chose the default):

    - ``"brute"`` (default): one GEMM per chunk of points, ``[a, 1] @ [-2 b_j, ||b_j||^2]^T``
      = ``||a - b_j||^2 - ||a||^2`` (the row constant ``||a||^2`` dropped); every point within a
      rounding-error bound of the row minimum is then re-scored with the direct
      ``((a - b_j) ** 2).sum()``, smallest index first on exact ties: the same answer as a naive
      loop over the points. Predictable time, about 0.5 ms for one query among 61k points.
    - ``"kdtree"``: ``scipy.spatial.cKDTree`` (``eps=0``, exact; ties may pick another of the
      equidistant points), built on first use. Faster than brute only for queries very close to
      the points; slower, with a long tail, for queries as far from them as real predictions
      (and the TestPool states themselves) are; up to 10x slower in the worst case.

    Queries further than ``far`` from the origin (a diverging rollout) are searched at norm
    ``far`` along their direction (which keeps the GEMM finite); both methods use brute force
    for them.
    """

    METHODS: ClassVar[tuple[str, ...]] = ("brute", "kdtree")

    def __init__(self, points: np.ndarray, method: str = "brute",
                 chunk_elems: int = 1 << 18, far: float = 1e8) -> None:
        if method not in self.METHODS:
            raise ValueError(f"method must be one of {self.METHODS}, got {method!r}")
        P = np.asarray(points, dtype=np.float64)
        if P.ndim != 2 or P.shape[0] == 0:
            raise ValueError(f"points must be a non-empty (n, d) array, got {P.shape}")
        if not np.all(np.isfinite(P)):
            raise ValueError("points hold NaN or inf")
        self.method = method
        self.chunk_elems = int(chunk_elems)
        self.far = float(far)
        n, d = P.shape
        sq = np.einsum("ij,ij->i", P, P)
        # [-2 P, ||P||^2]^T, (d + 1, n); -0.5 * its first d rows give P^T back exactly (scaling by
        # 2 is exact). Stored transposed: a single query is then an axpy-friendly (1, d+1) GEMM.
        self._augT = np.empty((d + 1, n))
        self._augT[:d] = -2.0 * P.T
        self._augT[d] = sq
        self._max_norm = float(np.sqrt(sq.max()))
        self._tree = None

    @property
    def n_points(self) -> int:
        return self._augT.shape[1]

    @property
    def dim(self) -> int:
        return self._augT.shape[0] - 1

    @property
    def points(self) -> np.ndarray:
        """(n, d) the points (a new array)."""
        return -0.5 * self._augT[:-1].T

    def build_tree(self):
        """The cKDTree over the points (built once; build early to keep it out of a 10 ms step)."""
        if self._tree is None:
            from scipy.spatial import cKDTree
            self._tree = cKDTree(self.points)
        return self._tree

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
        out[near] = self.build_tree().query(A[near], k=1, eps=0.0, p=2.0)[1]
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
            exact = ((A[r] - (-0.5 * self._augT[:d, c].T)) ** 2).sum(axis=1)
            best_idx[r] = c[np.argmin(exact)]   # first of equal minima = smallest index
        return best_idx


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
                 scale: np.ndarray | None = None, nn_method: str = "brute") -> None:
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
                    alpha: float = 0.5, nn_method: str = "brute") -> Projection:
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
