"""rbsm_dyn.mesh: polyhedron mass properties, Voronoi / block meshes, spring points.

Every check is a geometric fact with a tolerance set by round-off:
~1e-12 relative for closed-form quantities computed in a few dozen float
operations, 1e-10 relative for sums over a whole mesh.
"""
import numpy as np
import pytest
from scipy.spatial import ConvexHull, cKDTree
from scipy.spatial.transform import Rotation

from rbsm_dyn.mesh import (
    Mesh,
    block_mesh,
    mass_properties,
    principal_axes,
    spring_points,
    voronoi_mesh,
    voronoi_seeds,
)

RTOL = 1e-12


def rel(a, b):
    """Max abs difference relative to the magnitude of b."""
    a, b = np.asarray(a, float), np.asarray(b, float)
    assert a.shape == b.shape
    if a.size == 0:
        return 0.0
    return np.max(np.abs(a - b)) / max(np.max(np.abs(b)), 1e-300)


# --------------------------------------------------------------------------
# polyhedron mass properties
# --------------------------------------------------------------------------

CUBE = np.array([[x, y, z] for x in (0, 1) for y in (0, 1) for z in (0, 1)], float)
# the six quads of CUBE (some deliberately clockwise: mass_properties orients)
CUBE_FACES = [[0, 1, 3, 2], [4, 6, 7, 5], [0, 4, 5, 1], [2, 3, 7, 6], [0, 2, 6, 4], [1, 5, 7, 3]]


def divergence_reference(points):
    """Independent exact mass properties of the convex hull of points, by the
    divergence theorem over the hull triangles (no interior point, no
    tetrahedra): div(x) = 3, div(x_i x) = 4 x_i, div(x_i x_j x) = 5 x_i x_j,
    and x·n = d is constant on a planar face, so
      V = Σ d A / 3,  ∫x dV = Σ d ∫x dA / 4,  ∫x xᵀ dV = Σ d ∫x xᵀ dA / 5,
    with the exact triangle moments ∫x dA = A s/3, ∫x xᵀ dA = A/12 (Σ v vᵀ + s sᵀ)."""
    hull = ConvexHull(points)
    V = 0.0
    first = np.zeros(3)
    second = np.zeros((3, 3))
    for simplex, eq in zip(hull.simplices, hull.equations):
        v = hull.points[simplex]
        n = eq[:3]
        area = 0.5 * abs(np.dot(np.cross(v[1] - v[0], v[2] - v[0]), n))
        d = np.dot(n, v[0])
        s = v.sum(axis=0)
        V += d * area / 3.0
        first += d * area * s / 3.0 / 4.0
        second += d * area / 12.0 * (v.T @ v + np.outer(s, s)) / 5.0
    g = first / V
    CG = second - V * np.outer(g, g)
    return V, g, np.trace(CG) * np.eye(3) - CG


def test_unit_cube_hull_and_polygons():
    for args in ((CUBE,), (CUBE, CUBE_FACES), (ConvexHull(CUBE),)):
        V, c, I = mass_properties(*args)
        assert abs(V - 1.0) < RTOL
        assert rel(c, [0.5, 0.5, 0.5]) < RTOL
        assert rel(I, np.eye(3) / 6.0) < RTOL


def test_tetrahedra_closed_form():
    # unit right tetrahedron: ∫x^a y^b z^c = a! b! c! / (a+b+c+3)!
    tet = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1]], float)
    V, c, I = mass_properties(tet)
    g = np.full(3, 0.25)
    cov = np.full((3, 3), 1 / 120.0) + np.eye(3) / 120.0 - V * np.outer(g, g)  # ∫x²=1/60, ∫xy=1/120
    assert abs(V - 1 / 6) < RTOL / 6
    assert rel(c, g) < RTOL
    assert rel(I, np.trace(cov) * np.eye(3) - cov) < RTOL
    assert rel(I, [[1 / 80, 1 / 480, 1 / 480], [1 / 480, 1 / 80, 1 / 480], [1 / 480, 1 / 480, 1 / 80]]) < RTOL
    # regular tetrahedron of edge a: V = a³/(6√2), isotropic I = V a²/20 about the centroid
    a = 0.7
    reg = a / np.sqrt(8.0) * np.array([[1, 1, 1], [1, -1, -1], [-1, 1, -1], [-1, -1, 1]], float)
    reg = reg @ Rotation.from_rotvec([0.3, -1.1, 0.4]).as_matrix().T + [2.0, -1.0, 0.5]
    V, c, I = mass_properties(reg, [[0, 1, 2], [0, 3, 1], [0, 2, 3], [1, 3, 2]])
    assert abs(V - a**3 / (6 * np.sqrt(2))) < RTOL * V
    assert rel(c, reg.mean(axis=0)) < RTOL
    assert rel(I, V * a * a / 20.0 * np.eye(3)) < RTOL


