"""Balanced k-means clusters of the training inputs, and nearest-centre lookup (for LGPR).

k-means on trot data is lopsided (standing and slow moves pile up in a few clusters), and a
local GP's cost is cubic in its size, so :func:`balanced_clusters` splits clusters that are too
large and dissolves those that are too small; :func:`nearest_rows` assigns queries to the
nearest centre in blocks (bounded memory).
"""
from __future__ import annotations

import math

import numpy as np
from threadpoolctl import threadpool_limits

__all__ = ["balanced_clusters", "nearest_rows"]


def _kmeans(X: np.ndarray, k: int, seed: int) -> tuple[np.ndarray, np.ndarray]:
    """Seeded k-means (Lloyd, k-means++, one init) -> (labels (n,), centres (k, d))."""
    from sklearn.cluster import KMeans
    km = KMeans(n_clusters=k, n_init=1, random_state=seed).fit(X)
    return km.labels_.astype(np.int64), km.cluster_centers_


def _chunks_along_principal_axis(X: np.ndarray, n_parts: int) -> np.ndarray:
    """Labels (n,) cutting X (n, d) into ``n_parts`` equal-count chunks along its first PC."""
    Z = X - X.mean(axis=0)
    _, _, vt = np.linalg.svd(Z, full_matrices=False)
    order = np.argsort(Z @ vt[0], kind="stable")
    labels = np.empty(X.shape[0], dtype=np.int64)
    for part, rows in enumerate(np.array_split(order, n_parts)):
        labels[rows] = part
    return labels


def balanced_clusters(X: np.ndarray, n_clusters: int, *, max_cluster_factor: float = 1.5,
                      min_cluster_factor: float = 0.25, random_state: int = 0
                      ) -> tuple[np.ndarray, np.ndarray]:
    """k-means partition of X (n, d) with oversized clusters split and tiny ones dissolved.

    Returns (labels (n,) int64 in 0..k'-1, centres (k', d) = the cluster means), clusters
    numbered by their first member's row. The rules: ``lgpr.py``'s module docstring,
    "Clustering". Seeded and deterministic; BLAS/OpenMP limited to one thread meanwhile.
    """
    X = np.asarray(X, dtype=np.float64)
    n = X.shape[0]
    k = int(n_clusters)
    if not 1 <= k <= n:
        raise ValueError(f"n_clusters must be in [1, n={n}]; got {n_clusters}")
    if max_cluster_factor < 1.0:
        raise ValueError(f"max_cluster_factor must be >= 1; got {max_cluster_factor}")
    if k == 1:
        return np.zeros(n, dtype=np.int64), X.mean(axis=0, keepdims=True)
    target = n / k
    max_size = max(1, int(math.floor(max_cluster_factor * target)))
    min_size = int(math.ceil(min_cluster_factor * target))
    with threadpool_limits(limits=1):
        labels, _ = _kmeans(X, k, random_state)
        groups = [np.flatnonzero(labels == c) for c in range(k)]
        final: list[np.ndarray] = []
        while groups:
            g = groups.pop()
            if g.size <= max_size:
                final.append(g)
                continue
            parts = int(math.ceil(g.size / target))
            sub, _ = _kmeans(X[g], parts, random_state)
            pieces = [g[sub == j] for j in range(parts)]
            for piece in pieces:
                if piece.size > max_size:  # k-means could not split it evenly: equal chunks
                    cut = _chunks_along_principal_axis(X[piece], int(math.ceil(piece.size
                                                                             / target)))
                    final.extend(piece[cut == j] for j in range(cut.max() + 1))
                elif piece.size:
                    final.append(piece)
    # dissolve tiny clusters into the nearest remaining centre (smallest first)
    final.sort(key=lambda g: (g.size, g[0]))
    while len(final) > 1 and final[0].size < min_size:
        small = final.pop(0)
        centres = np.stack([X[g].mean(axis=0) for g in final])
        near = nearest_rows(X[small], centres)
        for j in np.unique(near):
            final[j] = np.sort(np.concatenate([final[j], small[near == j]]))
        final.sort(key=lambda g: (g.size, g[0]))
    final.sort(key=lambda g: g[0])
    labels = np.empty(n, dtype=np.int64)
    for c, g in enumerate(final):
        labels[g] = c
    centres = np.stack([X[g].mean(axis=0) for g in final])
    return labels, centres


def _sqdist_to_centres(X: np.ndarray, centres: np.ndarray) -> np.ndarray:
    """Exact squared distances (n, k) (direct differences: no cancellation)."""
    diff = X[:, None, :] - centres[None, :, :]
    return np.einsum("nkd,nkd->nk", diff, diff)


def nearest_rows(X: np.ndarray, centres: np.ndarray, block: int = 2048) -> np.ndarray:
    """Index (n,) of the nearest centre of each row (first of equal minima)."""
    out = np.empty(X.shape[0], dtype=np.int64)
    for a in range(0, X.shape[0], block):
        out[a:a + block] = np.argmin(_sqdist_to_centres(X[a:a + block], centres), axis=1)
    return out
