"""Voronoi cells of a box one at a time, as voro++ builds them.

Each cell starts as the box and is cut by the bisector plane of its seed p
and each neighbour q, nearest first, keeping {x : (q − p)·x ≤ (|q|² −
|p|²)/2}; once the next neighbour is at least twice as far as the cell's
farthest vertex, no further plane can cut it (Rycroft, "VORO++: A
three-dimensional Voronoi cell library in C++", Chaos 19 (2009) 041111,
§II).  A cell so built is exactly the Voronoi cell of p among all the seeds,
clipped to the box, and it depends on p and its neighbours only: no qhull
run over the whole point set, no mirrors across the sides, each cell on its
own thread, and the same cell whichever cells are built beside it (the
distributed build of DESIGN.md §10).

A cut keeps the vertices on the inner side of the plane or within ``eps``
of it (so a near-degenerate configuration of seeds gives one vertex, not
two a round-off apart), puts a vertex on each edge that crosses the plane
(the same vertex for both faces of the edge) and closes the cell with the
plane's polygon, its vertices ordered by angle about the outward normal
(counter-clockwise seen from outside).  Faces are tagged with the
neighbour that made them (≥ 0) or the box side (−1 − side).
"""
import numba as nb
import numpy as np

from ..threads import build_threads, on_threads
from ._core import SIDES, Mesh, _gather
from .polyhedron import cells_mass_properties
from .spring_points import plane_basis

JIT = dict(cache=True, nogil=True, error_model="numpy")

#: capacities of one cell under construction (a Voronoi cell of random
#: seeds has about 15 faces and 27 vertices; a cut adds a few vertices
#: and one face): faces, vertices of a face, vertices of a cell
MF = 64
MFV = 32
MV = 256

# the box's faces, counter-clockwise seen from outside, as corner numbers
# i = x + 2y + 4z (x, y, z ∈ {0 lo, 1 hi}), four bits each
_BOX_FACES = (0x2640, 0x5731, 0x4510, 0x3762, 0x1320, 0x6754)


@nb.njit(**JIT)
def _start(lo, hi, vx, fv, fn, ftag):
    """The box as the first cell: 8 vertices, 6 faces tagged −1 − side."""
    for i in range(8):
        vx[i, 0] = hi[0] if i & 1 else lo[0]
        vx[i, 1] = hi[1] if (i >> 1) & 1 else lo[1]
        vx[i, 2] = hi[2] if (i >> 2) & 1 else lo[2]
    for f in range(6):
        code = _BOX_FACES[f]
        for j in range(4):
            fv[f, j] = (code >> (4 * j)) & 0xF
        fn[f] = 4
        ftag[f] = -1 - f
    return 8, 6


