"""Random Voronoi tessellation of a box, clipped exactly to the box.

Seeds
    ``round(volume / size³)`` points (at least 1), uniform in the box with a
    minimum mutual distance ``min_spacing · size`` (random sequential
    addition, "dart throwing", vectorised in batches with a k-d tree: a
    candidate is rejected if it is closer than the spacing to an accepted
    seed or to an earlier candidate of its batch).  Reproducible from
    ``seed`` (numpy ``default_rng``).  ``scipy.stats.qmc.PoissonDisk`` is not
    used: it grows its sample outward from one point, so stopping it at the
    wanted count leaves part of the box empty, and filling the box first
    needs several times the wanted count.  The seeds are then put in Morton
    (Z-curve) order of a grid of spacing ``size``, so that cells close in
    space are close in memory (cache locality of the kernels).

Cells
    Each cell is built on its own, as voro++ does (mesh/voronoi_cell.py):
    the box cut by the bisector planes of its nearest seeds until no
    further seed can cut it.  This is about three times faster than the
    dual of qhull's Delaunay triangulation below, runs on every thread, and
    gives a cell that depends only on its seed and its neighbours.  The
    triangulation below stays as the fallback, taken if the cells do not
    tile the box (never seen), and for voronoi_cells.

Clipping (the fallback)
    The seeds are mirrored across the box sides and the Voronoi diagram of
    seeds + mirrors is taken (as the dual of qhull's Delaunay
    triangulation, mesh/dual.py).  A point of the box is never strictly closer to
    a mirror than to its original, and a point outside side k is closer to
    the mirror across k than to the original, so the Voronoi cell of an
    original seed is exactly its Voronoi cell among the seeds clipped to the
    box.  Ridges between two seeds are internal faces; a ridge between a
    seed and its own mirror across side k is a boundary face on side k; a
    ridge between a seed and another seed's mirror lies on the side plane
    and has no area (dropped).  Only the seeds within a few ``size`` of a
    side are mirrored across it; if any cell is then not closed inside the
    box, the tessellation is redone with all mirrors (exact in every case).

Clean-up
    Vertices of a boundary face are put exactly on its side plane, and any
    vertex within 1e-10·size of a side plane is snapped onto it.  Voronoi
    vertices closer than 1e-10·size to each other (near-degenerate seed
    configurations) are merged.  Face polygons are ordered by angle about
    their normal; polygons left with fewer than 3 vertices or with an area
    below 1e-16·size² are dropped (their area is round-off).
"""
from __future__ import annotations

import numba as nb
import numpy as np

from ._core import Mesh, _gather, assemble, check_box
from .dual import JIT, voronoi_ridges
from .spring_points import polygon_properties

__all__ = ["voronoi_mesh", "voronoi_seeds"]

# seeds closer than _REACH * size to a side are mirrored across it (first try)
_REACH = 3.0


def _kdtree():
    """scipy.spatial.cKDTree, imported on first use (scipy.spatial costs about
    0.4 s to import: a block-mesh run should not pay it at start-up)."""
    from scipy.spatial import cKDTree
    return cKDTree


def _morton_order(points, lo, h):
    """Argsort of points along a Z-order curve on a grid of spacing h."""
    q = np.floor((points - lo) / h).astype(np.int64)
    q = np.clip(q, 0, (1 << 21) - 1)
    key = np.zeros(len(points), dtype=np.int64)
    for bit in range(21):
        for a in range(3):
            key |= ((q[:, a] >> bit) & 1) << (3 * bit + a)
    return np.argsort(key, kind="stable")


