"""Cells clipped to a solid: a box tessellation cut by a closed faceted surface.

The cells of a tessellation of a box that holds the solid (Voronoi of seeds
inside the solid, or blocks) are intersected with the solid in one boolean
(one per colour, below) of manifold3d (Emmett Lalish et al., https://github.com/elalish/manifold:
exact, symbolic perturbation for coincident faces).  All cells go in as one
manifold of many touching components; manifold3d keeps each component's
vertices and faces, so the result is again one closed component per piece of
a cell inside the solid (measured: 6 245 Voronoi cells in a 64-gon cylinder,
0.7 s, every cell one component, volumes exact).

Each input triangle carries a ``face_id``: for a triangle of internal face f
of the tessellation seen from its cell a (b), 2f (2f + 1); for a triangle
on boundary face j of the tessellation's box, 2F + j; for a triangle on
facet k of the solid's surface (a planar set of its triangles on one named
surface), 2F + B + k (manifold3d keeps face ids as 32-bit integers).  The result's triangles keep them, so

* the pieces are the connected components of the result (halfedge
  adjacency), each the part of one cell inside the solid; a cell cut in two
  by a notch gives two pieces, which become two bodies;
* a piece's faces are its triangles grouped by face_id: planar regions whose
  boundary edges chain into polygons, counter-clockwise about the outward
  normal;
* internal face f joins the piece holding its 2f region with the piece
  holding its 2f + 1 region (matched by centroid when a face is split);
  facet regions are boundary faces on the facet's surface.

A cell face in the plane of a face of the solid (blocks: a block plane
through an L-panel's inner corner, a notch's end or side on a block plane)
is where manifold3d's symbolic perturbation decides: the result keeps each
piece's region in that plane exactly, but not which part of it is the
cell's face and which the solid's (measured: a block face half on a notch's
end came out split along its diagonal, a cell outside the solid as a
zero-volume sheet or flap, cells touching there as one component).  When
the tessellation has such internal faces (_coplanar_faces), cells that share
a face go into different booleans (two for blocks) and sheets are dropped;
each such face, and each side of the box lying on two facets (two surfaces
in one plane), is rebuilt from the triangles of the pieces in its plane
(_split_coplanar_faces): internal where both sides hold material, a
boundary face on the solid's facet where one side does.  Tessellations
without such faces go through the one boolean as before.

Pieces smaller than ``min_volume`` × the mean cell volume (slivers at
corners and notches, which would set a tiny stable step) are merged into the
neighbour with which they share the largest face (repeated until none is
left); a merged body is the union of its pieces (non-convex in general: mass
properties by the divergence theorem over its faces, exact).  Two bodies may
then share more than one face.
"""
from __future__ import annotations

from typing import NamedTuple

import numpy as np
from numba import njit

from ._core import _gather, assemble
from .interface import _area2, _simplify

__all__ = ["clip_to_solid", "solid_facets"]



def solid_facets(vertices, triangles, tri_surface, tol=1e-9):
    """Group a closed surface's triangles into planar facets: triangles of one
    surface whose planes agree (unit normal within ``tol``, offset within
    ``tol`` × the surface's size) and that are connected by edges.
    Returns (tri_facet (T,), facet_normal (K, 3), facet_surface (K,))."""
    from scipy.sparse import coo_matrix
    from scipy.sparse.csgraph import connected_components

    v = np.asarray(vertices, float)
    t = np.asarray(triangles, np.int64)
    s = np.asarray(tri_surface, np.int64)
    n = np.cross(v[t[:, 1]] - v[t[:, 0]], v[t[:, 2]] - v[t[:, 0]])
    n /= np.linalg.norm(n, axis=1)[:, None]
    d = np.einsum("ij,ij->i", n, v[t[:, 0]])
    size = np.ptp(v, axis=0).max()
    nb = _edge_neighbours(t, len(v))
    T = len(t)
    i = np.repeat(np.arange(T), 3)
    j = nb.reshape(-1)
    same = ((s[i] == s[j]) & (np.abs(n[i] - n[j]).max(axis=1) <= tol)
            & (np.abs(d[i] - d[j]) <= tol * size))
    g = coo_matrix((np.ones(int(same.sum())), (i[same], j[same])), shape=(T, T))
    k, facet = connected_components(g, directed=False)
    area = np.linalg.norm(np.cross(v[t[:, 1]] - v[t[:, 0]], v[t[:, 2]] - v[t[:, 0]]), axis=1)
    fn = np.stack([np.bincount(facet, area * n[:, c], minlength=k) for c in range(3)], 1)
    fn /= np.linalg.norm(fn, axis=1)[:, None]
    fs = np.zeros(k, np.int64)
    fs[facet] = s
    return facet, fn, fs


