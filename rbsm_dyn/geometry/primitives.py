"""Faceted primitives as explicit triangle meshes with named faces.

Each builder returns a :class:`Facets`: vertices (V, 3) float64, triangles
(T, 3) int64 counter-clockwise seen from outside, ``tri_face`` (T,) int64
index into ``face_names`` (the primitive's own face names: ``xmin``, ``side``,
``hole0.side3`` ...).  Vertex coordinates are computed once, so the
triangles of a planar face share exactly the same vertex values (a box face,
a prism side, an axis-aligned cylinder cap are coplanar to the last bit).

Faceting of curved surfaces (``chord`` = the largest distance allowed
between the smooth surface and its facets, in metres):

* circle of radius r (cylinder): n segments, the smallest n >= 8 with
  sagitta r (1 - cos(pi/n)) <= chord (the sagitta of the chord subtending
  2 pi/n; vertices lie on the circle, so the facets are inside it);
* sphere of radius r: a latitude-longitude sphere, n (even) meridian
  segments and n/2 latitude bands, vertices on the sphere; n is the
  smallest even n >= 8 with every facet's cap height r - sqrt(r^2 - rho^2)
  <= chord (rho: the facet's circumradius; that cap height bounds the
  distance from the sphere to the facet; the four corners of a band quad
  are concyclic, so both its triangles have the same circumcircle).
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from .errors import GeometryError

__all__ = [
    "Facets", "circle_segments", "sphere_segments", "box_facets",
    "cylinder_facets", "sphere_facets", "prism_facets", "axis_frame",
    "MAX_TRIANGLES",
]

#: refuse a primitive of more facets than this (a chord given in the wrong
#: units); 4·10⁶ triangles are ~200 MB of mesh
MAX_TRIANGLES = 4_000_000

BOX_FACES = ("xmin", "xmax", "ymin", "ymax", "zmin", "zmax")


@dataclass(frozen=True, eq=False)
class Facets:
    #: (V, 3) float64 [m]
    vertices: np.ndarray
    #: (T, 3) int64, counter-clockwise seen from outside
    triangles: np.ndarray
    #: (T,) int64 index into face_names
    tri_face: np.ndarray
    #: the primitive's face names, e.g. ("bottom", "top", "side")
    face_names: tuple


def circle_segments(radius: float, chord: float) -> int:
    """Smallest n >= 8 with r (1 - cos(pi/n)) <= chord: the sagitta of a
    circular segment of angle 2 pi/n, s = r (1 - cos(θ/2)), is the largest
    distance between the circle and a side of the inscribed regular n-gon."""
    if chord >= radius:
        return 8
    # sagitta s = r (1 - cos(pi/n))  =>  n = pi / acos(1 - s/r); then fix
    # the rounding of acos by stepping to the smallest n that satisfies it
    n = max(8, math.ceil(math.pi / math.acos(1.0 - chord / radius)))
    while n > 8 and radius * (1.0 - math.cos(math.pi / (n - 1))) <= chord:
        n -= 1
    while radius * (1.0 - math.cos(math.pi / n)) > chord:
        n += 1
    return n


def _cap_height(radius, rho):
    """Height of the spherical cap over a circle of radius rho on a sphere of
    radius r: r - sqrt(r^2 - rho^2) (Pythagoras: the circle's plane is
    sqrt(r^2 - rho^2) from the centre), written without cancellation."""
    return rho * rho / (radius + np.sqrt(np.maximum(radius * radius - rho * rho, 0.0)))


def _circumradius(a, b, c):
    """Circumradius R = |ab| |bc| |ca| / (4 area) of triangles (..., 3) (law
    of sines, a = 2 R sin A, with area = (1/2) b c sin A)."""
    ab = np.linalg.norm(b - a, axis=-1)
    bc = np.linalg.norm(c - b, axis=-1)
    ca = np.linalg.norm(a - c, axis=-1)
    area2 = np.linalg.norm(np.cross(b - a, c - a), axis=-1)      # 2 * area
    return ab * bc * ca / (2.0 * area2)


def _uv_sphere_unit(n):
    """Vertices (unit sphere) and triangles of the latitude-longitude sphere
    with n meridian segments and m = n/2 bands."""
    m = n // 2
    phi = np.pi * np.arange(1, m) / m                 # polar angles of the rings
    th = 2.0 * np.pi * np.arange(n) / n
    ring = np.stack([
        np.outer(np.sin(phi), np.cos(th)),
        np.outer(np.sin(phi), np.sin(th)),
        np.repeat(np.cos(phi)[:, None], n, axis=1),
    ], axis=-1).reshape(-1, 3)
    verts = np.vstack([[0.0, 0.0, 1.0], ring, [0.0, 0.0, -1.0]])
    south = len(verts) - 1
    k = np.arange(n)
    k1 = (k + 1) % n
    tris = [np.stack([np.zeros(n, np.int64), 1 + k, 1 + k1], axis=1)]   # north fan
    for j in range(m - 2):                       # band between ring j and j+1
        up, lo = 1 + j * n, 1 + (j + 1) * n
        tris.append(np.stack([up + k, lo + k, lo + k1], axis=1))
        tris.append(np.stack([up + k, lo + k1, up + k1], axis=1))
    last = 1 + (m - 2) * n
    tris.append(np.stack([np.full(n, south), last + k1, last + k], axis=1))  # south fan
    return verts, np.vstack(tris).astype(np.int64)


def _sphere_deviation(n, radius):
    """Largest cap height over the facets of the n-segment sphere (one facet
    per band is enough: the bands are rotationally symmetric)."""
    m = n // 2
    phi = np.pi * np.arange(0, m + 1) / m
    th = 2.0 * np.pi / n

    def p(ph, t):
        return radius * np.stack([np.sin(ph) * np.cos(t), np.sin(ph) * np.sin(t),
                                  np.cos(ph)], axis=-1)

    a, b, c = p(phi[:-1], 0.0), p(phi[1:], 0.0), p(phi[1:], th)
    # pole triangles: use the triangle (pole, ring point, next ring point)
    c[-1] = p(phi[-2], th)
    rho = _circumradius(a, b, c)
    return float(np.max(_cap_height(radius, rho)))


def sphere_segments(radius: float, chord: float) -> int:
    """Smallest even n >= 8 whose latitude-longitude sphere (n meridian
    segments, n/2 bands) has every facet's cap height <= chord."""
    # near the equator a band quad spans about 2 pi r/n both ways, so its cap
    # height is about twice the sagitta of one segment: start from the circle
    # rule at chord/2 and step to the smallest even n
    n = circle_segments(radius, 0.5 * chord)
    n += n % 2
    while n > 8 and _sphere_deviation(n - 2, radius) <= chord:
        n -= 2
    while _sphere_deviation(n, radius) > chord and n * n <= MAX_TRIANGLES:
        n += 2
    return n


