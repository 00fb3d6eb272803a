"""Faces → spring points (integration rules over planar convex polygons).

A face is a planar convex polygon, its vertices counter-clockwise about its
unit normal ``n``.  It is cut into a fan of triangles (c, v_k, v_k+1) from its
area centroid ``c``.  Three rules place the spring points:

``centroid``
    one point per fan triangle, at the triangle centroid, weight = its area.
    Exact for constant and linear fields (Σ w = A, Σ w (p − c) = 0), but it
    under-integrates the face's own second moment of area: for a b × h
    rectangle (4 fan triangles) the points give Σ w y² = b h³/18 instead of
    the exact b h³/12, one third short.  In an RBSM the face second moment is
    the bending/torsion stiffness of the spring set, so a beam a few cells
    deep comes out too flexible (+9 % tip deflection on a cantilever with
    2 blocks through the depth).
``three``
    three points per triangle at barycentric (2/3, 1/6, 1/6) and
    permutations, weight area/3: the degree-2 rule, exact second moments, at
    three times the springs.
``moment`` (default)
    the ``centroid`` points moved in the face plane by a 2×2 linear map per
    face about the face centroid, p' = c + T (p − c), chosen so that the
    points' second moment equals the exact one J of the polygon:

        Σ w (p' − c)(p' − c)ᵀ = T Jp Tᵀ = J   with   T = J^½ Jp^-½

    (symmetric square roots; Jp = Σ w (p − c)(p − c)ᵀ).  The weights are
    untouched and, since Σ w (p − c) = 0 exactly for the fan from the area
    centroid, Σ w (p' − c) = T Σ w (p − c) = 0: area and first moments stay
    exact, so a uniform strain is carried exactly as before.  Same cost as
    ``centroid``, the accuracy of ``three`` on bending.

For a face so thin that its in-plane moment tensors are numerically singular
(det J < 1e-12 (tr J)², i.e. an aspect ratio below about 1e-6) the map
falls back to an isotropic scaling that makes the polar moment tr J exact.

Everything is vectorised over faces; the only per-face work is batched 2×2
algebra in closed form.
"""
from __future__ import annotations

from typing import NamedTuple

import numpy as np

__all__ = ["SpringPoints", "spring_points", "polygon_properties", "RULES"]

RULES = ("centroid", "moment", "three")


class SpringPoints(NamedTuple):
    point: np.ndarray   # (P, 3) [m]
    weight: np.ndarray  # (P,) [m²], sums to the face area over each face
    face: np.ndarray    # (P,) int64, index of the face each point belongs to


def _polygon_index(vertex_ptr):
    vertex_ptr = np.asarray(vertex_ptr, dtype=np.int64)
    n = np.diff(vertex_ptr)
    if np.any(n < 3):
        raise ValueError("every face needs at least 3 vertices")
    poly = np.repeat(np.arange(len(n), dtype=np.int64), n)
    nxt = np.arange(int(vertex_ptr[-1]), dtype=np.int64) + 1
    nxt[vertex_ptr[1:] - 1] = vertex_ptr[:-1]
    return n, poly, nxt


def _segment_sum(values, seg, nseg):
    """Sum rows of ``values`` (K, ...) by segment id ``seg`` (K,)."""
    values = np.asarray(values)
    if values.ndim == 1:
        return np.bincount(seg, values, minlength=nseg)
    flat = values.reshape(len(values), int(np.prod(values.shape[1:])))
    out = np.stack([np.bincount(seg, flat[:, j], minlength=nseg) for j in range(flat.shape[1])], 1)
    return out.reshape((nseg,) + values.shape[1:])


def polygon_properties(vertex_ptr, vertex_xyz, normal):
    """Area and area centroid of planar polygons (counter-clockwise about ``normal``).

    Returns ``area (F,)``, ``centroid (F, 3)``.  Areas are signed: a polygon
    ordered clockwise about its normal gets a negative area.
    """
    vertex_xyz = np.asarray(vertex_xyz, dtype=np.float64)
    normal = np.asarray(normal, dtype=np.float64)
    n, poly, nxt = _polygon_index(vertex_ptr)
    F = len(n)
    m = _segment_sum(vertex_xyz, poly, F) / n[:, None]  # vertex mean, inside a convex polygon
    a = vertex_xyz - m[poly]
    b = vertex_xyz[nxt] - m[poly]
    ta = 0.5 * np.einsum("ij,ij->i", np.cross(a, b), normal[poly])
    area = np.bincount(poly, ta, minlength=F)
    g = _segment_sum(ta[:, None] * (a + b) / 3.0, poly, F)
    with np.errstate(invalid="ignore", divide="ignore"):
        centroid = m + g / area[:, None]
    return area, centroid


def _sqrt_spd2(a, b, d):
    """Symmetric square root of [[a, b], [b, d]] (batched, closed form):
    √M = (M + s 1) / t with s = √det M, t = √(tr M + 2 s)."""
    s = np.sqrt(np.maximum(a * d - b * b, 0.0))
    t = np.sqrt(a + d + 2.0 * s)
    return (a + s) / t, b / t, (d + s) / t


