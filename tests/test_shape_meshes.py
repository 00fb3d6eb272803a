"""Every primitive and boolean meshed from a case text, in Voronoi cells and
in blocks (issue 12, "What must be shown"): a sphere, an L-panel prism, a
plate with a round hole (box − cylinder) and a notched beam (box − box).
The blocks put their planes on the solids' edges as a specimen does: through
the L's inner corner (its inner sides on block faces) and on the notch's end
(block faces half on it, half inside: mesh/clip.py splits them).  Facts of
any partition of a faceted solid into polyhedra:

* the cells' volumes sum to the solid's: manifold3d's volume of the solid
  the case built, and the closed form where there is one;
* the boundary faces cover the surface: their areas sum to its area, and
  over them ∮ x ⊗ n dA = V I (divergence theorem: areas and normals right);
* each named surface holds faces of its area, on its plane with its outward
  normal (curved: within the faceting chord of the true surface);
* each cell's volume and centroid are those of its faces (divergence
  theorem, computed here); a convex cell's are its vertices' convex hull's;
  a cell is convex unless the solid is concave inside it (a cell is the part
  of a convex Voronoi cell or block inside the solid).

Tolerances: 1e-9 relative on sums over faces and on mass properties (the
issue's criterion; the faces are exact up to round-off, ~1e-16 per vertex,
so 1e-9 leaves room for sums of hundreds of terms); 1e-12 on the unit
normals and plane offsets of planar faces (exact coordinates, one rounding
per operation); convexity judged at 1e-9 × the cell size (vertices behind
every face plane)."""
import math
import textwrap

import numpy as np
import pytest
from scipy.spatial import ConvexHull

from rbsm_dyn.case import domain_solid, load_case_text
from rbsm_dyn.geometry import circle_segments
from rbsm_dyn.model import build_mesh
from test_geometry import ngon_area, ngon_perimeter, shoelace

CHORD = 0.05                      # faceting chord / cell size (mesh.chord)
R_BALL = 0.1
L_POLY = [[0, 0], [1, 0], [1, 0.5], [0.5, 0.5], [0.5, 1], [0, 1]]
L_T = 0.1                         # L-panel thickness
PLATE, PLATE_T, R_HOLE = 0.2, 0.02, 0.05
BEAM = (0.4, 0.1, 0.1)
NOTCH_X, NOTCH_D = (0.19, 0.21), 0.05     # notch 20 mm wide, 50 mm deep, through the width

# (domain, Voronoi cell size, block divisions); the blocks' cell size (the
# chord's reference) is their smallest edge
SHAPES = {
    "sphere": ("{sphere: {center: [0, 0, 0], radius: 0.1}, name: ball}", 0.03, (6, 6, 6)),
    # blocks of 1/8: planes x = 0.5 and y = 0.5 hold the inner sides and corner
    "L-panel": (f"{{prism: {{polygon: {L_POLY}, axis: z, from: 0, to: {L_T}}}, name: panel}}",
                0.07, (8, 8, 2)),
    "plate with a hole": ("{difference: [{box: [[0, 0, 0], [0.2, 0.2, 0.02]], name: plate},"
                          " {cylinder: {base: [0.1, 0.1, -0.01], axis: [0, 0, 0.04],"
                          " radius: 0.05}, name: hole}]}", 0.015, (8, 8, 2)),
    # blocks of 0.02 × 0.025 × 0.025: the notch's end z = 0.05 on a block
    # plane, its sides x = 0.19, 0.21 through the middle of blocks
    "notched beam": ("{difference: [{box: [[0, 0, 0], [0.4, 0.1, 0.1]], name: beam},"
                     " {box: [[0.19, -0.1, -0.1], [0.21, 0.2, 0.05]], name: notch}]}",
                     0.025, (20, 4, 4)),
}
BOUNDS = {"sphere": ((-R_BALL,) * 3, (R_BALL,) * 3), "L-panel": ((0, 0, 0), (1, 1, L_T)),
          "plate with a hole": ((0, 0, 0), (PLATE, PLATE, PLATE_T)),
          "notched beam": ((0, 0, 0), BEAM)}