def axis_frame(axis):
    """Right-handed orthonormal (e1, e2, e3) with e3 along ``axis``; e1 is the
    coordinate axis least aligned with e3 (first of x, y, z in a tie) made
    orthogonal to it: for axis z this is (x, y, z), for axis x (y, z, x)."""
    e3 = np.asarray(axis, dtype=np.float64)
    e3 = e3 / np.linalg.norm(e3)
    t = np.zeros(3)
    t[int(np.argmin(np.abs(e3)))] = 1.0
    e1 = t - (t @ e3) * e3
    e1 /= np.linalg.norm(e1)
    e2 = np.cross(e3, e1)
    return e1, e2, e3


def box_facets(lo, hi) -> Facets:
    lo = np.asarray(lo, dtype=np.float64)
    hi = np.asarray(hi, dtype=np.float64)
    # vertex index = ix + 2 iy + 4 iz
    verts = np.array([[(lo, hi)[ix][0], (lo, hi)[iy][1], (lo, hi)[iz][2]]
                      for iz in (0, 1) for iy in (0, 1) for ix in (0, 1)])
    quads = np.array([
        [0, 4, 6, 2],   # xmin
        [1, 3, 7, 5],   # xmax
        [0, 1, 5, 4],   # ymin
        [2, 6, 7, 3],   # ymax
        [0, 2, 3, 1],   # zmin
        [4, 5, 7, 6],   # zmax
    ], dtype=np.int64)
    tris = np.concatenate([quads[:, [0, 1, 2]], quads[:, [0, 2, 3]]])
    face = np.concatenate([np.arange(6), np.arange(6)]).astype(np.int64)
    order = np.argsort(face, kind="stable")
    return Facets(verts, tris[order], face[order], BOX_FACES)