@nb.njit(**JIT)
def _cut(cell, nv, nf, plane, eps, tag, w):
    """Cut the cell (cell = (vx, fv, fn, ftag): vertices vx[:nv], faces
    fv/fn/ftag[:nf]) by n·x ≤ d (plane = (n0, n1, n2, d), n unit; w the
    work arrays); returns (nv, nf, cut?) or (−1, −1, 0) when a capacity is
    exceeded."""
    vx, fv, fn, ftag = cell
    n0, n1, n2, d = plane
    s, keep, tmp, ea, eb, ev, cap, ang = w
    nout = 0
    for i in range(nv):
        s[i] = vx[i, 0] * n0 + vx[i, 1] * n1 + vx[i, 2] * n2 - d
        if s[i] > eps:
            nout += 1
    if nout == 0:
        return nv, nf, 0
    ne = 0
    nf2 = 0
    for f in range(nf):
        m = fn[f]
        k = 0
        allon = True
        for j in range(m):
            a = fv[f, j]
            b = fv[f, j + 1] if j + 1 < m else fv[f, 0]
            sa = s[a]
            sb = s[b]
            if sa <= eps:
                tmp[k] = a
                k += 1
                if sa < -eps:
                    allon = False
            # an edge from inside to outside (strictly): its crossing vertex
            if (sa < -eps and sb > eps) or (sa > eps and sb < -eps):
                lo_ = min(a, b)
                hi_ = max(a, b)
                v = -1
                for e in range(ne):
                    if ea[e] == lo_ and eb[e] == hi_:
                        v = ev[e]
                        break
                if v < 0:
                    if nv >= vx.shape[0]:
                        return -1, -1, 0
                    i_ = a if sa < 0 else b
                    o_ = b if sa < 0 else a
                    t = s[i_] / (s[i_] - s[o_])
                    for c in range(3):
                        vx[nv, c] = vx[i_, c] + t * (vx[o_, c] - vx[i_, c])
                    s[nv] = 0.0
                    v = nv
                    nv += 1
                    ea[ne] = lo_
                    eb[ne] = hi_
                    ev[ne] = v
                    ne += 1
                tmp[k] = v
                k += 1
        # a face left with fewer than 3 vertices, or lying in the plane
        # (the new face replaces it), goes
        if k >= 3 and not allon:
            if k > fv.shape[1]:
                return -1, -1, 0
            for j in range(k):
                fv[nf2, j] = tmp[j]
            fn[nf2] = k
            ftag[nf2] = ftag[f]
            nf2 += 1
    # the new face: the kept vertices on the plane (old ones within eps and
    # the crossings), ordered by angle about n
    for i in range(nv):
        keep[i] = 0
    for f in range(nf2):
        for j in range(fn[f]):
            keep[fv[f, j]] = 1
    nc = 0
    for i in range(nv):
        if keep[i] == 1 and abs(s[i]) <= eps:
            cap[nc] = i
            nc += 1
    if nc >= 3:
        if nf2 >= fv.shape[0] or nc > fv.shape[1]:
            return -1, -1, 0
        c0 = c1 = c2 = 0.0
        for j in range(nc):
            c0 += vx[cap[j], 0]
            c1 += vx[cap[j], 1]
            c2 += vx[cap[j], 2]
        c0 /= nc
        c1 /= nc
        c2 /= nc
        # the angle about n grows counter-clockwise
        e10, e11, e12, e20, e21, e22 = plane_basis(n0, n1, n2)
        for j in range(nc):
            x0 = vx[cap[j], 0] - c0
            x1 = vx[cap[j], 1] - c1
            x2 = vx[cap[j], 2] - c2
            ang[j] = np.arctan2(x0 * e20 + x1 * e21 + x2 * e22, x0 * e10 + x1 * e11 + x2 * e12)
        for j in range(1, nc):              # insertion sort by angle
            a = ang[j]
            v = cap[j]
            i = j
            while i > 0 and ang[i - 1] > a:
                ang[i] = ang[i - 1]
                cap[i] = cap[i - 1]
                i -= 1
            ang[i] = a
            cap[i] = v
        for j in range(nc):
            fv[nf2, j] = cap[j]
        fn[nf2] = nc
        ftag[nf2] = tag
        nf2 += 1
    # drop the vertices no face uses (those outside), renumbered in order
    for i in range(nv):
        keep[i] = -1
    for f in range(nf2):
        for j in range(fn[f]):
            keep[fv[f, j]] = 1
    k = 0
    for i in range(nv):
        if keep[i] == 1:
            keep[i] = k
            if k != i:
                vx[k, 0] = vx[i, 0]
                vx[k, 1] = vx[i, 1]
                vx[k, 2] = vx[i, 2]
            k += 1
    for f in range(nf2):
        for j in range(fn[f]):
            fv[f, j] = keep[fv[f, j]]
    return k, nf2, 1


