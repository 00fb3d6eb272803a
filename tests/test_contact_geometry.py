"""The overlap of two convex cells and of a cell and the ground
(physics/contact_geometry.py) against exact boxes and prisms, against
qhull's intersection of the half-spaces (scipy.spatial.HalfspaceIntersection)
for rotated cubes and random convex polyhedra, and S_B against the
gradient of V (moving B by u changes V by u·S_B).

Tolerances: 1e-12 for results of a few dozen flops on unit cells; 1e-9
(relative to V, to the unit cell size for the centroid) against qhull,
whose vertices carry its own round-off; finite differences of V with step
h = 1e-6 are good to O(h²) + O(1e-15/h), so 1e-7."""
import numpy as np
import pytest
from scipy.optimize import linprog
from scipy.spatial import ConvexHull, HalfspaceIntersection
from scipy.spatial.transform import Rotation

from rbsm_dyn.physics.contact_geometry import (SCRATCH_ROWS, overlap, overlap_halfspace,
                                               planes_from_loops)

I3 = np.eye(3)
CUBE = np.array([[i & 1, (i >> 1) & 1, (i >> 2) & 1] for i in range(8)], float)


def hull_loops(points):
    """The faces of the convex hull of points: coplanar hull triangles merged,
    each loop's vertex indices counter-clockwise seen from outside."""
    hull = ConvexHull(points)
    _, group = np.unique(np.round(hull.equations, 9), axis=0, return_inverse=True)
    group = group.ravel()
    loops = []
    for g in range(group.max() + 1):
        idx = np.unique(hull.simplices[group == g])
        n = hull.equations[group == g][0, :3]
        x = points[idx] - points[idx].mean(axis=0)
        u = x[0] / np.linalg.norm(x[0])
        v = np.cross(n, u)
        loops.append(idx[np.argsort(np.arctan2(x @ v, x @ u))])
    return loops


class Mesh:
    """Cells given by their points (each a convex hull); body frame: the
    points less their mean.  Arrays as the kernels take them."""

    def __init__(self, *point_sets):
        cfp, lp, xyz, self.origin = [0], [0], [], []
        for pts in point_sets:
            pts = np.asarray(pts, float)
            o = pts.mean(axis=0)
            self.origin.append(o)
            for loop in hull_loops(pts):
                xyz.extend(pts[loop] - o)
                lp.append(lp[-1] + len(loop))
            cfp.append(len(lp) - 1)
        self.cell_face_ptr = np.array(cfp, dtype=np.int64)
        self.loop_ptr = np.array(lp, dtype=np.int64)
        self.loop_xyz = np.array(xyz)
        self.face_plane = planes_from_loops(self.loop_ptr, self.loop_xyz)
        cell_rows = self.loop_ptr[self.cell_face_ptr]
        self.radius = np.maximum.reduceat(np.linalg.norm(self.loop_xyz, axis=1), cell_rows[:-1])
        rows = SCRATCH_ROWS(np.diff(cell_rows).max(), np.diff(self.cell_face_ptr).max())
        self.scratch = np.zeros((rows, 3))

    def args(self):
        return (self.cell_face_ptr, self.loop_ptr, self.loop_xyz, self.face_plane, self.radius,
                self.scratch)

    def overlap(self, a, pa, Ra, b, pb, Rb):
        return np.array(overlap(a, np.asarray(pa, float), Ra, b, np.asarray(pb, float), Rb,
                                *self.args()))

    def ground(self, a, pa, Ra, n, d):
        return np.array(overlap_halfspace(a, np.asarray(pa, float), Ra, np.asarray(n, float),
                                          float(d), *self.args()))

    def halfspaces(self, c, p, R):
        """(F, 4) rows [n, −d] of n·x ≤ d in the world (qhull's form)."""
        f = slice(self.cell_face_ptr[c], self.cell_face_ptr[c + 1])
        n = self.face_plane[f, :3] @ R.T
        return np.column_stack([n, -(self.face_plane[f, 3] + n @ p)])


def reference(halfspaces):
    """(V, centroid) of the intersection of half-spaces rows [n, −d] (unit
    n), by qhull; (0, None) if it is thinner than 1e-3."""
    A, b = halfspaces[:, :3], -halfspaces[:, 3]
    # Chebyshev centre: max t with n·x + t ≤ d
    res = linprog([0, 0, 0, -1], A_ub=np.column_stack([A, np.ones(len(A))]), b_ub=b,
                  bounds=[(None, None)] * 3 + [(None, 1.0)])
    if res.status != 0 or res.x[3] < 1e-3:
        return 0.0, None
    pts = HalfspaceIntersection(halfspaces, res.x[:3]).intersections
    hull = ConvexHull(pts)
    r = pts.mean(axis=0)
    t = pts[hull.simplices] - r
    vol = np.abs(np.einsum("ij,ij->i", t[:, 0], np.cross(t[:, 1], t[:, 2]))) / 6.0
    # tetrahedra (r, a, b, c): centroid (r + a + b + c)/4
    cen = r + (vol[:, None] * t.sum(axis=1) / 4.0).sum(axis=0) / vol.sum()
    return vol.sum(), cen