def test_rotated_translated_box():
    rng = np.random.default_rng(1)
    dims = np.array([0.3, 1.7, 0.9])
    R = Rotation.random(random_state=rng).as_matrix()
    t = np.array([12.0, -7.0, 3.0])
    pts = ((CUBE - 0.5) * dims) @ R.T + t
    V, c, I = mass_properties(pts)
    a, b, cc = dims
    I0 = V / 12.0 * np.diag([b * b + cc * cc, a * a + cc * cc, a * a + b * b])
    assert abs(V - dims.prod()) < RTOL * V
    assert rel(c, t) < RTOL
    assert rel(I, R @ I0 @ R.T) < RTOL
    moments, Ra = principal_axes(I)
    assert rel(moments, np.sort(np.diag(I0))) < RTOL
    assert abs(np.linalg.det(Ra) - 1.0) < 1e-14
    assert rel(Ra.T @ Ra, np.eye(3)) < 1e-14
    assert rel(Ra @ np.diag(moments) @ Ra.T, I) < RTOL
    # principal axes are the box axes (up to sign)
    order = np.argsort(np.diag(I0))
    assert rel(np.abs(Ra.T @ R[:, order]), np.eye(3)) < 1e-10


@pytest.mark.parametrize("kind", ["cube", "sphere", "flat"])
def test_random_convex_hulls_against_divergence_theorem(kind):
    rng = np.random.default_rng({"cube": 2, "sphere": 3, "flat": 4}[kind])
    for _ in range(10):
        if kind == "cube":
            pts = rng.uniform(-1, 1, (rng.integers(8, 60), 3))
        elif kind == "sphere":
            pts = rng.normal(size=(rng.integers(8, 200), 3))
            pts /= np.linalg.norm(pts, axis=1)[:, None]
        else:
            pts = rng.uniform(-1, 1, (30, 3)) * [1.0, 0.5, 0.05]
        pts = pts + rng.uniform(-3, 3, 3)
        V, c, I = mass_properties(pts)
        Vr, cr, Ir = divergence_reference(pts)
        assert abs(V - ConvexHull(pts).volume) < RTOL * V
        assert abs(V - Vr) < RTOL * V
        assert rel(c, cr) < RTOL * max(1.0, np.abs(cr).max())
        assert rel(I, Ir) < 1e-11  # the reference itself works about the origin
        assert rel(I, I.T) == 0.0


def test_principal_axes_stack_and_sorting():
    rng = np.random.default_rng(5)
    Rs = Rotation.random(20, random_state=rng).as_matrix()
    m = rng.uniform(0.1, 2.0, (20, 3))
    I = np.einsum("nij,nj,nkj->nik", Rs, m, Rs)
    w, R = principal_axes(I)
    assert np.all(np.diff(w, axis=1) >= 0)
    assert rel(w, np.sort(m, axis=1)) < 1e-12
    assert np.allclose(np.linalg.det(R), 1.0, atol=1e-14)
    assert rel(np.einsum("nij,nj,nkj->nik", R, w, R), I) < 1e-12


# --------------------------------------------------------------------------
# meshes: generic checks
# --------------------------------------------------------------------------


def polygon_area_vectors(ptr, xyz):
    """Newell area vector of each polygon (independent of the mesh code)."""
    out = np.zeros((len(ptr) - 1, 3))
    for p in range(len(ptr) - 1):
        v = xyz[ptr[p]:ptr[p + 1]]
        out[p] = 0.5 * np.cross(v, np.roll(v, -1, axis=0)).sum(axis=0)
    return out


