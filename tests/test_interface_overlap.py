"""rbsm_dyn.mesh.interface.face_overlaps: overlap polygons of touching boundary
faces of cells in different parts."""
import numpy as np
import pytest

from rbsm_dyn.mesh import block_mesh, voronoi_mesh
from rbsm_dyn.mesh.interface import Overlaps, face_overlaps
from rbsm_dyn.mesh.spring_points import polygon_properties

TOL = 1e-9  # length_tol [m] for unit-sized parts


def combine(*meshes):
    """The boundary faces of several meshes as one set: (ptr, xyz, normal,
    cell, cell_part, cell offsets), mesh k is part k."""
    ptrs, offs = [np.zeros(1, np.int64)], [0]
    for m in meshes:
        ptrs.append(m.bface_vertex_ptr[1:] + ptrs[-1][-1])
        offs.append(offs[-1] + m.n_cells)
    return (
        np.concatenate(ptrs),
        np.concatenate([m.bface_vertex_xyz for m in meshes]),
        np.concatenate([m.bface_normal for m in meshes]),
        np.concatenate([m.bface_cell + o for m, o in zip(meshes, offs)]),
        np.concatenate([np.full(m.n_cells, k) for k, m in enumerate(meshes)]),
        offs,
    )


def from_polygons(polys, normals, cells):
    """CSR boundary-face arrays from lists of 3D polygons."""
    ptr = np.concatenate([[0], np.cumsum([len(p) for p in polys])]).astype(np.int64)
    return ptr, np.concatenate([np.asarray(p, float) for p in polys]), np.asarray(normals, float), \
        np.asarray(cells, np.int64)


def overlaps_of(*meshes, **kw):
    ptr, xyz, nrm, cell, part, offs = combine(*meshes)
    return face_overlaps(ptr, xyz, nrm, cell, part, length_tol=kw.pop("length_tol", TOL), **kw), offs


def signed_areas(ov):
    return polygon_properties(ov.vertex_ptr, ov.vertex_xyz, ov.normal)[0]


def check_structure(ov):
    """Invariants of every Overlaps: shapes, a < b, sort order, unit normals,
    counter-clockwise simple-ish polygons with no repeated vertices."""
    K = len(ov)
    assert isinstance(ov, Overlaps)
    assert ov.cells.shape == (K, 2) and ov.faces.shape == (K, 2) and ov.normal.shape == (K, 3)
    assert ov.cells.dtype == np.int64 and ov.faces.dtype == np.int64 and ov.vertex_ptr.dtype == np.int64
    assert ov.vertex_ptr.shape == (K + 1,) and ov.vertex_ptr[-1] == len(ov.vertex_xyz)
    assert np.all(np.diff(ov.vertex_ptr) >= 3)
    assert np.all(ov.cells[:, 0] < ov.cells[:, 1])
    key = ov.cells[:, 0] * 10**12 + ov.cells[:, 1] * 10**6 + ov.faces[:, 0]
    assert np.all(np.diff(key) >= 0)
    np.testing.assert_allclose(np.linalg.norm(ov.normal, axis=1), 1.0, atol=1e-14)
    assert np.all(signed_areas(ov) > 0)
    np.testing.assert_allclose(signed_areas(ov), ov.area, rtol=0, atol=1e-15)
    # no vertex within length_tol of the next (cyclically)
    x = ov.vertex_xyz
    nxt = np.arange(len(x)) + 1
    nxt[ov.vertex_ptr[1:] - 1] = ov.vertex_ptr[:-1]
    if K:
        assert np.linalg.norm(x[nxt] - x, axis=1).min() >= TOL