def spring_points(vertex_ptr, vertex_xyz, normal, rule="moment"):
    """Spring points on a set of planar convex polygons.

    Parameters
    ----------
    vertex_ptr : (F+1,) int — face f has vertices vertex_xyz[ptr[f]:ptr[f+1]]
    vertex_xyz : (K, 3) polygon vertices, counter-clockwise about ``normal``
    normal : (F, 3) unit face normals
    rule : "moment" (default), "centroid" or "three" (see the module docstring)

    Returns
    -------
    SpringPoints(point (P, 3), weight (P,), face (P,) int64), ordered by face,
    then by fan triangle (the triangle (c, v_k, v_k+1) for k = 0, 1, ...), then
    (rule "three") by sub-point.  P = K for "centroid"/"moment", 3 K for "three".
    """
    if rule not in RULES:
        raise ValueError(f"unknown spring point rule {rule!r}; expected one of {RULES}")
    vertex_xyz = np.asarray(vertex_xyz, dtype=np.float64)
    normal = np.asarray(normal, dtype=np.float64)
    n, poly, nxt = _polygon_index(vertex_ptr)
    F = len(n)
    area, c = polygon_properties(vertex_ptr, vertex_xyz, normal)
    # fan triangles (c, v_k, v_k+1), one per polygon vertex k
    a = vertex_xyz - c[poly]
    b = vertex_xyz[nxt] - c[poly]
    w = 0.5 * np.einsum("ij,ij->i", np.cross(a, b), normal[poly])
    if rule == "three":
        # barycentric (2/3, 1/6, 1/6) on (c, v_k, v_k+1) and permutations
        offs = np.stack([(a + b) / 6.0, (4.0 * a + b) / 6.0, (a + 4.0 * b) / 6.0], axis=1)
        point = (c[poly][:, None, :] + offs).reshape(-1, 3)
        weight = np.repeat(w / 3.0, 3)
        face = np.repeat(poly, 3)
        return SpringPoints(point, weight, face)
    d = (a + b) / 3.0  # triangle centroid − c
    if rule == "centroid":
        return SpringPoints(c[poly] + d, w, poly.copy())

    # rule "moment": in-plane orthonormal basis (e1, e2) with e1 × e2 = n
    e1 = np.cross(normal, np.where(np.abs(normal[:, :1]) < 0.9, [[1.0, 0.0, 0.0]], [[0.0, 1.0, 0.0]]))
    e1 /= np.linalg.norm(e1, axis=1)[:, None]
    e2 = np.cross(normal, e1)
    au = np.einsum("ij,ij->i", a, e1[poly])
    av = np.einsum("ij,ij->i", a, e2[poly])
    bu = np.einsum("ij,ij->i", b, e1[poly])
    bv = np.einsum("ij,ij->i", b, e2[poly])
    su, sv = au + bu, av + bv
    # exact: ∫ over triangle (0, a, b) of x xᵀ = A/12 (a aᵀ + b bᵀ + s sᵀ)
    J11 = np.bincount(poly, w * (au * au + bu * bu + su * su), minlength=F) / 12.0
    J12 = np.bincount(poly, w * (au * av + bu * bv + su * sv), minlength=F) / 12.0
    J22 = np.bincount(poly, w * (av * av + bv * bv + sv * sv), minlength=F) / 12.0
    # points: Σ w g gᵀ with g = s/3
    P11 = np.bincount(poly, w * su * su, minlength=F) / 9.0
    P12 = np.bincount(poly, w * su * sv, minlength=F) / 9.0
    P22 = np.bincount(poly, w * sv * sv, minlength=F) / 9.0
    # T = J^½ Jp^-½
    r11, r12, r22 = _sqrt_spd2(J11, J12, J22)
    q11, q12, q22 = _sqrt_spd2(P11, P12, P22)
    qdet = q11 * q22 - q12 * q12
    with np.errstate(invalid="ignore", divide="ignore"):
        i11, i12, i22 = q22 / qdet, -q12 / qdet, q11 / qdet
    T11 = r11 * i11 + r12 * i12
    T12 = r11 * i12 + r12 * i22
    T21 = r12 * i11 + r22 * i12
    T22 = r12 * i12 + r22 * i22
    trJ, trP = J11 + J22, P11 + P22
    detJ, detP = J11 * J22 - J12 * J12, P11 * P22 - P12 * P12
    bad = ~(
        (detJ > 1e-12 * trJ * trJ) & (detP > 1e-12 * trP * trP)
        & np.isfinite(T11) & np.isfinite(T12) & np.isfinite(T21) & np.isfinite(T22)
    )
    if np.any(bad):  # sliver faces: scale isotropically to the exact polar moment
        with np.errstate(invalid="ignore", divide="ignore"):
            sc = np.sqrt(trJ[bad] / trP[bad])
        sc[~np.isfinite(sc)] = 1.0
        T11[bad], T12[bad], T21[bad], T22[bad] = sc, 0.0, 0.0, sc
    du = su / 3.0
    dv = sv / 3.0
    nu = T11[poly] * du + T12[poly] * dv
    nv = T21[poly] * du + T22[poly] * dv
    point = c[poly] + nu[:, None] * e1[poly] + nv[:, None] * e2[poly]
    return SpringPoints(point, w, poly.copy())