def cylinder_facets(base, axis, radius, n) -> Facets:
    """Faces bottom (at base), top (at base + axis), side; caps fanned from
    their centres."""
    base = np.asarray(base, dtype=np.float64)
    axis = np.asarray(axis, dtype=np.float64)
    e1, e2, _ = axis_frame(axis)
    th = 2.0 * np.pi * np.arange(n) / n
    ring = radius * (np.cos(th)[:, None] * e1 + np.sin(th)[:, None] * e2)
    bottom = base + ring
    top = (base + axis) + ring
    verts = np.vstack([bottom, top, base, base + axis])
    cb, ct = 2 * n, 2 * n + 1
    k = np.arange(n, dtype=np.int64)
    k1 = (k + 1) % n
    # (e1, e2, axis) is right-handed: the rings run counter-clockwise seen from +axis
    t_bottom = np.stack([np.full(n, cb), k1, k], axis=1)
    t_top = np.stack([np.full(n, ct), n + k, n + k1], axis=1)
    t_side = np.concatenate([np.stack([k, k1, n + k1], axis=1),
                             np.stack([k, n + k1, n + k], axis=1)])
    tris = np.vstack([t_bottom, t_top, t_side])
    face = np.repeat(np.arange(3, dtype=np.int64), [n, n, 2 * n])
    return Facets(verts, tris, face, ("bottom", "top", "side"))


def sphere_facets(center, radius, n) -> Facets:
    verts, tris = _uv_sphere_unit(n)
    verts = np.asarray(center, dtype=np.float64) + radius * verts
    return Facets(verts, tris, np.zeros(len(tris), np.int64), ("surface",))


# -- prism ------------------------------------------------------------------

def _shoelace(p):
    """Signed area of a closed polygon (Gauss's shoelace formula), positive
    counter-clockwise."""
    q = np.roll(p, -1, axis=0)
    return 0.5 * float(np.sum(p[:, 0] * q[:, 1] - q[:, 0] * p[:, 1]))


def _orient(a, b, c):
    return (b[..., 0] - a[..., 0]) * (c[..., 1] - a[..., 1]) - \
           (b[..., 1] - a[..., 1]) * (c[..., 0] - a[..., 0])


def _on_segment(a, b, c, tol):
    """c collinear with a-b (|orient| <= tol) and within its box."""
    return (np.abs(_orient(a, b, c)) <= tol) & \
        (np.minimum(a[..., 0], b[..., 0]) <= c[..., 0]) & \
        (c[..., 0] <= np.maximum(a[..., 0], b[..., 0])) & \
        (np.minimum(a[..., 1], b[..., 1]) <= c[..., 1]) & \
        (c[..., 1] <= np.maximum(a[..., 1], b[..., 1]))