def _edge_neighbours(tri, n_vertices):
    """(T, 3): the triangle across each directed edge (v0v1, v1v2, v2v0) of a
    closed manifold triangle mesh (its reverse edge)."""
    T = len(tri)
    a = tri.reshape(-1)
    b = tri[:, [1, 2, 0]].reshape(-1)
    key = a * n_vertices + b
    rev = b * n_vertices + a
    order = np.argsort(key, kind="stable")
    pos = np.searchsorted(key[order], rev)
    if np.any(pos >= len(key)) or np.any(key[order[np.minimum(pos, len(key) - 1)]] != rev):
        raise ValueError("the surface is not closed (an edge without its reverse)")
    return (order[pos] // 3).reshape(T, 3)


@njit(cache=True)
def _chain(edge_from, edge_to, edge_region, n_vertices):
    """Chain boundary edges into loops.  Edges of one region: the next edge of
    (u→v) is the region's edge leaving v (unique for a simple region).
    Returns (loop id per edge in loop order, order of edges, loop count)."""
    E = len(edge_from)
    # hash (region, from) -> edge
    size = 1
    while size < 2 * E + 2:
        size *= 2
    keys = np.full(size, -1, np.int64)
    vals = np.full(size, -1, np.int64)
    for e in range(E):
        k = edge_region[e] * n_vertices + edge_from[e]
        h = (k * 0x9E3779B1) & (size - 1)
        while keys[h] != -1:
            if keys[h] == k:
                return np.empty(0, np.int64), np.empty(0, np.int64), -1   # pinched region
            h = (h + 1) & (size - 1)
        keys[h] = k
        vals[h] = e
    nxt = np.full(E, -1, np.int64)
    for e in range(E):
        k = edge_region[e] * n_vertices + edge_to[e]
        h = (k * 0x9E3779B1) & (size - 1)
        while keys[h] != -1 and keys[h] != k:
            h = (h + 1) & (size - 1)
        if keys[h] != k:
            return np.empty(0, np.int64), np.empty(0, np.int64), -2       # open loop
        nxt[e] = vals[h]
    loop = np.full(E, -1, np.int64)
    order = np.empty(E, np.int64)
    n_loops = 0
    w = 0
    for e0 in range(E):
        if loop[e0] != -1:
            continue
        e = e0
        while loop[e] == -1:
            loop[e] = n_loops
            order[w] = e
            w += 1
            e = nxt[e]
        n_loops += 1
    return loop, order, n_loops


def clip_to_solid(mesh, vertices, triangles, tri_surface, surface_names, *, min_volume=0.1,
                  box=None, contains=None):
    """The cells of ``mesh`` (a tessellation of a box holding the solid, its
    box strictly larger than the solid's bounds) clipped to the closed
    surface (vertices, triangles counter-clockwise from outside, tri_surface
    ids into surface_names).  Returns a Mesh whose boundary faces carry the
    surface ids in ``bface_side`` and whose ``surface_names`` are the given
    names; pieces below ``min_volume`` × mean cell volume are merged.
    ``contains`` (points → bool, the solid's inside test): cells that lie
    inside the solid away from its surface (no triangle's bounding box meets
    theirs) skip the boolean (a large mesh: only its surface layer goes
    through manifold3d)."""
    import manifold3d as m3
    from scipy.sparse import coo_matrix
    from scipy.sparse.csgraph import connected_components

    F, B, N = mesh.n_faces, mesh.n_bfaces, mesh.n_cells
    # face_id of each cell polygon (polygons are grouped by cell: internal
    # faces seen from a, from b, boundary faces; _core.assemble)
    pcell = np.concatenate([mesh.face_cells[:, 0], mesh.face_cells[:, 1], mesh.bface_cell])
    order = np.argsort(pcell, kind="stable")
    pfid = np.concatenate([2 * np.arange(F), 2 * np.arange(F) + 1,
                           2 * F + np.arange(B)])[order]
    from .polyhedron import _fan_triangles
    _SOLID = 2 * F + B
    if _SOLID + len(triangles) >= 2 ** 31:
        raise ValueError("too many faces for one clipping boolean")
    interior = (np.zeros(N, bool) if contains is None
                else _interior_cells(mesh, vertices, triangles, contains))
    # the polygons (and their vertices) of the cells that go through the boolean
    npoly = np.diff(mesh.cell_poly_ptr)
    cut_poly = np.repeat(~interior, npoly)
    facet, facet_normal, facet_surface = solid_facets(vertices, triangles, tri_surface)
    scale = np.ptp(mesh.box, axis=0).max()
    # cell faces on a plane of the solid's surface (blocks on a notch's side,
    # an L-panel's inner sides; box sides on two surfaces)
    cop = _coplanar_faces(mesh, ~interior, vertices, triangles, facet, facet_normal, scale)
    coplanar_inside = bool(np.any(cop.cells[:, 1] >= 0))
    if not coplanar_inside:
        colour = np.zeros(N, np.int64)
    else:
        # manifold3d resolves a cell face lying on the solid's face by symbolic
        # perturbation; cells touching there, in one operand, may then come out
        # fused (measured: three blocks under a notch's end as one component).
        # Cells that share a face go into different booleans
        colour = _colours(mesh.face_cells, ~interior)
    poly_cell = np.repeat(np.arange(N), npoly)
    cells = []
    for k in range(int(colour.max()) + 1):
        polys = np.nonzero(cut_poly & (colour[poly_cell] == k))[0]
        sp_ptr, sp_vid = _gather(mesh.poly_ptr, mesh.poly_vertex, polys,
                                 np.zeros(len(polys), bool))
        ctri, ctri_poly = _fan_triangles(sp_ptr, sp_vid)
        cells.append(m3.Manifold(m3.Mesh64(vert_properties=np.array(mesh.vertices, np.float64),
                                           tri_verts=np.array(ctri, np.uint64),
                                           face_id=np.array(pfid[polys][ctri_poly], np.uint64))))
    # made after the cells' (manifold3d numbers its meshes in order of
    # creation, and its results depend on the numbers)
    solid = m3.Manifold(m3.Mesh64(vert_properties=np.array(vertices, np.float64),
                                  tri_verts=np.array(triangles, np.uint64),
                                  face_id=np.array(_SOLID + facet.astype(np.int64), np.uint64)))
    if solid.status() != m3.Error.NoError:
        raise ValueError(f"the solid is not a closed manifold ({solid.status()})")
    parts = []
    for c in cells:
        res = (c ^ solid).to_mesh64()
        parts.append((np.array(res.vert_properties, np.float64)[:, :3],
                      np.array(res.tri_verts, np.int64), np.array(res.face_id, np.int64)))
    if len(parts) == 1:
        xyz, tri, fid = parts[0]
    else:
        offset = np.cumsum([0] + [len(p[0]) for p in parts])
        xyz = np.vstack([p[0] for p in parts])
        tri = np.vstack([p[1] + o for p, o in zip(parts, offset)])
        fid = np.concatenate([p[2] for p in parts])
    T, V = len(tri), len(xyz)

    # pieces: connected components of the halfedge adjacency
    nb = _edge_neighbours(tri, V)
    g = coo_matrix((np.ones(3 * T), (np.repeat(np.arange(T), 3), nb.reshape(-1))), shape=(T, T))
    n_comp, comp = connected_components(g, directed=False)
    if coplanar_inside:
        # a cell outside the solid touching it on a face in the face's plane
        # comes out as a sheet: its face and the solid's, back to back (zero
        # volume); dropped
        tri, fid, nb, n_comp, comp = _drop_sheets(xyz, tri, fid, nb, comp, n_comp, scale)
        T = len(tri)
    is_cell = fid < 2 * F + B
    tri_cell = np.full(T, -1, np.int64)
    internal = fid < 2 * F
    tri_cell[internal] = mesh.face_cells[fid[internal] // 2, fid[internal] % 2]
    bnd = is_cell & ~internal
    tri_cell[bnd] = mesh.bface_cell[fid[bnd] - 2 * F]
    comp_cell = np.full(n_comp, -1, np.int64)
    comp_cell[comp[is_cell]] = tri_cell[is_cell]
    if np.any(comp_cell < 0):
        raise ValueError("a part of the solid lies inside one cell without touching its faces: "
                         "make the cells smaller than the solid's features")
    # pieces numbered by (cell, component): a cell's pieces stay together;
    # an interior cell is one piece
    inner = np.nonzero(interior)[0]
    all_cell = np.concatenate([comp_cell, inner])
    porder = np.lexsort((np.arange(len(all_cell)), all_cell))
    piece_of = np.empty(len(all_cell), np.int64)
    piece_of[porder] = np.arange(len(all_cell))
    piece = piece_of[comp]
    piece_cell = all_cell[porder]

    # a cell face on a plane of the solid (blocks: a block face in the
    # plane of a notch's side) may come out of the boolean with the cell's
    # face_id where it lies on the surface: such triangles are the facet's
    tn = np.empty((T, 3))
    tn[internal] = mesh.face_normal[fid[internal] // 2] * \
        np.where(fid[internal] % 2 == 0, 1.0, -1.0)[:, None]
    tn[bnd] = mesh.bface_normal[fid[bnd] - 2 * F]
    cand = np.nonzero(is_cell)[0]
    on = _facet_holding(xyz[tri[cand]].mean(axis=1), tn[cand], vertices, triangles, facet,
                        facet_normal, scale)
    fid[cand[on >= 0]] = _SOLID + on[on >= 0]
    if len(cop.fid):
        # where a cell face lies on the solid's face, manifold3d keeps the
        # region of the piece in that plane exactly, but not which part is
        # the cell's face and which the solid's (it may split them along a
        # diagonal, or leave a flap of the cell's face back to back with the
        # solid's): the piece's triangles in that plane are left out of the
        # regions and the face is split from them below
        if np.any(tri_cell[is_cell] != comp_cell[comp[is_cell]]):
            raise ValueError("cells came out of the clipping boolean joined; shift or resize "
                             "the cells slightly")
        q_face, q_side, q_sign = _coplanar_triangles(xyz, tri, piece_cell[piece], cop, scale)

    # regions: triangles of one piece with one face_id; boundary edges
    rkey = piece * (_SOLID + len(triangles)) + fid
    ukey, region = np.unique(rkey, return_inverse=True)
    region_piece = ukey // (_SOLID + len(triangles))
    region_fid = ukey % (_SOLID + len(triangles))
    e_from = tri.reshape(-1)
    e_to = tri[:, [1, 2, 0]].reshape(-1)
    e_reg = np.repeat(region, 3)
    border = e_reg != region[nb.reshape(-1)]
    if len(cop.fid):
        # the triangles left out bound the regions next to them
        left = q_face >= 0
        border = (border | left[nb.reshape(-1)]) & ~np.repeat(left, 3)
    loop, lorder, n_loops = _chain(e_from[border], e_to[border], e_reg[border], V)
    if n_loops < 0:
        raise ValueError("a clipped face is pinched at a vertex; move the solid or the seeds "
                         "slightly")
    bf = e_from[border][lorder]
    bl = loop[lorder]
    breg = e_reg[border][lorder]
    counts = np.bincount(bl, minlength=n_loops)
    ptr = np.zeros(n_loops + 1, np.int64)
    np.cumsum(counts, out=ptr[1:])
    loop_region = np.zeros(n_loops, np.int64)
    loop_region[bl] = breg
    lfid = region_fid[loop_region]
    lpiece = region_piece[loop_region]
    if len(cop.fid):
        q = np.nonzero(q_face >= 0)[0]
        xyz, bf, ptr, lfid, lpiece = _split_coplanar_faces(
            cop, xyz, bf, ptr, lfid, lpiece, q_face[q], xyz[tri[q]], q_side[q], piece[q],
            q_sign[q], vertices, triangles, facet, _SOLID, scale)
        V = len(xyz)
        n_loops = len(lfid)
    if len(inner):
        # the interior cells' own polygons, as loops of their pieces
        ipoly = np.nonzero(~cut_poly)[0]
        i_ptr, i_vid = _gather(mesh.poly_ptr, mesh.poly_vertex, ipoly, np.zeros(len(ipoly), bool))
        bf = np.concatenate([bf, i_vid + V])
        ptr = np.concatenate([ptr, ptr[-1] + i_ptr[1:]])
        lfid = np.concatenate([lfid, pfid[ipoly]])
        pc = np.repeat(np.arange(N), npoly)[ipoly]
        rank = np.full(N, -1, np.int64)
        rank[inner] = np.arange(len(inner))
        lpiece = np.concatenate([lpiece, piece_of[n_comp + rank[pc]]])
        xyz = np.vstack([xyz, mesh.vertices])
        V = len(xyz)
        n_loops = len(lfid)

    # outward normals: the tessellation's face normal (from a to b: side 0)
    # or the facet's
    is_int = lfid < 2 * F
    is_sol = lfid >= _SOLID
    if np.any(~is_int & ~is_sol):
        raise ValueError("a side of the tessellation's box cuts the solid: the box must hold it")
    lnormal = np.empty((n_loops, 3))
    side = np.where(is_int, lfid % 2, -1)
    lnormal[is_int] = mesh.face_normal[lfid[is_int] // 2] * \
        np.where(side[is_int] == 0, 1.0, -1.0)[:, None]
    lnormal[is_sol] = facet_normal[lfid[is_sol] - _SOLID]
    from .spring_points import polygon_properties
    larea, lcen = polygon_properties(ptr, xyz[bf], lnormal)
    if np.any(larea <= 0):
        raise ValueError("a clipped face has a hole (a part of the solid thinner than a cell "
                         "passes through it); make the cells smaller")

    # internal faces: pair the side-0 loop with the side-1 loop of the same
    # face (same face, same centroid)
    from scipy.spatial import cKDTree
    i0 = np.nonzero(side == 0)[0]
    i1 = np.nonzero(side == 1)[0]
    pts0 = np.column_stack([lcen[i0], lfid[i0] // 2 * (10.0 * scale)])
    pts1 = np.column_stack([lcen[i1], lfid[i1] // 2 * (10.0 * scale)])
    mismatch = ("the two sides of a clipped face do not match (a cell face on the solid's "
                "surface that could not be split into its inner and surface parts); shift or "
                "resize the cells slightly")
    if len(i0) != len(i1):
        raise ValueError(mismatch)
    if len(i0):
        dist, j = cKDTree(pts0).query(pts1)
        if np.any(dist > 1e-7 * scale) or len(np.unique(j)) != len(j):
            raise ValueError(mismatch)
    else:
        j = np.zeros(0, np.int64)
    fa = lpiece[i0[j]]
    fb = lpiece[i1]
    f_loop = i0[j]
    b_loop = np.nonzero(is_sol)[0]
    b_piece = lpiece[b_loop]
    b_surf = facet_surface[lfid[b_loop] - _SOLID]

    # merge small pieces into the neighbour sharing the largest face
    vol = _piece_volumes(ptr, xyz[bf], lpiece, len(piece_cell))
    target = np.arange(len(piece_cell))
    small_limit = min_volume * vol.sum() / N
    for _ in range(32):
        root = _roots(target)
        va = np.bincount(root, vol, minlength=len(vol))
        ra, rb = root[fa], root[fb]
        keep = ra != rb
        small = (va < small_limit) & (root == np.arange(len(vol)))
        if not small.any():
            break
        # the largest shared face of each small root
        aa = np.concatenate([ra[keep], rb[keep]])
        bb = np.concatenate([rb[keep], ra[keep]])
        ar = np.concatenate([larea[f_loop][keep], larea[f_loop][keep]])
        pair = np.unique(np.column_stack([aa, bb]), axis=0, return_inverse=True)
        pa = np.bincount(pair[1].reshape(-1), ar, minlength=len(pair[0]))
        cand = pair[0]
        o = np.lexsort((-pa, cand[:, 0]))
        first = np.ones(len(o), bool)
        first[1:] = cand[o[1:], 0] != cand[o[:-1], 0]
        best = cand[o[first]]
        sel = small[best[:, 0]]
        # a pair of small roots merging into each other: the larger id yields
        src, dst = best[sel, 0], best[sel, 1]
        mutual = small[dst] & (np.isin(dst, src))
        drop = mutual & (src < dst)
        target[src[~drop]] = dst[~drop]
        if not sel.any():
            raise ValueError("a piece of the solid smaller than min_volume has no neighbour")
    root = _roots(target)
    _, body = np.unique(root, return_inverse=True)
    n_bodies = int(body.max()) + 1
    ra, rb = body[fa], body[fb]
    keep = ra != rb
    a_ = np.minimum(ra, rb)[keep]
    b_ = np.maximum(ra, rb)[keep]
    flip = (ra > rb)[keep]
    # internal polygons, counter-clockwise about the normal from a to b
    fl = f_loop[keep]
    f_ptr, f_vid = _gather(ptr, bf, fl, flip)
    f_normal = np.where(flip[:, None], -lnormal[fl], lnormal[fl])
    b_ptr, b_vid = _gather(ptr, bf, b_loop, np.zeros(len(b_loop), bool))
    # drop the vertices no polygon uses: ids into the used ones
    used = np.unique(np.concatenate([f_vid, b_vid]))
    remap = np.full(V, -1, np.int64)
    remap[used] = np.arange(len(used))
    lo = np.asarray(vertices, float).min(axis=0) if box is None else np.asarray(box, float)[0]
    hi = np.asarray(vertices, float).max(axis=0) if box is None else np.asarray(box, float)[1]
    return assemble(np.array([lo, hi]), xyz[used], np.column_stack([a_, b_]), f_ptr,
                    remap[f_vid], f_normal, body[b_piece], b_surf, b_ptr, remap[b_vid],
                    n_bodies, b_normal=lnormal[b_loop], surface_names=tuple(surface_names))


def _facet_holding(points, normals, vertices, triangles, tri_facet, facet_normal, scale):
    """The facet holding each point (a triangle's centroid, with its outward
    normal), or −1: a solid triangle with the same outward normal (1e-8),
    whose plane holds the point (1e-8 × scale) and which contains it
    (barycentric coordinates ≥ −1e-9)."""
    from scipy.spatial import cKDTree
    v = np.asarray(vertices, float)
    t = np.asarray(triangles, np.int64)
    n = facet_normal[tri_facet]
    d = np.einsum("ij,ij->i", n, v[t[:, 0]]) / scale
    pd = np.einsum("ij,ij->i", normals, points) / scale
    pairs = cKDTree(np.column_stack([normals, pd])).sparse_distance_matrix(
        cKDTree(np.column_stack([n, d])), 1e-8, output_type="ndarray")
    q = pairs["i"].astype(np.int64)
    tri = pairs["j"].astype(np.int64)
    a, b, c = v[t[tri, 0]], v[t[tri, 1]], v[t[tri, 2]]
    p = points[q]
    # barycentric coordinates in the triangle's plane
    e1, e2, ep = b - a, c - a, p - a
    d11 = np.einsum("ij,ij->i", e1, e1)
    d12 = np.einsum("ij,ij->i", e1, e2)
    d22 = np.einsum("ij,ij->i", e2, e2)
    dp1 = np.einsum("ij,ij->i", ep, e1)
    dp2 = np.einsum("ij,ij->i", ep, e2)
    den = d11 * d22 - d12 * d12
    u = (d22 * dp1 - d12 * dp2) / den
    w = (d11 * dp2 - d12 * dp1) / den
    inside = (u >= -1e-9) & (w >= -1e-9) & (u + w <= 1 + 1e-9)
    out = np.full(len(points), -1, np.int64)
    out[q[inside]] = tri_facet[tri[inside]]
    return out


def _interior_cells(mesh, vertices, triangles, contains):
    """Cells inside the solid that no surface triangle comes near: a cell
    whose bounding box lies in the solid's and meets no triangle's bounding
    box, and whose centroid is inside.  The triangles' boxes are marked on a grid of the mean cell
    size and each cell's box is looked up in the grid's summed-volume table
    (no loop over cells or triangles)."""
    v = np.asarray(vertices, float)
    t = np.asarray(triangles, np.int64)
    lo, hi = v.min(axis=0), v.max(axis=0)
    h = float(np.median(mesh.cell_volume)) ** (1 / 3)
    n = np.maximum(np.ceil((hi - lo) / h).astype(np.int64), 1)
    h = (hi - lo) / n

    def index(x):
        return np.clip(np.floor((x - lo) / h).astype(np.int64), 0, n - 1)

    tv = v[t]
    t0, t1 = index(tv.min(axis=1)), index(tv.max(axis=1))
    ext = t1 - t0 + 1
    cnt = ext.prod(axis=1)
    if cnt.sum() > 50 * n.prod():      # huge slanted triangles: no shortcut
        return np.zeros(mesh.n_cells, bool)
    tri = np.repeat(np.arange(len(t)), cnt)
    r = np.arange(cnt.sum()) - np.repeat(np.cumsum(cnt) - cnt, cnt)
    e = ext[tri]
    i = t0[tri, 0] + r // (e[:, 1] * e[:, 2])
    j = t0[tri, 1] + (r // e[:, 2]) % e[:, 1]
    k = t0[tri, 2] + r % e[:, 2]
    grid = np.zeros(n + 1, np.int64)
    np.add.at(grid, (i + 1, j + 1, k + 1), 1)
    sat = grid.cumsum(0).cumsum(1).cumsum(2)
    cv = np.repeat(np.arange(mesh.n_cells), np.diff(mesh.cell_vertex_ptr))
    cmin = np.full((mesh.n_cells, 3), np.inf)
    cmax = np.full((mesh.n_cells, 3), -np.inf)
    np.minimum.at(cmin, cv, mesh.vertices)
    np.maximum.at(cmax, cv, mesh.vertices)
    a, b = index(cmin), index(cmax) + 1
    hits = (sat[b[:, 0], b[:, 1], b[:, 2]] - sat[a[:, 0], b[:, 1], b[:, 2]]
            - sat[b[:, 0], a[:, 1], b[:, 2]] - sat[b[:, 0], b[:, 1], a[:, 2]]
            + sat[a[:, 0], a[:, 1], b[:, 2]] + sat[a[:, 0], b[:, 1], a[:, 2]]
            + sat[b[:, 0], a[:, 1], a[:, 2]] - sat[a[:, 0], a[:, 1], a[:, 2]])
    within = np.all((cmin > lo) & (cmax < hi), axis=1)
    return within & (hits == 0) & np.asarray(contains(mesh.cell_centroid), bool)


def _roots(target):
    r = target.copy()
    while True:
        nr = r[r]
        if np.array_equal(nr, r):
            return r
        r = nr


def _piece_volumes(ptr, pxyz, lpiece, n):
    """Volume of each piece by the divergence theorem over its loops (fan)."""
    cnt = np.diff(ptr)
    first = np.repeat(ptr[:-1], cnt)
    k = np.arange(len(pxyz))
    nxt = np.where(k + 1 < np.repeat(ptr[1:], cnt), k + 1, first)
    a, b, c = pxyz[first], pxyz[k], pxyz[nxt]
    v6 = np.einsum("ij,ij->i", a, np.cross(b, c))
    return np.bincount(np.repeat(lpiece, cnt), v6, minlength=n) / 6.0


# ---------------------------------------------------------------------------
# cell faces lying on the solid's faces (blocks on a notch's side or end, an
# L-panel's inner sides)

class _Coplanar(NamedTuple):
    """Cell faces lying in a plane of the solid's surface (G of them) and the
    solid's triangles there (P pairs, sorted by face)."""

    #: (G,) the face's face_id seen from its first cell: 2f (internal face
    #: f), 2F + j (side j of the tessellation's box)
    fid: np.ndarray
    #: (G, 2) its cells (a, b); b = −1 on the box
    cells: np.ndarray
    #: (G, 3) unit normal (from a to b, or outward), (G, 3) centroid, (G,) area
    normal: np.ndarray
    centroid: np.ndarray
    area: np.ndarray
    #: (G+1,), (K, 3): the polygon, counter-clockwise about the normal
    vertex_ptr: np.ndarray
    vertex_xyz: np.ndarray
    #: (P,) face index, (P,) solid triangle, (P,) +1: the triangle's outward
    #: normal is the face's, −1: opposite
    pair_face: np.ndarray
    pair_tri: np.ndarray
    pair_sign: np.ndarray


def _coplanar_faces(mesh, cut, vertices, triangles, tri_facet, facet_normal, scale):
    """The cell faces that need _split_coplanar_faces: internal faces between
    two cells that go through the boolean lying in the plane of a solid
    triangle (either orientation), and sides of the tessellation's box lying
    in the plane of triangles of two or more facets (two surfaces: the
    triangle under a point of the face decides which).  In a plane: unit
    normals within 1e-8, offsets within 1e-8 × scale; and the bounding boxes
    of the face and the triangle overlap in area (by more than 1e-9 × scale
    across the plane)."""
    from scipy.spatial import cKDTree
    v = np.asarray(vertices, float)
    t = np.asarray(triangles, np.int64)
    tnrm = facet_normal[tri_facet]
    tree = cKDTree(np.column_stack([tnrm, np.einsum("ij,ij->i", tnrm, v[t[:, 0]]) / scale]))
    tv = v[t]
    tlo, thi = tv.min(axis=1), tv.max(axis=1)
    tol = 1e-9 * scale

    def pairs(faces, normal, centroid, ptr, xyz, signs):
        if len(faces) == 0:
            e = np.zeros(0, np.int64)
            return e, e, e
        fd = np.einsum("ij,ij->i", normal, centroid) / scale
        pf, pt, ps = [], [], []
        for sign in signs:
            d = cKDTree(np.column_stack([sign * normal, sign * fd])).sparse_distance_matrix(
                tree, 1e-8, output_type="ndarray")
            pf.append(d["i"].astype(np.int64))
            pt.append(d["j"].astype(np.int64))
            ps.append(np.full(len(d), sign, np.int64))
        pf, pt, ps = np.concatenate(pf), np.concatenate(pt), np.concatenate(ps)
        n = np.diff(ptr)[faces]
        sel = np.repeat(ptr[faces], n) + np.arange(n.sum()) - np.repeat(np.cumsum(n) - n, n)
        start = np.cumsum(n) - n
        flo = np.minimum.reduceat(xyz[sel], start, axis=0)[pf] if len(pf) else np.zeros((0, 3))
        fhi = np.maximum.reduceat(xyz[sel], start, axis=0)[pf] if len(pf) else np.zeros((0, 3))
        lo = np.maximum(flo, tlo[pt])
        hi = np.minimum(fhi, thi[pt])
        flat = ((fhi - flo) <= tol) & ((thi[pt] - tlo[pt]) <= tol)
        ok = np.all(np.where(flat, hi - lo >= -tol, hi - lo > tol), axis=1)
        return faces[pf[ok]], pt[ok], ps[ok]

    fc = mesh.face_cells
    fi = np.nonzero(cut[fc[:, 0]] & cut[fc[:, 1]])[0]
    a_face, a_tri, a_sign = pairs(fi, mesh.face_normal[fi], mesh.face_centroid[fi],
                                  mesh.face_vertex_ptr, mesh.face_vertex_xyz, (1, -1))
    bi = np.nonzero(cut[mesh.bface_cell])[0]
    b_face, b_tri, b_sign = pairs(bi, mesh.bface_normal[bi], mesh.bface_centroid[bi],
                                  mesh.bface_vertex_ptr, mesh.bface_vertex_xyz, (1,))
    # box sides: only those on two facets or more
    key = np.unique(np.column_stack([b_face, tri_facet[b_tri]]), axis=0)
    many = np.unique(key[:, 0], return_counts=True)
    keep = np.isin(b_face, many[0][many[1] > 1])
    b_face, b_tri, b_sign = b_face[keep], b_tri[keep], b_sign[keep]
    fa = np.unique(a_face)
    fb = np.unique(b_face)
    F = mesh.n_faces
    cells = np.vstack([fc[fa], np.column_stack([mesh.bface_cell[fb], np.full(len(fb), -1)])])
    a_ptr, a_xyz = _gather_xyz(mesh.face_vertex_ptr, mesh.face_vertex_xyz, fa)
    b_ptr, b_xyz = _gather_xyz(mesh.bface_vertex_ptr, mesh.bface_vertex_xyz, fb)
    ptr = np.concatenate([a_ptr, a_ptr[-1] + b_ptr[1:]])
    xyz = np.vstack([a_xyz, b_xyz])
    g = np.concatenate([np.searchsorted(fa, a_face), len(fa) + np.searchsorted(fb, b_face)])
    o = np.lexsort((np.concatenate([a_tri, b_tri]), g))
    return _Coplanar(
        np.concatenate([2 * fa, 2 * F + fb]), cells,
        np.vstack([mesh.face_normal[fa], mesh.bface_normal[fb]]),
        np.vstack([mesh.face_centroid[fa], mesh.bface_centroid[fb]]),
        np.concatenate([mesh.face_area[fa], mesh.bface_area[fb]]), ptr, xyz,
        g[o], np.concatenate([a_tri, b_tri])[o], np.concatenate([a_sign, b_sign])[o])


def _colours(face_cells, cut):
    """A colour per cell (0, 1, …) such that no face joins two cut cells of
    one colour: the parity of the distance from a root of each connected
    set when the face graph is bipartite (blocks: two colours), else
    independent sets chosen in rounds by random priority (Luby 1986)."""
    from scipy.sparse import coo_matrix
    from scipy.sparse.csgraph import connected_components, dijkstra
    n = len(cut)
    a, b = face_cells[:, 0], face_cells[:, 1]
    m = cut[a] & cut[b]
    a, b = a[m], b[m]
    g = coo_matrix((np.ones(len(a)), (a, b)), shape=(n, n)).tocsr()
    _, label = connected_components(g, directed=False)
    _, root = np.unique(label, return_index=True)
    dist = dijkstra(g, directed=False, indices=root, unweighted=True, min_only=True)
    colour = (dist.astype(np.int64) % 2)
    if np.all(colour[a] != colour[b]):
        return colour
    prio = np.random.default_rng(0).random(n)
    colour = np.full(n, -1, np.int64)
    k = 0
    while np.any(colour < 0):
        free = colour < 0
        # the largest priority among each cell's uncoloured neighbours
        top = np.zeros(n)
        np.maximum.at(top, a, np.where(free[b], prio[b], 0.0))
        np.maximum.at(top, b, np.where(free[a], prio[a], 0.0))
        colour[free & (prio > top)] = k
        k += 1
    return colour


def _drop_sheets(xyz, tri, fid, nb, comp, n_comp, scale):
    """Drop the components of zero thickness (volume ≤ 1e-10 × area ×
    scale, the volume summed about a vertex of the component): a cell face
    and the solid's face back to back.  Returns tri, fid, nb, n_comp, comp
    renumbered."""
    ref = np.zeros((n_comp, 3))
    ref[comp] = xyz[tri[:, 0]]
    p = xyz[tri] - ref[comp][:, None, :]
    v6 = np.einsum("ij,ij->i", p[:, 0], np.cross(p[:, 1], p[:, 2]))
    ar = 0.5 * np.linalg.norm(np.cross(p[:, 1] - p[:, 0], p[:, 2] - p[:, 0]), axis=1)
    vol = np.bincount(comp, v6, minlength=n_comp) / 6.0
    area = np.bincount(comp, ar, minlength=n_comp)
    sheet = np.abs(vol) <= 1e-10 * area * scale
    if not sheet.any():
        return tri, fid, nb, n_comp, comp
    keep = ~sheet[comp]
    new = np.cumsum(keep) - 1
    _, comp = np.unique(comp[keep], return_inverse=True)
    return tri[keep], fid[keep], new[nb[keep]], int(comp.max()) + 1 if len(comp) else 0, comp


def _coplanar_triangles(xyz, tri, tri_cell, cop, scale):
    """The triangles of the pieces that lie in the plane of one of their
    cell's faces in ``cop`` (each vertex within 1e-9 × scale of the plane):
    per triangle the index of the face in cop (−1: none), the cell's side of
    it (0: a, 1: b) and the orientation of the triangle (+1: the cell's
    outward normal there, −1: the opposite, a flap back to back with the
    solid's face)."""
    # (cell, face, side) for the faces' cells, sorted by cell
    cell = cop.cells.reshape(-1)
    g = np.repeat(np.arange(len(cop.fid)), 2)
    side = np.tile([0, 1], len(cop.fid))
    o = np.argsort(cell, kind="stable")
    cell, g, side = cell[o], g[o], side[o]
    T = len(tri)
    lo = np.searchsorted(cell, tri_cell, side="left")
    cnt = np.searchsorted(cell, tri_cell, side="right") - lo
    t = np.repeat(np.arange(T), cnt)
    k = lo[t] + np.arange(cnt.sum()) - np.repeat(np.cumsum(cnt) - cnt, cnt)
    f = g[k]
    n = cop.normal[f] * np.where(side[k] == 0, 1.0, -1.0)[:, None]
    p = xyz[tri[t]]
    tn = np.cross(p[:, 1] - p[:, 0], p[:, 2] - p[:, 0])
    dist = np.einsum("ikj,ij->ik", p - cop.centroid[f][:, None, :], n)
    hit = np.abs(dist).max(axis=1) <= 1e-9 * scale
    q_face = np.full(T, -1, np.int64)
    q_side = np.zeros(T, np.int64)
    q_sign = np.zeros(T, np.int64)
    q_face[t[hit]] = f[hit]
    q_side[t[hit]] = side[k[hit]]
    q_sign[t[hit]] = np.where(np.einsum("ij,ij->i", tn[hit], n[hit]) > 0, 1, -1)
    return q_face, q_side, q_sign


def _split_coplanar_faces(cop, xyz, bf, ptr, lfid, lpiece, q_face, q_xyz, q_side, q_piece,
                          q_sign, vertices, triangles, tri_facet, solid0, scale):
    """Loops of the faces in ``cop`` from the pieces' triangles in their
    planes (q_*: face index, (Q, 3, 3) corners, side, piece, orientation;
    _coplanar_triangles): where both sides hold a piece, an internal face (a
    loop per side); where one side only, a boundary face on the solid's
    facet there.  The face polygon is cut by the lines of the triangles'
    edges and of the edges between coplanar facets (a convex polygon cut by
    lines: convex cells, each wholly inside or outside every triangle, no
    T-junctions); a cell belongs to the piece of a side whose triangles wind
    round its vertex mean (Σ orientation > 0: a flap and the solid's face
    back to back cancel) and the cells of one class are merged (shared edges
    cancel).  Returns xyz, bf, ptr, lfid, lpiece with the new loops
    appended."""
    G = len(cop.fid)
    o = np.argsort(q_face, kind="stable")
    q_face, q_xyz, q_side, q_piece, q_sign = q_face[o], q_xyz[o], q_side[o], q_piece[o], q_sign[o]
    q_face_ptr = np.searchsorted(q_face, np.arange(G + 1))
    # the solid's triangles in the faces' planes; an edge is a facet's border
    # when the triangle across it belongs to another facet
    t = np.asarray(triangles, np.int64)
    v = np.asarray(vertices, float)
    nbt = _edge_neighbours(t, len(v))
    pt = cop.pair_tri
    t_face_ptr = np.searchsorted(cop.pair_face, np.arange(G + 1))
    t_border = tri_facet[nbt[pt]] != tri_facet[pt][:, None]
    vp, vx = cop.vertex_ptr, cop.vertex_xyz
    e1 = vx[vp[:-1] + 1] - vx[vp[:-1]]
    e1 /= np.linalg.norm(e1, axis=1)[:, None]
    e2 = np.cross(cop.normal, e1)
    tol = 1e-9 * np.sqrt(np.maximum(cop.area, 0.0)) + 1e-13 * scale
    o_ptr, o_xyz, o_j, o_kind, o_piece, o_facet, status = _overlay_kernel(
        (vp, vx), (cop.centroid, e1, e2, tol), (q_face_ptr, q_xyz, q_side, q_piece, q_sign),
        (t_face_ptr, v[t[pt]], np.where(cop.pair_sign > 0, 0, 1), tri_facet[pt], t_border))
    if np.any(status == 1):
        raise ValueError("a cell face on the solid's surface is split into parts that touch "
                         "at a point only; shift or resize the cells slightly")
    if np.any(status == 2):
        raise ValueError("a part of a cell face on the solid's surface lies on no facet of "
                         "the solid; shift or resize the cells slightly")
    V = len(xyz)
    new_fid = np.where(o_kind == 2, solid0 + o_facet, cop.fid[o_j] + o_kind)
    return (np.vstack([xyz, o_xyz]), np.concatenate([bf, V + np.arange(len(o_xyz))]),
            np.concatenate([ptr, ptr[-1] + o_ptr[1:]]), np.concatenate([lfid, new_fid]),
            np.concatenate([lpiece, o_piece]))


def _gather_xyz(ptr, xyz, sel):
    """CSR subset (ptr, coordinates) of the polygons ``sel``."""
    n = np.diff(ptr)[sel]
    out = np.zeros(len(n) + 1, np.int64)
    np.cumsum(n, out=out[1:])
    j = np.arange(out[-1], dtype=np.int64) - np.repeat(out[:-1], n)
    return out, xyz[np.repeat(ptr[sel], n) + j]


@njit(cache=True)
def _halves(p, nx, ny, c, tol):
    """The convex polygon p (k, 2) cut by the line n·x = c: (left part,
    right part, True), or (p, p, False) when no vertex lies farther than
    ``tol`` on both sides.  A vertex within ``tol`` of the line goes to both
    parts; the point where an edge crosses is computed from its ends in
    lexicographic order, so that the cell across the edge gets the same
    point bit for bit."""
    k = p.shape[0]
    d = np.empty(k)
    pos = False
    neg = False
    for i in range(k):
        d[i] = nx * p[i, 0] + ny * p[i, 1] - c
        if d[i] > tol:
            pos = True
        elif d[i] < -tol:
            neg = True
    if not (pos and neg):
        return p, p, False
    a = np.empty((2 * k, 2))
    b = np.empty((2 * k, 2))
    na = 0
    nb = 0
    for i in range(k):
        j = (i + 1) % k
        si = 1 if d[i] > tol else (-1 if d[i] < -tol else 0)
        sj = 1 if d[j] > tol else (-1 if d[j] < -tol else 0)
        if si >= 0:
            a[na] = p[i]
            na += 1
        if si <= 0:
            b[nb] = p[i]
            nb += 1
        if si * sj < 0:
            if p[i, 0] < p[j, 0] or (p[i, 0] == p[j, 0] and p[i, 1] < p[j, 1]):
                q0, q1 = i, j
            else:
                q0, q1 = j, i
            s = d[q0] / (d[q0] - d[q1])
            x = p[q0, 0] + s * (p[q1, 0] - p[q0, 0])
            y = p[q0, 1] + s * (p[q1, 1] - p[q0, 1])
            a[na, 0] = x
            a[na, 1] = y
            b[nb, 0] = x
            b[nb, 1] = y
            na += 1
            nb += 1
    return a[:na].copy(), b[:nb].copy(), True


@njit(cache=True)
def _in_triangle(x, y, q):
    """(x, y) inside the triangle q (3, 2) of either orientation
    (barycentric coordinates ≥ −1e-9)."""
    ax, ay = q[1, 0] - q[0, 0], q[1, 1] - q[0, 1]
    bx, by = q[2, 0] - q[0, 0], q[2, 1] - q[0, 1]
    px, py = x - q[0, 0], y - q[0, 1]
    den = ax * by - ay * bx
    if den == 0.0:
        return False
    w1 = (px * by - py * bx) / den
    w2 = (ax * py - ay * px) / den
    return w1 >= -1e-9 and w2 >= -1e-9 and w1 + w2 <= 1.0 + 1e-9


@njit(cache=True)
def _to2(xyz, o, e1, e2):
    m = xyz.shape[0]
    p = np.empty((m, 2))
    for k in range(m):
        dx, dy, dz = xyz[k, 0] - o[0], xyz[k, 1] - o[1], xyz[k, 2] - o[2]
        p[k, 0] = dx * e1[0] + dy * e1[1] + dz * e1[2]
        p[k, 1] = dx * e2[0] + dy * e2[1] + dz * e2[2]
    return p


@njit(cache=True)
def _grown(a, n):
    """The int64 array ``a`` extended to length ``n`` (new entries 0)."""
    out = np.zeros(n, np.int64)
    out[:a.shape[0]] = a
    return out


@njit(cache=True)
def _overlay_kernel(faces, plane, pieces, solid):
    """_split_coplanar_faces for each face j: its polygon (faces: f_ptr,
    f_xyz; plane: origin, e1, e2, tol), the pieces' triangles
    q_face_ptr[j]:q_face_ptr[j+1] in its plane (pieces: q_face_ptr, q_xyz,
    q_side, q_piece, q_sign; side 0: cell a's, 1: cell b's; orientation
    ±1), the solid's triangles t_face_ptr[j]:t_face_ptr[j+1] in its plane
    (solid: t_face_ptr, t_xyz, t_side, t_facet, t_border; t_side 0: outward
    normal the face's, a's surface; 1: b's).  Returns the new loops: ptr, xyz, face j,
    kind (0: internal seen from a, 1: from b, 2: boundary), piece, facet, and
    a status per face (0 ok, 1 a part pinched at a vertex, 2 a part on the
    surface outside every facet)."""
    f_ptr, f_xyz = faces
    origin, e1, e2, tol = plane
    q_face_ptr, q_xyz, q_side, q_piece, q_sign = pieces
    t_face_ptr, t_xyz, t_side, t_facet, t_border = solid
    J = f_ptr.shape[0] - 1
    status = np.zeros(J, np.int64)
    cap_l = 64
    cap_v = 256
    o_ptr = np.zeros(cap_l + 1, np.int64)
    o_xyz = np.empty((cap_v, 3))
    o_j = np.empty(cap_l, np.int64)
    o_kind = np.empty(cap_l, np.int64)
    o_piece = np.empty(cap_l, np.int64)
    o_facet = np.empty(cap_l, np.int64)
    L = 0
    M = 0
    for j in range(J):
        o = origin[j]
        tl = tol[j]
        poly = _to2(f_xyz[f_ptr[j]:f_ptr[j + 1]], o, e1[j], e2[j])
        q0, q1 = q_face_ptr[j], q_face_ptr[j + 1]
        t0, t1 = t_face_ptr[j], t_face_ptr[j + 1]
        qs = np.empty((q1 - q0, 3, 2))
        for r in range(q0, q1):
            qs[r - q0] = _to2(q_xyz[r], o, e1[j], e2[j])
        ts = np.empty((t1 - t0, 3, 2))
        for r in range(t0, t1):
            ts[r - t0] = _to2(t_xyz[r], o, e1[j], e2[j])
        # lines: the pieces' triangles' edges and the facets' borders
        n_lines = 3 * (q1 - q0)
        for r in range(t1 - t0):
            for i in range(3):
                if t_border[t0 + r, i]:
                    n_lines += 1
        lines = np.empty((n_lines, 4))
        w = 0
        for r in range(q1 - q0):
            for i in range(3):
                lines[w, 0], lines[w, 1] = qs[r, i, 0], qs[r, i, 1]
                lines[w, 2], lines[w, 3] = qs[r, (i + 1) % 3, 0], qs[r, (i + 1) % 3, 1]
                w += 1
        for r in range(t1 - t0):
            for i in range(3):
                if t_border[t0 + r, i]:
                    lines[w, 0], lines[w, 1] = ts[r, i, 0], ts[r, i, 1]
                    lines[w, 2], lines[w, 3] = ts[r, (i + 1) % 3, 0], ts[r, (i + 1) % 3, 1]
                    w += 1
        cells = [poly]
        for li in range(n_lines):
            dx, dy = lines[li, 2] - lines[li, 0], lines[li, 3] - lines[li, 1]
            h = np.hypot(dx, dy)
            if h <= tl:
                continue
            nx, ny = -dy / h, dx / h
            c = nx * lines[li, 0] + ny * lines[li, 1]
            nxt = [poly[:0]]
            nxt.pop()
            for cell in cells:
                a, b, cut = _halves(cell, nx, ny, c, tl)
                if cut:
                    nxt.append(a)
                    nxt.append(b)
                else:
                    nxt.append(cell)
            cells = nxt
        # class of each cell: internal (pieces a, b), or a's / b's surface
        # (piece, facet)
        C = len(cells)
        ckind = np.full(C, -1, np.int64)
        cpiece = np.full(C, -1, np.int64)
        cother = np.full(C, -1, np.int64)
        inq = np.zeros(q1 - q0, np.bool_)
        for ci in range(C):
            cell = cells[ci]
            x = cell[:, 0].mean()
            y = cell[:, 1].mean()
            for r in range(q1 - q0):
                inq[r] = _in_triangle(x, y, qs[r])
            side_piece = np.full(2, -1, np.int64)
            for r in range(q1 - q0):
                s = q_side[q0 + r]
                pc = q_piece[q0 + r]
                if not inq[r] or side_piece[s] >= 0:
                    continue
                wind = 0
                for r2 in range(q1 - q0):
                    if inq[r2] and q_side[q0 + r2] == s and q_piece[q0 + r2] == pc:
                        wind += q_sign[q0 + r2]
                if wind > 0:
                    side_piece[s] = pc
            if side_piece[0] >= 0 and side_piece[1] >= 0:
                ckind[ci] = 0
                cpiece[ci] = side_piece[0]
                cother[ci] = side_piece[1]
            elif side_piece[0] >= 0 or side_piece[1] >= 0:
                s = 0 if side_piece[0] >= 0 else 1
                fct = -1
                for r in range(t1 - t0):
                    if t_side[t0 + r] == s and _in_triangle(x, y, ts[r]):
                        fct = t_facet[t0 + r]
                        break
                if fct < 0:
                    status[j] = 2
                ckind[ci] = 1 + s
                cpiece[ci] = side_piece[s]
                cother[ci] = fct
        if status[j] != 0:
            continue
        # merge the cells of each class: their edges less the shared ones,
        # chained into loops
        done = np.zeros(C, np.bool_)
        for ci in range(C):
            if done[ci] or ckind[ci] < 0:
                continue
            E = 0
            for cj in range(ci, C):
                if (not done[cj] and ckind[cj] == ckind[ci] and cpiece[cj] == cpiece[ci]
                        and cother[cj] == cother[ci]):
                    E += cells[cj].shape[0]
            ed = np.empty((E, 4))
            e = 0
            for cj in range(ci, C):
                if (not done[cj] and ckind[cj] == ckind[ci] and cpiece[cj] == cpiece[ci]
                        and cother[cj] == cother[ci]):
                    done[cj] = True
                    cq = cells[cj]
                    for i in range(cq.shape[0]):
                        i2 = (i + 1) % cq.shape[0]
                        ed[e, 0], ed[e, 1] = cq[i, 0], cq[i, 1]
                        ed[e, 2], ed[e, 3] = cq[i2, 0], cq[i2, 1]
                        e += 1
            alive = np.ones(E, np.bool_)
            for e in range(E):
                if ed[e, 0] == ed[e, 2] and ed[e, 1] == ed[e, 3]:
                    alive[e] = False
            for e in range(E):
                if not alive[e]:
                    continue
                for f in range(e + 1, E):
                    if (alive[f] and ed[e, 0] == ed[f, 2] and ed[e, 1] == ed[f, 3]
                            and ed[e, 2] == ed[f, 0] and ed[e, 3] == ed[f, 1]):
                        alive[e] = False
                        alive[f] = False
                        break
            for e in range(E):
                if not alive[e]:
                    continue
                # chain a loop from edge e
                loop = np.empty((E, 2))
                n_l = 0
                cur = e
                while True:
                    alive[cur] = False
                    loop[n_l, 0] = ed[cur, 0]
                    loop[n_l, 1] = ed[cur, 1]
                    n_l += 1
                    nxt_e = -1
                    count = 0
                    for f in range(E):
                        if alive[f] and ed[f, 0] == ed[cur, 2] and ed[f, 1] == ed[cur, 3]:
                            count += 1
                            nxt_e = f
                    if ed[cur, 2] == ed[e, 0] and ed[cur, 3] == ed[e, 1]:
                        if count > 0:
                            status[j] = 1
                        break
                    if count != 1:
                        status[j] = 1
                        break
                    cur = nxt_e
                if status[j] != 0:
                    break
                pl = _simplify(loop[:n_l], tl)
                m = pl.shape[0]
                if m < 3 or abs(_area2(pl)) <= 2.0 * tl * tl:
                    continue
                kind = ckind[ci]
                for side in range(2 if kind == 0 else 1):
                    if L + 1 > cap_l:
                        cap_l *= 2
                        o_ptr = _grown(o_ptr, cap_l + 1)
                        o_j = _grown(o_j, cap_l)
                        o_kind = _grown(o_kind, cap_l)
                        o_piece = _grown(o_piece, cap_l)
                        o_facet = _grown(o_facet, cap_l)
                    while M + m > cap_v:
                        cap_v *= 2
                        grown = np.empty((cap_v, 3))
                        grown[:M] = o_xyz[:M]
                        o_xyz = grown
                    # counter-clockwise about the loop's outward normal: the
                    # face's normal for a's side, else reversed
                    rev = (kind == 0 and side == 1) or kind == 2
                    for k in range(m):
                        kk = m - 1 - k if rev else k
                        # a corner of the pieces' triangles: its own
                        # coordinates (those of the piece's other faces)
                        best_r = -1
                        best_i = -1
                        bd = tl
                        for r in range(q1 - q0):
                            for i in range(3):
                                dd = max(abs(qs[r, i, 0] - pl[kk, 0]),
                                         abs(qs[r, i, 1] - pl[kk, 1]))
                                if dd <= bd:
                                    bd = dd
                                    best_r = q0 + r
                                    best_i = i
                        for c3 in range(3):
                            if best_r >= 0:
                                o_xyz[M + k, c3] = q_xyz[best_r, best_i, c3]
                            else:
                                o_xyz[M + k, c3] = (o[c3] + pl[kk, 0] * e1[j, c3]
                                                    + pl[kk, 1] * e2[j, c3])
                    o_j[L] = j
                    o_kind[L] = side if kind == 0 else 2
                    o_piece[L] = cpiece[ci] if (kind != 0 or side == 0) else cother[ci]
                    o_facet[L] = cother[ci] if kind != 0 else -1
                    M += m
                    L += 1
                    o_ptr[L] = M
            if status[j] != 0:
                break
    return (o_ptr[:L + 1].copy(), o_xyz[:M].copy(), o_j[:L].copy(), o_kind[:L].copy(),
            o_piece[:L].copy(), o_facet[:L].copy(), status)
