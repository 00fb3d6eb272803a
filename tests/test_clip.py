"""Cells clipped to a solid (rbsm_dyn/mesh/clip.py, issue 12 item 3): the
Voronoi cells of seeds inside a faceted solid, intersected with it.  The
solids here are manifold3d primitives (a cylinder, a thick-walled pipe, a
notched beam) with their surfaces named by the normal of their facets; the
facts checked are those of any partition of a solid into polyhedra."""
import numpy as np
import pytest
from scipy.spatial import ConvexHull

from rbsm_dyn.mesh import voronoi_mesh
from rbsm_dyn.mesh.clip import clip_to_solid
from rbsm_dyn.mesh.voronoi import voronoi_seeds

import manifold3d as m3  # noqa: E402

R, L, H = 0.05, 0.1, 0.01          # cylinder radius, length; cell size
N_SEG = 32


def surface_of(solid):
    """Vertices, triangles and surface ids of a manifold: 0 'side' (normal
    ⊥ z), 1 'bottom' (−z), 2 'top' (+z)."""
    m = solid.to_mesh64()
    v = np.array(m.vert_properties)[:, :3]
    t = np.array(m.tri_verts, np.int64)
    n = np.cross(v[t[:, 1]] - v[t[:, 0]], v[t[:, 2]] - v[t[:, 0]])
    nz = n[:, 2] / np.linalg.norm(n, axis=1)
    s = np.where(nz < -0.5, 1, np.where(nz > 0.5, 2, 0))
    return v, t, s


def clipped(solid, inside, size=H, seed=1, contains=True):
    """The clipped mesh (interior cells skipping the boolean when
    ``contains``) and the tessellation it came from."""
    v, t, s = surface_of(solid)
    box = np.array([v.min(0) - 0.5 * size, v.max(0) + 0.5 * size])
    seeds = voronoi_seeds(box, size, seed)
    cells = voronoi_mesh(box, size, seeds=seeds[inside(seeds)])
    return clip_to_solid(cells, v, t, s, ("side", "bottom", "top"),
                         contains=inside if contains else None), cells


def in_cylinder(p, r=R):
    return (p[:, 0] ** 2 + p[:, 1] ** 2 < r * r) & (p[:, 2] > 0) & (p[:, 2] < L)


SOLIDS = {
    # faceted volumes: (n/2) r² sin(2π/n) L for an n-gon prism
    "cylinder": (lambda: m3.Manifold.cylinder(L, R, R, N_SEG),
                 in_cylinder,
                 N_SEG / 2 * R ** 2 * np.sin(2 * np.pi / N_SEG) * L),
    "pipe": (lambda: m3.Manifold.cylinder(L, R, R, N_SEG)
             - m3.Manifold.cylinder(3 * L, R / 2, R / 2, N_SEG, True),
             lambda p: in_cylinder(p) & ~in_cylinder(p, R / 2),
             N_SEG / 2 * (R ** 2 - R ** 2 / 4) * np.sin(2 * np.pi / N_SEG) * L),
    # a beam 0.2 × 0.05 × 0.05 with a notch 4 mm wide, 20 mm deep at midspan
    "notched beam": (lambda: m3.Manifold.cube([0.2, 0.05, 0.05])
                     - m3.Manifold.cube([0.004, 0.2, 0.02]).translate([0.098, -0.05, -0.01]),
                     lambda p: np.all((p > 0) & (p < [0.2, 0.05, 0.05]), 1)
                     & ~((np.abs(p[:, 0] - 0.1) < 0.002) & (p[:, 2] < 0.01)),
                     0.2 * 0.05 * 0.05 - 0.004 * 0.05 * 0.01),
}


@pytest.fixture(scope="module", params=list(SOLIDS))
def solid_mesh(request):
    make, inside, volume = SOLIDS[request.param]
    solid = make()
    mesh, cells = clipped(solid, inside)
    return request.param, solid, mesh, cells, volume


@pytest.mark.parametrize("name", list(SOLIDS))
def test_interior_cells_skip_the_boolean_unchanged(name):
    """Cells away from the surface skip the boolean: the mesh is the same
    as when every cell goes through it (volumes, centroids, faces)."""
    make, inside, volume = SOLIDS[name]
    a, _ = clipped(make(), inside, contains=True)
    b, _ = clipped(make(), inside, contains=False)
    assert a.n_cells == b.n_cells and a.n_faces == b.n_faces and a.n_bfaces == b.n_bfaces
    np.testing.assert_allclose(a.cell_volume, b.cell_volume, rtol=1e-9)
    np.testing.assert_allclose(a.cell_centroid, b.cell_centroid, atol=1e-12)
    np.testing.assert_array_equal(a.face_cells, b.face_cells)
    np.testing.assert_allclose(a.face_area, b.face_area, rtol=1e-9, atol=1e-18)


def test_cells_tile_the_solid(solid_mesh):
    """Cell volumes sum to the faceted solid's volume (from the n-gon formula)
    to 1e-9, and the boundary faces cover its surface (area sum)."""
    name, solid, mesh, cells, volume = solid_mesh
    assert mesh.cell_volume.sum() == pytest.approx(volume, rel=1e-9)
    assert mesh.bface_area.sum() == pytest.approx(solid.surface_area(), rel=1e-9)
    assert np.all(mesh.cell_volume > 0)