@nb.njit(**JIT)
def _one_cell(p, seeds, nbr, nd2, box, reach2, eps, vx, fv, fn, ftag, w):
    """Build cell p in vx/fv/fn/ftag from its neighbours nbr (nearest first,
    −1 padded, squared distances nd2), box = (lo, hi); reach2: the squared
    distance within which nbr holds every seed (−1: no such claim); returns
    (nv, nf, status): status 0 done, 1 the neighbours ran out before the
    cell was closed, 2 a capacity exceeded."""
    lo, hi = box
    nv, nf = _start(lo, hi, vx, fv, fn, ftag)
    px, py, pz = seeds[p, 0], seeds[p, 1], seeds[p, 2]
    r2 = 0.0
    for i in range(nv):
        dx, dy, dz = vx[i, 0] - px, vx[i, 1] - py, vx[i, 2] - pz
        r2 = max(r2, dx * dx + dy * dy + dz * dz)
    for j in range(nbr.shape[0]):
        q = nbr[j]
        if q < 0:
            # every seed not listed is at least √reach2 away: done when that
            # is beyond the farthest vertex's bisector (the test below)
            return nv, nf, 0 if reach2 >= 4.0 * r2 * (1.0 + 1e-12) else 1
        # the bisector is √nd2/2 from p: beyond the farthest vertex, done
        if nd2[j] >= 4.0 * r2 * (1.0 + 1e-12):
            return nv, nf, 0
        n0 = seeds[q, 0] - px
        n1 = seeds[q, 1] - py
        n2 = seeds[q, 2] - pz
        L = np.sqrt(n0 * n0 + n1 * n1 + n2 * n2)
        n0 /= L
        n1 /= L
        n2 /= L
        # the bisector through the midpoint, n·x = n·(p + q)/2
        d = 0.5 * (n0 * (seeds[q, 0] + px) + n1 * (seeds[q, 1] + py) + n2 * (seeds[q, 2] + pz))
        nv, nf, cut = _cut((vx, fv, fn, ftag), nv, nf, (n0, n1, n2, d), eps, q, w)
        if nv < 0:
            return 0, 0, 2
        if cut:
            r2 = 0.0
            for i in range(nv):
                dx, dy, dz = vx[i, 0] - px, vx[i, 1] - py, vx[i, 2] - pz
                r2 = max(r2, dx * dx + dy * dy + dz * dz)
    if nbr.shape[0] == 0:
        return nv, nf, 0
    return nv, nf, 1


@nb.njit(**JIT)
def build_cells(cells, seeds, nbr, nd2, box, reach2, eps, i0, i1, out, status):
    """Cells cells[i0:i1] (each row of nbr/nd2 its neighbours) into the
    fixed-capacity rows out_*[i] (i the position in ``cells``); status[i]
    as _one_cell's.  box = (lo, hi); reach2 as _one_cell's; out = (out_nv,
    out_vx, out_nf, out_fn, out_ftag, out_fv).  Serial and without the GIL:
    cells_of_box runs a range on each thread (a parallel loop here took 2 s
    more to compile)."""
    out_nv, out_vx, out_nf, out_fn, out_ftag, out_fv = out
    s = np.empty(MV)
    keep = np.empty(MV, dtype=np.int64)
    tmp = np.empty(MFV * 2, dtype=np.int64)
    ea = np.empty(MV, dtype=np.int64)
    eb = np.empty(MV, dtype=np.int64)
    ev = np.empty(MV, dtype=np.int64)
    cap = np.empty(MV, dtype=np.int64)
    ang = np.empty(MV)
    w = (s, keep, tmp, ea, eb, ev, cap, ang)
    for i in range(i0, i1):
        nv, nf, st = _one_cell(cells[i], seeds, nbr[i], nd2[i], box, reach2, eps, out_vx[i],
                               out_fv[i], out_fn[i], out_ftag[i], w)
        out_nv[i] = nv
        out_nf[i] = nf
        status[i] = st