def test_two_block_boxes_grid_overlay():
    A = block_mesh([[0, 0, 0], [1, 1, 1]], (2, 3, 2))
    Bm = block_mesh([[1, 0, 0], [2, 1, 1]], (2, 2, 3))
    ov, offs = overlaps_of(A, Bm)
    check_structure(ov)
    # the contact face x = 1 is the unit square
    assert abs(ov.area.sum() - 1.0) <= 1e-12
    np.testing.assert_allclose(ov.vertex_xyz[:, 0], 1.0, rtol=0, atol=1e-15)
    np.testing.assert_allclose(ov.centroid[:, 0], 1.0, rtol=0, atol=1e-15)
    # from the part-0 cell (ids < offs[1]) to the part-1 cell, normal +x
    assert np.all(ov.cells[:, 0] < offs[1]) and np.all(ov.cells[:, 1] >= offs[1])
    np.testing.assert_allclose(ov.normal, np.tile([1.0, 0, 0], (len(ov), 1)), atol=0)
    # each piece: a's face is A's xmax face, b's face is B's xmin face
    ptr, xyz, nrm, cell, part, _ = combine(A, Bm)
    np.testing.assert_array_equal(cell[ov.faces], ov.cells)
    np.testing.assert_allclose(nrm[ov.faces[:, 0]], ov.normal, atol=0)
    np.testing.assert_allclose(nrm[ov.faces[:, 1]], -ov.normal, atol=0)
    # pieces = rectangles of the overlay of a 3 × 2 and a 2 × 3 grid (y × z)
    ylines = np.unique(np.round(np.concatenate([np.linspace(0, 1, 4), np.linspace(0, 1, 3)]), 12))
    zlines = np.unique(np.round(np.concatenate([np.linspace(0, 1, 3), np.linspace(0, 1, 4)]), 12))
    assert len(ov) == (len(ylines) - 1) * (len(zlines) - 1) == 16
    # every piece is one overlay rectangle (4 corners), its area the product of its sides
    assert np.all(np.diff(ov.vertex_ptr) == 4)
    ymin = np.minimum.reduceat(ov.vertex_xyz[:, 1], ov.vertex_ptr[:-1])
    ymax = np.maximum.reduceat(ov.vertex_xyz[:, 1], ov.vertex_ptr[:-1])
    zmin = np.minimum.reduceat(ov.vertex_xyz[:, 2], ov.vertex_ptr[:-1])
    zmax = np.maximum.reduceat(ov.vertex_xyz[:, 2], ov.vertex_ptr[:-1])
    np.testing.assert_allclose(ov.area, (ymax - ymin) * (zmax - zmin), rtol=0, atol=1e-15)
    # each pair of cells at most once (convex faces: one piece per face pair)
    assert len(np.unique(ov.cells, axis=0)) == len(ov)


@pytest.mark.parametrize("voronoi_first", [True, False])
def test_voronoi_against_blocks_area_and_first_moment(voronoi_first):
    V = voronoi_mesh([[0, 0, 0], [1, 1, 1]], 0.3, seed=3)
    Bm = block_mesh([[1, 0, 0], [2, 1, 1]], (1, 3, 2))
    meshes = (V, Bm) if voronoi_first else (Bm, V)
    ov, offs = overlaps_of(*meshes)
    check_structure(ov)
    # the contact face: the unit square at x = 1, centroid (1, 0.5, 0.5)
    assert abs(ov.area.sum() - 1.0) <= 1e-10
    moment = (ov.area[:, None] * ov.centroid).sum(axis=0)
    np.testing.assert_allclose(moment, [1.0, 0.5, 0.5], rtol=0, atol=1e-10)
    np.testing.assert_allclose(ov.vertex_xyz[:, 0], 1.0, rtol=0, atol=1e-12)
    # normal from the lower cell: the first mesh's face (Voronoi +x, blocks −x)
    ptr, xyz, nrm, cell, part, _ = combine(*meshes)
    expect = [1.0, 0, 0] if voronoi_first else [-1.0, 0, 0]
    np.testing.assert_allclose(ov.normal, np.tile(expect, (len(ov), 1)), atol=1e-15)
    np.testing.assert_array_equal(part[ov.cells[:, 0]], 0)
    np.testing.assert_array_equal(part[ov.cells[:, 1]], 1)
    # every contact face of either part is covered exactly by its overlaps
    face_area, _ = polygon_properties(ptr, xyz, nrm)
    for col in (0, 1):
        covered = np.bincount(ov.faces[:, col], ov.area, minlength=len(cell))
        on_contact = np.flatnonzero(np.isin(np.arange(len(cell)), ov.faces[:, col]))
        np.testing.assert_allclose(covered[on_contact], face_area[on_contact], rtol=0, atol=1e-12)
        # and no contact face is missed
        cen = np.add.reduceat(xyz, ptr[:-1]) / np.diff(ptr)[:, None]
        sel = (np.abs(cen[:, 0] - 1.0) < 1e-12) & (part[cell] == col)
        assert set(np.flatnonzero(sel)) == set(on_contact)