def random_pose(rng, spread):
    return rng.uniform(-spread, spread, 3), Rotation.random(random_state=rng).as_matrix()


def test_planes_from_loops_cube():
    m = Mesh(CUBE)
    nrm, d = m.face_plane[:, :3], m.face_plane[:, 3]
    # body frame: the cube centred at 0, so every face has d = 1/2
    assert len(nrm) == 6
    assert np.allclose(np.sort(nrm.ravel()), [-1] * 3 + [0] * 12 + [1] * 3, rtol=0, atol=1e-15)
    assert np.allclose(np.abs(nrm).sum(axis=1), 1.0, rtol=0, atol=1e-15)
    assert np.allclose(d, 0.5, rtol=0, atol=1e-15)
    for f in range(6):
        x = m.loop_xyz[m.loop_ptr[f]:m.loop_ptr[f + 1]]
        # outward: the face's mean lies along +n from the centre
        assert np.dot(x.mean(axis=0), nrm[f]) == pytest.approx(0.5, abs=1e-15)


def test_planes_from_loops_random_hulls():
    rng = np.random.default_rng(1)
    for _ in range(10):
        m = Mesh(rng.normal(size=(30, 3)))
        hull = ConvexHull(m.loop_xyz)
        # every vertex inside every face plane; each plane one of qhull's
        s = m.loop_xyz @ m.face_plane[:, :3].T - m.face_plane[:, 3]
        assert s.max() < 1e-12
        for p in m.face_plane:
            assert np.min(np.abs(hull.equations - np.r_[p[:3], -p[3]]).max(axis=1)) < 1e-12


def test_two_boxes():
    """Unit cubes, B shifted (0.7, 0.2, 0.1): P the box [0.7, 1]×[0.2, 1]×[0.1, 1];
    S_B the area vectors of B's −x, −y, −z faces inside A."""
    m = Mesh(CUBE, CUBE)
    pa, pb = m.origin[0], m.origin[1] + [0.7, 0.2, 0.1]
    out = m.overlap(0, pa, I3, 1, pb, I3)
    s = [-0.8 * 0.9, -0.3 * 0.9, -0.3 * 0.8]
    want = np.r_[0.3 * 0.8 * 0.9, 0.85, 0.6, 0.55, s, np.linalg.norm(s)]
    assert np.allclose(out, want, rtol=0, atol=1e-12)
    # the same under a rigid motion of both: V kept, c and S_B turned
    rng = np.random.default_rng(2)
    t, Q = random_pose(rng, 10.0)
    out = m.overlap(0, Q @ pa + t, Q, 1, Q @ pb + t, Q)
    assert out[0] == pytest.approx(want[0], abs=1e-12)
    assert np.allclose(out[1:4], Q @ want[1:4] + t, rtol=0, atol=1e-12)
    assert np.allclose(out[4:7], Q @ want[4:7], rtol=0, atol=1e-12)


def test_coplanar_faces():
    """A box of height 0.5 on the unit cube's bottom plane, shifted (0.7, 0.2):
    P = [0.7, 1]×[0.2, 1]×[0, 0.5]; the bottoms share a plane (half of that
    face's area vector −0.24 e_z to S_B), B's top lies inside A (+0.24 e_z):
    S_B = (−0.8·0.5, −0.3·0.5, 0.24 − 0.12); swapping the cells gives −S_B."""
    box = CUBE * [1.0, 1.0, 0.5]
    m = Mesh(CUBE, box)
    pa, pb = m.origin[0], m.origin[1] + [0.7, 0.2, 0.0]
    want = np.r_[0.3 * 0.8 * 0.5, 0.85, 0.6, 0.25, -0.4, -0.15, 0.12]
    rng = np.random.default_rng(3)
    for k in range(20):
        t, Q = (np.zeros(3), I3) if k == 0 else random_pose(rng, 10.0)
        ab = m.overlap(0, Q @ pa + t, Q, 1, Q @ pb + t, Q)
        ba = m.overlap(1, Q @ pb + t, Q, 0, Q @ pa + t, Q)
        for out, sign in ((ab, 1.0), (ba, -1.0)):
            assert out[0] == pytest.approx(want[0], abs=1e-12)
            assert np.allclose(out[1:4], Q @ want[1:4] + t, rtol=0, atol=1e-12)
            assert np.allclose(out[4:7], sign * Q @ want[4:7], rtol=0, atol=1e-12)
            assert out[7] == pytest.approx(np.linalg.norm(want[4:7]), abs=1e-12)
    # both cells the unit cube side by side, shifted 0.7 along x: the shared
    # top, bottom and sides cancel in pairs, S_B = −e_x × 1
    m = Mesh(CUBE, CUBE)
    out = m.overlap(0, m.origin[0], I3, 1, m.origin[1] + [0.7, 0, 0], I3)
    assert np.allclose(out, [0.3, 0.85, 0.5, 0.5, -1, 0, 0, 1], rtol=0, atol=1e-12)