@nb.njit(**JIT)
def _count(sel, out_nv, out_nf, out_fn):
    """Vertices, polygons and polygon entries of the built cells sel."""
    n = len(sel)
    nv = np.empty(n, dtype=np.int64)
    npoly = np.empty(n, dtype=np.int64)
    nent = np.empty(n, dtype=np.int64)
    for ii in range(n):
        i = sel[ii]
        nv[ii] = out_nv[i]
        npoly[ii] = out_nf[i]
        k = 0
        for f in range(out_nf[i]):
            k += out_fn[i, f]
        nent[ii] = k
    return nv, npoly, nent


@nb.njit(**JIT)
def _compact(cells, sel, out, dest, key):
    """Copy the built cells sel of this chunk (out: build_cells' rows) into
    the chunk's CSR arrays dest = (vertices, poly_ptr, poly_vertex,
    poly_tag); each cell's polygons ordered as Mesh has them: faces to
    higher cells (by cell), to lower cells (by cell), then box sides (by
    side)."""
    out_nv, out_vx, out_nf, out_fn, out_ftag, out_fv = out
    vertices, poly_ptr, poly_vertex, poly_tag = dest
    v0 = p0 = e0 = 0
    for i in sel:
        c = cells[i]
        nf = out_nf[i]
        for j in range(out_nv[i]):
            for a in range(3):
                vertices[v0 + j, a] = out_vx[i, j, a]
        for f in range(nf):
            t = out_ftag[i, f]
            key[f] = (0 if t > c else 1) * (1 << 40) + t if t >= 0 else 2 * (1 << 40) - t
        # insertion sort of the cell's polygons by key
        order = np.arange(nf)
        for f in range(1, nf):
            x = order[f]
            g = f
            while g > 0 and key[order[g - 1]] > key[x]:
                order[g] = order[g - 1]
                g -= 1
            order[g] = x
        for f in range(nf):
            src = order[f]
            poly_tag[p0] = out_ftag[i, src]
            for j in range(out_fn[i, src]):
                poly_vertex[e0 + j] = v0 + out_fv[i, src, j]
            e0 += out_fn[i, src]
            p0 += 1
            poly_ptr[p0] = e0
        v0 += out_nv[i]


#: [cell sizes] the first neighbour search's reach (cells_of_box): a seed
#: farther than it cannot cut a cell whose farthest vertex is within half
#: of it (the cells of random seeds: 1.2 sizes, min_spacing 0.5)
REACH = 3.0
#: cells from which cells_of_box cuts on threads
THREADED_CELLS = 8192


