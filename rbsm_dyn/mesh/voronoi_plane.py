"""Voronoi cells of a plane model: the 2D Voronoi diagram of seeds in the
mid-plane, clipped exactly to a rectangle by mirrored seeds (as
mesh/voronoi.py in 3D: a point of the rectangle is never closer to a
mirror than to its seed), extruded to prisms z ∈ [−t/2, t/2].

Internal faces are the rectangles over the ridges between two seeds; a
ridge between a seed and its own mirror across side k is a boundary face
on side k (xmin, xmax, ymin, ymax); every cell has its bottom (zmin) and
top (zmax) polygon.  Voronoi vertices closer than 1e-10·size (cocircular
seeds and mirrors) are merged, and ridges left shorter than that dropped.
"""
from __future__ import annotations

import numpy as np

from ._core import assemble, check_box


def plane_voronoi_mesh(box, size, seeds):
    """Mesh of prisms: the Voronoi cells of `seeds` (N, 2 or 3; their x, y)
    in the rectangle of `box` (2, 3), z from box[0, 2] to box[1, 2]."""
    from scipy.spatial import Voronoi, cKDTree
    box = check_box(box)
    pts = np.asarray(seeds, dtype=float)[:, :2]
    n = len(pts)
    lo, hi = box[0, :2], box[1, :2]
    # mirrors across the four sides (all of them: a seed far from a side
    # adds a ridge that no cell keeps)
    allp, src, side = [pts], [np.arange(n)], [np.full(n, -1)]
    for k in range(4):
        a, plane = k // 2, box[k % 2, k // 2]
        m = pts.copy()
        m[:, a] = 2.0 * plane - m[:, a]
        allp.append(m)
        src.append(np.arange(n))
        side.append(np.full(n, k))
    allp = np.vstack(allp)
    src = np.concatenate(src)
    side = np.concatenate(side)
    if n == 1:
        rp = np.array([[0, n + k] for k in range(4)])
        V = np.array([[lo[0], lo[1]], [hi[0], lo[1]], [hi[0], hi[1]], [lo[0], hi[1]]])
        rv = np.array([[0, 3], [1, 2], [0, 1], [3, 2]])
    else:
        vor = Voronoi(allp)
        V = vor.vertices.copy()
        rp = np.asarray(vor.ridge_points, dtype=np.int64)
        rv = np.asarray(vor.ridge_vertices, dtype=np.int64)
    p = np.minimum(rp[:, 0], rp[:, 1])
    q = np.maximum(rp[:, 0], rp[:, 1])
    internal = q < n
    bnd = (p < n) & (q >= n) & (src[q] == p)
    keep = internal | bnd
    p, q, rv = p[keep], q[keep], rv[keep]
    if np.any(rv < 0):
        raise RuntimeError("an unbounded Voronoi cell inside the rectangle")
    kside = np.where(q < n, -1, side[q])
    # boundary ridges on their side's line, then everything near a side onto it
    tol = 1e-10 * size
    for r in np.flatnonzero(kside >= 0):
        k = kside[r]
        V[rv[r], k // 2] = box[k % 2, k // 2]
    for a in range(2):
        for s in range(2):
            V[np.abs(V[:, a] - box[s, a]) <= tol, a] = box[s, a]
    # merge vertices closer than tol (union by the smaller id)
    rep = np.arange(len(V))
    for i, j in sorted(cKDTree(V).query_pairs(tol)):
        ri, rj = rep[i], rep[j]
        while rep[ri] != ri:
            ri = rep[ri]
        while rep[rj] != rj:
            rj = rep[rj]
        rep[max(ri, rj)] = min(ri, rj)
    for i in range(len(rep)):
        while rep[rep[i]] != rep[i]:
            rep[i] = rep[rep[i]]
    rv = rep[rv]
    ok = rv[:, 0] != rv[:, 1]
    p, q, rv, kside = p[ok], q[ok], rv[ok], kside[ok]
    # each ridge's normal: from seed p to seed q (or to its mirror), so the
    # tangent τ = e_z × n orders its two vertices
    other = np.where(q < n, q, q)
    nrm = allp[other] - pts[p]
    nrm /= np.linalg.norm(nrm, axis=1)[:, None]
    tau = np.stack([-nrm[:, 1], nrm[:, 0]], axis=1)
    swap = np.einsum("ij,ij->i", V[rv[:, 1]] - V[rv[:, 0]], tau) < 0
    rv[swap] = rv[swap][:, ::-1]
    # 3D points: vertex v at the bottom is 2v, at the top 2v + 1
    z0, z1 = box[0, 2], box[1, 2]
    xyz = np.empty((2 * len(V), 3))
    xyz[0::2, :2] = V
    xyz[1::2, :2] = V
    xyz[0::2, 2] = z0
    xyz[1::2, 2] = z1
    # side rectangles, counter-clockwise about n: (v1, bottom), (v2, bottom),
    # (v2, top), (v1, top) (τ then e_z: τ × e_z = n)
    quad = np.stack([2 * rv[:, 0], 2 * rv[:, 1], 2 * rv[:, 1] + 1, 2 * rv[:, 0] + 1], axis=1)
    n3 = np.zeros((len(p), 3))
    n3[:, :2] = nrm
    fi = np.flatnonzero(kside < 0)
    bi = np.flatnonzero(kside >= 0)
    f_cells = np.stack([p[fi], q[fi]], axis=1)
    f_ptr = np.arange(len(fi) + 1) * 4
    f_vid = quad[fi].reshape(-1)
    # bottoms and tops: each cell's vertices ordered by angle about its seed
    cell_of = np.concatenate([p, q[q < n]])
    verts = np.concatenate([rv[:, 0], rv[q < n, 1]])
    cell_of = np.concatenate([cell_of, p, q[q < n]])
    verts = np.concatenate([verts, rv[:, 1], rv[q < n, 0]])
    pair = np.unique(cell_of * len(V) + verts)
    pc, pv = pair // len(V), pair % len(V)
    ang = np.arctan2(V[pv, 1] - pts[pc, 1], V[pv, 0] - pts[pc, 0])
    order = np.lexsort((ang, pc))
    pc, pv = pc[order], pv[order]
    cnt = np.bincount(pc, minlength=n)
    if np.any(cnt < 3):
        raise RuntimeError("a Voronoi cell of the plane has fewer than 3 vertices")
    cptr = np.concatenate([[0], np.cumsum(cnt)])
    top_vid = 2 * pv + 1
    # the bottom, counter-clockwise about −z: the reversed order
    j = np.arange(len(pv)) - np.repeat(cptr[:-1], cnt)
    bot_vid = 2 * pv[np.repeat(cptr[:-1], cnt) + (np.repeat(cnt, cnt) - 1 - j)]
    b_cell = np.concatenate([p[bi], np.arange(n), np.arange(n)])
    b_side = np.concatenate([kside[bi], np.full(n, 4), np.full(n, 5)])
    b_ptr = np.concatenate([np.arange(len(bi)) * 4, 4 * len(bi) + cptr,
                            4 * len(bi) + len(pv) + cptr[1:]])
    b_vid = np.concatenate([quad[bi].reshape(-1), bot_vid, top_vid])
    ref = np.column_stack([pts, np.full(n, 0.5 * (z0 + z1))])
    return assemble(box, xyz, f_cells, f_ptr, f_vid, n3[fi], b_cell, b_side, b_ptr, b_vid, n,
                    ref=ref)