def case_text(domain, mesh):
    return textwrap.dedent(f"""
        name: shape
        domain: {domain}
        mesh: {mesh}
        materials: {{concrete: {{density: 2400, young: 3.0e10, poisson: 0.2}}}}
        solver: {{mode: dynamic, end_time: 1.0e-5}}
        """)


def cell_size(shape, kind):
    domain, size, div = SHAPES[shape]
    if kind == "voronoi":
        return size
    lo, hi = np.array(BOUNDS[shape], float)
    return float(np.min((hi - lo) / div))


@pytest.fixture(scope="module", params=[(s, k) for s in SHAPES for k in ("voronoi", "blocks")],
                ids=lambda p: f"{p[0]}-{p[1]}")
def shape_mesh(request):
    shape, kind = request.param
    domain, size, div = SHAPES[shape]
    mesh = (f"{{kind: voronoi, size: {size}, seed: 1, chord: {CHORD}}}" if kind == "voronoi"
            else f"{{kind: blocks, divisions: {list(div)}, chord: {CHORD}}}")
    case = load_case_text(case_text(domain, mesh))
    return shape, kind, build_mesh(case), domain_solid(case), cell_size(shape, kind)


# -- reference values ---------------------------------------------------------------

def prism_sides(poly, t, node):
    """Side i of a counter-clockwise polygon extruded by t: area |e_i| t,
    outward normal (e_y, −e_x), on the plane n · x = n · p_i."""
    p = np.asarray(poly, float)
    out = {}
    for i in range(len(p)):
        e = p[(i + 1) % len(p)] - p[i]
        n = np.array([e[1], -e[0], 0.0]) / np.linalg.norm(e)
        out[f"{node}.side{i}"] = (np.linalg.norm(e) * t, n, float(n[:2] @ p[i]))
    return out


def box_faces(lo, hi, node, less=None):
    """The six faces of a box: (area, outward normal, offset), minus ``less``
    (area removed per face)."""
    lo, hi = np.asarray(lo, float), np.asarray(hi, float)
    d = hi - lo
    out = {}
    for a, ax in enumerate("xyz"):
        area = d[(a + 1) % 3] * d[(a + 2) % 3]
        for side, sign, x in (("min", -1.0, lo[a]), ("max", 1.0, hi[a])):
            n = np.zeros(3)
            n[a] = sign
            name = f"{node}.{ax}{side}"
            out[name] = (area - (less or {}).get(name, 0.0), n, sign * x)
    return out


def planar_surfaces(shape, h):
    """name -> (area, outward unit normal, offset n · x) of each planar surface."""
    if shape == "L-panel":
        area = shoelace(L_POLY)
        return {"panel.bottom": (area, np.array([0, 0, -1.0]), 0.0),
                "panel.top": (area, np.array([0, 0, 1.0]), L_T),
                **prism_sides(L_POLY, L_T, "panel")}
    if shape == "plate with a hole":
        hole = ngon_area(R_HOLE, circle_segments(R_HOLE, CHORD * h))
        return box_faces((0, 0, 0), (PLATE, PLATE, PLATE_T), "plate",
                         {"plate.zmin": hole, "plate.zmax": hole})
    if shape == "notched beam":
        (x0, x1), d = NOTCH_X, NOTCH_D
        w, depth = x1 - x0, BEAM[1]
        faces = box_faces((0, 0, 0), BEAM, "beam",
                          {"beam.ymin": w * d, "beam.ymax": w * d, "beam.zmin": w * depth})
        faces["notch.xmin"] = (d * depth, np.array([1.0, 0, 0]), x0)     # facing into the notch
        faces["notch.xmax"] = (d * depth, np.array([-1.0, 0, 0]), -x1)
        faces["notch.zmax"] = (w * depth, np.array([0, 0, -1.0]), -d)    # the notch's end
        return faces
    return {}


