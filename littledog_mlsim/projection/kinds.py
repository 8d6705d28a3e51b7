"""Projection of predicted states back towards the TrainPool (paper Section VI).

Every state the learned simulator predicts is passed through a ``Projection`` before it is fed
back as the next feature vector (``rollout.simulate.rollout``). Three kinds:

- ``none``:  no adjustment (the paper's baseline).
- ``bound``: BOUND, ``s^i := min(U^i, max(s^i, L^i))`` with ``L^i``/``U^i`` the minimum/maximum of
  element ``i`` over the TrainPool states.
- ``alpha``: alpha-PROJ, ``s := (1 - alpha) s + alpha q``, ``0 <= alpha <= 1``, with ``q`` the
  TrainPool state nearest to ``s``. Nearest is measured in the *normalised* Euclidean distance
  over all 33 state elements: each element divided by its TrainPool standard deviation (divisor 1
  where the std is below 1e-12), the distance the paper uses to pick LGPR's local model. (The
  paper's equation for q writes the plain norm; normalising keeps metres, radians and rad/s
  elements comparable.) The search is exact; see ``.neighbours.NearestNeighbour``.

  Gated alpha-PROJ (an extension, not in the paper): with ``radius = r > 0`` (normalised units)
  a state within ``r`` of its nearest TrainPool state is left alone, and alpha pulls only the
  excess beyond ``r``: with ``d = ||(s - q) / scale||``,
  ``s := s - alpha * max(0, 1 - r / d) * (s - q)``; the new distance to ``q`` is
  ``r + (1 - alpha) (d - r)`` for ``d > r`` (``alpha = 1``: ``s := q + (s - q) r / d``, the
  point of the ball of radius ``r`` around ``q`` nearest to ``s``). ``q`` stays the nearest
  TrainPool state of the result. ``r = 0`` (the default) is plain alpha-PROJ, computed by its
  own formula above (bit for bit as without the option). A natural ``r`` is a quantile of the
  distances of real states to their nearest TrainPool state of *another* move
  (``leave_move_out_distances``): states as close to the TrainPool as held-out real states
  usually are stay untouched.

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
not stored). The gated projection's ``radius`` is stored only when it is not 0 (absent = 0), so
the arrays of plain alpha-PROJ are the same as before the option.
"""
from __future__ import annotations

from typing import Any, ClassVar, Mapping

import numpy as np

from ..layout import JOINT_LOWER, JOINT_UPPER, N_STATE, WRAPPED_STATE, S, wrap_angle
from .neighbours import CandidateGroups, NearestNeighbour

__all__ = [
    "PROJECTION_KINDS", "PROJECTION_FORMAT_VERSION", "Projection", "NoProjection",
    "BoundProjection", "AlphaProjection", "NearestNeighbour", "make_projection",
    "enforce_limits", "leave_move_out_distances", "radius_from_quantile",
    "GATE_QUANTILE", "GATE_EVERY", "gate_radius", "GATE_MARGIN", "CandidateGroups",
]

