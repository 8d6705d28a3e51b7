"""Triangle meshes of the URDF's primitive shapes, in plain NumPy.

The view sends each shape to the page once, as vertices and faces (viser's ``add_mesh_simple``).
Generating them here, rather than with trimesh, keeps trimesh's import (and SciPy's, which it
pulls in) off the view's start path (start-up: benchmarks/viewer).

Conventions match the URDF: a box of ``extents`` (x, y, z) centred at the origin; a capsule and
a cylinder along z, centred, ``length`` being the capsule's distance between its two sphere
centres (the cylinder part) and the cylinder's height; a sphere at the origin. Faces wind
counter-clockwise seen from outside (outward normals); every mesh is closed.
"""
from __future__ import annotations

import numpy as np

__all__ = ["box", "capsule", "cylinder", "sphere", "shape_mesh"]

Mesh = tuple[np.ndarray, np.ndarray]     # vertices (n, 3) float32, faces (m, 3) uint32


def box(extents: tuple[float, float, float]) -> Mesh:
    """12 triangles, 4 vertices per side (so each side shades flat)."""
    h = 0.5 * np.asarray(extents, dtype=np.float64)
    eye = np.eye(3)
    verts, faces = [], []
    for k in range(3):
        for s in (1.0, -1.0):
            u, v = eye[(k + 1) % 3], eye[(k + 2) % 3]
            if s < 0:                       # keep u x v = the outward normal
                u, v = v, u
            c = s * eye[k]
            quad = [c - u - v, c + u - v, c + u + v, c - u + v]
            base = len(verts)
            verts += [p * h for p in quad]
            faces += [[base, base + 1, base + 2], [base, base + 2, base + 3]]
    return np.asarray(verts, dtype=np.float32), np.asarray(faces, dtype=np.uint32)


def _lathe(profile: np.ndarray, sections: int) -> Mesh:
    """The surface swept by turning ``profile`` (k, 2) of (radius, z), from the bottom pole
    (radius 0) up to the top pole, about the z axis. Consecutive equal profile points (a sharp
    edge) and the degenerate triangles at the poles are left out."""
    profile = np.array(profile, dtype=np.float64)
    profile[profile[:, 0] < 1e-9 * np.abs(profile).max(), 0] = 0.0   # cos(pi/2) is not 0
    a = 2.0 * np.pi * np.arange(sections) / sections
    ring = np.stack([np.cos(a), np.sin(a)], axis=1)
    verts = np.concatenate([np.column_stack([r * ring, np.full(sections, z)])
                            for r, z in profile])
    faces = []
    j = np.arange(sections)
    jn = (j + 1) % sections
    for i in range(len(profile) - 1):
        if np.allclose(profile[i], profile[i + 1]):
            continue
        lo, hi = i * sections, (i + 1) * sections
        a_, b_, c_, d_ = lo + j, lo + jn, hi + jn, hi + j
        if profile[i][0] > 0:               # not the bottom pole: triangle a b c
            faces.append(np.stack([a_, b_, c_], axis=1))
        if profile[i + 1][0] > 0:           # not the top pole: triangle a c d
            faces.append(np.stack([a_, c_, d_], axis=1))
    return verts.astype(np.float32), np.concatenate(faces).astype(np.uint32)


def _cap(radius: float, z0: float, rings: int, up: bool) -> np.ndarray:
    """Profile of a hemisphere centred at (0, z0): pole to equator (bottom) or equator to
    pole (top)."""
    phi = np.linspace(0.0, 0.5 * np.pi, rings + 1)
    if up:
        return np.column_stack([radius * np.cos(phi), z0 + radius * np.sin(phi)])
    return np.column_stack([radius * np.sin(phi), z0 - radius * np.cos(phi)])


def sphere(radius: float, rings: int = 8, sections: int = 16) -> Mesh:
    return _lathe(np.concatenate([_cap(radius, 0.0, rings, False),
                                  _cap(radius, 0.0, rings, True)[1:]]), sections)


def capsule(radius: float, length: float, rings: int = 6, sections: int = 12) -> Mesh:
    h = 0.5 * length
    return _lathe(np.concatenate([_cap(radius, -h, rings, False),
                                  _cap(radius, h, rings, True)]), sections)


def cylinder(radius: float, length: float, sections: int = 16) -> Mesh:
    h = 0.5 * length
    # the rim points are repeated so the sides and the caps do not share (smoothed) vertices
    profile = np.array([[0.0, -h], [radius, -h], [radius, -h], [radius, h], [radius, h],
                        [0.0, h]])
    v, f = _lathe(profile, sections)
    return v, f


def shape_mesh(kind: str, size: tuple[float, ...]) -> Mesh:
    """The mesh of a URDF visual (``urdf.Visual``: box size (x, y, z); capsule and cylinder
    (radius, length); sphere (radius,))."""
    if kind == "box":
        return box((size[0], size[1], size[2]))
    if kind == "capsule":
        return capsule(size[0], size[1])
    if kind == "cylinder":
        return cylinder(size[0], size[1])
    if kind == "sphere":
        return sphere(size[0])
    raise ValueError(f"no mesh for shape {kind!r}")
