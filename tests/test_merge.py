"""rbsm_dyn.mesh.merge: a rigid body as one cell, meshes of several parts
and the faces between parts.

Geometric facts with round-off tolerances: 1e-12 relative for mass
properties of a few dozen tetrahedra; exact equality where merge_meshes only
copies (and offsets) the arrays of its parts.
"""
import numpy as np
import pytest

from rbsm_dyn.geometry import build_solid
from rbsm_dyn.mesh import block_mesh, polygon_properties, voronoi_mesh
from rbsm_dyn.mesh.merge import add_interface_faces, merge_meshes, rigid_mesh

RTOL = 1e-12


def rel(a, b):
    a, b = np.asarray(a, float), np.asarray(b, float)
    assert a.shape == b.shape
    return np.max(np.abs(a - b)) / max(np.max(np.abs(b)), 1e-300)


def rigid(solid):
    return rigid_mesh(solid.vertices, solid.triangles, solid.tri_surface, solid.surface_names)


def box_inertia(a, b, c):
    v = a * b * c
    return v / 12.0 * np.diag([b * b + c * c, a * a + c * c, a * a + b * b])


# --------------------------------------------------------------------------
# rigid_mesh
# --------------------------------------------------------------------------

def test_rigid_box():
    s = build_solid({"box": [[0, 0, 0], [2, 1, 0.5]]}, chord=0.01)
    m = rigid(s)
    assert m.n_cells == 1 and m.n_faces == 0 and m.n_bfaces == len(s.triangles)
    assert m.face_cells.shape == (0, 2)
    assert abs(m.cell_volume[0] - 1.0) < RTOL
    assert rel(m.cell_centroid[0], [1.0, 0.5, 0.25]) < RTOL
    assert rel(m.cell_inertia[0], box_inertia(2.0, 1.0, 0.5)) < RTOL
    assert abs(m.bface_area.sum() - 7.0) < 7.0 * RTOL
    assert np.allclose(m.box, [[0, 0, 0], [2, 1, 0.5]], rtol=0, atol=0)
    assert m.surface_names == s.surface_names
    assert np.all(m.bface_cell == 0)
    # boundary faces sorted by side; each box face's triangles carry its name
    assert np.all(np.diff(m.bface_side) >= 0)
    names = np.array(m.surface_names)[m.bface_side]
    expect = {"xmin": (0, -1), "xmax": (0, 1), "ymin": (1, -1), "ymax": (1, 1), "zmin": (2, -1), "zmax": (2, 1)}
    areas = {"xmin": 0.5, "xmax": 0.5, "ymin": 1.0, "ymax": 1.0, "zmin": 2.0, "zmax": 2.0}
    for face, (axis, sign) in expect.items():
        e = np.zeros(3)
        e[axis] = sign
        on = np.abs(m.bface_normal - e).max(axis=1) < 1e-15
        assert on.sum() >= 2
        assert np.all(names[on] == f"box0.{face}")
        assert np.all(on[names == f"box0.{face}"])
        assert abs(m.bface_area[on].sum() - areas[face]) < RTOL
    # each boundary face is a triangle of the solid, counter-clockwise about its normal
    assert np.all(np.diff(m.bface_vertex_ptr) == 3)
    a, _ = polygon_properties(m.bface_vertex_ptr, m.bface_vertex_xyz, m.bface_normal)
    assert rel(a, m.bface_area) < RTOL and np.all(a > 0)
    # the drawing polygons are the same triangles
    assert m.cell_poly_ptr.tolist() == [0, len(s.triangles)]
    assert np.all(np.diff(m.poly_ptr) == 3)


def test_rigid_l_prism_non_convex():
    s = build_solid({"prism": {"polygon": [[0, 0], [2, 0], [2, 1], [1, 1], [1, 2], [0, 2]],
                               "axis": "z", "from": 0, "to": 1}}, chord=0.01)
    m = rigid(s)
    assert abs(m.cell_volume[0] - 3.0) < 3.0 * RTOL
    g = np.array([5 / 6, 5 / 6, 0.5])
    assert rel(m.cell_centroid[0], g) < RTOL
    # three unit cubes, parallel-axis theorem: I = Σ I_cube + (|d|² 1 − d dᵀ)
    centres = np.array([[0.5, 0.5, 0.5], [1.5, 0.5, 0.5], [0.5, 1.5, 0.5]])
    inertia = np.zeros((3, 3))
    for c in centres:
        d = c - g
        inertia += box_inertia(1.0, 1.0, 1.0) + (d @ d) * np.eye(3) - np.outer(d, d)
    assert rel(m.cell_inertia[0], inertia) < RTOL
    assert abs(inertia[0, 1] - 1 / 3) < 1e-15  # a non-zero product of inertia
    assert abs(m.bface_area.sum() - (2 * 3 + 8)) < 14 * RTOL