def test_edge_contact_gap_and_tilt_give_nothing():
    A = block_mesh([[0, 0, 0], [1, 1, 1]], (2, 2, 2))
    # touching along the edge x = 1, y = 1 only
    edge = block_mesh([[1, 1, 0], [2, 2, 1]], (2, 2, 2))
    ov, _ = overlaps_of(A, edge)
    assert len(ov) == 0 and ov.vertex_ptr.tolist() == [0] and ov.vertex_xyz.shape == (0, 3)
    # a gap of 10 length_tol
    gap = block_mesh([[1 + 10 * TOL, 0, 0], [2, 1, 1]], (2, 2, 2))
    assert len(overlaps_of(A, gap)[0]) == 0
    # ... while a gap of 0.5 length_tol is contact
    near = block_mesh([[1 + 0.5 * TOL, 0, 0], [2, 1, 1]], (1, 1, 1))
    ov, _ = overlaps_of(A, near)
    assert len(ov) == 4 and abs(ov.area.sum() - 1.0) <= 1e-12
    # a box turned by 1e-3 rad about the z axis through (1, 0.5, 0.5):
    # its xmin face passes through the contact face's centre, normals differ by 1e-3
    B = block_mesh([[1, 0, 0], [2, 1, 1]], (1, 1, 1))
    t = 1e-3
    R = np.array([[np.cos(t), -np.sin(t), 0], [np.sin(t), np.cos(t), 0], [0, 0, 1]])
    c = np.array([1.0, 0.5, 0.5])
    ptr, xyz, nrm, cell, part, _ = combine(A, B)
    mine = np.repeat(part[cell] == 1, np.diff(ptr))
    xyz = xyz.copy()
    xyz[mine] = (xyz[mine] - c) @ R.T + c
    nrm = nrm.copy()
    nrm[part[cell] == 1] = nrm[part[cell] == 1] @ R.T
    ov = face_overlaps(ptr, xyz, nrm, cell, part, length_tol=TOL)
    assert len(ov) == 0
    # the same turn with angle_tol = 2e-3 and a plane tolerance that covers
    # the tilt (half-width 0.5 × sin 1e-3) is contact again: the turned face
    # projected on x = 1 is cos t wide in y (centred on y = 0.5), 1 in z
    ov = face_overlaps(ptr, xyz, nrm, cell, part, length_tol=1e-3, angle_tol=2e-3)
    assert len(ov) == 4 and abs(ov.area.sum() - np.cos(t)) <= 1e-12


def rotation(seed):
    q, r = np.linalg.qr(np.random.default_rng(seed).normal(size=(3, 3)))
    q = q * np.sign(np.diag(r))
    return q if np.linalg.det(q) > 0 else -q


def in_plane(poly2d, R, origin):
    """2D (u, v) points on the plane through ``origin`` with axes R[:, 0], R[:, 1]
    (normal R[:, 2])."""
    p = np.asarray(poly2d, float)
    return origin + p[:, :1] * R[:, 0] + p[:, 1:2] * R[:, 1]


# counter-clockwise L: [0,2]×[0,1] ∪ [0,1]×[1,2], area 3
L = [(0, 0), (2, 0), (2, 1), (1, 1), (1, 2), (0, 2)]
# U (not star-shaped about its centroid, which lies in the notch): area 7
U = [(0, 0), (3, 0), (3, 3), (2, 3), (2, 1), (1, 1), (1, 3), (0, 3)]


def pair_of_faces(p, q, seed=0, q_offset=0.0):
    """Face 0 (cell 0, part 0): polygon p, ccw about +n; face 1 (cell 1,
    part 1): polygon q (given ccw in the same (u, v) axes), reversed so that
    it is ccw about −n; both on one tilted plane (``q_offset`` along n)."""
    R = rotation(seed)
    o = np.array([0.3, -0.2, 0.7])
    n = R[:, 2]
    a = in_plane(p, R, o)
    b = in_plane(q, R, o + q_offset * n)[::-1]
    ptr, xyz, nrm, cell = from_polygons([a, b], [n, -n], [0, 1])
    return ptr, xyz, nrm, cell, np.array([0, 1]), R, o


@pytest.mark.parametrize("swap", [False, True])
def test_nonconvex_face_against_square(swap):
    # square [0.5, 1.5]²: covers [0.5,1.5]×[0.5,1] of the bottom arm and
    # [0.5,1]×[1,1.5] of the top arm: area 0.5 + 0.25
    S = [(0.5, 0.5), (1.5, 0.5), (1.5, 1.5), (0.5, 1.5)]
    p, q = (S, L) if swap else (L, S)
    ptr, xyz, nrm, cell, part, R, o = pair_of_faces(p, q, seed=1)
    ov = face_overlaps(ptr, xyz, nrm, cell, part, length_tol=TOL)
    check_structure(ov)
    assert len(ov) == 1
    assert ov.cells.tolist() == [[0, 1]] and ov.faces.tolist() == [[0, 1]]
    np.testing.assert_allclose(ov.normal[0], R[:, 2], atol=1e-15)
    assert abs(ov.area[0] - 0.75) <= 1e-12
    # first moment: 0.5 × (1, 0.75) + 0.25 × (0.75, 1.25)
    c2 = (0.5 * np.array([1.0, 0.75]) + 0.25 * np.array([0.75, 1.25])) / 0.75
    np.testing.assert_allclose(ov.centroid[0], in_plane([c2], R, o)[0], rtol=0, atol=1e-12)
    # the overlap is the (non-convex) hexagon itself, in face 0's plane
    assert np.diff(ov.vertex_ptr).tolist() == [6]
    d = (ov.vertex_xyz - o) @ R[:, 2]
    np.testing.assert_allclose(d, 0.0, rtol=0, atol=1e-14)