def cells_of_box(seeds, box, size, chunk=4096, k0=64):
    """The Voronoi cells of ``seeds`` clipped to ``box``, one at a time:
    (vertices (V, 3), cell_vertex_ptr (N+1,), poly_ptr, poly_vertex (ids into
    vertices), cell_poly_ptr (N+1,), poly_tag (neighbour ≥ 0 or −1 − side)).
    Neighbours come from a k-d tree, at first the ``k0`` nearest within
    REACH cell sizes (about 1 % of the cells of random seeds then need
    more) and twice as many, unbounded, for the cells they did not close.
    The cells go in chunks of ``chunk`` through fixed-capacity work rows
    (about 30 MB)."""
    from scipy.spatial import cKDTree
    seeds = np.ascontiguousarray(seeds, dtype=np.float64)
    box = np.asarray(box, dtype=np.float64)
    lo, hi = box[0].copy(), box[1].copy()
    N = len(seeds)
    eps = 1e-10 * size
    tree = cKDTree(seeds)
    # threads (Numba's count, threads.py) for a mesh large enough to pay
    # for them (8 192 cells cut in about 0.4 s on one)
    nt = build_threads() if N >= THREADED_CELLS else 1
    chunk = max(1, min(chunk, N))
    out = (np.empty(chunk, dtype=np.int64), np.empty((chunk, MV, 3)),
           np.empty(chunk, dtype=np.int64), np.empty((chunk, MF), dtype=np.int64),
           np.empty((chunk, MF), dtype=np.int64), np.empty((chunk, MF, MFV), dtype=np.int32))
    status = np.empty(chunk, dtype=np.int64)
    key = np.empty(MF, dtype=np.int64)
    parts = []
    pending = np.arange(N)
    k = min(k0, N - 1)
    first = True
    while len(pending):
        nxt = []
        for c0 in range(0, len(pending), chunk):
            cells = pending[c0:c0 + chunk]
            m = len(cells)
            # the first pass lists the seeds within REACH cell sizes (a
            # pruned search: 40 % faster); a cell that needs farther ones
            # goes again with twice as many, unbounded
            reach = REACH * size if first else np.inf
            d, j = tree.query(seeds[cells], k=k + 1, workers=nt, distance_upper_bound=reach)
            d, j = d.reshape(m, -1)[:, 1:], j.reshape(m, -1)[:, 1:]
            nd2 = np.ascontiguousarray(d * d)
            nbr = np.ascontiguousarray(np.where(j >= N, -1, j), dtype=np.int64)
            o = tuple(a[:m] for a in out)
            reach2 = reach * reach if np.isfinite(reach) else -1.0
            on_threads(build_cells, m, nt,
                       lambda i0, i1: (cells, seeds, nbr, nd2, (lo, hi), reach2, eps, i0, i1,
                                       o, status[:m]))
            st = status[:m]
            if np.any(st == 2):
                raise RuntimeError("a Voronoi cell has more faces or vertices than the "
                                   "cell builder holds (mesh/voronoi_cell.py MF, MFV, MV)")
            ok = (st == 0) | ((k >= N - 1) and not first)
            nxt.append(cells[~ok])
            sel = np.flatnonzero(ok)
            if len(sel) == 0:
                continue
            nv, npoly, nent = _count(sel, o[0], o[2], o[3])
            vertices = np.empty((int(nv.sum()), 3))
            poly_ptr = np.zeros(int(npoly.sum()) + 1, dtype=np.int64)
            poly_vertex = np.empty(int(nent.sum()), dtype=np.int64)
            poly_tag = np.empty(int(npoly.sum()), dtype=np.int64)
            _compact(cells, sel, o, (vertices, poly_ptr, poly_vertex, poly_tag), key)
            parts.append((cells[sel], nv, npoly, nent, vertices, poly_ptr, poly_vertex,
                          poly_tag))
        pending = np.concatenate(nxt)
        k = min(2 * k, N - 1)
        first = False
    return _join(parts, N)


def _join(parts, N):
    """The chunks' cells (each part: cells, per-cell counts and its CSR
    arrays) put in cell order."""
    nv = np.zeros(N, dtype=np.int64)
    npoly = np.zeros(N, dtype=np.int64)
    nent = np.zeros(N, dtype=np.int64)
    for cs, a, b, c, *_ in parts:
        nv[cs], npoly[cs], nent[cs] = a, b, c
    cvp, cpp, cep = (np.concatenate(([0], np.cumsum(x))) for x in (nv, npoly, nent))
    vertices = np.empty((cvp[-1], 3))
    poly_ptr = np.zeros(cpp[-1] + 1, dtype=np.int64)
    poly_vertex = np.empty(cep[-1], dtype=np.int64)
    poly_tag = np.empty(cpp[-1], dtype=np.int64)

    def place(k0, k1):
        # (the chunks' cells go to disjoint rows: chunks on threads)
        for (cs, a, b, c, vx, ptr, vid, tag) in parts[k0:k1]:
            _place(cs, a, b, (vx, ptr, vid, tag), (cvp, cpp, cep),
                   (vertices, poly_ptr, poly_vertex, poly_tag))
    on_threads(place, len(parts), build_threads() if N >= THREADED_CELLS else 1,
               lambda k0, k1: (k0, k1))
    np.cumsum(poly_ptr, out=poly_ptr)
    return vertices, cvp, poly_ptr, poly_vertex, cpp, poly_tag