def test_rigid_cylinder_matches_solid():
    s = build_solid({"cylinder": {"base": [0.3, -0.2, 1.0], "axis": [0.2, 0.1, 0.8],
                                  "radius": 0.25}}, chord=0.01)
    m = rigid(s)
    assert abs(m.cell_volume[0] - s.volume) < RTOL * s.volume
    vol, cen, inertia = s.mass_properties()
    assert rel(m.cell_centroid[0], cen) < RTOL
    assert rel(m.cell_inertia[0], inertia) < RTOL
    assert abs(m.bface_area.sum() - s.area()) < RTOL * s.area()
    assert rel(m.bface_normal, s.triangle_normals[np.argsort(s.tri_surface, kind="stable")]) < 1e-14


def test_rigid_rejects_open_or_inward():
    s = build_solid({"box": [[0, 0, 0], [1, 1, 1]]}, chord=0.01)
    with pytest.raises(ValueError, match="closed"):
        rigid_mesh(s.vertices, s.triangles[1:], s.tri_surface[1:], s.surface_names)
    with pytest.raises(ValueError, match="volume"):
        rigid_mesh(s.vertices, s.triangles[:, ::-1], s.tri_surface, s.surface_names)


# --------------------------------------------------------------------------
# merge_meshes
# --------------------------------------------------------------------------

@pytest.fixture(scope="module")
def parts():
    blocks = block_mesh([[0, 0, 0], [1, 1, 1]], (2, 2, 2))
    vor = voronoi_mesh([[1, 0, 0], [2, 1, 1]], 0.35, seed=3)
    lid = rigid(build_solid({"box": [[2, 0, 0], [2.5, 1, 1]]}, chord=0.01))
    names = ("blocks", "vor", "lid")
    return (blocks, vor, lid), names, merge_meshes((blocks, vor, lid), names)


def test_merge_counts_and_names(parts):
    meshes, names, m = parts
    assert m.n_cells == sum(p.n_cells for p in meshes)
    assert m.n_faces == sum(p.n_faces for p in meshes)
    assert m.n_bfaces == sum(p.n_bfaces for p in meshes)
    assert m.part_names == names
    assert m.cell_part.dtype == np.int64
    assert m.cell_part.tolist() == sum(([k] * p.n_cells for k, p in enumerate(meshes)), [])
    assert m.face_interface.dtype == np.int64 and np.all(m.face_interface == -1)
    assert len(m.face_interface) == m.n_faces
    assert m.surface_names == tuple(f"{n}.{s}" for n, p in zip(names, meshes) for s in p.surface_names)
    assert m.surface_names[:2] == ("blocks.xmin", "blocks.xmax")
    assert m.surface_names[-1] == "lid.box0.zmax"
    assert np.array_equal(m.box, [[0, 0, 0], [2.5, 1, 1]])
    fc = m.face_cells
    assert np.all(fc[:, 0] < fc[:, 1])
    assert np.array_equal(np.lexsort((fc[:, 1], fc[:, 0])), np.arange(m.n_faces))
    assert np.array_equal(np.lexsort((m.bface_cell, m.bface_side)), np.arange(m.n_bfaces))
    for a in (m.cell_vertex_ptr, m.poly_ptr, m.poly_vertex, m.cell_poly_ptr, m.face_cells,
              m.face_vertex_ptr, m.bface_cell, m.bface_side, m.bface_vertex_ptr):
        assert a.dtype == np.int64


