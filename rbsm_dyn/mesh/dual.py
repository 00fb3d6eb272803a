"""Voronoi ridges as the dual of scipy's Delaunay triangulation, in Numba.

``scipy.spatial.Voronoi`` hands its ridges back as a Python list of lists
(one list per ridge): at 10⁵ cells that is millions of Python ints, most of
a Voronoi mesh's build time and memory.  The Voronoi diagram is the dual of
the Delaunay triangulation (Okabe, Boots, Sugihara & Chiu, *Spatial
Tessellations*, 2nd ed., 2000, §2.4): its vertices are the circumcentres of
the Delaunay tetrahedra, and the ridge between points p and q is the
polygon of the circumcentres of the tetrahedra around the Delaunay edge pq,
in the order of that ring.  So one qhull run (``scipy.spatial.Delaunay``)
and one compiled walk over the tetrahedra give the ridges as flat arrays.

Degenerate tetrahedra (four cospherical and coplanar points, which mirrors
across a box side make common: a seed, its mirror, another seed and its
mirror form an isosceles trapezoid) have no circumcentre; their vertex is
NaN and the rings skip it (the ring's other vertices already span the
polygon: the flat tetrahedron's centre would lie on the segment between its
two neighbours' centres).  A ring that meets the hull (an unbounded ridge)
is marked with −1, as ``Voronoi.ridge_vertices`` does.
"""
import numba as nb
import numpy as np

JIT = dict(cache=True, nogil=True)

#: a tetrahedron whose volume is below FLAT × the product of three edges is
#: flat: its circumcentre is lost to round-off (its error grows as 1/volume)
#: and is not used.  Such tetrahedra come from (nearly) cospherical points,
#: whose tetrahedra share one centre (the rings' other vertices hold it).
FLAT = 1e-8

# local edges (i, j) of a tetrahedron and the two other local vertices (k, l)
_EDGES = np.array([[0, 1, 2, 3], [0, 2, 1, 3], [0, 3, 1, 2],
                   [1, 2, 0, 3], [1, 3, 0, 2], [2, 3, 0, 1]], dtype=np.int64)


@nb.njit(**JIT)
def circumcentres(points, simplices, rel_tol):
    """(T, 3) circumcentres of the tetrahedra; NaN where the volume is below
    rel_tol × the product of its three edge lengths from vertex 0 (flat)."""
    T = simplices.shape[0]
    out = np.empty((T, 3))
    for t in range(T):
        a = simplices[t, 0]
        ax, ay, az = points[a, 0], points[a, 1], points[a, 2]
        ux = points[simplices[t, 1], 0] - ax
        uy = points[simplices[t, 1], 1] - ay
        uz = points[simplices[t, 1], 2] - az
        vx = points[simplices[t, 2], 0] - ax
        vy = points[simplices[t, 2], 1] - ay
        vz = points[simplices[t, 2], 2] - az
        wx = points[simplices[t, 3], 0] - ax
        wy = points[simplices[t, 3], 1] - ay
        wz = points[simplices[t, 3], 2] - az
        # v × w, w × u, u × v
        c1x, c1y, c1z = vy * wz - vz * wy, vz * wx - vx * wz, vx * wy - vy * wx
        c2x, c2y, c2z = wy * uz - wz * uy, wz * ux - wx * uz, wx * uy - wy * ux
        c3x, c3y, c3z = uy * vz - uz * vy, uz * vx - ux * vz, ux * vy - uy * vx
        det = ux * c1x + uy * c1y + uz * c1z
        uu = ux * ux + uy * uy + uz * uz
        vv = vx * vx + vy * vy + vz * vz
        ww = wx * wx + wy * wy + wz * wz
        if abs(det) <= rel_tol * np.sqrt(uu * vv * ww):
            out[t, 0] = out[t, 1] = out[t, 2] = np.nan
            continue
        # centre = a + (|u|² v×w + |v|² w×u + |w|² u×v) / (2 u·(v×w))
        s = 0.5 / det
        out[t, 0] = ax + s * (uu * c1x + vv * c2x + ww * c3x)
        out[t, 1] = ay + s * (uu * c1y + vv * c2y + ww * c3y)
        out[t, 2] = az + s * (uu * c1z + vv * c2z + ww * c3z)
    return out