def check_mesh(m: Mesh):
    box = m.box
    lo, hi = box
    size = np.prod(hi - lo) ** (1 / 3)
    N, F, B = m.n_cells, len(m.face_cells), len(m.bface_cell)
    for name in ("cell_vertex_ptr", "poly_ptr", "poly_vertex", "cell_poly_ptr", "face_cells",
                 "face_vertex_ptr", "bface_cell", "bface_side", "bface_vertex_ptr"):
        assert getattr(m, name).dtype == np.int64, name
    # cells tile the box
    assert abs(m.cell_volume.sum() - np.prod(hi - lo)) < 1e-10 * np.prod(hi - lo)
    assert np.all(m.cell_volume > 0)
    assert np.all((m.cell_centroid > lo) & (m.cell_centroid < hi))
    assert np.all((m.vertices >= lo) & (m.vertices <= hi))
    assert np.all(np.linalg.eigvalsh(m.cell_inertia) > 0)
    # drawing geometry: each cell's polygons use its own vertex rows and close
    pcell = np.repeat(np.arange(N), np.diff(m.cell_poly_ptr))
    vcell = np.repeat(pcell, np.diff(m.poly_ptr))
    assert np.all(m.poly_vertex >= m.cell_vertex_ptr[vcell])
    assert np.all(m.poly_vertex < m.cell_vertex_ptr[vcell + 1])
    pav = polygon_area_vectors(m.poly_ptr, m.vertices[m.poly_vertex])
    closure = np.zeros((N, 3))
    np.add.at(closure, pcell, pav)
    assert np.abs(closure).max() < 1e-12 * size**2
    assert len(pav) == 2 * F + B
    # the volume from the drawing polygons by the divergence theorem (centroid as origin)
    pc = np.zeros((len(pav), 3))
    cnt = np.diff(m.poly_ptr)
    np.add.at(pc, np.repeat(np.arange(len(pav)), cnt), m.vertices[m.poly_vertex])
    pc /= cnt[:, None]
    vol = np.zeros(N)
    np.add.at(vol, pcell, np.einsum("ij,ij->i", pav, pc - m.cell_centroid[pcell]) / 3.0)
    assert rel(vol, m.cell_volume) < 1e-10
    # internal faces: a < b, unique, unit normal a -> b, polygon counter-clockwise about it
    a, b = m.face_cells.T
    if F == 0:
        assert N == 1
    else:
        check_internal_faces(m, pcell, pc, pav, size)
    # boundary faces: on their side plane, outward, areas sum to the side areas
    assert np.all((m.bface_side >= 0) & (m.bface_side < 6))
    axis, upper = m.bface_side // 2, m.bface_side % 2
    expect = np.zeros((B, 3))
    expect[np.arange(B), axis] = np.where(upper == 1, 1.0, -1.0)
    assert np.array_equal(m.bface_normal, expect)
    bav = polygon_area_vectors(m.bface_vertex_ptr, m.bface_vertex_xyz)
    assert rel(bav, m.bface_area[:, None] * m.bface_normal) < 1e-10
    vside = np.repeat(m.bface_side, np.diff(m.bface_vertex_ptr))
    assert np.all(m.bface_vertex_xyz[np.arange(len(vside)), vside // 2] == box[vside % 2, vside // 2])
    ext = hi - lo
    side_area = np.array([ext[1] * ext[2]] * 2 + [ext[0] * ext[2]] * 2 + [ext[0] * ext[1]] * 2)
    assert rel(np.bincount(m.bface_side, m.bface_area, minlength=6), side_area) < 1e-10
    check_convex_planar(m.bface_vertex_ptr, m.bface_vertex_xyz, m.bface_normal, m.bface_centroid, size)
    # sorting contracts
    assert np.all(np.diff(a * N + b) > 0)
    assert np.all(np.diff(m.bface_side * N + m.bface_cell) > 0)


def check_internal_faces(m, pcell, pc, pav, size):
    N, F = m.n_cells, len(m.face_cells)
    a, b = m.face_cells.T
    assert np.all(a < b)
    assert len(np.unique(a * N + b)) == F
    assert np.allclose(np.linalg.norm(m.face_normal, axis=1), 1.0, atol=1e-14)
    assert np.all(np.einsum("ij,ij->i", m.cell_centroid[b] - m.cell_centroid[a], m.face_normal) > 0)
    fav = polygon_area_vectors(m.face_vertex_ptr, m.face_vertex_xyz)
    assert rel(fav, m.face_area[:, None] * m.face_normal) < 1e-10
    assert np.all(m.face_area > 0)
    check_convex_planar(m.face_vertex_ptr, m.face_vertex_xyz, m.face_normal, m.face_centroid, size)
    # each internal face is a polygon of cell a (normal +n) and of cell b (normal -n)
    tree = cKDTree(pc)
    fcen_v = np.zeros((F, 3))
    np.add.at(fcen_v, np.repeat(np.arange(F), np.diff(m.face_vertex_ptr)), m.face_vertex_xyz)
    fcen_v /= np.diff(m.face_vertex_ptr)[:, None]
    d, j = tree.query(fcen_v, k=2)
    assert d.max() < 1e-12 * size
    cells_found = np.sort(pcell[j], axis=1)
    assert np.array_equal(cells_found, m.face_cells)
    ja = np.where(pcell[j[:, 0]] == a, j[:, 0], j[:, 1])
    jb = np.where(pcell[j[:, 0]] == a, j[:, 1], j[:, 0])
    assert rel(pav[ja], fav) < 1e-12 and rel(pav[jb], -fav) < 1e-12
    assert rel(np.linalg.norm(pav[ja], axis=1), m.face_area) < 1e-12


def check_convex_planar(ptr, xyz, normal, centroid, size):
    f = np.repeat(np.arange(len(ptr) - 1), np.diff(ptr))
    # planar: every vertex in the plane through the area centroid
    off = np.einsum("ij,ij->i", xyz - centroid[f], normal[f])
    assert np.abs(off).max() < 1e-9 * size
    # convex and counter-clockwise: consecutive edges turn left about n
    nxt = np.arange(len(f)) + 1
    nxt[ptr[1:] - 1] = ptr[:-1]
    nn = nxt[nxt]
    turn = np.einsum("ij,ij->i", np.cross(xyz[nxt] - xyz, xyz[nn] - xyz[nxt]), normal[f])
    assert turn.min() > -1e-12 * size**2


# --------------------------------------------------------------------------
# block meshes
# --------------------------------------------------------------------------


@pytest.mark.parametrize("div", [(3, 4, 5), (1, 1, 1), (7, 1, 2)])
def test_block_mesh(div):
    box = np.array([[-0.5, 0.2, 1.0], [1.5, 0.8, 2.5]])
    m = block_mesh(box, div)
    check_mesh(m)
    nx, ny, nz = div
    assert m.n_cells == nx * ny * nz
    assert len(m.face_cells) == (nx - 1) * ny * nz + nx * (ny - 1) * nz + nx * ny * (nz - 1)
    assert len(m.bface_cell) == 2 * (ny * nz + nx * nz + nx * ny)
    h = (box[1] - box[0]) / div
    V = h.prod()
    assert rel(m.cell_volume, np.full(m.n_cells, V)) < RTOL
    I0 = V / 12.0 * np.diag([h[1] ** 2 + h[2] ** 2, h[0] ** 2 + h[2] ** 2, h[0] ** 2 + h[1] ** 2])
    assert rel(m.cell_inertia, np.broadcast_to(I0, m.cell_inertia.shape)) < RTOL
    # cell (i, j, k) -> (i * ny + j) * nz + k, centroid at the block centre
    i, j, k = np.unravel_index(np.arange(m.n_cells), div)
    assert rel(m.cell_centroid, box[0] + (np.stack([i, j, k], 1) + 0.5) * h) < RTOL
    # internal faces join face-neighbours only: centroid distance = one block
    dc = m.cell_centroid[m.face_cells[:, 1]] - m.cell_centroid[m.face_cells[:, 0]]
    assert rel(np.abs(dc).sum(axis=1), h @ np.abs(m.face_normal).T) < RTOL
    assert rel(np.einsum("ij,ij->i", dc, m.face_normal), np.linalg.norm(dc, axis=1)) < RTOL


def test_block_mesh_rejects_bad_input():
    with pytest.raises(ValueError):
        block_mesh([[0, 0, 0], [1, 1, 1]], (2, 0, 1))
    with pytest.raises(ValueError):
        block_mesh([[0, 0, 0], [1, -1, 1]], (2, 2, 2))


# --------------------------------------------------------------------------
# Voronoi meshes
# --------------------------------------------------------------------------

VORONOI_CASES = {
    "cube": ([[0, 0, 0], [1, 1, 1]], 0.1, 0),
    "beam": ([[0, 0, 0], [1.0, 0.1, 0.1]], 0.02, 3),
    "slab1": ([[0, 0, 0], [1.0, 1.0, 0.05]], 0.05, 1),   # one cell thick
    "slab2": ([[0, -1, 2], [0.6, 0.0, 2.12]], 0.06, 2),  # two cells thick, off the origin
    "rod": ([[0, 0, 0], [1.0, 0.1, 0.1]], 0.1, 4),       # 10 cells, each filling the section
}


@pytest.fixture(scope="module", params=list(VORONOI_CASES))
def voronoi_case(request):
    box, size, seed = VORONOI_CASES[request.param]
    return np.array(box, float), size, seed, voronoi_mesh(box, size, seed=seed)


def test_voronoi_tiles_box(voronoi_case):
    box, size, seed, m = voronoi_case
    check_mesh(m)
    assert m.n_cells == max(1, round(np.prod(box[1] - box[0]) / size**3))


def test_voronoi_cells_are_voronoi_cells(voronoi_case):
    """Face = perpendicular bisector of the two seeds; each seed inside its cell."""
    box, size, seed, m = voronoi_case
    s = voronoi_seeds(box, size, seed)
    a, b = m.face_cells.T
    d = s[b] - s[a]
    assert rel(m.face_normal, d / np.linalg.norm(d, axis=1)[:, None]) < 1e-12
    off = np.einsum("ij,ij->i", m.face_centroid - 0.5 * (s[a] + s[b]), m.face_normal)
    assert np.abs(off).max() < 1e-10 * size
    # each seed is on the inner side of every polygon of its cell
    N = m.n_cells
    pcell = np.repeat(np.arange(N), np.diff(m.cell_poly_ptr))
    pav = polygon_area_vectors(m.poly_ptr, m.vertices[m.poly_vertex])
    p0 = m.vertices[m.poly_vertex[m.poly_ptr[:-1]]]
    assert np.all(np.einsum("ij,ij->i", pav, s[pcell] - p0) < 0)
    # every cell has a neighbour
    assert len(np.unique(m.face_cells.ravel())) == N or N == 1


def test_voronoi_seeds_spacing_and_reproducibility():
    box = np.array([[0, 0, 0], [1.0, 0.5, 0.3]])
    size = 0.04
    for ms in (0.5, 0.7):
        s = voronoi_seeds(box, size, seed=11, min_spacing=ms)
        assert len(s) == round(0.15 / size**3)
        assert np.all((s > box[0]) & (s < box[1]))
        d, _ = cKDTree(s).query(s, k=2)
        assert d[:, 1].min() >= ms * size
    s1 = voronoi_seeds(box, size, seed=11)
    assert np.array_equal(s1, voronoi_seeds(box, size, seed=11))
    assert not np.array_equal(s1, voronoi_seeds(box, size, seed=12))
    # uniform density: each half of the box holds half the seeds (binomial 5 sigma)
    n = len(s1)
    assert abs((s1[:, 0] < 0.5).sum() - n / 2) < 5 * np.sqrt(n / 4)


@pytest.mark.parametrize("hi, n, r", [((8.0, 8.0, 8.0), 20000, 0.5), ((10.0, 3.0, 0.0), 3000, 0.3),
                                      ((5.0, 5.0, 5.0), 200, 2.0), ((50.0, 1.0, 20.0), 20000, 0.4)])
def test_the_later_of_each_close_pair_is_dropped_as_query_pairs_finds_it(hi, n, r):
    """voronoi_seeds' spacing (mesh/voronoi.py _first_of_close): a candidate
    is dropped when an earlier one lies within r (distance ≤ r), whether
    or not that one is kept: the set cKDTree.query_pairs(r) gives, so the
    seeds of a case are those it gave (a cube, a flat box as a plane
    model's, few points in large bins, a slab one bin thick)."""
    from rbsm_dyn.mesh.voronoi import _first_of_close
    lo, hi = np.zeros(3), np.array(hi)
    c = np.random.default_rng(5).uniform(lo, hi, size=(n, 3))
    keep = np.ones(n, dtype=bool)
    pairs = cKDTree(c).query_pairs(r, output_type="ndarray")
    keep[pairs.max(axis=1)] = False
    got = _first_of_close(c, r, lo, hi)
    assert 0 < (~keep).sum() < n and np.array_equal(got, keep)


def test_voronoi_mesh_reproducible():
    box, size = [[0, 0, 0], [0.5, 0.4, 0.3]], 0.05
    m1, m2, m3 = (voronoi_mesh(box, size, seed=s) for s in (5, 5, 6))
    for name in Mesh.__dataclass_fields__:
        assert np.array_equal(getattr(m1, name), getattr(m2, name)), name
    assert not np.array_equal(m1.cell_centroid, m3.cell_centroid)


def test_voronoi_fewer_mirrors_same_cells(monkeypatch):
    """Mirroring only the seeds near each side (and retrying with all mirrors when a
    cell is left open) gives the same cells as mirroring every seed."""
    import rbsm_dyn.mesh.voronoi as vm

    box, size = [[0, 0, 0], [0.5, 0.3, 0.2]], 0.05
    ref = voronoi_mesh(box, size, seed=3)
    for reach in (0.3, np.inf):  # 0.3: some cells open -> retry; inf: all mirrors at once
        monkeypatch.setattr(vm, "_REACH", reach)
        m = voronoi_mesh(box, size, seed=3)
        assert np.array_equal(m.face_cells, ref.face_cells)
        assert np.array_equal(m.bface_cell, ref.bface_cell)
        assert rel(m.cell_volume, ref.cell_volume) < 1e-12
        assert rel(m.cell_inertia, ref.cell_inertia) < 1e-12
        assert rel(m.face_area, ref.face_area) < 1e-12
        assert rel(m.bface_area, ref.bface_area) < 1e-12


def test_voronoi_lattice_seeds_give_blocks():
    """A lattice of seeds (maximally degenerate for Qhull) must give the block mesh."""
    box = np.array([[0, 0, 0], [2.0, 1.0, 1.5]])
    div = (4, 2, 3)
    h = (box[1] - box[0]) / div
    g = np.stack(np.meshgrid(*[box[0, a] + h[a] * (np.arange(div[a]) + 0.5) for a in range(3)],
                             indexing="ij"), -1).reshape(-1, 3)
    m = voronoi_mesh(box, 0.5, seeds=g)
    bm = block_mesh(box, div)
    check_mesh(m)
    assert np.array_equal(m.face_cells, bm.face_cells)
    assert np.array_equal(m.bface_cell, bm.bface_cell) and np.array_equal(m.bface_side, bm.bface_side)
    assert rel(m.cell_volume, bm.cell_volume) < RTOL
    assert rel(m.cell_inertia, bm.cell_inertia) < RTOL
    assert rel(m.face_area, bm.face_area) < RTOL
    assert rel(m.face_centroid, bm.face_centroid) < RTOL


# --------------------------------------------------------------------------
# spring points
# --------------------------------------------------------------------------


def plane_basis(n):
    n = n / np.linalg.norm(n)
    e1 = np.cross(n, [0.3, 0.5, 0.8])
    e1 /= np.linalg.norm(e1)
    return e1, np.cross(n, e1), n


def embed(poly2d, n, origin):
    e1, e2, n = plane_basis(np.asarray(n, float))
    return origin + poly2d[:, :1] * e1 + poly2d[:, 1:] * e2, (e1, e2, n)


def green_moments(p):
    """Exact area, centroid and central second moments of a CCW 2-D polygon
    (Green's theorem; computed about the vertex mean, then shifted)."""
    q = p - p.mean(axis=0)
    x, y = q[:, 0], q[:, 1]
    x1, y1 = np.roll(x, -1), np.roll(y, -1)
    cr = x * y1 - x1 * y
    A = cr.sum() / 2
    cx = ((x + x1) * cr).sum() / (6 * A)
    cy = ((y + y1) * cr).sum() / (6 * A)
    Iyy = ((x * x + x * x1 + x1 * x1) * cr).sum() / 12  # ∫x² dA
    Ixx = ((y * y + y * y1 + y1 * y1) * cr).sum() / 12  # ∫y² dA
    Ixy = ((x * y1 + 2 * x * y + 2 * x1 * y1 + x1 * y) * cr).sum() / 24
    J = np.array([[Iyy - A * cx * cx, Ixy - A * cx * cy], [Ixy - A * cx * cy, Ixx - A * cy * cy]])
    return A, p.mean(axis=0) + [cx, cy], J


def random_convex_polygon(rng):
    k = rng.integers(3, 12)
    t = np.sort(rng.uniform(0, 2 * np.pi, k))
    ax = rng.uniform(0.2, 2.0, 2)
    p = np.stack([ax[0] * np.cos(t), ax[1] * np.sin(t)], 1)
    c, s = np.cos(rng.uniform(0, np.pi)), np.sin(rng.uniform(0, np.pi))
    return p @ np.array([[c, -s], [s, c]]).T + rng.uniform(-1, 1, 2)


def face_set(polys2d, rng):
    """Embed 2-D polygons in random planes; returns ptr, xyz, normal, bases, exact (A, c3, J3)."""
    ptr, xyz, normal, exact = [0], [], [], []
    for p in polys2d:
        n = rng.normal(size=3)
        origin = rng.uniform(-5, 5, 3)
        v, (e1, e2, n) = embed(p, n, origin)
        A, c2, J = green_moments(p)
        E = np.stack([e1, e2], 1)
        exact.append((A, origin + E @ c2, E @ J @ E.T))
        ptr.append(ptr[-1] + len(p))
        xyz.append(v)
        normal.append(n)
    return np.array(ptr), np.vstack(xyz), np.array(normal), exact


def check_rule(ptr, xyz, normal, exact, rule, exact_second):
    sp = spring_points(ptr, xyz, normal, rule)
    F = len(ptr) - 1
    assert sp.face.dtype == np.int64
    assert np.all(np.diff(sp.face) >= 0)
    assert len(sp.point) == (3 if rule == "three" else 1) * len(xyz)
    W = np.bincount(sp.face, sp.weight, minlength=F)
    for f, (A, c, J) in enumerate(exact):
        sel = sp.face == f
        w, p = sp.weight[sel], sp.point[sel]
        L = np.sqrt(A)
        assert abs(W[f] - A) < RTOL * A
        assert np.all(w > 0)
        d = p - c
        assert np.abs(d @ normal[f]).max() < 1e-12 * max(L, np.abs(c).max())  # in the plane
        assert np.abs(w @ d).max() < 1e-12 * A * max(L, np.abs(c).max())      # first moment exact
        M = (w[:, None] * d).T @ d
        if exact_second:
            assert rel(M, J) < 1e-10
    return sp


def test_spring_points_rectangle_centroid_rule_is_a_third_short():
    b, h = 0.7, 0.3
    rect = np.array([[-b / 2, -h / 2], [b / 2, -h / 2], [b / 2, h / 2], [-b / 2, h / 2]])
    rng = np.random.default_rng(7)
    ptr, xyz, normal, exact = face_set([rect], rng)
    A, c, J = exact[0]
    e1, e2, _ = plane_basis(normal[0])
    assert abs(e2 @ J @ e2 - b * h**3 / 12) < RTOL * b * h**3 / 12
    sp = check_rule(ptr, xyz, normal, exact, "centroid", exact_second=False)
    d = sp.point - c
    Iy = sp.weight @ (d @ e2) ** 2  # second moment about the rectangle's long axis
    Ix = sp.weight @ (d @ e1) ** 2
    assert abs(Iy - b * h**3 / 18) < RTOL * b * h**3
    assert abs(Ix - h * b**3 / 18) < RTOL * h * b**3
    for rule in ("moment", "three"):
        sp = check_rule(ptr, xyz, normal, exact, rule, exact_second=True)
        d = sp.point - c
        assert abs(sp.weight @ (d @ e2) ** 2 - b * h**3 / 12) < 1e-10 * b * h**3


def test_spring_points_regular_hexagon():
    s = 0.4
    t = np.arange(6) * np.pi / 3
    hexa = s * np.stack([np.cos(t), np.sin(t)], 1)
    rng = np.random.default_rng(8)
    ptr, xyz, normal, exact = face_set([hexa], rng)
    A, c, J = exact[0]
    assert abs(A - 3 * np.sqrt(3) / 2 * s**2) < RTOL * A
    Jh = 5 * np.sqrt(3) / 16 * s**4  # about any in-plane axis through the centre
    e1, e2, _ = plane_basis(normal[0])
    assert rel(J, Jh * (np.outer(e1, e1) + np.outer(e2, e2))) < 1e-12
    for rule in ("moment", "three"):
        check_rule(ptr, xyz, normal, exact, rule, exact_second=True)
    check_rule(ptr, xyz, normal, exact, "centroid", exact_second=False)


def test_spring_points_random_convex_polygons():
    rng = np.random.default_rng(9)
    polys = [random_convex_polygon(rng) for _ in range(40)]
    polys.append(np.array([[0, 0], [1, 0], [0, 1.0]]))  # a triangle: 3 points
    ptr, xyz, normal, exact = face_set(polys, rng)
    for rule in ("moment", "three"):
        check_rule(ptr, xyz, normal, exact, rule, exact_second=True)
    c = check_rule(ptr, xyz, normal, exact, "centroid", exact_second=False)
    m = spring_points(ptr, xyz, normal)  # default rule: moment
    assert np.array_equal(m.weight, c.weight) and np.array_equal(m.face, c.face)
    with pytest.raises(ValueError):
        spring_points(ptr, xyz, normal, "gauss")


def test_spring_points_on_mesh_faces():
    """On every face of a Voronoi mesh the moment rule matches the three-point rule's
    (exact) second moment, and weights sum to the face areas."""
    m = voronoi_mesh([[0, 0, 0], [0.4, 0.3, 0.2]], 0.05, seed=1)
    F = len(m.face_cells)
    mo = spring_points(m.face_vertex_ptr, m.face_vertex_xyz, m.face_normal, "moment")
    th = spring_points(m.face_vertex_ptr, m.face_vertex_xyz, m.face_normal, "three")
    for sp in (mo, th):
        assert rel(np.bincount(sp.face, sp.weight, minlength=F), m.face_area) < 1e-12
        d = sp.point - m.face_centroid[sp.face]
        first = np.zeros((F, 3))
        np.add.at(first, sp.face, sp.weight[:, None] * d)
        assert np.abs(first).max() < 1e-12 * 0.05**3
    J = []
    for sp in (mo, th):
        d = sp.point - m.face_centroid[sp.face]
        M = np.zeros((F, 3, 3))
        np.add.at(M, sp.face, sp.weight[:, None, None] * d[:, :, None] * d[:, None, :])
        J.append(M)
    scale = np.trace(J[1], axis1=1, axis2=2)
    assert (np.abs(J[0] - J[1]).max(axis=(1, 2)) / scale).max() < 1e-10
    b = spring_points(m.bface_vertex_ptr, m.bface_vertex_xyz, m.bface_normal)
    assert rel(np.bincount(b.face, b.weight, minlength=len(m.bface_cell)), m.bface_area) < 1e-12


@pytest.mark.parametrize("rule", ["centroid", "moment", "three"])
def test_spring_points_on_a_non_convex_face_are_positive(rule):
    """A U-shaped face (3 × 3 square less a 1 × 2 slot; its centroid
    (1.5, 19/14) lies in the slot, so the fan from it has triangles of
    negative area) is cut by ear clipping: every weight is positive, they
    sum to the area 7, their first moment gives the centroid (1e-12), and
    the moment and three-point rules give the exact second moments about it
    (∫(x − x̄)² = 79/12, ∫(y − ȳ)² from the square less the slot: 1e-12);
    a tilted copy gives the same."""
    from rbsm_dyn.mesh import spring_points
    U = np.array([[0, 0], [3, 0], [3, 3], [2, 3], [2, 1], [1, 1], [1, 3], [0, 3]], float)
    R = Rotation.from_euler("xyz", [0.3, -0.5, 0.9]).as_matrix()
    xyz = np.c_[U, np.zeros(len(U))] @ R.T + [0.2, -0.1, 0.4]
    sp = spring_points(np.array([0, 8]), xyz, R[:, 2][None, :], rule)
    assert np.all(sp.weight > 0)
    assert sp.weight.sum() == pytest.approx(7.0, rel=1e-12)
    local = (sp.point - [0.2, -0.1, 0.4]) @ R
    c = sp.weight @ local / 7.0
    assert c == pytest.approx([1.5, 19 / 14, 0.0], abs=1e-12)
    ybar = 19 / 14
    iyy = 3 * 27 / 12 + 9 * (1.5 - ybar) ** 2 - (8 / 12 + 2 * (2 - ybar) ** 2)
    if rule != "centroid":
        assert sp.weight @ (local[:, 0] - 1.5) ** 2 == pytest.approx(79 / 12, rel=1e-12)
        assert sp.weight @ (local[:, 1] - ybar) ** 2 == pytest.approx(iyy, rel=1e-12)