def solid_volume(shape, h):
    """Closed-form volume of the faceted solid (None: only bounds)."""
    if shape == "L-panel":
        return shoelace(L_POLY) * L_T
    if shape == "plate with a hole":
        return (PLATE ** 2 - ngon_area(R_HOLE, circle_segments(R_HOLE, CHORD * h))) * PLATE_T
    if shape == "notched beam":
        return BEAM[0] * BEAM[1] * BEAM[2] - (NOTCH_X[1] - NOTCH_X[0]) * BEAM[1] * NOTCH_D
    return None


# -- the facts ----------------------------------------------------------------------

def test_cells_fill_the_faceted_solid(shape_mesh):
    """Σ cell volumes = the faceted solid's volume (manifold3d's, and the
    closed form: L area × thickness; plate less the n-gon hole, n from the
    chord rule; beam less the notch) to 1e-9; the sphere's lies between the
    balls of radius R − chord (its facets are within the chord) and R."""
    shape, kind, mesh, solid, h = shape_mesh
    assert np.all(mesh.cell_volume > 0)
    assert mesh.cell_volume.sum() == pytest.approx(solid.manifold.volume(), rel=1e-9)
    exact = solid_volume(shape, h)
    if exact is not None:
        assert mesh.cell_volume.sum() == pytest.approx(exact, rel=1e-9)
    else:
        r = R_BALL
        ball = 4 / 3 * math.pi
        assert ball * (r - CHORD * h) ** 3 < mesh.cell_volume.sum() < ball * r ** 3


def test_boundary_faces_cover_the_surface(shape_mesh):
    """The boundary faces' areas sum to the faceted surface's (manifold3d's
    surface area) to 1e-9, and their normals close it: ∮ x ⊗ n dA = V I
    (divergence theorem of x), to 1e-9 V."""
    shape, kind, mesh, solid, h = shape_mesh
    assert mesh.bface_area.sum() == pytest.approx(solid.manifold.surface_area(), rel=1e-9)
    volume = solid.manifold.volume()
    xn = np.einsum("f,fi,fj->ij", mesh.bface_area, mesh.bface_centroid, mesh.bface_normal)
    np.testing.assert_allclose(xn, volume * np.eye(3), rtol=0, atol=1e-9 * volume)


def test_named_surfaces_hold_their_faces(shape_mesh):
    """Each named surface's faces sum to its area (formulas, 1e-9) and lie on
    its plane with its outward normal (1e-12).  Curved: the sphere's faces
    and the hole's lie within the chord of the true surface (all vertices at
    most R from the centre / axis, each face's plane at least R − chord from
    it, facing out of the solid), with the faceted areas n 2R sin(π/n) t for
    the hole and 4π(R − chord)² < A < 4π R² for the sphere."""
    shape, kind, mesh, solid, h = shape_mesh
    names = mesh.surface_names
    planar = planar_surfaces(shape, h)
    curved = {"sphere": ["ball.surface"], "plate with a hole": ["hole.side"]}.get(shape, [])
    assert sorted(names) == sorted(list(planar) + curved)
    side = mesh.bface_side
    for name, (area, normal, offset) in planar.items():
        on = side == names.index(name)
        assert mesh.bface_area[on].sum() == pytest.approx(area, rel=1e-9), name
        np.testing.assert_allclose(mesh.bface_normal[on], np.tile(normal, (on.sum(), 1)),
                                   rtol=0, atol=1e-12, err_msg=name)
        np.testing.assert_allclose(mesh.bface_centroid[on] @ normal, offset, rtol=0, atol=1e-12)
    chord = CHORD * h
    poly = np.repeat(np.arange(mesh.n_bfaces), np.diff(mesh.bface_vertex_ptr))
    for name in curved:
        on = side == names.index(name)
        area = mesh.bface_area[on].sum()
        if shape == "sphere":
            # from the centre; the faces face away from it
            centre, r, keep, out = np.zeros(3), R_BALL, np.ones(3), 1.0
            assert 4 * math.pi * (r - chord) ** 2 < area < 4 * math.pi * r ** 2
        else:
            # from the hole's axis (z); the faces face it
            centre, r, keep, out = np.array([0.1, 0.1, 0.0]), R_HOLE, np.array([1, 1, 0.0]), -1.0
            n = circle_segments(r, chord)
            assert area == pytest.approx(ngon_perimeter(r, n) * PLATE_T, rel=1e-9)
            assert np.abs(mesh.bface_normal[on][:, 2]).max() < 1e-12
        radial = (mesh.bface_vertex_xyz[on[poly]] - centre) * keep
        assert np.linalg.norm(radial, axis=1).max() <= r * (1 + 1e-12)
        # each face's plane: at least R − chord from the centre or axis
        dist = out * np.einsum("ij,ij->i", (mesh.bface_centroid[on] - centre) * keep,
                               mesh.bface_normal[on])
        assert dist.min() >= r - chord * (1 + 1e-9)