def test_nonconvex_disconnected_overlap_keeps_area_and_moment():
    # the convex pentagon {u + v >= 2.5} ∩ [0, 3]² cuts off the ends of both
    # arms of L but not its corner: two triangles (legs 0.5, area 0.125 each)
    # with centroids (11/6, 5/6) and (5/6, 11/6).  Sutherland-Hodgman returns
    # them as one polygon joined along the clip line (documented): area and
    # first moment are still exact.
    S = [(2.5, 0.0), (3.0, 0.0), (3.0, 3.0), (0.0, 3.0), (0.0, 2.5)]
    ptr, xyz, nrm, cell, part, R, o = pair_of_faces(L, S, seed=2)
    ov = face_overlaps(ptr, xyz, nrm, cell, part, length_tol=TOL)
    check_structure(ov)
    assert len(ov) == 1
    assert abs(ov.area[0] - 0.25) <= 1e-12
    np.testing.assert_allclose(ov.centroid[0], in_plane([(4 / 3, 4 / 3)], R, o)[0], rtol=0, atol=1e-12)


def test_both_nonconvex_fan_pieces():
    # L and its half-turn about (1, 1): [0,2]×[1,2] ∪ [1,2]×[0,1]; the overlap is
    # [1,2]×[0,1] ∪ [0,1]×[1,2], area 2, centroid (1, 1); both star-shaped
    L2 = [(2 - u, 2 - v) for u, v in L]
    ptr, xyz, nrm, cell, part, R, o = pair_of_faces(L, L2, seed=3, q_offset=0.3 * TOL)
    ov = face_overlaps(ptr, xyz, nrm, cell, part, length_tol=TOL)
    check_structure(ov)
    assert len(ov) >= 2
    assert np.all(ov.cells == [0, 1]) and np.all(ov.faces == [0, 1])
    assert abs(ov.area.sum() - 2.0) <= 1e-12
    moment = (ov.area[:, None] * ov.centroid).sum(axis=0) / 2.0
    np.testing.assert_allclose(moment, in_plane([(1.0, 1.0)], R, o)[0], rtol=0, atol=1e-12)
    # the pieces are in face 0's plane even though face 1 is 0.3 length_tol off
    np.testing.assert_allclose((ov.vertex_xyz - o) @ R[:, 2], 0.0, rtol=0, atol=1e-14)


def test_both_nonconvex_not_star_shaped_raises():
    U2 = [(3 - u, 3 - v) for u, v in U]
    ptr, xyz, nrm, cell, part, R, o = pair_of_faces(U, U2, seed=4)
    cell = np.array([5, 2])
    part = np.array([0, 0, 1, 0, 0, 2])
    with pytest.raises(ValueError, match="cells 2 and 5 are both non-convex"):
        face_overlaps(ptr, xyz, nrm, cell, part, length_tol=TOL)


def test_same_part_faces_are_not_compared():
    A = block_mesh([[0, 0, 0], [1, 1, 1]], (1, 1, 1))
    B = block_mesh([[1, 0, 0], [2, 1, 1]], (1, 1, 1))
    ptr, xyz, nrm, cell, part, _ = combine(A, B)
    ov = face_overlaps(ptr, xyz, nrm, cell, np.zeros_like(part), length_tol=TOL)
    assert len(ov) == 0
    ov = face_overlaps(ptr, xyz, nrm, cell, part, length_tol=TOL)
    assert len(ov) == 1 and abs(ov.area[0] - 1.0) <= 1e-12


def test_coarse_part_against_fine_part():
    # one cell against many: the broad phase must not pair every fine face
    # with every other; the contact face (y = 1, 1 × 1) is covered exactly
    coarse = block_mesh([[0, 1, 0], [1, 2, 1]], (1, 1, 1))
    fine = block_mesh([[0, 0, 0], [1, 1, 1]], (12, 12, 12))
    ov, offs = overlaps_of(fine, coarse)
    check_structure(ov)
    assert len(ov) == 144
    assert abs(ov.area.sum() - 1.0) <= 1e-12
    np.testing.assert_allclose(ov.normal, np.tile([0, 1.0, 0], (144, 1)), atol=0)
    np.testing.assert_array_equal(ov.cells[:, 1], offs[1])