def voronoi_seeds(box, size, seed=0, min_spacing=0.5, n=None, plane=False):
    """The seed points used by ``voronoi_mesh`` (Morton-ordered), shape (N, 3).

    N = ``n`` if given, else max(1, round(volume / size³)).  Any two seeds are
    at least ``min_spacing * size`` apart.  ``plane``: seeds of a plane
    model (mesh/voronoi_plane.py), on the box's mid-plane in z, N =
    round(area / size²).
    """
    box = check_box(box)
    if not size > 0:
        raise ValueError(f"size must be positive, got {size!r}")
    if not 0 <= min_spacing < 1.0:
        raise ValueError(f"min_spacing must be in [0, 1), got {min_spacing!r}")
    lo, hi = box
    if plane:
        lo, hi = lo.copy(), hi.copy()
        lo[2] = hi[2] = 0.5 * (lo[2] + hi[2])
        vol = float(np.prod((hi - lo)[:2])) * size
    else:
        vol = float(np.prod(hi - lo))
    N = max(1, int(round(vol / size**3))) if n is None else int(n)
    r = float(min_spacing) * size
    rng = np.random.default_rng(seed)
    acc = np.empty((0, 3))
    tries = 0
    while len(acc) < N:
        need = N - len(acc)
        cand = rng.uniform(lo, hi, size=(max(2 * need, 64), 3))
        if r > 0:
            if len(acc):
                d, _ = _kdtree()(acc).query(cand, k=1, distance_upper_bound=r)
                cand = cand[d >= r]
            # drop the later of each pair closer than r (cKDTree.query_pairs:
            # distance ≤ r; one compiled pass over bins, 10⁶ seeds in 0.3 s
            # where the tree and its pairs took 3 s)
            cand = cand[_first_of_close(cand, r, lo, hi)]
        acc = np.vstack([acc, cand[:need]])
        tries += 1
        if tries > 200:
            raise RuntimeError(
                f"could not place {N} seeds {r:g} apart in the box (placed {len(acc)}); "
                "lower min_spacing"
            )
    return acc[_morton_order(acc, lo, size)]


def _first_of_close(p, r, lo, hi):
    """keep (len(p),) bool: no earlier point of p at distance ≤ r (the later
    of each pair cKDTree.query_pairs(r) finds is dropped, whether or not the
    earlier one is kept), by bins of side h ≥ r, about one point a bin."""
    ext = np.maximum(np.asarray(hi, float) - np.asarray(lo, float), 0.0)
    pos = ext[ext > 0]
    h = float(r)
    if len(pos) and len(p):
        h = max(h, float(np.prod(pos) / len(p)) ** (1.0 / len(pos)))
    dims = (np.floor(ext / h).astype(np.int64) + 1)
    return _keep_first(np.ascontiguousarray(p, dtype=np.float64), float(r),
                       np.asarray(lo, dtype=np.float64), h, dims)


@nb.njit(cache=True, nogil=True)
def _keep_first(p, r, lo, h, dims):
    """_first_of_close's pass: the points sorted into bins (stable: each bin's
    in index order, their coordinates copied in that order), then bin by
    bin each point tested against the earlier points of its 27 bins,
    |p_i − p_j|² ≤ r² summed x, y, z as cKDTree sums it."""
    n = len(p)
    cell = np.empty(n, dtype=np.int64)
    for i in range(n):
        c = 0
        for a in range(3):
            k = min(max(int((p[i, a] - lo[a]) / h), 0), dims[a] - 1)
            c = c * dims[a] + k
        cell[i] = c
    start = np.zeros(dims[0] * dims[1] * dims[2] + 1, dtype=np.int64)
    for i in range(n):
        start[cell[i] + 1] += 1
    for b in range(1, len(start)):
        start[b] += start[b - 1]
    at = start[:-1].copy()
    idx = np.empty(n, dtype=np.int64)
    q = np.empty((n, 3))
    for i in range(n):
        k = at[cell[i]]
        idx[k] = i
        q[k, 0], q[k, 1], q[k, 2] = p[i, 0], p[i, 1], p[i, 2]
        at[cell[i]] += 1
    r2 = r * r
    keep = np.ones(n, dtype=np.bool_)
    for x0 in range(dims[0]):
        for x1 in range(dims[1]):
            for x2 in range(dims[2]):
                b0 = (x0 * dims[1] + x1) * dims[2] + x2
                for k0 in range(start[b0], start[b0 + 1]):
                    i = idx[k0]
                    close = False
                    for d0 in range(max(x0 - 1, 0), min(x0 + 2, dims[0])):
                        for d1 in range(max(x1 - 1, 0), min(x1 + 2, dims[1])):
                            b = (d0 * dims[1] + d1) * dims[2]
                            for k in range(start[b + max(x2 - 1, 0)],
                                           start[b + min(x2 + 2, dims[2])]):
                                j = idx[k]
                                if j >= i:
                                    continue
                                e0 = q[k0, 0] - q[k, 0]
                                e1 = q[k0, 1] - q[k, 1]
                                e2 = q[k0, 2] - q[k, 2]
                                if e0 * e0 + e1 * e1 + e2 * e2 <= r2:
                                    close = True
                                    break
                            if close:
                                break
                        if close:
                            break
                    keep[i] = not close
    return keep


