"""Exact mass properties of convex polyhedra (per unit density).

A polyhedron is given by its vertices and its polygon faces.  Each face is
fanned into triangles from its first vertex and each triangle is closed into a
tetrahedron with a reference point ``o`` (the mean of the vertices, inside a
convex polyhedron).  For a tetrahedron with vertices ``o, v1, v2, v3`` and
``r_i = v_i - o`` (signed volume ``V = det[r1 r2 r3] / 6``), the exact second
moment about ``o`` is the canonical-tetrahedron covariance

    C = ∫ r rᵀ dV = V/20 · (Σ r_i r_iᵀ + s sᵀ),   s = Σ r_i,

(Tonon, "Explicit exact formulas for the 3-D tetrahedron inertia tensor in
terms of its vertex coordinates", J. Math. Stat. 1 (2004) 8-11; equivalently
the affine image of ∫ x^a y^b z^c = a! b! c! / (a+b+c+3)! over the unit
simplex).  Summing the signed contributions gives the exact polyhedron
moments; the centroid is Σ V (r1+r2+r3)/4 / Σ V and the inertia about the
centroid is

    I = tr(C_G) 1 − C_G,   C_G = C − V g gᵀ   (g = centroid − o).

Faces must be counter-clockwise seen from outside (``mass_properties`` can
orient them for you since the polyhedron is convex).  Everything is computed
in coordinates relative to ``o``, so the result does not lose digits when the
body sits far from the origin.
"""
from __future__ import annotations

import numba as nb
import numpy as np

__all__ = ["mass_properties", "principal_axes", "cells_mass_properties"]


def _fan_triangles(poly_ptr, poly_vertex):
    """Fan every polygon from its first vertex.

    Returns (tri (T, 3) global vertex ids, tri_poly (T,) polygon index)."""
    poly_ptr = np.asarray(poly_ptr, dtype=np.int64)
    poly_vertex = np.asarray(poly_vertex, dtype=np.int64)
    n = np.diff(poly_ptr)
    if np.any(n < 3):
        raise ValueError("every polygon needs at least 3 vertices")
    ntri = n - 2
    tri_poly = np.repeat(np.arange(len(n), dtype=np.int64), ntri)
    # local index k = 1 .. n-2 of the triangle (v0, v_k, v_k+1)
    first_tri = np.cumsum(ntri) - ntri
    k = np.arange(ntri.sum(), dtype=np.int64) - np.repeat(first_tri, ntri) + 1
    base = poly_ptr[tri_poly]
    tri = np.stack(
        [poly_vertex[base], poly_vertex[base + k], poly_vertex[base + k + 1]], axis=1
    )
    return tri, tri_poly


@nb.njit(cache=True)
def _tet_moments(vertices, poly_ptr, poly_vertex, cell_poly_ptr, ref, volume, first, cov):
    """Σ over the fan tetrahedra (ref, v0, v_k, v_k+1) of each cell: volume
    V = r1·(r2 × r3)/6, first moment V s/4 and second moment V/20 (Σ r_i r_iᵀ
    + s sᵀ), s = r1 + r2 + r3 (the module docstring; Tonon 2004); a loop,
    no per-triangle temporaries."""
    for c in range(cell_poly_ptr.shape[0] - 1):
        o0, o1, o2 = ref[c, 0], ref[c, 1], ref[c, 2]
        for p in range(cell_poly_ptr[c], cell_poly_ptr[c + 1]):
            b = poly_ptr[p]
            v = poly_vertex[b]
            a0, a1, a2 = vertices[v, 0] - o0, vertices[v, 1] - o1, vertices[v, 2] - o2
            for k in range(b + 1, poly_ptr[p + 1] - 1):
                v = poly_vertex[k]
                b0, b1, b2 = vertices[v, 0] - o0, vertices[v, 1] - o1, vertices[v, 2] - o2
                v = poly_vertex[k + 1]
                d0, d1, d2 = vertices[v, 0] - o0, vertices[v, 1] - o1, vertices[v, 2] - o2
                vol = (a0 * (b1 * d2 - b2 * d1) + a1 * (b2 * d0 - b0 * d2)
                       + a2 * (b0 * d1 - b1 * d0)) / 6.0
                s0, s1, s2 = a0 + b0 + d0, a1 + b1 + d1, a2 + b2 + d2
                volume[c] += vol
                first[c, 0] += vol * s0
                first[c, 1] += vol * s1
                first[c, 2] += vol * s2
                r1 = (a0, a1, a2)
                r2 = (b0, b1, b2)
                r3 = (d0, d1, d2)
                s = (s0, s1, s2)
                for i in range(3):
                    for j in range(i, 3):
                        t = r1[i] * r1[j] + r2[i] * r2[j] + r3[i] * r3[j] + s[i] * s[j]
                        cov[c, i, j] += vol * t
        # (the sums first, the constant factors after: the rounding of the
        # per-triangle NumPy form this replaced, bit for bit)
        for i in range(3):
            first[c, i] /= 4.0
            for j in range(i, 3):
                cov[c, i, j] /= 20.0
                cov[c, j, i] = cov[c, i, j]