def _random_polygon(rng, convex):
    """Counter-clockwise polygon around a random centre: on an ellipse
    (convex) or with random radii at sorted angles (star-shaped about the
    centre, in general non-convex)."""
    n = int(rng.integers(3, 8) if convex else rng.integers(5, 10))
    ang = np.sort(rng.uniform(0, 2 * np.pi, n))
    while np.max(np.diff(np.r_[ang, ang[0] + 2 * np.pi])) > 0.9 * np.pi:  # keep the centre inside
        ang = np.sort(rng.uniform(0, 2 * np.pi, n))
    r = np.ones(n) if convex else rng.uniform(0.3, 1.2, n)
    ab = rng.uniform(0.5, 1.2, 2)
    return rng.uniform(-0.5, 0.5, 2) + np.stack([ab[0] * r * np.cos(ang), ab[1] * r * np.sin(ang)], 1)


def _area_moment(poly):
    """Shoelace area and first moment (∫ x dA) of a closed polygon."""
    x, y = poly[:, 0], poly[:, 1]
    xn, yn = np.roll(x, -1), np.roll(y, -1)
    w = x * yn - xn * y
    return 0.5 * w.sum(), np.array([((x + xn) * w).sum(), ((y + yn) * w).sum()]) / 6.0


def _star_about_centroid(poly):
    a, m = _area_moment(poly)
    d = poly - m / a
    return bool(np.all(d[:, 0] * np.roll(d[:, 1], -1) - np.roll(d[:, 0], -1) * d[:, 1] > 0))


def test_random_polygon_pairs_match_manifold_boolean():
    """Random pairs (convex/convex, convex/non-convex, non-convex/non-convex
    star-shaped), each on its own tilted plane far from the others, all in
    one call: the area and first moment of each pair's overlap pieces agree
    with manifold3d's polygon intersection (Clipper2, ~1e-8 precision)."""
    manifold3d = pytest.importorskip("manifold3d")
    rng = np.random.default_rng(7)
    polys, normals, cells, frames, expect = [], [], [], [], []
    for k in range(120):
        kind = k % 4
        p = _random_polygon(rng, convex=kind in (0, 2))
        q = _random_polygon(rng, convex=kind in (0, 1))
        if kind == 3:
            while not _star_about_centroid(q):
                q = _random_polygon(rng, convex=False)
        R = rotation(100 + k)
        o = np.array([10.0 * k, 0.0, 0.0])
        polys += [in_plane(p, R, o), in_plane(q, R, o)[::-1]]
        normals += [R[:, 2], -R[:, 2]]
        cells += [2 * k, 2 * k + 1]
        frames.append((R, o))
        inter = manifold3d.CrossSection([p]) ^ manifold3d.CrossSection([q])
        am = [_area_moment(c) for c in inter.to_polygons()]
        expect.append((sum(a for a, _ in am), sum((m for _, m in am), np.zeros(2))))
    ptr, xyz, nrm, cell = from_polygons(polys, normals, cells)
    part = np.arange(len(cell)) % 2
    ov = face_overlaps(ptr, xyz, nrm, cell, part, length_tol=TOL)
    check_structure(ov)
    assert np.all(ov.cells[:, 1] == ov.cells[:, 0] + 1) and np.all(ov.cells[:, 0] % 2 == 0)
    k_of = ov.cells[:, 0] // 2
    got_area = np.bincount(k_of, ov.area, minlength=120)
    for k, (R, o) in enumerate(frames):
        sel = k_of == k
        uv = (ov.centroid[sel] - o) @ R[:, :2]
        got_moment = (ov.area[sel, None] * uv).sum(axis=0)
        assert abs(got_area[k] - expect[k][0]) <= 1e-6, k
        np.testing.assert_allclose(got_moment, expect[k][1], rtol=0, atol=1e-6, err_msg=str(k))
        # on face 2k's plane, to rounding of coordinates up to |o| ~ 10³
        np.testing.assert_allclose((ov.vertex_xyz[np.repeat(sel, np.diff(ov.vertex_ptr))] - o) @ R[:, 2], 0.0,
                                   atol=1e-14 * (1 + np.abs(o).max()))
    assert np.count_nonzero(got_area > 0) > 60   # most pairs do overlap