def _tessellate(seeds, box, size, reach):
    """Voronoi of seeds + mirrors of the seeds within ``reach`` of each side.

    Returns the raw pieces, or None if some cell is not closed inside the box
    (then call again with reach = inf)."""
    N = len(seeds)
    lo, hi = box
    pts = [seeds]
    src = [np.arange(N)]
    side = [np.full(N, -1)]
    for k in range(6):
        a, plane = k // 2, box[k % 2, k // 2]
        sel = np.flatnonzero(np.abs(seeds[:, a] - plane) < reach)
        m = seeds[sel].copy()
        m[:, a] = 2.0 * plane - m[:, a]
        pts.append(m)
        src.append(sel)
        side.append(np.full(len(sel), k))
    pts = np.vstack(pts)
    src = np.concatenate(src)
    side = np.concatenate(side)
    V, rp, rptr, rvid = voronoi_ridges(pts, n_keep=N)     # (mesh/dual.py)
    p, q = rp[:, 0], rp[:, 1]
    internal = q < N
    bnd = (p < N) & (q >= N) & (src[q] == p)
    keep = np.flatnonzero(internal | bnd)
    rptr, vid = _gather(rptr, rvid, keep)
    del rvid, rp
    if np.any(vid < 0):
        return None  # an unbounded cell: a needed mirror is missing
    cnt = np.diff(rptr)
    rid = np.repeat(np.arange(len(keep)), cnt)
    kp, kq = p[keep], q[keep]
    kside = np.where(kq < N, -1, side[kq])
    # vertices of a boundary face lie on its side plane: put them there
    vb = kside[rid] >= 0
    V[vid[vb], kside[rid[vb]] // 2] = box[kside[rid[vb]] % 2, kside[rid[vb]] // 2]
    used = _used(vid, len(V))
    tol = 1e-10 * size
    Vu = V[used]
    for a in range(3):
        for s in range(2):
            near = np.abs(Vu[:, a] - box[s, a]) <= tol
            Vu[near, a] = box[s, a]
    if np.any(Vu < lo - tol) or np.any(Vu > hi + tol):
        return None  # a cell pokes out of the box: a needed mirror is missing
    V[used] = Vu
    return V, vid, rid, cnt, kp, kq, kside


def voronoi_mesh(box, size, seed=0, min_spacing=0.5, *, seeds=None) -> Mesh:
    """Voronoi tessellation of ``box`` with cells of mean size ``size``.

    Parameters
    ----------
    box : [[xmin, ymin, zmin], [xmax, ymax, zmax]]
    size : mean cell size; the number of cells is about volume / size³
    seed : random seed (same seed, same mesh)
    min_spacing : minimum seed distance as a fraction of ``size``
    seeds : optional (N, 3) seed points inside the box to use instead of the
        random ones (``size`` then only sets tolerances)

    Cell i is the Voronoi cell of seed i (``voronoi_seeds(box, size, seed,
    min_spacing)``), clipped exactly to the box.
    """
    box = check_box(box)
    if not size > 0:
        raise ValueError(f"size must be positive, got {size!r}")
    if seeds is None:
        seeds = voronoi_seeds(box, size, seed, min_spacing)
    else:
        seeds = np.asarray(seeds, dtype=np.float64)
        if seeds.ndim != 2 or seeds.shape[1] != 3 or len(seeds) < 1:
            raise ValueError("seeds must be an (N, 3) array")
        if np.any(seeds <= box[0]) or np.any(seeds >= box[1]):
            raise ValueError("seeds must lie strictly inside the box")
    N = len(seeds)
    if N < 2:
        # a single cell is the box itself
        from .blocks import block_mesh
        return block_mesh(box, (1, 1, 1))

    from .voronoi_cell import box_voronoi_mesh
    try:
        mesh = box_voronoi_mesh(seeds, box, size)
    except RuntimeError:        # a cell beyond the builder's capacities
        mesh = None
    if mesh is not None and _tiles(mesh, box):
        return mesh
    return delaunay_mesh(box, size, seeds)


def _tiles(mesh, box):
    """Whether the cells fill the box (volumes positive, summing to its own)."""
    box_volume = float(np.prod(box[1] - box[0]))
    return (abs(mesh.cell_volume.sum() - box_volume) <= 1e-9 * box_volume
            and bool(np.all(mesh.cell_volume > 0)))


def delaunay_mesh(box, size, seeds):
    """voronoi_mesh's cells from the dual of qhull's Delaunay triangulation of
    the seeds and their mirrors (the module docstring's fallback)."""
    for reach in (_REACH * size, np.inf):
        out = _tessellate(seeds, box, size, reach)
        if out is None:
            continue
        mesh = _build(box, size, seeds, list(out))
        del out
        if _tiles(mesh, box):
            return mesh
    raise RuntimeError("Voronoi tessellation failed to tile the box")


def _build(box, size, seeds, data, bnormal=None):
    """Mesh from qhull's ridges, data = [V, vid, rid, cnt, kp, kq, kside]
    (kp, kq: seed ids, kside: the box side of a boundary ridge or −1;
    emptied here, so that its arrays are freed as soon as they are used:
    the build's peak memory); ``bnormal`` (R, 3): outward normals of the
    boundary ridges when they are not box sides, voronoi_cells."""
    N = len(seeds)
    V, vid, rid, cnt, kp, kq, kside = data
    data.clear()

    # merge Voronoi vertices closer than tol (near-degenerate seed sets)
    tol = 1e-10 * size
    used = _used(vid, len(V))
    inv = _renumber(used, len(V))[vid]
    Vu = V[used]
    pairs = _kdtree()(Vu).query_pairs(tol, output_type="ndarray")
    if len(pairs):
        from scipy.sparse import coo_matrix
        from scipy.sparse.csgraph import connected_components

        g = coo_matrix((np.ones(len(pairs)), (pairs[:, 0], pairs[:, 1])), shape=(len(Vu), len(Vu)))
        _, lab = connected_components(g, directed=False)
        # representative: the member with the most zero coordinates on the box? keep the first
        rep = np.full(lab.max() + 1, -1, dtype=np.int64)
        rep[lab[::-1]] = np.arange(len(Vu))[::-1]
        inv = rep[lab][inv]
    vid = inv
    xyz = Vu
    del V, used, inv, Vu

    # unique (ridge, vertex) pairs, ordered by angle about the ridge normal
    R = len(kp)
    rid, vid = _ridge_vertices(rid, vid)
    normal = np.empty((R, 3))
    isb = kside >= 0
    d = seeds[kq[~isb]] - seeds[kp[~isb]]
    normal[~isb] = d / np.linalg.norm(d, axis=1)[:, None]
    normal[isb] = 0.0
    if bnormal is None:
        ax = kside[isb] // 2
        normal[np.flatnonzero(isb), ax] = np.where(kside[isb] % 2 == 0, -1.0, 1.0)
    else:
        normal[isb] = bnormal[isb]
    cnt = np.bincount(rid, minlength=R)
    m = np.stack([np.bincount(rid, xyz[vid, j], minlength=R) for j in range(3)], 1)
    with np.errstate(invalid="ignore", divide="ignore"):
        m /= cnt[:, None]
    e1 = np.cross(normal, np.where(np.abs(normal[:, :1]) < 0.9, [[1.0, 0.0, 0.0]], [[0.0, 1.0, 0.0]]))
    e1 /= np.linalg.norm(e1, axis=1)[:, None]
    e2 = np.cross(normal, e1)
    rel = xyz[vid] - m[rid]
    ang = np.arctan2(np.einsum("ij,ij->i", rel, e2[rid]), np.einsum("ij,ij->i", rel, e1[rid]))
    o = _order_in_segments(ang, cnt)
    rid, vid = rid[o], vid[o]
    ptr = np.zeros(R + 1, dtype=np.int64)
    np.cumsum(cnt, out=ptr[1:])

    # drop degenerate ridges (fewer than 3 vertices or round-off area)
    ok = cnt >= 3
    area = np.zeros(R)
    sel = np.flatnonzero(ok)
    sp, sv = _gather(ptr, vid, sel)
    area[sel], _ = polygon_properties(sp, xyz[sv], normal[sel])
    ok &= area > 1e-16 * size * size
    sel = np.flatnonzero(ok)
    ptr, vid = _gather(ptr, vid, sel)
    kp, kq, kside, normal = kp[sel], kq[sel], kside[sel], normal[sel]
    isb = kside >= 0

    fi = np.flatnonzero(~isb)
    bi = np.flatnonzero(isb)
    f_ptr, f_vid = _gather(ptr, vid, fi)
    b_ptr, b_vid = _gather(ptr, vid, bi)
    f_cells, b_cell, b_side = np.stack([kp[fi], kq[fi]], axis=1), kp[bi], kside[bi]
    f_normal, b_normal = normal[fi], None if bnormal is None else normal[bi]
    del rid, vid, ptr, normal, rel, ang, o, e1, e2, m, cnt, area, sel, sp, sv, ok, isb
    del kp, kq, kside, fi, bi, bnormal, d, pairs
    return assemble(box, xyz, f_cells, f_ptr, f_vid, f_normal, b_cell, b_side, b_ptr, b_vid,
                    n_cells=N, ref=seeds, b_normal=b_normal)


def _used(vid, n):
    """The sorted distinct values of vid (of 0..n−1): np.unique(vid), by a
    mask in O(n) (numpy's unique hashes or sorts: 2.2 s of a 10.7 s build
    of 50 000 cells)."""
    mask = np.zeros(n, dtype=bool)
    mask[vid] = True
    return np.flatnonzero(mask)


def _renumber(used, n):
    """(n,) the rank of each of `used` (sorted) among them: with _used, the
    inverse of np.unique(vid, return_inverse=True) is _renumber(used)[vid]."""
    pos = np.full(n, -1, dtype=np.int64)
    pos[used] = np.arange(len(used))
    return pos


@nb.njit(**JIT)
def _ridge_vertices(rid, vid):
    """The distinct (ridge, vertex) pairs of rid (sorted) and vid, ordered
    by ridge then vertex: np.unique(rid * V + vid) split back, per ridge
    (each a few vertices, sorted by insertion)."""
    n = len(rid)
    out_r = np.empty(n, dtype=np.int64)
    out_v = np.empty(n, dtype=np.int64)
    k = 0
    i = 0
    while i < n:
        j = i
        while j < n and rid[j] == rid[i]:
            j += 1
        start = k
        for a in range(i, j):
            v = vid[a]
            # insert v into out_v[start:k] (sorted), unless present
            pos = k
            while pos > start and out_v[pos - 1] > v:
                pos -= 1
            if pos > start and out_v[pos - 1] == v:
                continue
            for b in range(k, pos, -1):
                out_v[b] = out_v[b - 1]
            out_v[pos] = v
            k += 1
        for b in range(start, k):
            out_r[b] = rid[i]
        i = j
    return out_r[:k].copy(), out_v[:k].copy()


@nb.njit(**JIT)
def _order_in_segments(key, cnt):
    """The permutation that sorts `key` within consecutive segments of
    lengths cnt, stably: np.lexsort((key, seg)) for sorted segment ids, by
    insertion in each segment (a face's few vertices)."""
    n = len(key)
    o = np.arange(n)
    start = 0
    for c in cnt:
        for a in range(start + 1, start + c):
            x = o[a]
            b = a
            while b > start and key[o[b - 1]] > key[x]:
                o[b] = o[b - 1]
                b -= 1
            o[b] = x
        start += c
    return o


def voronoi_cells(seeds, size, box) -> Mesh:
    """Voronoi cells of ``seeds`` (inside ``box``), for cells that are
    clipped to a solid in the box afterwards (mesh/clip.py): built cell by
    cell and clipped to the box (mesh/voronoi_cell.py; the box has a margin
    about the solid, so its sides lie outside it), their boundary faces
    bface_side 0 with their outward normals.  The Mesh's box is a frame 4
    box diagonals about the box's centre (clip_to_solid's tolerances scale
    with it).  If the cells do not fill the box, _frame_cells: one qhull
    run on the seeds and 26 frame points."""
    seeds = np.asarray(seeds, dtype=np.float64)
    box = check_box(box)
    c = box.mean(axis=0)
    d = float(np.linalg.norm(box[1] - box[0]))
    big = np.array([c - 4.0 * d, c + 4.0 * d])
    from .voronoi_cell import box_voronoi_mesh
    try:
        mesh = box_voronoi_mesh(seeds, box, size)
    except RuntimeError:        # a cell beyond the builder's capacities
        mesh = None
    if mesh is not None and _tiles(mesh, box):
        import dataclasses
        return dataclasses.replace(mesh, box=big, bface_side=np.zeros_like(mesh.bface_side))
    return _frame_cells(seeds, size, box)


def _frame_cells(seeds, size, box) -> Mesh:
    """Voronoi cells of ``seeds`` (inside ``box``), closed far outside it:
    26 frame points at 4 box diagonals from its centre (the directions of a
    cube's corners, edges and faces) bound every cell, and a face between a
    seed and a frame point lies more than 1.75 diagonals from the centre,
    outside the box.  No mirrors: for cells that are clipped to a solid in
    the box afterwards (mesh/clip.py), one qhull run on N + 26 points.  The
    Mesh's boundary faces are those frame faces (bface_side 0, their true
    normals); its box is the frame's."""
    seeds = np.asarray(seeds, dtype=np.float64)
    box = check_box(box)
    N = len(seeds)
    c = box.mean(axis=0)
    d = float(np.linalg.norm(box[1] - box[0]))
    g = np.array(np.meshgrid([-1, 0, 1], [-1, 0, 1], [-1, 0, 1], indexing="ij")).reshape(3, -1).T
    g = g[np.any(g != 0, axis=1)].astype(np.float64)
    frame = c + 4.0 * d * g / np.linalg.norm(g, axis=1)[:, None]
    pts = np.vstack([seeds, frame])
    V, rp, rptr, vid = voronoi_ridges(pts, n_keep=N)      # (mesh/dual.py)
    if np.any(vid < 0):
        raise RuntimeError("a Voronoi cell is not closed by the frame points")
    cnt = np.diff(rptr)
    rid = np.repeat(np.arange(len(rp)), cnt)
    kp, kq = rp[:, 0], rp[:, 1]
    kside = np.where(kq < N, -1, 0)
    bn = pts[kq] - seeds[kp]
    bn /= np.linalg.norm(bn, axis=1)[:, None]
    big = np.array([c - 4.0 * d, c + 4.0 * d])
    data = [V, vid, rid, cnt, kp, kq, kside]
    del V, rp, rptr, vid, rid, cnt, kp, kq, kside
    return _build(big, size, seeds, data, bnormal=bn)