def cells_mass_properties(vertices, poly_ptr, poly_vertex, cell_poly_ptr, ref=None):
    """Volume, centroid and inertia (about the centroid) of many polyhedra.

    vertices (V, 3); polygon p has vertex ids poly_vertex[poly_ptr[p]:poly_ptr[p+1]]
    (counter-clockwise seen from outside); cell c owns polygons
    cell_poly_ptr[c]:cell_poly_ptr[c+1].  ``ref`` (N, 3) are reference points
    (default: the mean of each cell's polygon vertices).

    Returns volume (N,), centroid (N, 3), inertia (N, 3, 3) per unit density.
    """
    vertices = np.asarray(vertices, dtype=np.float64)
    cell_poly_ptr = np.asarray(cell_poly_ptr, dtype=np.int64)
    n_cells = len(cell_poly_ptr) - 1
    poly_cell = np.repeat(np.arange(n_cells, dtype=np.int64), np.diff(cell_poly_ptr))
    if ref is None:
        poly_ptr_ = np.asarray(poly_ptr, dtype=np.int64)
        vcell = np.repeat(poly_cell, np.diff(poly_ptr_))
        cnt = np.bincount(vcell, minlength=n_cells).astype(np.float64)
        ref = np.stack(
            [np.bincount(vcell, vertices[poly_vertex, j], minlength=n_cells) for j in range(3)],
            axis=1,
        ) / cnt[:, None]
    ref = np.ascontiguousarray(ref, dtype=np.float64)
    poly_ptr = np.asarray(poly_ptr, dtype=np.int64)
    if np.any(np.diff(poly_ptr) < 3):
        raise ValueError("every polygon needs at least 3 vertices")
    volume = np.zeros(n_cells)
    first = np.zeros((n_cells, 3))
    cov = np.zeros((n_cells, 3, 3))
    _tet_moments(vertices, poly_ptr, np.asarray(poly_vertex, dtype=np.int64), cell_poly_ptr,
                 ref, volume, first, cov)
    g = first / volume[:, None]
    cov -= volume[:, None, None] * (g[:, :, None] * g[:, None, :])  # exactly symmetric
    tr = np.trace(cov, axis1=1, axis2=2)
    inertia = tr[:, None, None] * np.eye(3) - cov
    return volume, ref + g, inertia


def _as_polyhedron(vertices, faces):
    """Normalise the accepted inputs to (vertices, poly_ptr, poly_vertex)."""
    from scipy.spatial import ConvexHull

    if isinstance(vertices, ConvexHull):
        hull, faces = vertices, None
        vertices = hull.points
    else:
        vertices = np.asarray(vertices, dtype=np.float64)
        hull = ConvexHull(vertices) if faces is None else None
    if hull is not None:
        tri = np.asarray(hull.simplices, dtype=np.int64)
        vertices = np.asarray(hull.points, dtype=np.float64)
        ptr = np.arange(0, 3 * len(tri) + 1, 3, dtype=np.int64)
        return vertices, ptr, tri.ravel()
    faces = [np.asarray(f, dtype=np.int64).ravel() for f in faces]
    ptr = np.zeros(len(faces) + 1, dtype=np.int64)
    ptr[1:] = np.cumsum([len(f) for f in faces])
    return vertices, ptr, np.concatenate(faces)


def mass_properties(vertices, faces=None, orient=True):
    """Exact volume, centroid and inertia tensor of a convex polyhedron.

    Parameters
    ----------
    vertices : (V, 3) array, or a ``scipy.spatial.ConvexHull``
    faces : sequence of vertex-index sequences (one polygon each, planar), or
        None to take the convex hull of ``vertices``.
    orient : if True (default) every face is turned counter-clockwise seen
        from outside (valid for convex polyhedra); if False the given order is
        trusted.

    Returns
    -------
    volume : float
    centroid : (3,)
    inertia : (3, 3) ``∫(|r|² 1 − r rᵀ) dV`` about the centroid, per unit
        density (multiply by the density for kg·m²).
    """
    verts, ptr, pv = _as_polyhedron(vertices, faces)
    if orient:
        ref = verts[np.unique(pv)].mean(axis=0)
        pv = pv.copy()
        n = np.diff(ptr)
        poly = np.repeat(np.arange(len(n)), n)
        nxt = np.arange(len(pv)) + 1
        nxt[ptr[1:] - 1] = ptr[:-1]
        a = verts[pv] - ref
        b = verts[pv[nxt]] - ref
        cr = np.cross(a, b)  # Σ over a polygon = 2 × area vector (Newell)
        area_vec = np.stack([np.bincount(poly, cr[:, j], minlength=len(n)) for j in range(3)], 1)
        fc = np.stack([np.bincount(poly, a[:, j], minlength=len(n)) for j in range(3)], 1) / n[:, None]
        flip = np.einsum("ij,ij->i", area_vec, fc) < 0
        for f in np.flatnonzero(flip):
            pv[ptr[f]:ptr[f + 1]] = pv[ptr[f]:ptr[f + 1]][::-1]
    else:
        ref = None
    vol, cen, inertia = cells_mass_properties(
        verts, ptr, pv, np.array([0, len(ptr) - 1]), None if ref is None else ref[None]
    )
    return float(vol[0]), cen[0], inertia[0]


def principal_axes(inertia):
    """Principal moments and axes of a symmetric 3×3 inertia tensor.

    Returns ``moments (3,)`` in ascending order and ``R (3, 3)`` whose columns
    are the corresponding unit principal axes, with det R = +1, so that
    ``inertia = R @ diag(moments) @ R.T``.  The sign of each axis is fixed so
    that its largest-magnitude component is positive (the third axis then
    follows from right-handedness), which makes the result deterministic.
    Accepts a stack (..., 3, 3) as well.
    """
    inertia = np.asarray(inertia, dtype=np.float64)
    sym = 0.5 * (inertia + np.swapaxes(inertia, -1, -2))
    w, R = np.linalg.eigh(sym)  # ascending
    R = R.copy()
    for j in range(2):
        col = R[..., :, j]
        idx = np.argmax(np.abs(col), axis=-1)
        sgn = np.sign(np.take_along_axis(col, idx[..., None], axis=-1))
        sgn[sgn == 0] = 1.0
        R[..., :, j] = col * sgn
    R[..., :, 2] = np.cross(R[..., :, 0], R[..., :, 1])
    return w, R