def _check_rings(rings, paths, scale):
    """Raise GeometryError if the rings (outer first, then holes) are not
    simple, disjoint polygons: any two non-adjacent edges that cross or
    touch, an edge folding back on the previous one, a hole outside the
    outer polygon or inside another hole."""
    tol = 1e-12 * scale * scale        # |orient| is an area
    starts = np.cumsum([0] + [len(r) for r in rings])
    a = np.vstack(rings)
    b = np.vstack([np.roll(r, -1, axis=0) for r in rings])
    ring_of = np.repeat(np.arange(len(rings)), [len(r) for r in rings])
    local = np.arange(len(a)) - starts[ring_of]
    size = np.array([len(r) for r in rings])[ring_of]
    m = len(a)

    def where(e):
        r, i = int(ring_of[e]), int(local[e])
        return paths[r], i

    def ring_desc(e):
        r = int(ring_of[e])
        return "the polygon" if r == 0 else f"hole {r - 1}"

    # an edge folding back on the previous one (a spike)
    nxt = np.arange(m) + 1
    nxt[local == size - 1] = starts[ring_of[local == size - 1]]
    c = b[nxt]
    spike = (np.abs(_orient(a, b, c)) <= tol) & \
        (np.einsum("ij,ij->i", b - a, c - b) < 0)
    if np.any(spike):
        e = int(np.argmax(spike))
        path, i = where(e)
        raise GeometryError(path, f"self-intersecting polygon: edge {i} folds back "
                                  f"on edge {(i + 1) % int(size[e])}")
    # candidate pairs: edges whose bounding boxes overlap (sweep over x)
    margin = 1e-9 * scale
    xmin, xmax = np.minimum(a[:, 0], b[:, 0]), np.maximum(a[:, 0], b[:, 0]) + margin
    ymin, ymax = np.minimum(a[:, 1], b[:, 1]), np.maximum(a[:, 1], b[:, 1]) + margin
    order = np.argsort(xmin, kind="stable")
    hi = np.searchsorted(xmin[order], xmax[order], side="right")
    count = np.maximum(hi - np.arange(m) - 1, 0)
    first = np.repeat(np.arange(m), count)
    second = first + 1 + (np.arange(count.sum()) - np.repeat(np.cumsum(count) - count, count))
    i_all, j_all = order[first], order[second]
    keep = (ymin[i_all] <= ymax[j_all]) & (ymin[j_all] <= ymax[i_all])
    i_all, j_all = np.minimum(i_all, j_all)[keep], np.maximum(i_all, j_all)[keep]
    adjacent = (ring_of[i_all] == ring_of[j_all]) & ((j_all == nxt[i_all]) | (i_all == nxt[j_all]))
    i_all, j_all = i_all[~adjacent], j_all[~adjacent]
    chunk = 1_000_000
    for s in range(0, len(i_all), chunk):
        i, j = i_all[s:s + chunk], j_all[s:s + chunk]
        ai, bi, aj, bj = a[i], b[i], a[j], b[j]
        o1, o2 = _orient(ai, bi, aj), _orient(ai, bi, bj)
        o3, o4 = _orient(aj, bj, ai), _orient(aj, bj, bi)
        proper = (o1 * o2 < 0) & (o3 * o4 < 0) & \
            (np.abs(o1) > tol) & (np.abs(o2) > tol) & (np.abs(o3) > tol) & (np.abs(o4) > tol)
        touch = _on_segment(ai, bi, aj, tol) | _on_segment(ai, bi, bj, tol) | \
            _on_segment(aj, bj, ai, tol) | _on_segment(aj, bj, bi, tol)
        bad = proper | touch
        if np.any(bad):
            # report the first offending pair in input order
            k = np.flatnonzero(bad)
            k = k[np.lexsort((j[k], i[k]))[0]]
            e, f = int(i[k]), int(j[k])
            pe, ie = where(e)
            pf, jf = where(f)
            if pe == pf:
                raise GeometryError(pe, f"self-intersecting polygon: edges {ie} and {jf} "
                                        f"{'cross' if proper[k] else 'touch'}")
            raise GeometryError(pf, f"edge {jf} {'crosses' if proper[k] else 'touches'} "
                                    f"edge {ie} of {ring_desc(e)}")
    # containment: no edges cross, so one vertex decides
    for h in range(1, len(rings)):
        if not _point_in_ring(rings[h][0], rings[0]):
            raise GeometryError(paths[h], "hole lies outside the polygon")
        for g in range(1, len(rings)):
            if g != h and _point_in_ring(rings[h][0], rings[g]):
                raise GeometryError(paths[h], f"hole lies inside hole {g - 1}")


def _point_in_ring(p, ring):
    """Even-odd crossing test of one point against a polygon (a ray crosses
    the boundary an odd number of times from inside: Jordan curve theorem)."""
    a = ring
    b = np.roll(ring, -1, axis=0)
    up = (a[:, 1] <= p[1]) != (b[:, 1] <= p[1])
    with np.errstate(divide="ignore", invalid="ignore"):
        x = a[:, 0] + (p[1] - a[:, 1]) * (b[:, 0] - a[:, 0]) / (b[:, 1] - a[:, 1])
    return bool(np.count_nonzero(up & (x > p[0])) % 2)