def test_apart_and_touching():
    m = Mesh(CUBE, CUBE)
    pa = m.origin[0]
    for shift in ([1.5, 0, 0], [1.0 + 1e-9, 0.3, 0.2], [0.5, 1.2, 0.1]):
        assert np.all(m.overlap(0, pa, I3, 1, pa + shift, I3) == 0.0)
    rng = np.random.default_rng(4)
    for k in range(20):
        t, Q = (np.zeros(3), I3) if k == 0 else random_pose(rng, 10.0)
        shift = [[1.0, 0.3, 0.2], [0.2, -1.0, 0.6], [0.0, 0.0, 1.0]][k % 3]
        out = m.overlap(0, Q @ pa + t, Q, 1, Q @ (pa + shift) + t, Q)
        assert np.all(np.isfinite(out)) and abs(out[0]) <= 1e-12
    # edge against edge: A turned 45° about y (a top edge along y), B 45°
    # about x (a bottom edge along x) above it; no face normal separates them
    Ra = Rotation.from_euler("y", 45, degrees=True).as_matrix()
    Rb = Rotation.from_euler("x", 45, degrees=True).as_matrix()
    for gap in (0.01, 1e-6):
        pb = [0, 0, np.sqrt(2) + gap]
        assert np.all(m.overlap(0, np.zeros(3), Ra, 1, pb, Rb) == 0.0)
    # and into each other by 0.05: qhull's V and centroid
    pb = np.array([0, 0, np.sqrt(2) - 0.05])
    out = m.overlap(0, np.zeros(3), Ra, 1, pb, Rb)
    vol, cen = reference(np.vstack([m.halfspaces(0, np.zeros(3), Ra), m.halfspaces(1, pb, Rb)]))
    assert out[0] == pytest.approx(vol, rel=1e-9)
    assert np.allclose(out[1:4], cen, rtol=0, atol=1e-9)


def _compare(m, rng, n_cases, spread, a=0, b=1):
    """Random poses of cells a and b: V and centroid against qhull, the
    swapped call's S = −S_B; returns the number of overlapping cases."""
    hit = 0
    for _ in range(n_cases):
        pa, Ra = random_pose(rng, spread)
        pb, Rb = random_pose(rng, spread)
        pa += 50.0                          # away from the world origin
        pb += 50.0
        out = m.overlap(a, pa, Ra, b, pb, Rb)
        vol, cen = reference(np.vstack([m.halfspaces(a, pa, Ra), m.halfspaces(b, pb, Rb)]))
        if cen is None:
            # apart, or thinner than 1e-3: V below the thickness × the area
            assert 0.0 <= out[0] < 1e-2 and np.all(np.isfinite(out))
            continue
        hit += 1
        assert out[0] == pytest.approx(vol, rel=1e-9)
        assert np.allclose(out[1:4], cen, rtol=0, atol=1e-9)
        assert out[7] == pytest.approx(np.linalg.norm(out[4:7]), rel=1e-14)
        swap = m.overlap(b, pb, Rb, a, pa, Ra)
        assert np.allclose(swap[:4], out[:4], rtol=0, atol=1e-12)
        assert np.allclose(swap[4:7], -out[4:7], rtol=0, atol=1e-12)
    return hit


def test_rotated_cubes_against_qhull():
    m = Mesh(CUBE, CUBE)
    assert _compare(m, np.random.default_rng(5), 200, 0.6) > 150


def test_random_polyhedra_against_qhull():
    rng = np.random.default_rng(6)
    hit = 0
    for _ in range(20):
        m = Mesh(rng.normal(size=(30, 3)), rng.normal(size=(12, 3)) * [1.5, 1.0, 0.5])
        hit += _compare(m, rng, 10, 1.5)
    assert hit > 120