@nb.njit(inline="always", **JIT)
def _local(simplices, t, v):
    """Local index of vertex v in tetrahedron t (−1 if absent)."""
    for i in range(4):
        if simplices[t, i] == v:
            return i
    return -1


@nb.njit(inline="always", **JIT)
def _walk(simplices, neighbors, t, p, q, a, b, ring, fill):
    """Walk the ring of tetrahedra about the edge pq from t, first across
    t's face opposite its vertex a (that face holds p, q and b, t's other
    vertex off pq).  Returns (status, n): 1 back at t (closed), 0 at the
    hull, 2 at a tetrahedron numbered below t; ring[:n] the tetrahedra
    passed, t first (when `fill`)."""
    n = 0
    if fill:
        ring[0] = t
        n = 1
    c = t
    for _ in range(simplices.shape[0]):
        nxt = neighbors[c, _local(simplices, c, a)]
        if nxt < 0:
            return 0, n
        if nxt == t:
            return 1, n
        if nxt < t:
            return 2, n
        # nxt shares the face (p, q, b) with c: its fourth vertex is new,
        # and the walk goes on across nxt's face opposite b
        new = -1
        for i in range(4):
            v = simplices[nxt, i]
            if v != p and v != q and v != b:
                new = v
        a, b = b, new
        if fill:
            ring[n] = nxt
            n += 1
        c = nxt
    return 0, n           # (not reached on a valid triangulation)


@nb.njit(**JIT)
def ridges(simplices, neighbors, centre_ok, n_keep, edges):
    """The Voronoi ridges of the Delaunay edges pq with min(p, q) < n_keep.

    Returns (ridge_points (R, 2) with p < q, ridge_ptr (R + 1,), ridge_vertex
    (tetrahedron ids in ring order, flat ones left out; a single −1 for a
    ring open at the hull)).  Each ring is emitted by its lowest-numbered
    tetrahedron, so once."""
    T = simplices.shape[0]
    pts = np.empty((6 * T, 2), dtype=np.int64)
    ptr = np.zeros(6 * T + 1, dtype=np.int64)
    vid = np.empty(6 * T, dtype=np.int64)
    ring = np.empty(T + 1, dtype=np.int64)
    R = 0
    K = 0
    for t in range(T):
        for e in range(6):
            p = simplices[t, edges[e, 0]]
            q = simplices[t, edges[e, 1]]
            if p >= n_keep and q >= n_keep:
                continue
            r = simplices[t, edges[e, 2]]
            s_ = simplices[t, edges[e, 3]]
            status, n = _walk(simplices, neighbors, t, p, q, r, s_, ring, True)
            if status == 2:
                continue
            if status == 0:
                back, _ = _walk(simplices, neighbors, t, p, q, s_, r, ring, False)
                if back == 2:
                    continue
            pts[R, 0] = min(p, q)
            pts[R, 1] = max(p, q)
            if status == 1:
                for i in range(n):
                    if centre_ok[ring[i]]:
                        vid[K] = ring[i]
                        K += 1
            else:
                vid[K] = -1
                K += 1
            R += 1
            ptr[R] = K
    return pts[:R].copy(), ptr[:R + 1].copy(), vid[:K].copy()


def voronoi_ridges(points, n_keep=None):
    """Voronoi vertices and the ridges of points[:n_keep] (all by default):
    (V (T, 3), ridge_points (R, 2) p < q, ridge_ptr (R + 1,), ridge_vertex).
    A ridge that is unbounded has the single vertex −1."""
    from scipy.spatial import Delaunay
    points = np.ascontiguousarray(points, dtype=np.float64)
    tri = Delaunay(points)
    simplices = np.ascontiguousarray(tri.simplices, dtype=np.int64)
    neighbors = np.ascontiguousarray(tri.neighbors, dtype=np.int64)
    del tri
    V = circumcentres(points, simplices, FLAT)
    ok = np.isfinite(V[:, 0])
    rp, ptr, vid = ridges(simplices, neighbors, ok, len(points) if n_keep is None else n_keep,
                          _EDGES)
    return V, rp, ptr, vid