@nb.njit(**JIT)
def _place(cs, nv, npoly, src, at, dest):
    """Copy one chunk's cells cs (src = (vx, ptr, vid, tag): their rows in
    order) to their places at = (cvp, cpp, cep)[c] in dest = (vertices,
    plen, poly_vertex, poly_tag); plen[p + 1] the length of polygon p."""
    vx, ptr, vid, tag = src
    cvp, cpp, cep = at
    vertices, plen, poly_vertex, poly_tag = dest
    v = 0
    q = 0
    for i in range(len(cs)):
        c = cs[i]
        shift = cvp[c] - v
        for j in range(nv[i]):
            vertices[cvp[c] + j, 0] = vx[v + j, 0]
            vertices[cvp[c] + j, 1] = vx[v + j, 1]
            vertices[cvp[c] + j, 2] = vx[v + j, 2]
        e = cep[c]
        for k in range(npoly[i]):
            P = cpp[c] + k
            poly_tag[P] = tag[q + k]
            plen[P + 1] = ptr[q + k + 1] - ptr[q + k]
            for t in range(ptr[q + k], ptr[q + k + 1]):
                poly_vertex[e] = vid[t] + shift
                e += 1
        v += nv[i]
        q += npoly[i]


@nb.njit(**JIT)
def _polygons(cpp, poly_ptr, poly_vertex, tag, vertices, seeds, out, c0, c1):
    """The polygons of the cells c0 … c1 − 1: the unit normal (to the
    neighbour's seed, or the box side's), area and area centroid (the fan
    from the vertex mean, as spring_points._polygon_properties sums it),
    into out = (normal, area, centroid)."""
    normal, area, centroid = out
    for c in range(c0, c1):
        for p in range(cpp[c], cpp[c + 1]):
            t = tag[p]
            if t >= 0:
                d0 = seeds[t, 0] - seeds[c, 0]
                d1 = seeds[t, 1] - seeds[c, 1]
                d2 = seeds[t, 2] - seeds[c, 2]
                L = np.sqrt(d0 * d0 + d1 * d1 + d2 * d2)
                normal[p, 0], normal[p, 1], normal[p, 2] = d0 / L, d1 / L, d2 / L
            else:
                side = -1 - t
                normal[p, 0] = normal[p, 1] = normal[p, 2] = 0.0
                normal[p, side // 2] = -1.0 if side % 2 == 0 else 1.0
            a0, a1 = poly_ptr[p], poly_ptr[p + 1]
            m0 = m1 = m2 = 0.0
            for i in range(a0, a1):
                v = poly_vertex[i]
                m0 += vertices[v, 0]
                m1 += vertices[v, 1]
                m2 += vertices[v, 2]
            k = a1 - a0
            m0 /= k
            m1 /= k
            m2 /= k
            A = g0 = g1 = g2 = 0.0
            for i in range(a0, a1):
                v = poly_vertex[i]
                w = poly_vertex[i + 1] if i + 1 < a1 else poly_vertex[a0]
                ax, ay, az = vertices[v, 0] - m0, vertices[v, 1] - m1, vertices[v, 2] - m2
                bx, by, bz = vertices[w, 0] - m0, vertices[w, 1] - m1, vertices[w, 2] - m2
                cx = ay * bz - az * by
                cy = az * bx - ax * bz
                cz = ax * by - ay * bx
                ta = 0.5 * ((cx * normal[p, 0] + cz * normal[p, 2]) + cy * normal[p, 1])
                A += ta
                g0 += ta * (ax + bx) / 3.0
                g1 += ta * (ay + by) / 3.0
                g2 += ta * (az + bz) / 3.0
            area[p] = A
            centroid[p, 0] = m0 + g0 / A
            centroid[p, 1] = m1 + g1 / A
            centroid[p, 2] = m2 + g2 / A


@nb.njit(**JIT)
def _subset(sel, poly_ptr, poly_vertex, vertices):
    """The polygons sel as (ptr, their vertices' coordinates)."""
    ptr = np.zeros(len(sel) + 1, dtype=np.int64)
    for i in range(len(sel)):
        ptr[i + 1] = ptr[i] + poly_ptr[sel[i] + 1] - poly_ptr[sel[i]]
    xyz = np.empty((ptr[-1], 3))
    for i in range(len(sel)):
        k = ptr[i]
        for j in range(poly_ptr[sel[i]], poly_ptr[sel[i] + 1]):
            v = poly_vertex[j]
            xyz[k, 0] = vertices[v, 0]
            xyz[k, 1] = vertices[v, 1]
            xyz[k, 2] = vertices[v, 2]
            k += 1
    return ptr, xyz


def box_voronoi_mesh(seeds, box, size):
    """Mesh of the Voronoi cells of ``seeds`` clipped to ``box``
    (cells_of_box): internal faces from the lower cell's polygons (a < b,
    the normal from a to b), boundary faces sorted by (side, cell).  A
    polygon of round-off area (≤ 1e-16 size²) is dropped, as a face and
    from its cell."""
    N = len(seeds)
    vertices, cvp, poly_ptr, poly_vertex, cpp, tag = cells_of_box(seeds, box, size)
    pcell = np.repeat(np.arange(N), np.diff(cpp))
    P = len(tag)
    pn, parea, pcen = np.empty((P, 3)), np.empty(P), np.empty((P, 3))
    on_threads(_polygons, N, build_threads() if N >= THREADED_CELLS else 1,
               lambda c0, c1: (cpp, poly_ptr, poly_vertex, tag, vertices, seeds,
                               (pn, parea, pcen), c0, c1))
    keep = parea > 1e-16 * size * size
    if not np.all(keep):
        sel = np.flatnonzero(keep)
        poly_ptr, poly_vertex = _gather(poly_ptr, poly_vertex, sel)
        tag, pcell, pn, parea, pcen = tag[sel], pcell[sel], pn[sel], parea[sel], pcen[sel]
        cpp = np.zeros(N + 1, dtype=np.int64)
        np.cumsum(np.bincount(pcell, minlength=N), out=cpp[1:])
    if np.any(np.diff(cpp) < 4):
        raise RuntimeError("a cell has fewer than 4 faces")
    vol, cen, inertia = cells_mass_properties(vertices, poly_ptr, poly_vertex, cpp, seeds)
    fi = np.flatnonzero(tag > pcell)
    bi = np.flatnonzero(tag < 0)
    bi = bi[np.argsort(-1 - tag[bi], kind="stable")]
    f_ptr, f_xyz = _subset(fi, poly_ptr, poly_vertex, vertices)
    b_ptr, b_xyz = _subset(bi, poly_ptr, poly_vertex, vertices)
    i64 = lambda a: np.ascontiguousarray(a, dtype=np.int64)  # noqa: E731
    f64 = lambda a: np.ascontiguousarray(a, dtype=np.float64)  # noqa: E731
    return Mesh(
        cell_volume=f64(vol), cell_centroid=f64(cen), cell_inertia=f64(inertia),
        vertices=f64(vertices), cell_vertex_ptr=i64(cvp), poly_ptr=i64(poly_ptr),
        poly_vertex=i64(poly_vertex), cell_poly_ptr=i64(cpp),
        face_cells=i64(np.stack([pcell[fi], tag[fi]], axis=1)), face_normal=f64(pn[fi]),
        face_area=f64(parea[fi]), face_centroid=f64(pcen[fi]), face_vertex_ptr=i64(f_ptr),
        face_vertex_xyz=f_xyz,
        bface_cell=i64(pcell[bi]), bface_side=i64(-1 - tag[bi]), bface_normal=f64(pn[bi]),
        bface_area=f64(parea[bi]), bface_centroid=f64(pcen[bi]), bface_vertex_ptr=i64(b_ptr),
        bface_vertex_xyz=b_xyz, box=f64(box), surface_names=SIDES,
    )