def cell_moments(mesh):
    """Volume and centroid of each cell from its face polygons: the fan
    triangles (p0, p_k, p_k+1) of each, closed into tetrahedra at the mean
    of the cell's vertices (V = Σ r0 · (r1 × r2)/6, centroid Σ V_t (r0 + r1 + r2)/4 / V,
    r relative to that point; divergence theorem)."""
    N = mesh.n_cells
    ref = np.add.reduceat(mesh.vertices, mesh.cell_vertex_ptr[:-1], axis=0) \
        / np.diff(mesh.cell_vertex_ptr)[:, None]
    vol = np.zeros(N)
    mom = np.zeros((N, 3))
    for ptr, xyz, cells, signs in ((mesh.face_vertex_ptr, mesh.face_vertex_xyz,
                                    mesh.face_cells.T, (1.0, -1.0)),
                                   (mesh.bface_vertex_ptr, mesh.bface_vertex_xyz,
                                    mesh.bface_cell[None, :], (1.0,))):
        n = np.diff(ptr)
        poly = np.repeat(np.arange(len(n)), n - 2)
        k = np.arange(len(poly)) - np.repeat(np.cumsum(n - 2) - (n - 2), n - 2) + 1
        p0, p1, p2 = xyz[ptr[poly]], xyz[ptr[poly] + k], xyz[ptr[poly] + k + 1]
        for owner, sign in zip(cells, signs):
            c = owner[poly]
            r0, r1, r2 = p0 - ref[c], p1 - ref[c], p2 - ref[c]
            v = sign * np.einsum("ij,ij->i", r0, np.cross(r1, r2)) / 6.0
            vol += np.bincount(c, v, minlength=N)
            for a in range(3):
                mom[:, a] += np.bincount(c, v * (r0 + r1 + r2)[:, a] / 4.0, minlength=N)
    return vol, ref + mom / vol[:, None]


def convex_cells(mesh, tol):
    """Cells whose vertices all lie behind every one of their face planes
    (within tol)."""
    N = mesh.n_cells
    faces = [(mesh.face_cells[:, 0], mesh.face_normal, mesh.face_centroid),
             (mesh.face_cells[:, 1], -mesh.face_normal, mesh.face_centroid),
             (mesh.bface_cell, mesh.bface_normal, mesh.bface_centroid)]
    ok = np.ones(N, bool)
    cnt = np.diff(mesh.cell_vertex_ptr)
    for cell, normal, point in faces:
        # every (face, vertex of its cell) pair
        f = np.repeat(np.arange(len(cell)), cnt[cell])
        j = mesh.cell_vertex_ptr[cell][f] + np.arange(len(f)) \
            - np.repeat(np.cumsum(cnt[cell]) - cnt[cell], cnt[cell])
        out = np.einsum("ij,ij->i", mesh.vertices[j] - point[f], normal[f]) > tol
        ok &= np.bincount(cell[f], out, minlength=N) == 0
    return ok