# (u, v, w) -> (x, y, z): the (u, v) plane is normal to the axis, w along it;
# each map is a cyclic permutation, so (u, v, w) stays right-handed
_UVW = {"x": (1, 2, 0), "y": (2, 0, 1), "z": (0, 1, 2)}


def prism_facets(polygon, holes, axis, w0, w1, path=()) -> Facets:
    """Extrusion of a polygon with holes from w0 to w1 > w0 along ``axis``.

    Faces: bottom (w = w0), top (w = w1), ``side{i}`` for the edge from
    outer vertex i to i+1 (input numbering, either input orientation),
    ``hole{h}.side{i}`` for hole edges."""
    import manifold3d

    outer = np.asarray(polygon, dtype=np.float64)
    holes = [np.asarray(h, dtype=np.float64) for h in holes]
    rings = [outer] + holes
    paths = [tuple(path) + ("polygon",)] + [tuple(path) + ("holes", h) for h in range(len(holes))]
    scale = float(np.max(np.ptp(outer, axis=0)))
    if not scale > 0:
        raise GeometryError(paths[0], "polygon has zero area")
    _check_rings(rings, paths, scale)
    for r, pth in zip(rings, paths):
        if abs(_shoelace(r)) <= 1e-12 * scale * scale:
            raise GeometryError(pth, "polygon has zero area")
    # orient: outer counter-clockwise, holes clockwise (material on the left);
    # keep the input index of every edge for its name
    oriented, labels = [], []
    for h, r in enumerate(rings):
        n = len(r)
        want_ccw = h == 0
        if (_shoelace(r) > 0) == want_ccw:
            oriented.append(r)
            labels.append(np.arange(n))
        else:
            oriented.append(r[::-1].copy())
            # new edge j runs from old vertex n-1-j to n-2-j: old edge (n-2-j) mod n
            labels.append((n - 2 - np.arange(n)) % n)
    pts = np.vstack(oriented)
    npts = len(pts)
    tri2 = np.asarray(manifold3d.triangulate([np.ascontiguousarray(r) for r in oriented]),
                      dtype=np.int64).reshape(-1, 3)
    # the triangulation must tile the polygon: its area is the shoelace area
    a2 = pts[tri2]
    t_area = 0.5 * np.sum(_orient(a2[:, 0], a2[:, 1], a2[:, 2]))
    p_area = sum(_shoelace(r) for r in oriented)
    if len(tri2) == 0 or abs(t_area - p_area) > 1e-9 * abs(p_area):
        raise GeometryError(paths[0], "polygon could not be triangulated "
                                      "(self-intersecting or overlapping holes?)")
    uvw = np.empty((2 * npts, 3))
    uvw[:npts, :2] = pts
    uvw[npts:, :2] = pts
    uvw[:npts, 2] = w0
    uvw[npts:, 2] = w1
    verts = np.empty_like(uvw)
    for k, dst in enumerate(_UVW[axis]):
        verts[:, dst] = uvw[:, k]
    # caps: the 2D triangles are counter-clockwise seen from +w (top)
    t_bottom = tri2[:, [0, 2, 1]]
    t_top = tri2 + npts
    # sides: oriented edge i -> j, quad (b_i, b_j, t_j, t_i), normal (b_j - b_i) x w
    names = ["bottom", "top"]
    side_tris, side_face = [], []
    start = 0
    for h, r in enumerate(oriented):
        n = len(r)
        i = start + np.arange(n)
        j = start + (np.arange(n) + 1) % n
        side_tris += [np.stack([i, j, npts + j], axis=1), np.stack([i, npts + j, npts + i], axis=1)]
        prefix = "" if h == 0 else f"hole{h - 1}."
        face0 = len(names)
        names += [f"{prefix}side{k}" for k in range(n)]
        ids = face0 + labels[h]
        side_face += [ids, ids]
        start += n
    tris = np.vstack([t_bottom, t_top] + side_tris).astype(np.int64)
    face = np.concatenate([np.zeros(len(tri2), np.int64), np.ones(len(tri2), np.int64)]
                          + [np.asarray(f, np.int64) for f in side_face])
    return Facets(verts, tris, face, tuple(names))
