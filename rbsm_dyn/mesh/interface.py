"""Interfaces between parts: overlaps of touching boundary faces.

A scene of several parts, each meshed on its own, has all cells in one
``Mesh``.  Where part P touches part Q, a boundary face i of a cell of P and
a boundary face j of a cell of Q are coplanar with opposite outward normals
and overlap; their overlap polygon becomes an interface face between the two
cells (spring points go on it as on an internal face, mesh/spring_points.py).

``face_overlaps`` finds all of them in three stages, none with a Python loop
over faces or pairs:

1. Broad phase (Numba): the faces' axis-aligned bounding boxes, inflated by
   ``length_tol``, are binned on a uniform grid (spacing: the median box
   size, doubled until the number of (face, bin) entries stays within
   16 B + 65536, so one large face among many small ones costs (L/h)² bins,
   not B² pairs).  Faces sharing a bin, of cells in different parts, whose
   boxes overlap, are candidate pairs; a pair is reported only in the bin
   holding the lower corner of the boxes' intersection, so each pair comes
   out once without deduplication (the "reference point" method of Dittrich
   & Seeger, ICDE 2000, "Data redundancy and duplicate detection in spatial
   join processing").  Chosen over a cKDTree at radius 2 × the largest face
   circumradius because a scene with one coarse part against a fine one
   would then pair every fine face with every other.
2. Filters (NumPy, vectorised over the candidates): opposite normals,
   n_i · n_j ≤ −cos(angle_tol); each face's vertices within ``length_tol`` of
   the other face's plane (max over the vertices, both ways).
3. Clipping (one Numba kernel over the surviving pairs).  Face i (of the
   lower cell a) and face j are projected on an orthonormal basis (e1, e2)
   of face i's plane with e1 × e2 = n_i; face j's projection is reversed
   (it is counter-clockwise about n_j = −n_i).  Both are cleaned of vertices
   closer than ``length_tol`` to the previous one and of vertices where the
   boundary goes straight on or doubles back within ``length_tol``; so is
   every result (``_simplify``).  The overlap is
   the Sutherland–Hodgman clip (I. E. Sutherland, G. W. Hodgman,
   "Reentrant polygon clipping", Comm. ACM 17(1), 1974) of one polygon by
   the other, which must be convex: face j clips face i if face j is convex
   (no vertex turning right by more than ``length_tol``), else face i clips
   face j if face i is convex.  If neither is, the clip polygon (face j,
   else face i) is cut into the fan of triangles from its area centroid when
   all of them have positive area (the polygon is star-shaped about its
   centroid), the other polygon is clipped by each triangle and each
   non-empty piece is one overlap; otherwise ValueError.  The result is
   lifted back to 3D on face i's plane (x = o_i + u e1 + v e2, o_i the
   vertex mean of face i), so it lies exactly in the plane of cell a's face.

Overlaps smaller than ``min_area`` are dropped (faces touching along an edge
or at a point).  Note: the clip of a non-convex polygon by a convex one is
the exact overlap in area and first moment, but may be non-convex, and when
the overlap is disconnected Sutherland–Hodgman joins the pieces by
zero-width bridges along the clip edges; mesh/spring_points.py assumes
convex faces.  With convex cells on both sides (Voronoi and block meshes)
every overlap is convex.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numba import njit

from ._core import _gather
from .spring_points import polygon_properties

__all__ = ["Overlaps", "face_overlaps"]


@dataclass(frozen=True, eq=False)
class Overlaps:
    """Overlap polygons of touching boundary faces of cells in different parts.

    K overlaps, sorted by (a, b), then by a's face index (then by piece when
    a pair of non-convex faces gives several):
      cells (K, 2) int64: (a, b), a < b;
      faces (K, 2) int64: boundary-face indices (a's face, b's face);
      normal (K, 3): unit, from a to b (the outward normal of a's face);
      vertex_ptr (K+1,) int64, vertex_xyz (M, 3): the polygon, in the plane
        of a's face, counter-clockwise about ``normal``;
      area (K,) [m²], centroid (K, 3) [m] (area centroid).
    """

    cells: np.ndarray
    faces: np.ndarray
    normal: np.ndarray
    vertex_ptr: np.ndarray
    vertex_xyz: np.ndarray
    area: np.ndarray
    centroid: np.ndarray

    def __len__(self) -> int:
        return int(self.cells.shape[0])

    def __repr__(self) -> str:
        return f"Overlaps({len(self)} faces, total area {float(self.area.sum()):.6g})"


# ---------------------------------------------------------------------------
# broad phase: uniform grid of face bounding boxes

_BITS = 21                      # bits per axis in a bin key (3 × 21 < 63)
_MASK = (1 << _BITS) - 1


@njit(cache=True)
def _bin_entries(ilo, ihi, entry_ptr):
    """(key, face) for every grid bin touched by every face's box."""
    E = entry_ptr[-1]
    key = np.empty(E, np.int64)
    face = np.empty(E, np.int64)
    for f in range(ilo.shape[0]):
        e = entry_ptr[f]
        for ix in range(ilo[f, 0], ihi[f, 0] + 1):
            for iy in range(ilo[f, 1], ihi[f, 1] + 1):
                for iz in range(ilo[f, 2], ihi[f, 2] + 1):
                    key[e] = (ix << (2 * _BITS)) | (iy << _BITS) | iz
                    face[e] = f
                    e += 1
    return key, face


@njit(cache=True)
def _bin_pairs(group_ptr, key, face, ilo, lo, hi, part, out_i, out_j, fill):
    """Pairs of faces in one bin, of different parts, with overlapping boxes,
    reported only in the bin of the lower corner of the boxes' intersection
    (Dittrich & Seeger 2000: each pair once).  Returns the count; writes the
    pairs into out_i, out_j when ``fill``."""
    n = 0
    for g in range(group_ptr.shape[0] - 1):
        s0, s1 = group_ptr[g], group_ptr[g + 1]
        k = key[s0]
        bx, by, bz = k >> (2 * _BITS), (k >> _BITS) & _MASK, k & _MASK
        run_end = s0
        for s in range(s0, s1):
            fa = face[s]
            if s >= run_end:
                # faces of one part follow each other in a bin (sorted by
                # part): pairs only with the later parts' runs, so that a bin
                # crowded by one part's faces (a large rigid part's fan of
                # triangles) costs nothing
                run_end = s + 1
                while run_end < s1 and part[face[run_end]] == part[fa]:
                    run_end += 1
            for t in range(run_end, s1):
                fb = face[t]
                if (lo[fa, 0] > hi[fb, 0] or lo[fb, 0] > hi[fa, 0] or lo[fa, 1] > hi[fb, 1]
                        or lo[fb, 1] > hi[fa, 1] or lo[fa, 2] > hi[fb, 2] or lo[fb, 2] > hi[fa, 2]):
                    continue
                if (max(ilo[fa, 0], ilo[fb, 0]) != bx or max(ilo[fa, 1], ilo[fb, 1]) != by
                        or max(ilo[fa, 2], ilo[fb, 2]) != bz):
                    continue
                if fill:
                    out_i[n] = fa
                    out_j[n] = fb
                n += 1
    return n


def _candidate_pairs(lo, hi, part):
    """Pairs (i, j) of faces of different parts whose boxes [lo, hi] overlap."""
    B = len(lo)
    empty = np.zeros(0, np.int64)
    if B < 2:
        return empty, empty
    g0 = lo.min(axis=0)
    span = float((hi.max(axis=0) - g0).max())
    h = max(float(np.median((hi - lo).max(axis=1))), span / (_MASK - 1), 1e-300)
    budget = max(16 * B, 1 << 16)
    while True:
        ilo = np.minimum(np.floor((lo - g0) / h), _MASK).astype(np.int64)
        ihi = np.minimum(np.floor((hi - g0) / h), _MASK).astype(np.int64)
        cnt = np.prod(ihi - ilo + 1, axis=1)
        if cnt.sum() <= budget:
            break
        h *= 2.0
    entry_ptr = np.zeros(B + 1, np.int64)
    np.cumsum(cnt, out=entry_ptr[1:])
    key, face = _bin_entries(ilo, ihi, entry_ptr)
    part = np.ascontiguousarray(part, np.int64)
    order = np.lexsort((face, part[face], key))         # by bin, then part, then face
    key, face = key[order], face[order]
    starts = np.flatnonzero(np.concatenate([[True], key[1:] != key[:-1]]))
    group_ptr = np.concatenate([starts, [len(key)]]).astype(np.int64)
    n = _bin_pairs(group_ptr, key, face, ilo, lo, hi, part, empty, empty, False)
    fi = np.empty(n, np.int64)
    fj = np.empty(n, np.int64)
    _bin_pairs(group_ptr, key, face, ilo, lo, hi, part, fi, fj, True)
    return fi, fj


# ---------------------------------------------------------------------------
# 2D polygon kernels (polygons as (n, 2) arrays, counter-clockwise)

@njit(cache=True)
def _area2(p):
    """Twice the signed area (shoelace formula, Gauss)."""
    n = p.shape[0]
    s = 0.0
    for k in range(n):
        q = (k + 1) % n
        s += (p[k, 0] - p[0, 0]) * (p[q, 1] - p[0, 1]) - (p[q, 0] - p[0, 0]) * (p[k, 1] - p[0, 1])
    return s


@njit(cache=True)
def _centroid2(p):
    """Area centroid (shoelace-weighted triangle centroids, fan from vertex 0)."""
    n = p.shape[0]
    a = 0.0
    cx = 0.0
    cy = 0.0
    for k in range(1, n - 1):
        ux, uy = p[k, 0] - p[0, 0], p[k, 1] - p[0, 1]
        vx, vy = p[k + 1, 0] - p[0, 0], p[k + 1, 1] - p[0, 1]
        w = ux * vy - uy * vx
        a += w
        cx += w * (ux + vx) / 3.0
        cy += w * (uy + vy) / 3.0
    return p[0, 0] + cx / a, p[0, 1] + cy / a


@njit(cache=True)
def _simplify(p, tol):
    """Drop vertices closer than ``tol`` to the previous kept one (and a last
    one within ``tol`` of the first), then, repeatedly, vertices where the
    polygon goes straight on or doubles back within ``tol``:
    |e_prev × e_next| ≤ tol · max(|e_prev|, |e_next|), i.e. the end of the
    shorter edge lies within ``tol`` of the longer edge's line."""
    n = p.shape[0]
    q = np.empty((n, 2))
    m = 0
    for k in range(n):
        if m > 0 and np.hypot(p[k, 0] - q[m - 1, 0], p[k, 1] - q[m - 1, 1]) < tol:
            continue
        q[m, 0] = p[k, 0]
        q[m, 1] = p[k, 1]
        m += 1
    while m > 1 and np.hypot(q[m - 1, 0] - q[0, 0], q[m - 1, 1] - q[0, 1]) < tol:
        m -= 1
    changed = True
    while changed and m >= 3:
        changed = False
        for k in range(m):
            a = q[(k - 1) % m]
            b = q[k]
            c = q[(k + 1) % m]
            ux, uy = b[0] - a[0], b[1] - a[1]
            vx, vy = c[0] - b[0], c[1] - b[1]
            cr = ux * vy - uy * vx
            if abs(cr) <= tol * max(np.hypot(ux, uy), np.hypot(vx, vy)):
                for r in range(k, m - 1):
                    q[r, 0] = q[r + 1, 0]
                    q[r, 1] = q[r + 1, 1]
                m -= 1
                changed = True
                break
    if m < 3:
        m = 0
    return q[:m].copy()


@njit(cache=True)
def _is_convex(p, tol):
    """Counter-clockwise polygon convex within ``tol``: at no vertex does the
    boundary turn right by more than ``tol`` (edge cross products, the end of
    the shorter edge at most ``tol`` right of the longer edge's line)."""
    n = p.shape[0]
    for k in range(n):
        a = p[(k - 1) % n]
        b = p[k]
        c = p[(k + 1) % n]
        ux, uy = b[0] - a[0], b[1] - a[1]
        vx, vy = c[0] - b[0], c[1] - b[1]
        if ux * vy - uy * vx < -tol * max(np.hypot(ux, uy), np.hypot(vx, vy)):
            return False
    return True


@njit(cache=True)
def _clip(subject, clip):
    """Sutherland & Hodgman (1974): clip ``subject`` (any simple polygon) by
    each edge line of the convex ``clip`` in turn, keeping the left side
    (points on the line are inside; an intersection is emitted only where the
    signed distance changes sign strictly, so no duplicates at touching
    vertices)."""
    out = subject.copy()
    m = clip.shape[0]
    for k in range(m):
        n = out.shape[0]
        if n == 0:
            break
        ax, ay = clip[k, 0], clip[k, 1]
        ex, ey = clip[(k + 1) % m, 0] - ax, clip[(k + 1) % m, 1] - ay
        res = np.empty((2 * n, 2))
        c = 0
        px, py = out[n - 1, 0], out[n - 1, 1]
        dp = ex * (py - ay) - ey * (px - ax)        # > 0: left of the edge (inside)
        for q in range(n):
            x, y = out[q, 0], out[q, 1]
            d = ex * (y - ay) - ey * (x - ax)
            if (dp < 0.0 < d) or (d < 0.0 < dp):
                t = dp / (dp - d)
                res[c, 0] = px + t * (x - px)
                res[c, 1] = py + t * (y - py)
                c += 1
            if d >= 0.0:
                res[c, 0] = x
                res[c, 1] = y
                c += 1
            px, py, dp = x, y, d
        out = res[:c]
    return out


@njit(cache=True)
def _fan(p):
    """Fan triangles (c, p_k, p_k+1) from the area centroid c, (n, 3, 2), and
    whether all have positive area (p star-shaped about c)."""
    n = p.shape[0]
    cx, cy = _centroid2(p)
    tri = np.empty((n, 3, 2))
    ok = True
    for k in range(n):
        q = (k + 1) % n
        tri[k, 0, 0], tri[k, 0, 1] = cx, cy
        tri[k, 1, 0], tri[k, 1, 1] = p[k, 0], p[k, 1]
        tri[k, 2, 0], tri[k, 2, 1] = p[q, 0], p[q, 1]
        if (p[k, 0] - cx) * (p[q, 1] - cy) - (p[q, 0] - cx) * (p[k, 1] - cy) <= 0.0:
            ok = False
    return tri, ok


@njit(cache=True)
def _project(ptr, xyz, f, o, e1, e2, reverse):
    s, n = ptr[f], ptr[f + 1] - ptr[f]
    p = np.empty((n, 2))
    for k in range(n):
        v = s + (n - 1 - k if reverse else k)
        dx, dy, dz = xyz[v, 0] - o[0], xyz[v, 1] - o[1], xyz[v, 2] - o[2]
        p[k, 0] = dx * e1[0] + dy * e1[1] + dz * e1[2]
        p[k, 1] = dx * e2[0] + dy * e2[1] + dz * e2[2]
    return p


# ---------------------------------------------------------------------------
# narrow phase: one kernel over the candidate pairs

@njit(cache=True)
def _overlap_kernel(fi, fj, ptr, xyz, normal, origin, tol, min_area):
    """Overlap pieces of the pairs (fi[p], fj[p]), lifted to fi's plane.

    Returns piece_pair (K,), piece_seq (K,), piece_ptr (K+1,), piece_xyz
    (M, 3), status (P,): 0 ok, 1 both faces non-convex and neither
    star-shaped about its centroid."""
    P = fi.shape[0]
    status = np.zeros(P, np.int64)
    cap_k = max(16, P + 16)
    cap_m = max(64, 8 * P + 64)
    piece_pair = np.empty(cap_k, np.int64)
    piece_seq = np.empty(cap_k, np.int64)
    piece_ptr = np.zeros(cap_k + 1, np.int64)
    piece_xyz = np.empty((cap_m, 3))
    K = 0
    M = 0
    two_min = 2.0 * min_area
    for p in range(P):
        i, j = fi[p], fj[p]
        n = normal[i]
        # orthonormal basis of face i's plane, e1 × e2 = n (as in spring_points)
        if abs(n[0]) < 0.9:
            ax = np.array([1.0, 0.0, 0.0])
        else:
            ax = np.array([0.0, 1.0, 0.0])
        e1 = np.cross(n, ax)
        e1 /= np.sqrt(e1[0] ** 2 + e1[1] ** 2 + e1[2] ** 2)
        e2 = np.cross(n, e1)
        o = origin[i]
        a2 = _simplify(_project(ptr, xyz, i, o, e1, e2, False), tol)
        b2 = _simplify(_project(ptr, xyz, j, o, e1, e2, True), tol)   # ccw about n_i
        if a2.shape[0] < 3 or b2.shape[0] < 3 or _area2(a2) <= 0.0 or _area2(b2) <= 0.0:
            continue
        # (subject, clip triangles or the clip polygon itself)
        if _is_convex(b2, tol):
            subj = a2
            clips = np.empty((1, b2.shape[0], 2))
            clips[0] = b2
        elif _is_convex(a2, tol):
            subj = b2
            clips = np.empty((1, a2.shape[0], 2))
            clips[0] = a2
        else:
            tri, ok = _fan(b2)
            subj = a2
            if not ok:
                tri, ok = _fan(a2)
                subj = b2
            if not ok:
                status[p] = 1
                continue
            clips = tri
        for s in range(clips.shape[0]):
            piece = _simplify(_clip(subj, clips[s]), tol)
            m = piece.shape[0]
            if m < 3 or _area2(piece) < two_min:
                continue
            if K + 1 > cap_k:
                cap_k *= 2
                piece_pair = np.concatenate((piece_pair, np.empty(cap_k - piece_pair.shape[0], np.int64)))
                piece_seq = np.concatenate((piece_seq, np.empty(cap_k - piece_seq.shape[0], np.int64)))
                piece_ptr = np.concatenate((piece_ptr, np.zeros(cap_k + 1 - piece_ptr.shape[0], np.int64)))
            while M + m > cap_m:
                cap_m *= 2
                grown = np.empty((cap_m, 3))
                grown[:M] = piece_xyz[:M]
                piece_xyz = grown
            for k in range(m):
                for c in range(3):
                    piece_xyz[M + k, c] = o[c] + piece[k, 0] * e1[c] + piece[k, 1] * e2[c]
            piece_pair[K] = p
            piece_seq[K] = s
            M += m
            K += 1
            piece_ptr[K] = M
    return piece_pair[:K].copy(), piece_seq[:K].copy(), piece_ptr[:K + 1].copy(), piece_xyz[:M].copy(), status


# ---------------------------------------------------------------------------

def _empty_overlaps():
    return Overlaps(
        cells=np.zeros((0, 2), np.int64), faces=np.zeros((0, 2), np.int64), normal=np.zeros((0, 3)),
        vertex_ptr=np.zeros(1, np.int64), vertex_xyz=np.zeros((0, 3)), area=np.zeros(0),
        centroid=np.zeros((0, 3)),
    )


def face_overlaps(bface_vertex_ptr, bface_vertex_xyz, bface_normal, bface_cell, cell_part,
                  *, length_tol, angle_tol=1e-6, min_area=None) -> Overlaps:
    """Overlaps of coplanar, opposite boundary faces of cells in different parts.

    Parameters
    ----------
    bface_vertex_ptr (B+1,), bface_vertex_xyz (K, 3) : boundary-face polygons
        (CSR), each counter-clockwise about its outward normal
    bface_normal (B, 3) : outward normals (normalised here)
    bface_cell (B,) : the cell of each face
    cell_part (N,) : the part of each cell; only faces of cells in different
        parts are compared
    length_tol : [m] faces are coplanar when every vertex of each lies within
        length_tol of the other's plane; also the tolerance of the polygon
        clean-up (vertices closer than it merged, vertices within it of
        their neighbours' line dropped) and of the convexity test
    angle_tol : [rad] faces are opposite when n_i · n_j ≤ −cos(angle_tol)
    min_area : [m²] smaller overlaps are dropped (default 1e-10 × the largest
        boundary-face area): faces touching along an edge or at a point

    Returns
    -------
    Overlaps (see its docstring), polygons in the plane of the face of the
    lower cell a.  Raises ValueError when two overlapping faces are both
    non-convex and neither is star-shaped about its area centroid.
    """
    ptr = np.ascontiguousarray(bface_vertex_ptr, dtype=np.int64)
    xyz = np.ascontiguousarray(bface_vertex_xyz, dtype=np.float64)
    nrm = np.array(bface_normal, dtype=np.float64, ndmin=2)
    cell = np.ascontiguousarray(bface_cell, dtype=np.int64)
    cell_part = np.asarray(cell_part)
    B = len(cell)
    if ptr.shape != (B + 1,) or nrm.shape != (B, 3) or xyz.ndim != 2 or xyz.shape[1] != 3 \
            or ptr[-1] != len(xyz):
        raise ValueError("bface arrays disagree: need vertex_ptr (B+1,), vertex_xyz (ptr[-1], 3), "
                         "normal (B, 3), cell (B,)")
    if not length_tol > 0:
        raise ValueError(f"length_tol must be positive, got {length_tol!r}")
    if B < 2:
        return _empty_overlaps()
    nv = np.diff(ptr)
    if np.any(nv < 3):
        raise ValueError("every boundary face needs at least 3 vertices")
    nrm = nrm / np.linalg.norm(nrm, axis=1)[:, None]
    part = np.asarray(cell_part)[cell]
    if min_area is None:
        area, _ = polygon_properties(ptr, xyz, nrm)
        min_area = 1e-10 * float(np.abs(area).max())

    # 1. broad phase: grid bins of the boxes inflated by length_tol
    starts = ptr[:-1]
    lo = np.minimum.reduceat(xyz, starts, axis=0) - length_tol
    hi = np.maximum.reduceat(xyz, starts, axis=0) + length_tol
    _, part_id = np.unique(part, return_inverse=True)
    fi, fj = _candidate_pairs(lo, hi, part_id.reshape(-1))

    # 2. filters; i is the face of the lower cell
    swap = cell[fi] > cell[fj]
    fi, fj = np.where(swap, fj, fi), np.where(swap, fi, fj)
    keep = np.einsum("ij,ij->i", nrm[fi], nrm[fj]) <= -np.cos(angle_tol)
    fi, fj = fi[keep], fj[keep]
    origin = np.add.reduceat(xyz, starts, axis=0) / nv[:, None]    # vertex mean, on the plane

    def plane_gap(f_plane, f_pts):
        """max over the vertices of face f_pts of their distance to f_plane's plane."""
        cnt = nv[f_pts]
        seg = np.zeros(len(cnt) + 1, np.int64)
        np.cumsum(cnt, out=seg[1:])
        rep = np.repeat(np.arange(len(cnt)), cnt)
        vid = np.repeat(ptr[f_pts] - seg[:-1], cnt) + np.arange(seg[-1])
        d = np.abs(np.einsum("ij,ij->i", xyz[vid] - origin[f_plane][rep], nrm[f_plane][rep]))
        return np.maximum.reduceat(d, seg[:-1]) if len(cnt) else np.zeros(0)

    keep = (plane_gap(fi, fj) <= length_tol) & (plane_gap(fj, fi) <= length_tol)
    fi, fj = np.ascontiguousarray(fi[keep]), np.ascontiguousarray(fj[keep])
    if len(fi) == 0:
        return _empty_overlaps()

    # 3. clipping
    pair, seq, pptr, pxyz, status = _overlap_kernel(fi, fj, ptr, xyz, nrm, origin, float(length_tol),
                                                    float(min_area))
    if np.any(status):
        p = int(np.flatnonzero(status)[0])
        a, b = int(cell[fi[p]]), int(cell[fj[p]])
        raise ValueError(
            f"boundary faces of cells {a} and {b} are both non-convex and neither is star-shaped "
            f"about its area centroid (boundary faces {int(fi[p])} and {int(fj[p])}); "
            f"split one of them into convex faces")
    if len(pair) == 0:
        return _empty_overlaps()
    fa, fb = fi[pair], fj[pair]
    ca, cb = cell[fa], cell[fb]
    order = np.lexsort((seq, fa, cb, ca))
    pptr, pxyz = _gather(pptr, pxyz, order)
    fa, fb, ca, cb = fa[order], fb[order], ca[order], cb[order]
    normal = np.ascontiguousarray(nrm[fa])
    area, centroid = polygon_properties(pptr, pxyz, normal)
    return Overlaps(
        cells=np.ascontiguousarray(np.stack([ca, cb], axis=1), dtype=np.int64),
        faces=np.ascontiguousarray(np.stack([fa, fb], axis=1), dtype=np.int64),
        normal=normal, vertex_ptr=np.ascontiguousarray(pptr, dtype=np.int64),
        vertex_xyz=np.ascontiguousarray(pxyz, dtype=np.float64),
        area=area, centroid=centroid,
    )