PROJECTION_KINDS: tuple[str, ...] = ("none", "bound", "alpha")
PROJECTION_FORMAT_VERSION = 1
_MIN_STD = 1e-12
# relative margin below the gate radius for a candidate to prove a row inside the gate
# (AlphaProjection.project_distance): far above the rounding of two 33-term distance formulas
GATE_MARGIN = 1e-9


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
    distance (default: their std, 1 where std < 1e-12); ``nn_method`` see ``NearestNeighbour``;
    ``radius`` >= 0 (normalised units): gated alpha-PROJ (module doc), 0 = plain alpha-PROJ.
    """

    kind = "alpha"

    def __init__(self, train_states: np.ndarray, alpha: float = 0.5,
                 scale: np.ndarray | None = None, nn_method: str = "auto",
                 radius: float = 0.0) -> None:
        alpha = float(alpha)
        if not 0.0 <= alpha <= 1.0:
            raise ValueError(f"alpha must be in [0, 1], got {alpha}")
        radius = float(radius)
        if not (np.isfinite(radius) and radius >= 0.0):
            raise ValueError(f"radius must be finite and >= 0, got {radius}")
        self.alpha = alpha
        self.radius = radius
        self.train_states = np.ascontiguousarray(_check_states(train_states, "TrainPool states"))
        if scale is None:
            scale = train_scale(self.train_states)
        self.scale = _float_array(np.asarray(scale), (N_STATE,), "scale")
        if np.any(self.scale <= 0):
            raise ValueError("alpha projection: scale must be positive")
        self.nn = NearestNeighbour(self.train_states / self.scale, method=nn_method)

    def nearest(self, states: np.ndarray) -> np.ndarray:
        """Index into ``train_states`` (B,) of the nearest TrainPool state of each finite row."""
        return self.nn.query(np.asarray(states, dtype=np.float64) / self.scale)

    def __getstate__(self) -> dict:
        state = self.__dict__.copy()
        state.pop("_candidate_groups", None)       # a cache, rebuilt on use
        return state

    def candidate_groups(self, groups) -> CandidateGroups:
        """A :class:`.neighbours.CandidateGroups` over this projection's (normalised) TrainPool
        states, ``groups`` index arrays into ``train_states`` (``project_distance``'s
        ``candidates``). Kept for the next call with the same ``groups`` object."""
        cached = self.__dict__.get("_candidate_groups")
        if cached is not None and cached[0] is groups:
            return cached[1]
        cg = CandidateGroups(self.nn._P, groups)
        self._candidate_groups = (groups, cg)
        return cg

    def distance(self, states: np.ndarray, index: np.ndarray | None = None) -> np.ndarray:
        """(B,) normalised distance of each finite row (B, 33) to its nearest TrainPool state
        (or to ``train_states[index]``)."""
        s = np.asarray(states, dtype=np.float64)
        i = self.nearest(s) if index is None else np.asarray(index)
        diff = s / self.scale - self.nn._P[i]
        return np.sqrt(np.einsum("ij,ij->i", diff, diff))

    def _project(self, s: np.ndarray) -> np.ndarray:
        if self.alpha == 0.0:
            return s
        return self._project_from(s, self.nearest(s))[0]

    def _project_from(self, s: np.ndarray, i: np.ndarray) -> tuple[np.ndarray, np.ndarray | None]:
        """The projection of s given its nearest TrainPool states i; also their distances when
        the gate computed them (else None)."""
        q = self.train_states[i]
        if self.radius > 0.0:
            return self._gated(s, q, i)
        if self.alpha == 1.0:
            return q.copy(), None
        return (1.0 - self.alpha) * s + self.alpha * q, None

    def project_distance(self, states: np.ndarray, candidates: tuple | None = None,
                         index_out: np.ndarray | None = None
                         ) -> tuple[np.ndarray, np.ndarray]:
        """``self(states)`` for (B, 33) states, plus the normalised distance (B,) of each
        (limit-enforced) input row to its nearest TrainPool state (NaN for a non-finite row):
        how far the prediction left the data, from the projection's own search (no second
        one).

        ``candidates``: ``(groups, labels)`` or ``(groups, labels, first)``, a
        :class:`.neighbours.CandidateGroups` over the TrainPool states, a group label (B,) per
        row (the learned simulator: the TrainPool states of the LGPR cluster the step's
        features selected) and optionally TrainPool indices (B,) or (B, w) per row to try
        before its group (-1: none; the learned simulator: the last step's state and the
        three recorded after it). Gated
        alpha-PROJ only (``radius`` > 0, else ignored): a row whose candidate is within the
        gate (its distance at most ``radius (1 - GATE_MARGIN)``) is left alone without the
        exact search, and its distance is the candidate's, an upper bound on the exact one
        that is itself inside the gate. The projected states are bit for bit those without
        ``candidates``: the exact nearest state is at least as close as the candidate, so the
        gate leaves that row alone either way (``GATE_MARGIN`` covers the rounding of the two
        distance formulas). Rows outside get the exact search and the exact distance.

        ``index_out`` (B,) int64, optional: filled with the TrainPool index each distance is
        measured to (-1 for a non-finite row).
        """
        s = np.asarray(states, dtype=np.float64)
        if s.ndim != 2 or s.shape[1] != N_STATE:
            raise ValueError(f"states must be (B, {N_STATE}), got {s.shape}")
        d = np.full(s.shape[0], np.nan)
        if index_out is not None:
            index_out[:] = -1
        finite = np.isfinite(s).all(axis=1)
        out = enforce_limits(s)
        if not finite.any():
            out[:] = np.nan
            return out, d
        x = out[finite]
        if candidates is not None and self.radius > 0.0:
            j, sq = self._candidate_bound(x, finite, *candidates)
            inside = np.sqrt(sq) <= self.radius * (1.0 - GATE_MARGIN)
            if inside.all():
                y, dx = x, self.distance(x, j)
            else:
                y, dx = np.empty_like(x), np.empty(x.shape[0])
                y[inside] = x[inside]
                dx[inside] = self.distance(x[inside], j[inside])
                o = ~inside
                i = self.nn.query(x[o] / self.scale, upper=sq[o])
                j[o] = i
                y[o], dx[o] = self._project_exact(x[o], i)
        else:
            j = self.nearest(x)
            y, dx = self._project_exact(x, j)
        d[finite] = dx
        if index_out is not None:
            index_out[finite] = j
        out[finite] = enforce_limits(y)
        out[~finite] = np.nan
        return out, d

    def _candidate_bound(self, x: np.ndarray, finite: np.ndarray, groups: CandidateGroups,
                         labels: np.ndarray, first: np.ndarray | None = None
                         ) -> tuple[np.ndarray, np.ndarray]:
        """(index, naive squared normalised distance) of a candidate TrainPool state per
        finite row x: ``first`` where it is inside the gate, else the best of its group."""
        xs = x / self.scale
        lim = self.radius * (1.0 - GATE_MARGIN)
        n = x.shape[0]
        j = np.full(n, -1, dtype=np.int64)
        sq = np.full(n, np.inf)
        if first is not None:
            f = np.asarray(first, dtype=np.int64)
            f = (f.reshape(-1, 1) if f.ndim == 1 else f)[finite]      # (n, w) candidates
            have = (f >= 0) & (f < self.nn.n_points)
            if have.any():
                fi = np.where(have, f, 0)
                diff = xs[:, None, :] - self.nn._P[fi]
                sqw = np.where(have, (diff * diff).sum(axis=2), np.inf)
                a = sqw.argmin(axis=1)
                rows = np.arange(n)
                sq = sqw[rows, a]
                j = np.where(np.isfinite(sq), f[rows, a], -1)
        todo = ~(np.sqrt(sq) <= lim)
        if todo.any():
            lab = np.asarray(labels).reshape(-1)[finite]
            jg, sqg = groups.upper_bound(xs[todo], lab[todo])
            better = sqg < sq[todo]
            j[todo] = np.where(better, jg, j[todo])
            sq[todo] = np.where(better, sqg, sq[todo])
        return j, sq

    def _project_exact(self, x: np.ndarray, i: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Projection and distance of finite, limit-enforced rows x (B, 33) given their exact
        nearest TrainPool states i."""
        if self.alpha == 0.0:
            y, dx = x, None
        else:
            y, dx = self._project_from(x, i)
        return y, (self.distance(x, i) if dx is None else dx)

    def _gated(self, s: np.ndarray, q: np.ndarray, i: np.ndarray
               ) -> tuple[np.ndarray, np.ndarray]:
        d = self.distance(s, i)
        out = s.copy()
        far = np.flatnonzero(d > self.radius)
        if far.size:
            f = self.alpha * (1.0 - self.radius / d[far])        # share of (s - q) removed
            out[far] = s[far] - f[:, None] * (s[far] - q[far])
        return out, d

    def describe(self) -> dict[str, Any]:
        out = {"kind": self.kind, "alpha": self.alpha,
               "n_train_states": int(self.train_states.shape[0])}
        if self.radius > 0.0:
            out["radius"] = self.radius
        return out

    def _arrays(self) -> dict[str, np.ndarray]:
        out = {"alpha": np.array(self.alpha), "train_states": self.train_states,
               "scale": self.scale}
        if self.radius > 0.0:        # absent = 0: files of plain alpha-PROJ stay as they were
            out["radius"] = np.array(self.radius)
        return out

    @classmethod
    def _from(cls, get) -> "AlphaProjection":
        try:
            radius = float(_float_array(get("radius"), (), "radius"))
        except ValueError as e:      # arrays written before the option: plain alpha-PROJ
            if "missing" not in str(e):
                raise
            radius = 0.0
        return cls(_float_array(get("train_states"), (None, N_STATE), "train_states"),
                   alpha=float(_float_array(get("alpha"), (), "alpha")),
                   scale=_float_array(get("scale"), (N_STATE,), "scale"), radius=radius)


