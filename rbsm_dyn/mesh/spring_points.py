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

import numba as nb
import numpy as np

from ..threads import build_threads, on_threads

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
    ordered clockwise about its normal gets a negative area.  The fan of
    triangles from the vertex mean m: ½ ((v_k − m) × (v_k+1 − m))·n each,
    its centroid m + (v_k + v_k+1 − 2m)/3 (one compiled loop over the
    polygons, _polygon_properties; the vectorised form took 1.3 s of a
    50 000-cell build's 10 s).
    """
    vertex_ptr = np.asarray(vertex_ptr, dtype=np.int64)
    vertex_xyz = np.ascontiguousarray(vertex_xyz, dtype=np.float64)
    normal = np.ascontiguousarray(normal, dtype=np.float64)
    n = np.diff(vertex_ptr)
    if np.any(n < 3):
        raise ValueError("every face needs at least 3 vertices")
    F = len(n)
    area = np.empty(F)
    centroid = np.empty((F, 3))
    _polygon_properties(vertex_ptr, vertex_xyz, normal, area, centroid)
    return area, centroid


@nb.njit(cache=True, nogil=True, error_model="numpy")
def _polygon_properties(ptr, xyz, normal, area, centroid):
    """area (F,), centroid (F, 3) of polygons ptr/xyz about normal (F, 3)
    (polygon_properties); the sums in vertex order, as np.bincount took
    them."""
    m = np.empty(3)
    g = np.empty(3)
    for f in range(len(ptr) - 1):
        a0 = ptr[f]
        a1 = ptr[f + 1]
        for c in range(3):
            acc = 0.0
            for i in range(a0, a1):
                acc += xyz[i, c]
            m[c] = acc / (a1 - a0)
        A = 0.0
        g[0] = g[1] = g[2] = 0.0
        for i in range(a0, a1):
            j = i + 1 if i + 1 < a1 else a0
            ax = xyz[i, 0] - m[0]
            ay = xyz[i, 1] - m[1]
            az = xyz[i, 2] - m[2]
            bx = xyz[j, 0] - m[0]
            by = xyz[j, 1] - m[1]
            bz = xyz[j, 2] - m[2]
            cx = ay * bz - az * by
            cy = az * bx - ax * bz
            cz = ax * by - ay * bx
            # (x + z) + y: the order numpy's einsum summed it in, so that the
            # meshes stay the same bit for bit
            ta = 0.5 * ((cx * normal[f, 0] + cz * normal[f, 2]) + cy * normal[f, 1])
            A += ta
            g[0] += ta * (ax + bx) / 3.0
            g[1] += ta * (ay + by) / 3.0
            g[2] += ta * (az + bz) / 3.0
        area[f] = A
        for c in range(3):
            centroid[f, c] = m[c] + g[c] / A


def _sqrt_spd2(a, b, d):
    """Symmetric square root of [[a, b], [b, d]] (batched, closed form):
    √M = (M + s 1) / t with s = √det M, t = √(tr M + 2 s)."""
    s = np.sqrt(np.maximum(a * d - b * b, 0.0))
    t = np.sqrt(a + d + 2.0 * s)
    return (a + s) / t, b / t, (d + s) / t


#: faces per batch of spring_points: its temporaries (~400 B per point) stay
#: below ~50 MiB however large the mesh (each face is computed on its own,
#: so the result does not depend on the batching)
BATCH_FACES = 30000


def spring_points(vertex_ptr, vertex_xyz, normal, rule="moment"):
    """Spring points on a set of planar convex polygons (_spring_points in
    batches of BATCH_FACES faces; see there)."""
    vertex_ptr = np.asarray(vertex_ptr, dtype=np.int64)
    F = len(vertex_ptr) - 1
    if F <= BATCH_FACES:
        return _spring_points(vertex_ptr, vertex_xyz, normal, rule)
    if rule != "three":
        # the compiled loop has no temporaries: all faces at once
        sp = _convex_points(vertex_ptr, vertex_xyz, normal, rule)
        if sp is not None:
            return sp
    parts = []
    for f0 in range(0, F, BATCH_FACES):
        f1 = min(F, f0 + BATCH_FACES)
        v0, v1 = vertex_ptr[f0], vertex_ptr[f1]
        sp = _spring_points(vertex_ptr[f0:f1 + 1] - v0, vertex_xyz[v0:v1], normal[f0:f1], rule)
        parts.append(SpringPoints(sp.point, sp.weight, sp.face + f0))
    return SpringPoints(*(np.concatenate([getattr(p, k) for p in parts])
                          for k in SpringPoints._fields))


def _spring_points(vertex_ptr, vertex_xyz, normal, rule="moment"):
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
    vertex_xyz = np.ascontiguousarray(vertex_xyz, dtype=np.float64)
    normal = np.ascontiguousarray(normal, dtype=np.float64)
    if rule != "three":
        sp = _convex_points(vertex_ptr, vertex_xyz, normal, rule)
        if sp is not None:
            return sp
    n, poly, nxt = _polygon_index(vertex_ptr)
    F = len(n)
    area, c = polygon_properties(vertex_ptr, vertex_xyz, normal)
    # fan triangles (c, v_k, v_k+1), one per polygon vertex k: each triangle
    # is (q0, q1, q2) relative to the face centroid c, q0 = 0 on the fan
    q1 = vertex_xyz - c[poly]
    q2 = vertex_xyz[nxt] - c[poly]
    w = 0.5 * np.einsum("ij,ij->i", np.cross(q1, q2), normal[poly])
    q0 = np.zeros_like(q1)
    tri = poly
    bent = np.bincount(poly, w < 0.0, minlength=F) > 0
    if np.any(bent):
        # a non-convex face (a cell clipped round a notch tip): the fan has
        # triangles of negative area, i.e. negative springs.  Such faces are
        # cut by ear clipping instead (Eberly, "Triangulation by ear
        # clipping", 2002), n − 2 triangles of positive area.
        q0, q1, q2, w, tri = _ear_fans(vertex_ptr, vertex_xyz, normal, c, bent, poly,
                                       q0, q1, q2, w)
    s_ = q0 + q1 + q2
    if rule == "three":
        # barycentric (2/3, 1/6, 1/6) and permutations
        offs = np.stack([(4.0 * q0 + q1 + q2) / 6.0, (q0 + 4.0 * q1 + q2) / 6.0,
                         (q0 + q1 + 4.0 * q2) / 6.0], axis=1)
        point = (c[tri][:, None, :] + offs).reshape(-1, 3)
        weight = np.repeat(w / 3.0, 3)
        face = np.repeat(tri, 3)
        return SpringPoints(point, weight, face)
    d = s_ / 3.0  # triangle centroid − c
    if rule == "centroid":
        return SpringPoints(c[tri] + d, w, tri.copy())

    # rule "moment": in-plane orthonormal basis (e1, e2) with e1 × e2 = n
    e1 = np.cross(normal, np.where(np.abs(normal[:, :1]) < 0.9, [[1.0, 0.0, 0.0]], [[0.0, 1.0, 0.0]]))
    e1 /= np.linalg.norm(e1, axis=1)[:, None]
    e2 = np.cross(normal, e1)
    E1, E2 = e1[tri], e2[tri]
    u = [np.einsum("ij,ij->i", q, E1) for q in (q0, q1, q2)]
    v = [np.einsum("ij,ij->i", q, E2) for q in (q0, q1, q2)]
    su, sv = u[0] + u[1] + u[2], v[0] + v[1] + v[2]
    # exact: ∫ over the triangle (q0, q1, q2) of x xᵀ = A/12 (Σ qi qiᵀ + s sᵀ)
    J11 = np.bincount(tri, w * (u[0] * u[0] + u[1] * u[1] + u[2] * u[2] + su * su),
                      minlength=F) / 12.0
    J12 = np.bincount(tri, w * (u[0] * v[0] + u[1] * v[1] + u[2] * v[2] + su * sv),
                      minlength=F) / 12.0
    J22 = np.bincount(tri, w * (v[0] * v[0] + v[1] * v[1] + v[2] * v[2] + sv * sv),
                      minlength=F) / 12.0
    # points: Σ w g gᵀ with g = s/3
    P11 = np.bincount(tri, w * su * su, minlength=F) / 9.0
    P12 = np.bincount(tri, w * su * sv, minlength=F) / 9.0
    P22 = np.bincount(tri, w * sv * sv, minlength=F) / 9.0
    # T = J^½ Jp^-½
    r11, r12, r22 = _sqrt_spd2(J11, J12, J22)
    q11, q12, q22 = _sqrt_spd2(P11, P12, P22)
    qdet = q11 * q22 - q12 * q12
    with np.errstate(invalid="ignore", divide="ignore", over="ignore"):
        # (a singular Jp gives inf/NaN here: such faces are `bad` below)
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
    nu = T11[tri] * du + T12[tri] * dv
    nv = T21[tri] * du + T22[tri] * dv
    point = c[tri] + nu[:, None] * E1 + nv[:, None] * E2
    return SpringPoints(point, w, tri.copy())


def _convex_points(vertex_ptr, vertex_xyz, normal, rule):
    """Rules "centroid" and "moment" on convex faces in one compiled loop
    (_fan_points: the formulas of _spring_points); None if a face has a fan
    triangle of negative area (non-convex): the vectorised path cuts such
    faces by ear clipping."""
    vertex_ptr = np.asarray(vertex_ptr, dtype=np.int64)
    if np.any(np.diff(vertex_ptr) < 3):
        raise ValueError("every face needs at least 3 vertices")
    vertex_xyz = np.ascontiguousarray(vertex_xyz, dtype=np.float64)
    normal = np.ascontiguousarray(normal, dtype=np.float64)
    area, c = polygon_properties(vertex_ptr, vertex_xyz, normal)
    K = int(vertex_ptr[-1])
    point, weight = np.empty((K, 3)), np.empty(K)
    face = np.empty(K, dtype=np.int64)
    # faces in ranges on threads for a large mesh (a face's points are its own)
    F = len(vertex_ptr) - 1
    nt = build_threads() if K >= THREADED_POINTS else 1
    ok = on_threads(_fan_points, F, nt,
                    lambda f0, f1: (vertex_ptr, vertex_xyz, normal, c, rule == "moment",
                                    (point, weight, face), f0, f1))
    return SpringPoints(point, weight, face) if all(ok) else None


@nb.njit(inline="always", cache=True)
def plane_basis(n0, n1, n2):
    """The in-plane basis of unit normal n as the vectorised rule takes it:
    e1 = n × (x̂, or ŷ where |n_x| ≥ 0.9) normalised, e2 = n × e1 (so
    e1 × e2 = n: angles about n grow counter-clockwise)."""
    if abs(n0) < 0.9:
        e10, e11, e12 = 0.0, n2, -n1
    else:
        e10, e11, e12 = -n2, 0.0, n0
    r = np.sqrt(e10 * e10 + e11 * e11 + e12 * e12)
    e10 /= r
    e11 /= r
    e12 /= r
    return e10, e11, e12, n1 * e12 - n2 * e11, n2 * e10 - n0 * e12, n0 * e11 - n1 * e10


#: spring points from which _convex_points runs on threads
THREADED_POINTS = 200_000


@nb.njit(cache=True, nogil=True, error_model="numpy")
def _fan_points(ptr, xyz, normal, c, moment, out, f0, f1):
    """Rules "centroid" and "moment" (moment: True) on the convex faces f0 …
    f1 − 1, one point per fan triangle (c, v_k, v_k+1) into out = (point,
    weight, face) (rows of xyz); the module docstring's formulas, face by
    face.  Returns False (and leaves the rows unfinished) if a face has a
    fan triangle of negative area: a non-convex face, for the vectorised
    path's ear clipping."""
    point, weight, face = out
    ok = np.ones(max(f1 - f0, 0), dtype=np.bool_)
    for f in range(f0, f1):
        a0, a1 = ptr[f], ptr[f + 1]
        n0, n1, n2 = normal[f, 0], normal[f, 1], normal[f, 2]
        e10, e11, e12, e20, e21, e22 = plane_basis(n0, n1, n2)
        J11 = J12 = J22 = P11 = P12 = P22 = 0.0
        for i in range(a0, a1):
            j = i + 1 if i + 1 < a1 else a0
            q10, q11, q12 = xyz[i, 0] - c[f, 0], xyz[i, 1] - c[f, 1], xyz[i, 2] - c[f, 2]
            q20, q21, q22 = xyz[j, 0] - c[f, 0], xyz[j, 1] - c[f, 1], xyz[j, 2] - c[f, 2]
            w = 0.5 * ((q11 * q22 - q12 * q21) * n0 + (q12 * q20 - q10 * q22) * n1
                       + (q10 * q21 - q11 * q20) * n2)
            if w < 0.0:
                ok[f - f0] = False
            u1 = q10 * e10 + q11 * e11 + q12 * e12
            v1 = q10 * e20 + q11 * e21 + q12 * e22
            u2 = q20 * e10 + q21 * e11 + q22 * e12
            v2 = q20 * e20 + q21 * e21 + q22 * e22
            su, sv = u1 + u2, v1 + v2
            # ∫ over the triangle (0, q1, q2) of x xᵀ = A/12 (Σ qi qiᵀ + s sᵀ)
            J11 += w * (u1 * u1 + u2 * u2 + su * su)
            J12 += w * (u1 * v1 + u2 * v2 + su * sv)
            J22 += w * (v1 * v1 + v2 * v2 + sv * sv)
            P11 += w * su * su
            P12 += w * su * sv
            P22 += w * sv * sv
            weight[i] = w
            face[i] = f
            # the triangle's centroid offset s/3, in (e1, e2) for now
            point[i, 0] = su / 3.0
            point[i, 1] = sv / 3.0
        T11, T12, T21, T22 = 1.0, 0.0, 0.0, 1.0
        if moment:
            J11 /= 12.0
            J12 /= 12.0
            J22 /= 12.0
            P11 /= 9.0
            P12 /= 9.0
            P22 /= 9.0
            # T = J^½ Jp^-½ (symmetric square roots in closed form, _sqrt_spd2)
            sj = np.sqrt(max(J11 * J22 - J12 * J12, 0.0))
            tj = np.sqrt(J11 + J22 + 2.0 * sj)
            r11, r12, r22 = (J11 + sj) / tj, J12 / tj, (J22 + sj) / tj
            sp = np.sqrt(max(P11 * P22 - P12 * P12, 0.0))
            tp = np.sqrt(P11 + P22 + 2.0 * sp)
            p11, p12, p22 = (P11 + sp) / tp, P12 / tp, (P22 + sp) / tp
            qdet = p11 * p22 - p12 * p12
            i11, i12, i22 = p22 / qdet, -p12 / qdet, p11 / qdet
            T11 = r11 * i11 + r12 * i12
            T12 = r11 * i12 + r12 * i22
            T21 = r12 * i11 + r22 * i12
            T22 = r12 * i12 + r22 * i22
            trJ, trP = J11 + J22, P11 + P22
            good = ((J11 * J22 - J12 * J12 > 1e-12 * trJ * trJ)
                    and (P11 * P22 - P12 * P12 > 1e-12 * trP * trP)
                    and np.isfinite(T11) and np.isfinite(T12) and np.isfinite(T21)
                    and np.isfinite(T22))
            if not good:   # a sliver: scale isotropically to the exact polar moment
                sc = np.sqrt(trJ / trP)
                if not np.isfinite(sc):
                    sc = 1.0
                T11, T12, T21, T22 = sc, 0.0, 0.0, sc
        for i in range(a0, a1):
            du, dv = point[i, 0], point[i, 1]
            nu = T11 * du + T12 * dv
            nv = T21 * du + T22 * dv
            point[i, 0] = c[f, 0] + nu * e10 + nv * e20
            point[i, 1] = c[f, 1] + nu * e11 + nv * e21
            point[i, 2] = c[f, 2] + nu * e12 + nv * e22
    for k in range(len(ok)):
        if not ok[k]:
            return False
    return True


def _ear_fans(vertex_ptr, vertex_xyz, normal, c, bent, poly, q0, q1, q2, w):
    """Replace the fan triangles of the faces ``bent`` by an ear-clipping
    triangulation; returns (q0, q1, q2, w, face) ordered by face."""
    import numba  # noqa: F401  (the kernel below is compiled on first use)
    vertex_ptr = np.asarray(vertex_ptr, dtype=np.int64)
    faces = np.nonzero(bent)[0]
    e1 = np.cross(normal[faces], np.where(np.abs(normal[faces, :1]) < 0.9, [[1.0, 0, 0]],
                                          [[0, 1.0, 0]]))
    e1 /= np.linalg.norm(e1, axis=1)[:, None]
    e2 = np.cross(normal[faces], e1)
    cnt = np.diff(vertex_ptr)[faces]
    ptr = np.zeros(len(faces) + 1, dtype=np.int64)
    np.cumsum(cnt, out=ptr[1:])
    idx = np.repeat(vertex_ptr[faces], cnt) + np.arange(ptr[-1]) - np.repeat(ptr[:-1], cnt)
    fk = np.repeat(np.arange(len(faces)), cnt)
    rel = vertex_xyz[idx] - c[faces][fk]
    uv = np.stack([np.einsum("ij,ij->i", rel, e1[fk]), np.einsum("ij,ij->i", rel, e2[fk])], 1)
    tri = _ear_clip(ptr, np.ascontiguousarray(uv))          # (T, 3) local vertex rows
    tface = faces[np.repeat(np.arange(len(faces)), cnt - 2)]
    Q = rel[tri]                                              # (T, 3, 3)
    wt = 0.5 * np.einsum("ij,ij->i", np.cross(Q[:, 1] - Q[:, 0], Q[:, 2] - Q[:, 0]),
                         normal[tface])
    keep = ~bent[poly]
    face = np.concatenate([poly[keep], tface])
    order = np.argsort(face, kind="stable")
    cat = lambda a, b: np.concatenate([a[keep], b])[order]  # noqa: E731
    return (cat(q0, Q[:, 0]), cat(q1, Q[:, 1]), cat(q2, Q[:, 2]), cat(w, wt), face[order])


def _ear_clip_kernel():
    import numba as nb

    @nb.njit(cache=True)
    def ear_clip(ptr, uv):
        """Ear clipping of simple polygons (counter-clockwise, CSR ptr, 2D
        points uv): (Σ (n − 2), 3) local vertex indices (rows of uv)."""
        F = len(ptr) - 1
        total = 0
        for f in range(F):
            total += ptr[f + 1] - ptr[f] - 2
        out = np.empty((total, 3), dtype=np.int64)
        t = 0
        for f in range(F):
            p0, n = ptr[f], ptr[f + 1] - ptr[f]
            live = np.arange(n)
            m = n
            guard = 0
            i = 0
            while m > 3 and guard < 2 * n * n:
                guard += 1
                ia, ib, ic = live[(i - 1) % m], live[i % m], live[(i + 1) % m]
                ax, ay = uv[p0 + ia, 0], uv[p0 + ia, 1]
                bx, by = uv[p0 + ib, 0], uv[p0 + ib, 1]
                cx, cy = uv[p0 + ic, 0], uv[p0 + ic, 1]
                cross = (bx - ax) * (cy - ay) - (by - ay) * (cx - ax)
                ear = cross > 0.0
                if ear:
                    for k in range(m):
                        j = live[k]
                        if j == ia or j == ib or j == ic:
                            continue
                        px, py = uv[p0 + j, 0], uv[p0 + j, 1]
                        d1 = (bx - ax) * (py - ay) - (by - ay) * (px - ax)
                        d2 = (cx - bx) * (py - by) - (cy - by) * (px - bx)
                        d3 = (ax - cx) * (py - cy) - (ay - cy) * (px - cx)
                        if d1 >= 0.0 and d2 >= 0.0 and d3 >= 0.0:
                            ear = False
                            break
                if ear:
                    out[t, 0], out[t, 1], out[t, 2] = p0 + ia, p0 + ib, p0 + ic
                    t += 1
                    for k in range(i % m, m - 1):
                        live[k] = live[k + 1]
                    m -= 1
                    i = max(i - 1, 0)
                else:
                    i += 1
            if m == 3:
                out[t, 0], out[t, 1], out[t, 2] = p0 + live[0], p0 + live[1], p0 + live[2]
                t += 1
            else:
                # no ear found (a degenerate outline): fan the rest
                for k in range(1, m - 1):
                    out[t, 0], out[t, 1], out[t, 2] = p0 + live[0], p0 + live[k], p0 + live[k + 1]
                    t += 1
        return out

    return ear_clip


_EAR_CLIP = []


def _ear_clip(ptr, uv):
    if not _EAR_CLIP:
        _EAR_CLIP.append(_ear_clip_kernel())
    return _EAR_CLIP[0](ptr, uv)


def edge_spring_points(vertex_ptr, vertex_xyz, normal, rule="moment"):
    """Spring points of the plane mode: on the trace of each face in the
    mid-plane z = 0 (the faces of a plane mesh are the sides of prisms,
    normal to z), weights summing to the face's area (edge length × depth).

    Along an edge of length L about its centroid c and direction τ = e_z × n:
    ``centroid`` one point at c; ``moment`` (default) two at c ± L/(2√3) τ
    (the 2-point Gauss rule: area, first and second moment of the edge
    exact, Σ w s² = A L²/12, as the 3D rule's on the face of a slab, so a
    plane model and its one-cell slab have the same stiffness);
    ``three`` the 3-point Gauss rule (±√(3/5) L/2, weights 5/18, 8/18, 5/18;
    exact to degree 5).  A face not normal to z (a slab's top or bottom)
    is an error: it carries no springs in a plane model."""
    vertex_ptr = np.asarray(vertex_ptr, dtype=np.int64)
    xyz = np.asarray(vertex_xyz, dtype=np.float64)
    normal = np.asarray(normal, dtype=np.float64)
    if len(normal) and np.max(np.abs(normal[:, 2])) > 1e-9:
        raise ValueError("a face not normal to the plane (a top or bottom of the slab) "
                         "cannot carry plane springs")
    area, cen = polygon_properties(vertex_ptr, xyz, normal)
    n, poly, _ = _polygon_index(vertex_ptr)
    tau = np.stack([-normal[:, 1], normal[:, 0]], axis=1)
    s = np.einsum("ij,ij->i", xyz[:, :2] - cen[poly, :2], tau[poly])
    F = len(n)
    smin = np.full(F, np.inf)
    smax = np.full(F, -np.inf)
    np.minimum.at(smin, poly, s)
    np.maximum.at(smax, poly, s)
    length = smax - smin
    mid = 0.5 * (smin + smax)            # the trace's midpoint (the centroid of a rectangle)
    if rule == "centroid":
        off, w = np.array([0.0]), np.array([1.0])
    elif rule == "moment":
        off, w = np.array([-0.5, 0.5]) / np.sqrt(3.0), np.array([0.5, 0.5])
    elif rule == "three":
        off = np.array([-0.5, 0.0, 0.5]) * np.sqrt(0.6)
        w = np.array([5.0, 8.0, 5.0]) / 18.0
    else:
        raise ValueError(f"unknown spring-point rule {rule!r} (one of {', '.join(RULES)})")
    k = len(off)
    face = np.repeat(np.arange(F, dtype=np.int64), k)
    pos = np.tile(off, F) * np.repeat(length, k) + np.repeat(mid, k)
    point = np.zeros((F * k, 3))
    point[:, :2] = cen[face, :2] + pos[:, None] * tau[face]
    return SpringPoints(point, np.tile(w, F) * np.repeat(area, k), face)