# a cell that is not convex holds a concave part of the solid's surface: the L's
# inner corner (faces on both inner sides), the hole, the notch
CONCAVE = {"L-panel": ("panel.side2", "panel.side3"), "plate with a hole": ("hole.side",),
           "notched beam": ("notch.xmin", "notch.xmax", "notch.zmax")}


def test_cells_have_exact_mass_properties(shape_mesh):
    """Every cell's volume and centroid are those of its faces (divergence
    theorem, computed here) to 1e-9 (V; centroid 1e-9 of the cell size), and
    its faces close (Σ a n = 0).  A convex cell's are its vertices' convex
    hull's (1e-9).  Every cell of the convex sphere is convex, and so is
    every block of the L-panel and the notched beam (the block planes hold
    the L's sides and the notch's end; the notch's sides cut blocks into
    boxes); any other cell that is not convex holds a concave part of the
    surface."""
    shape, kind, mesh, solid, h = shape_mesh
    vol, cen = cell_moments(mesh)
    np.testing.assert_allclose(mesh.cell_volume, vol, rtol=1e-9, atol=0)
    np.testing.assert_allclose(mesh.cell_centroid, cen, rtol=0, atol=1e-9 * h)
    N = mesh.n_cells
    closure = np.zeros((N, 3))
    an = mesh.face_area[:, None] * mesh.face_normal
    bn = mesh.bface_area[:, None] * mesh.bface_normal
    for a in range(3):
        closure[:, a] = (np.bincount(mesh.face_cells[:, 0], an[:, a], N)
                         - np.bincount(mesh.face_cells[:, 1], an[:, a], N)
                         + np.bincount(mesh.bface_cell, bn[:, a], N))
    assert np.abs(closure).max() < 1e-9 * h * h
    convex = convex_cells(mesh, 1e-9 * h)
    for c in np.nonzero(convex)[0]:
        v = mesh.vertices[mesh.cell_vertex_ptr[c]:mesh.cell_vertex_ptr[c + 1]]
        hull = ConvexHull(v)
        t = v[hull.simplices] - v.mean(axis=0)
        tv = np.abs(np.einsum("ij,ij->i", t[:, 0], np.cross(t[:, 1], t[:, 2]))) / 6.0
        assert hull.volume == pytest.approx(mesh.cell_volume[c], rel=1e-9)
        np.testing.assert_allclose(v.mean(axis=0) + tv @ t.sum(axis=1) / 4.0 / tv.sum(),
                                   mesh.cell_centroid[c], rtol=0, atol=1e-9 * h)
    if shape == "sphere" or kind == "blocks" and shape in ("L-panel", "notched beam"):
        assert convex.all()
    else:
        concave = np.isin(mesh.bface_side, [mesh.surface_names.index(s) for s in CONCAVE[shape]])
        assert set(np.nonzero(~convex)[0]) <= set(mesh.bface_cell[concave])


# -- block planes on the solid's edges (the L-panel and notch of issue 12) ------------

def test_blocks_through_the_l_panels_inner_corner_are_whole():
    """Blocks of 1/8 over an L-panel [[0, 0], [1, 0], [1, 0.5], [0.5, 0.5],
    [0.5, 1], [0, 1]]: the planes x = 0.5 and y = 0.5 hold its inner sides,
    so every block is inside or outside it: 48 whole blocks per layer ×2 of
    1/8 × 1/8 × 0.05, and each inner side is 4 × 2 block faces."""
    domain = SHAPES["L-panel"][0]
    mesh = build_mesh(load_case_text(case_text(domain, "{kind: blocks, divisions: [8, 8, 2]}")))
    assert mesh.n_cells == 96
    np.testing.assert_allclose(mesh.cell_volume, 0.125 * 0.125 * 0.05, rtol=1e-12)
    for name in ("panel.side2", "panel.side3"):
        on = mesh.bface_side == mesh.surface_names.index(name)
        assert on.sum() == 8
        np.testing.assert_allclose(mesh.bface_area[on], 0.125 * 0.05, rtol=1e-12)