def train_scale(train_states: np.ndarray) -> np.ndarray:
    """(33,) the divisor of alpha-PROJ's normalised distance: the std of each element over the
    TrainPool states, 1 where it is below 1e-12."""
    std = np.asarray(train_states, dtype=np.float64).std(axis=0)
    return np.where(std < _MIN_STD, 1.0, std)


def leave_move_out_distances(train_states: np.ndarray, groups: np.ndarray,
                             scale: np.ndarray | None = None, every: int = 1,
                             block: int = 256) -> np.ndarray:
    """Normalised distance of TrainPool states to the nearest TrainPool state of another move.

    ``groups`` (n,) the move of each state (e.g. ``features_responses``' ``move_index``);
    ``scale`` as ``AlphaProjection`` (default ``train_scale``). Every ``every``-th state of each
    move is a query (in order); returns their distances (m,), in the order of the states. These
    are the distances to the TrainPool that real states of a move the TrainPool does not hold
    have, the scale for the gated projection's ``radius``.

    Exact up to rounding: a float64 GEMM over all states with the query's own move masked
    finds the nearest; its distance is then recomputed directly (``((x - p) ** 2).sum()``).
    Needs at least two moves.
    """
    S_ = _check_states(train_states, "TrainPool states")
    g = np.asarray(groups)
    if g.shape != (S_.shape[0],):
        raise ValueError(f"groups must have shape ({S_.shape[0]},), got {g.shape}")
    if np.unique(g).size < 2:
        raise ValueError("leave-move-out distances need at least two moves")
    every = int(every)
    if every < 1:
        raise ValueError(f"every must be >= 1, got {every}")
    sc = train_scale(S_) if scale is None else _float_array(np.asarray(scale), (N_STATE,),
                                                               "scale")
    P = S_ / sc
    sq = np.einsum("ij,ij->i", P, P)
    qidx = []
    for m in np.unique(g):
        qidx.append(np.flatnonzero(g == m)[::every])
    qidx = np.sort(np.concatenate(qidx))
    out = np.empty(qidx.size)
    for a in range(0, qidx.size, block):
        rows = qidx[a:a + block]
        Q = P[rows]
        D = sq[None, :] - 2.0 * (Q @ P.T)                  # ||p||^2 - 2 q.p, (b, n)
        D[g[rows][:, None] == g[None, :]] = np.inf         # own move
        j = D.argmin(axis=1)
        diff = Q - P[j]
        out[a:a + block] = np.sqrt(np.einsum("ij,ij->i", diff, diff))
    return out