def test_named_surfaces_hold_their_faces(solid_mesh):
    """A boundary face's outward normal is that of its surface: top +z,
    bottom −z, side ⊥ z; the areas per surface are the solid's."""
    name, solid, mesh, cells, volume = solid_mesh
    n = mesh.bface_normal
    s = mesh.bface_side
    assert mesh.surface_names == ("side", "bottom", "top")
    np.testing.assert_allclose(n[s == 2], np.tile([0, 0, 1.0], ((s == 2).sum(), 1)), atol=1e-12)
    np.testing.assert_allclose(n[s == 1], np.tile([0, 0, -1.0], ((s == 1).sum(), 1)), atol=1e-12)
    assert np.abs(n[s == 0][:, 2]).max() < 1e-12
    if name != "notched beam":
        # top and bottom: the n-gon annulus / disc
        area = N_SEG / 2 * R ** 2 * np.sin(2 * np.pi / N_SEG) * (0.75 if name == "pipe" else 1)
        assert mesh.bface_area[s == 2].sum() == pytest.approx(area, rel=1e-9)


def test_faces_are_planar_and_closed(solid_mesh):
    """Every face polygon lies in its plane (to 1e-9 of the cell size) and
    every cell is closed: Σ area × normal over its faces vanishes."""
    name, solid, mesh, cells, volume = solid_mesh
    for ptr, xyz, nrm in ((mesh.face_vertex_ptr, mesh.face_vertex_xyz, mesh.face_normal),
                          (mesh.bface_vertex_ptr, mesh.bface_vertex_xyz, mesh.bface_normal)):
        poly = np.repeat(np.arange(len(ptr) - 1), np.diff(ptr))
        d = np.einsum("ij,ij->i", xyz - xyz[ptr[:-1]][poly], nrm[poly])
        assert np.abs(d).max() < 1e-9 * H
    N = mesh.n_cells
    s = np.zeros((N, 3))
    for c in range(3):
        s[:, c] += np.bincount(mesh.face_cells[:, 0], mesh.face_area * mesh.face_normal[:, c], N)
        s[:, c] -= np.bincount(mesh.face_cells[:, 1], mesh.face_area * mesh.face_normal[:, c], N)
        s[:, c] += np.bincount(mesh.bface_cell, mesh.bface_area * mesh.bface_normal[:, c], N)
    assert np.abs(s).max() < 1e-9 * H ** 2


def test_convex_cells_have_exact_mass_properties(solid_mesh):
    """In the convex cylinder every clipped cell is convex: its volume is
    that of the convex hull of its vertices (1e-9), and its centroid the
    hull's; cells away from the surface are the tessellation's own."""
    name, solid, mesh, cells, volume = solid_mesh
    if name != "cylinder":
        assert mesh.n_cells >= cells.n_cells * 0.95
        return
    assert mesh.n_cells == cells.n_cells
    for c in range(0, mesh.n_cells, 7):
        v = mesh.vertices[mesh.cell_vertex_ptr[c]:mesh.cell_vertex_ptr[c + 1]]
        assert ConvexHull(v).volume == pytest.approx(mesh.cell_volume[c], rel=1e-9)
    inner = np.linalg.norm(cells.cell_centroid[:, :2], axis=1) < R - 2 * H
    inner &= (cells.cell_centroid[:, 2] > 2 * H) & (cells.cell_centroid[:, 2] < L - 2 * H)
    np.testing.assert_allclose(mesh.cell_volume[inner], cells.cell_volume[inner], rtol=1e-12)


def test_no_slivers(solid_mesh):
    """No body below min_volume (0.1) of the mean cell volume: slivers cut
    off at the notch and the curved surface are merged into a neighbour."""
    name, solid, mesh, cells, volume = solid_mesh
    assert mesh.cell_volume.min() >= 0.1 * volume / mesh.n_cells


def test_blocks_clipped_to_a_notched_beam_and_a_cylinder():
    """Blocks (voxels) clipped to a solid: the notch cuts blocks, the
    cylinder's ends lie on block faces and its side cuts blocks; volumes and
    surface areas exact (1e-9), each named surface's faces carry its normal,
    no piece below 0.1 of a block."""
    from rbsm_dyn.mesh import block_mesh
    beam = SOLIDS["notched beam"][0]()
    v, t, s = surface_of(beam)
    # 4 mm blocks from −0.003: the notch x ∈ [0.098, 0.102] cuts them
    cells = block_mesh([[-0.003, -0.003, -0.003], [0.205, 0.053, 0.053]], (52, 14, 14))
    mesh = clip_to_solid(cells, v, t, s, ("side", "bottom", "top"))
    assert mesh.cell_volume.sum() == pytest.approx(SOLIDS["notched beam"][2], rel=1e-9)
    assert mesh.bface_area.sum() == pytest.approx(beam.surface_area(), rel=1e-9)
    top = mesh.bface_side == 2
    assert mesh.bface_area[top].sum() == pytest.approx(0.2 * 0.05, rel=1e-9)
    # facing −z: the bottom without the notch's mouth, and the notch's end
    bottom = mesh.bface_side == 1
    assert mesh.bface_area[bottom].sum() == pytest.approx(0.2 * 0.05, rel=1e-9)
    assert np.sum(bottom & (np.abs(mesh.bface_centroid[:, 2] - 0.01) < 1e-12)) > 0
    np.testing.assert_allclose(mesh.bface_normal[top][:, 2], 1.0, atol=1e-12)
    assert mesh.cell_volume.min() >= 0.1 * 0.004 ** 3

    cyl = SOLIDS["cylinder"][0]()
    v, t, s = surface_of(cyl)
    cells = block_mesh([[-R, -R, 0], [R, R, L]], (10, 10, 10))
    mesh = clip_to_solid(cells, v, t, s, ("side", "bottom", "top"))
    assert mesh.cell_volume.sum() == pytest.approx(SOLIDS["cylinder"][2], rel=1e-9)
    assert mesh.bface_area.sum() == pytest.approx(cyl.surface_area(), rel=1e-9)
    assert mesh.cell_volume.min() >= 0.1 * (2 * R / 10) ** 2 * L / 10