def test_block_faces_half_on_the_notchs_end_are_split():
    """Blocks of 0.02 × 0.025 × 0.025 under a notch x ∈ [0.19, 0.21], z <
    0.05: the 8 block faces at z = 0.05 over x ∈ [0.18, 0.22] are half on
    the notch's end.  Each becomes an internal face of 0.01 × 0.025 between
    the half block below and the block above, and a boundary face of the same
    size on notch.zmax facing −z; the half blocks are 0.01 wide."""
    domain = SHAPES["notched beam"][0]
    mesh = build_mesh(load_case_text(case_text(domain, "{kind: blocks, divisions: [20, 4, 4]}")))
    end = mesh.bface_side == mesh.surface_names.index("notch.zmax")
    assert end.sum() == 8
    np.testing.assert_allclose(mesh.bface_area[end], 0.01 * 0.025, rtol=1e-12)
    x = mesh.face_centroid[:, 0]
    at_end = (np.abs(mesh.face_centroid[:, 2] - 0.05) < 1e-12) & (x > 0.18) & (x < 0.22)
    assert at_end.sum() == 8
    np.testing.assert_allclose(mesh.face_area[at_end], 0.01 * 0.025, rtol=1e-12)
    np.testing.assert_allclose(np.abs(x[at_end] - 0.2), 0.015, atol=1e-12)
    # the half block below, the whole block above
    cells = mesh.face_cells[at_end]
    below = np.where(mesh.cell_centroid[cells[:, 0], 2] < 0.05, cells[:, 0], cells[:, 1])
    above = cells.sum(axis=1) - below
    np.testing.assert_allclose(mesh.cell_volume[below], 0.01 * 0.025 * 0.025, rtol=1e-12)
    np.testing.assert_allclose(mesh.cell_volume[above], 0.02 * 0.025 * 0.025, rtol=1e-12)
    assert np.all(mesh.cell_centroid[above, 2] > 0.05)


def test_box_side_on_two_surfaces_of_a_t_beam():
    """A T-beam (a flange and a web, union) in blocks of 1/7 × 0.06 × 0.06:
    the block faces on its ends straddle the flange and the web, coplanar
    surfaces of two names.  Each end surface holds its own area (flange 0.3
    × 0.05, web 0.1 × 0.25) and every surface its formula's."""
    domain = ("{union: [{box: [[0, 0, 0], [1, 0.3, 0.05]], name: flange},"
              " {box: [[0, 0.1, 0.05], [1, 0.2, 0.3]], name: web}]}")
    mesh = build_mesh(load_case_text(case_text(domain, "{kind: blocks, divisions: [7, 5, 5]}")))
    area = dict(zip(mesh.surface_names,
                    np.bincount(mesh.bface_side, mesh.bface_area, len(mesh.surface_names))))
    want = {"flange.xmin": 0.3 * 0.05, "flange.xmax": 0.3 * 0.05, "web.xmin": 0.1 * 0.25,
            "web.xmax": 0.1 * 0.25, "flange.zmin": 0.3, "flange.zmax": 0.3 - 0.1,
            "flange.ymin": 0.05, "flange.ymax": 0.05, "web.ymin": 0.25, "web.ymax": 0.25,
            "web.zmax": 0.1}
    assert set(area) == set(want)
    for name, a in want.items():
        assert area[name] == pytest.approx(a, rel=1e-9), name