def radius_from_quantile(train_states: np.ndarray, groups: np.ndarray, quantile: float,
                         scale: np.ndarray | None = None, every: int = 4) -> float:
    """The ``quantile`` (0..1) of ``leave_move_out_distances`` (every ``every``-th state)."""
    quantile = float(quantile)
    if not 0.0 <= quantile <= 1.0:
        raise ValueError(f"quantile must be in [0, 1], got {quantile}")
    d = leave_move_out_distances(train_states, groups, scale=scale, every=every)
    return float(np.quantile(d, quantile))


GATE_QUANTILE = 0.9   # the default gate: this quantile of the leave-move-out distances
GATE_EVERY = 4        # ... over every 4th TrainPool state of each move


def gate_radius(train_states: np.ndarray, groups: np.ndarray, quantile: float = GATE_QUANTILE,
                every: int = GATE_EVERY) -> dict[str, Any]:
    """The default radius of the gated alpha-PROJ for a model, as a JSON-ready record:
    ``{"radius", "quantile", "every", "n_queries", "rule": "leave-move-out"}``.

    The radius is the ``quantile`` of ``leave_move_out_distances`` (every ``every``-th state):
    real states of a move the TrainPool does not hold are that close to it in that share of
    cases, so states as well covered as those stay untouched and only the excess is pulled.
    ``GATE_QUANTILE`` (0.9) is the documented default (docs/cli.md "Which projection",
    ``benchmarks/sim_node_10x``)."""
    d = leave_move_out_distances(train_states, groups, every=every)
    return {"radius": float(np.quantile(d, float(quantile))), "quantile": float(quantile),
            "every": int(every), "n_queries": int(d.size), "rule": "leave-move-out"}


_KINDS: dict[str, type[Projection]] = {
    "none": NoProjection, "bound": BoundProjection, "alpha": AlphaProjection,
}


def make_projection(kind: str, train_states: np.ndarray | None = None,
                    alpha: float = 0.5, nn_method: str = "auto",
                    radius: float = 0.0) -> Projection:
    """The projection ``kind`` (``none``/``bound``/``alpha``) built from TrainPool states (n, 33).

    ``train_states`` are the states of the TrainPool (e.g. the responses ``Y`` of
    ``features_responses`` on the TrainPool); not needed for ``none``. ``radius``: the gated
    alpha-PROJ's radius (normalised units; ``alpha`` only, 0 = plain alpha-PROJ).
    """
    if float(radius) != 0.0 and kind != "alpha":
        raise ValueError(f"radius applies to the alpha projection only, not {kind!r}")
    if kind not in _KINDS:
        raise ValueError(f"projection must be one of {PROJECTION_KINDS}, got {kind!r}")
    if kind == "none":
        return NoProjection()
    if train_states is None:
        raise ValueError(f"projection {kind!r} needs the TrainPool states")
    if kind == "bound":
        return BoundProjection.from_train_states(train_states)
    return AlphaProjection(train_states, alpha=alpha, nn_method=nn_method, radius=radius)