def test_merge_preserves_each_part(parts):
    meshes, names, m = parts
    c0 = s0 = 0
    f0 = b0 = 0
    for k, p in enumerate(meshes):
        cs = slice(c0, c0 + p.n_cells)
        assert np.array_equal(m.cell_volume[cs], p.cell_volume)
        assert np.array_equal(m.cell_centroid[cs], p.cell_centroid)
        assert np.array_equal(m.cell_inertia[cs], p.cell_inertia)
        # internal faces: the part's own plus the cell offset
        fs = slice(f0, f0 + p.n_faces)
        assert np.array_equal(m.face_cells[fs], p.face_cells + c0)
        assert np.array_equal(m.face_area[fs], p.face_area)
        assert np.array_equal(m.face_normal[fs], p.face_normal)
        fp = m.face_vertex_ptr
        assert np.array_equal(m.face_vertex_xyz[fp[f0]:fp[f0 + p.n_faces]], p.face_vertex_xyz)
        assert np.array_equal(fp[f0:f0 + p.n_faces + 1] - fp[f0], p.face_vertex_ptr)
        # drawing polygons: same vertex coordinates, polygon by polygon
        p_lo, p_hi = m.cell_poly_ptr[c0], m.cell_poly_ptr[c0 + p.n_cells]
        assert np.array_equal(m.cell_poly_ptr[c0:c0 + p.n_cells + 1] - p_lo, p.cell_poly_ptr)
        assert np.array_equal(m.poly_ptr[p_lo:p_hi + 1] - m.poly_ptr[p_lo], p.poly_ptr)
        ids = m.poly_vertex[m.poly_ptr[p_lo]:m.poly_ptr[p_hi]]
        assert np.array_equal(m.vertices[ids], p.vertices[p.poly_vertex])
        # each cell's polygons use only that cell's vertex rows
        vcell = np.searchsorted(m.cell_vertex_ptr, ids, side="right") - 1
        pcell = np.repeat(np.arange(c0, c0 + p.n_cells), np.diff(p.cell_poly_ptr))
        assert np.array_equal(vcell, np.repeat(pcell, np.diff(p.poly_ptr)))
        # boundary faces: same rows, side offset, same areas per surface name
        bs = slice(b0, b0 + p.n_bfaces)
        assert np.array_equal(m.bface_cell[bs], p.bface_cell + c0)
        assert np.array_equal(m.bface_side[bs], p.bface_side + s0)
        assert np.array_equal(m.bface_normal[bs], p.bface_normal)
        bp = m.bface_vertex_ptr
        assert np.array_equal(m.bface_vertex_xyz[bp[b0]:bp[b0 + p.n_bfaces]], p.bface_vertex_xyz)
        for i, name in enumerate(p.surface_names):
            sel = np.array(m.surface_names)[m.bface_side] == f"{names[k]}.{name}"
            assert np.array_equal(m.bface_area[sel], p.bface_area[p.bface_side == i])
        c0 += p.n_cells
        f0 += p.n_faces
        b0 += p.n_bfaces
        s0 += len(p.surface_names)
    assert m.cell_volume.sum() == pytest.approx(1.0 + 1.0 + 0.5, rel=1e-12)


def test_merge_rejects_bad_input(parts):
    meshes, names, m = parts
    with pytest.raises(ValueError):
        merge_meshes(meshes, names[:2])
    with pytest.raises(ValueError):
        merge_meshes(meshes[:2], ("a", "a"))
    with pytest.raises(ValueError):
        merge_meshes(meshes[:2], ("a.b", "c"))
    with pytest.raises(ValueError, match="several parts"):
        merge_meshes([m, meshes[0]], ("all", "more"))
    one = merge_meshes(meshes[:1], ("only",))
    assert one.n_cells == meshes[0].n_cells and np.all(one.cell_part == 0)


# --------------------------------------------------------------------------
# add_interface_faces
# --------------------------------------------------------------------------

def _bface(m, k):
    """Polygon of boundary face k of Mesh m (vertices, normal, area)."""
    p = m.bface_vertex_ptr
    return m.bface_vertex_xyz[p[k]:p[k + 1]], m.bface_normal[k], m.bface_area[k]