def test_s_b_is_the_gradient_of_v():
    """dV/dp_B = S_B, by central differences of V (step 1e-6)."""
    rng = np.random.default_rng(7)
    m = Mesh(CUBE, rng.normal(size=(30, 3)))
    h = 1e-6
    n = 0
    while n < 20:
        pa, Ra = random_pose(rng, 0.5)
        pb, Rb = random_pose(rng, 0.5)
        out = m.overlap(0, pa, Ra, 1, pb, Rb)
        if out[0] < 1e-3:
            continue
        n += 1
        grad = [(m.overlap(0, pa, Ra, 1, pb + h * e, Rb)[0]
                 - m.overlap(0, pa, Ra, 1, pb - h * e, Rb)[0]) / (2 * h) for e in I3]
        assert np.allclose(out[4:7], grad, rtol=0, atol=1e-7)


def test_ground_box():
    """Unit cube, bottom at z = −h on the ground z ≤ 0: V = h, centroid
    z = −h/2, S_B = e_z; whole below: V = 1, S_B = 0; resting or above: 0."""
    m = Mesh(CUBE)
    nz = np.array([0.0, 0.0, 1.0])
    for h in (0.01, 0.3, 0.99):
        out = m.ground(0, [0.3, -0.2, 0.5 - h], I3, nz, 0.0)
        assert np.allclose(out, [h, 0.3, -0.2, -h / 2, 0, 0, 1, 1], rtol=0, atol=1e-12)
    out = m.ground(0, [0.3, -0.2, 0.5 - 1.5], I3, nz, 0.0)
    assert np.allclose(out, [1, 0.3, -0.2, -1.0, 0, 0, 0, 0], rtol=0, atol=1e-12)
    for z in (0.5, 0.7, 3.0):
        assert np.all(m.ground(0, [0.3, -0.2, z], I3, nz, 0.0) == 0.0)
    # the top face in the ground plane, the cube below it: that face's area
    # vector e_z shared half and half
    out = m.ground(0, [0.3, -0.2, -0.5], I3, nz, 0.0)
    assert np.allclose(out, [1, 0.3, -0.2, -0.5, 0, 0, 0.5, 0.5], rtol=0, atol=1e-12)


def test_ground_edge_down():
    """Unit cube turned 45° about x, its bottom edge at depth h: the
    triangular prism of cross-section base 2h, height h: V = h² × 1,
    centroid z = −h/3, S_B = e_z × 2h (the 2h × 1 section)."""
    m = Mesh(CUBE)
    R = Rotation.from_euler("x", 45, degrees=True).as_matrix()
    for h in (0.01, 0.2, 0.5):
        out = m.ground(0, [0.1, 0.2, np.sqrt(0.5) - h], R, [0, 0, 1], 0.0)
        assert np.allclose(out, [h * h, 0.1, 0.2, -h / 3, 0, 0, 2 * h, 2 * h],
                           rtol=0, atol=1e-12)


def test_ground_tilted_against_qhull():
    """Random cells and ground planes: V, centroid against qhull, and
    |S_B| = dV/dd (raising the plane by δ adds the section × δ)."""
    rng = np.random.default_rng(8)
    m = Mesh(CUBE, rng.normal(size=(30, 3)))
    hit = 0
    for k in range(100):
        c = k % 2
        p, R = random_pose(rng, 5.0)
        n = rng.normal(size=3)
        n /= np.linalg.norm(n)
        d = n @ p + rng.uniform(-1.0, 1.0) * m.radius[c]
        out = m.ground(c, p, R, n, d)
        vol, cen = reference(np.vstack([m.halfspaces(c, p, R), np.r_[n, -d]]))
        if cen is None:
            assert 0.0 <= out[0] < 1e-2 and np.all(np.isfinite(out))
            continue
        hit += 1
        assert out[0] == pytest.approx(vol, rel=1e-9)
        assert np.allclose(out[1:4], cen, rtol=0, atol=1e-9)
        assert np.allclose(out[4:7], out[7] * n, rtol=0, atol=1e-12)
        h = 1e-6
        dvdd = (m.ground(c, p, R, n, d + h)[0] - m.ground(c, p, R, n, d - h)[0]) / (2 * h)
        assert out[7] == pytest.approx(dvdd, abs=1e-7)
    assert hit > 60


def test_scratch_too_small():
    m = Mesh(CUBE, CUBE)
    m.scratch = np.zeros((10, 3))
    with pytest.raises(ValueError):
        m.overlap(0, np.zeros(3), I3, 1, np.full(3, 0.5), I3)