def test_add_interface_faces(parts):
    meshes, names, m = parts
    side = np.array(m.surface_names)[m.bface_side]
    # face 1 (listed first): a voronoi cell's xmax face against the lid (interface 1)
    kv = np.flatnonzero(side == "vor.xmax")[0]
    xyz1, n1, a1 = _bface(m, kv)
    lid = m.n_cells - 1
    # face 2: a block cell's xmax face against the voronoi cell nearest to it (interface 0)
    kb = np.flatnonzero(side == "blocks.xmax")[1]
    xyz2, n2, a2 = _bface(m, kb)
    vx = np.flatnonzero(side == "vor.xmin")
    near = vx[np.argmin(np.linalg.norm(m.bface_centroid[vx] - m.bface_centroid[kb], axis=1))]
    pairs = np.array([[m.bface_cell[kv], lid], [m.bface_cell[kb], m.bface_cell[near]]])
    ptr = np.array([0, len(xyz1), len(xyz1) + len(xyz2)])
    out = add_interface_faces(m, pairs, ptr, np.concatenate([xyz1, xyz2]),
                              np.stack([n1, 2.0 * n2]), np.array([1, 0]))

    assert out.n_faces == m.n_faces + 2
    fc = out.face_cells
    assert np.all(fc[:, 0] < fc[:, 1])
    assert np.array_equal(np.lexsort((fc[:, 1], fc[:, 0])), np.arange(out.n_faces))
    new = out.face_interface >= 0
    assert new.sum() == 2
    rows = np.flatnonzero(new)
    # sorted: the block-voronoi face (smaller a) comes first
    assert fc[rows].tolist() == pairs[::-1].tolist()
    assert out.face_interface[rows].tolist() == [0, 1]
    assert rel(out.face_area[rows], [a2, a1]) < RTOL
    assert rel(out.face_normal[rows], np.stack([n2, n1])) < 1e-15
    fp = out.face_vertex_ptr
    assert np.array_equal(out.face_vertex_xyz[fp[rows[0]]:fp[rows[0] + 1]], xyz2)
    assert np.array_equal(out.face_vertex_xyz[fp[rows[1]]:fp[rows[1] + 1]], xyz1)
    _, cen = polygon_properties(np.array([0, len(xyz2)]), xyz2, n2[None])
    assert rel(out.face_centroid[rows[0]], cen[0]) < RTOL
    # the old faces keep their order and data; the cells are unchanged
    old = ~new
    assert np.array_equal(fc[old], m.face_cells)
    assert np.array_equal(out.face_area[old], m.face_area)
    assert np.array_equal(out.face_centroid[old], m.face_centroid)
    assert np.array_equal(out.face_normal[old], m.face_normal)
    old_poly = np.repeat(old, np.diff(fp))
    assert np.array_equal(out.face_vertex_xyz[old_poly], m.face_vertex_xyz)
    for f in ("cell_volume", "cell_inertia", "vertices", "poly_vertex", "bface_area"):
        assert getattr(out, f) is getattr(m, f)
    assert out.part_names == m.part_names and np.array_equal(out.cell_part, m.cell_part)
    # the input mesh is untouched
    assert m.n_faces == len(m.face_interface) and np.all(m.face_interface == -1)

    # adding again keeps the existing interface values in step with the faces
    again = add_interface_faces(out, pairs[:1], ptr[:2], xyz1, n1[None], [2])
    assert again.n_faces == out.n_faces + 1
    r = np.flatnonzero(again.face_interface >= 0)
    assert again.face_interface[r].tolist() == [0, 1, 2]
    assert again.face_cells[r].tolist() == [pairs[1].tolist(), pairs[0].tolist(), pairs[0].tolist()]


def test_add_interface_faces_rejects(parts):
    meshes, names, m = parts
    sq = np.array([[1, 0, 0], [1, 1, 0], [1, 1, 1], [1, 0, 1]], float)
    ptr = np.array([0, 4])
    ex = np.array([[1.0, 0, 0]])
    with pytest.raises(ValueError, match="different parts"):
        add_interface_faces(m, [[0, 1]], ptr, sq, ex, [0])
    with pytest.raises(ValueError, match="a < b"):
        add_interface_faces(m, [[10, 1]], ptr, sq, ex, [0])
    with pytest.raises(ValueError, match="counter-clockwise"):
        add_interface_faces(m, [[1, 10]], ptr, sq[::-1], ex, [0])
    with pytest.raises(ValueError, match=">= 0"):
        add_interface_faces(m, [[1, 10]], ptr, sq, ex, [-1])
    ok = add_interface_faces(m, [[1, 10]], ptr, sq, ex, [0])
    assert ok.face_area[ok.face_interface == 0].tolist() == [1.0]
