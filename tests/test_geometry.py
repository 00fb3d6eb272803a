"""rbsm_dyn.geometry: primitives, booleans, files -> closed faceted solids
with named surfaces.  Every reference value is a formula (source beside it)."""
import math
import sys
import types

import numpy as np
import pytest

from rbsm_dyn.geometry import (GeometryError, Solid, build_solid, circle_segments,
                               sphere_segments)
from rbsm_dyn.geometry.errors import format_path

CHORD = 2e-4


def sagitta(r, n):
    """Chord error of a regular n-gon inscribed in a circle of radius r."""
    return r * (1 - math.cos(math.pi / n))


def ngon_area(r, n):
    """Area of a regular n-gon inscribed in a circle of radius r: n isosceles
    triangles of apex angle 2 pi/n, (n/2) r² sin(2 pi/n)."""
    return 0.5 * n * r * r * math.sin(2 * math.pi / n)


def ngon_perimeter(r, n):
    return 2 * n * r * math.sin(math.pi / n)


def shoelace(p):
    p = np.asarray(p, float)
    q = np.roll(p, -1, axis=0)
    return 0.5 * abs(np.sum(p[:, 0] * q[:, 1] - q[:, 0] * p[:, 1]))


def normals(solid, name):
    return solid.triangle_normals[solid.surface(name)]


def face_id(solid):
    return np.asarray(solid.manifold.to_mesh64().face_id, dtype=np.int64)


def rel(a, b):
    return abs(a - b) / abs(b)


# -- faceting rules -----------------------------------------------------------------

@pytest.mark.parametrize("r", [1e-3, 0.05, 0.1, 1.0, 7.3])
@pytest.mark.parametrize("chord", [1e-5, 1e-4, 1e-3, 0.1])
def test_circle_segments_is_the_smallest_n_within_the_chord(r, chord):
    n = circle_segments(r, chord)
    assert n >= 8
    assert sagitta(r, n) <= chord
    assert n == 8 or sagitta(r, n - 1) > chord


def test_cylinder_has_n_segments_of_the_circle_rule():
    r, chord = 0.05, 1e-4
    n = circle_segments(r, chord)
    s = build_solid({"cylinder": {"base": [0, 0, 0], "axis": [0, 0, 0.2], "radius": r}},
                    chord=chord)
    assert len(s.triangles) == 4 * n                  # n + n cap fans, 2n side
    assert np.count_nonzero(s.surface("side")) == 2 * n


def test_sphere_facets_stay_within_the_chord_and_n_is_smallest():
    from rbsm_dyn.geometry.primitives import sphere_facets
    r, chord = 0.05, 1e-4
    n = sphere_segments(r, chord)

    def deviation(v, t):
        # distance from the sphere to a facet <= its cap height r - sqrt(r² - ρ²),
        # ρ the circumradius |ab||bc||ca| / (4 area)
        a, b, c = (v[t[:, i]] for i in range(3))
        rho = (np.linalg.norm(b - a, axis=1) * np.linalg.norm(c - b, axis=1)
               * np.linalg.norm(a - c, axis=1)
               / (2 * np.linalg.norm(np.cross(b - a, c - a), axis=1)))
        return np.max(r - np.sqrt(r * r - rho * rho))

    s = build_solid({"sphere": {"center": [0.1, 0, 0], "radius": r}}, chord=chord)
    assert n % 2 == 0 and n >= 8
    assert deviation(s.vertices - [0.1, 0, 0], s.triangles) <= chord
    f = sphere_facets([0, 0, 0], r, n - 2)
    assert deviation(f.vertices, f.triangles) > chord


# -- primitives ------------------------------------------------------------------

def test_box_volume_faces_and_mass_properties():
    lo, hi = np.array([0.1, -0.2, 0.3]), np.array([0.6, 0.1, 0.5])
    a, b, c = hi - lo
    s = build_solid({"box": [lo.tolist(), hi.tolist()]}, chord=CHORD)
    assert isinstance(s, Solid)
    assert s.surface_names == tuple(f"box0.{f}" for f in
                                    ("xmin", "xmax", "ymin", "ymax", "zmin", "zmax"))
    assert rel(s.volume, a * b * c) < 1e-12
    np.testing.assert_array_equal(s.bounds, [lo, hi])
    for f, area, n in [("xmin", b * c, [-1, 0, 0]), ("xmax", b * c, [1, 0, 0]),
                       ("ymin", a * c, [0, -1, 0]), ("ymax", a * c, [0, 1, 0]),
                       ("zmin", a * b, [0, 0, -1]), ("zmax", a * b, [0, 0, 1])]:
        assert rel(s.area(f), area) < 1e-12
        np.testing.assert_allclose(normals(s, f), np.tile(n, (2, 1)), atol=1e-15)
    # inertia of a cuboid per unit density: V/12 (b² + c², a² + c², a² + b²)
    vol, cen, inertia = s.mass_properties()
    assert rel(vol, a * b * c) < 1e-12
    np.testing.assert_allclose(cen, 0.5 * (lo + hi), rtol=0, atol=1e-15)
    np.testing.assert_allclose(inertia, np.diag([b * b + c * c, a * a + c * c, a * a + b * b])
                               * a * b * c / 12, rtol=0, atol=1e-13 * a * b * c * a * a)
    np.testing.assert_array_equal(face_id(s), s.tri_surface)


@pytest.mark.parametrize("axis", [[0, 0, 0.3], [0.3, 0, 0], [0.1, -0.2, 0.25]])
def test_cylinder_volume_areas_normals_and_inertia(axis):
    r, base = 0.04, np.array([0.01, 0.02, -0.03])
    axis = np.array(axis, float)
    length = np.linalg.norm(axis)
    e = axis / length
    n = circle_segments(r, CHORD)
    s = build_solid({"cylinder": {"base": base.tolist(), "axis": axis.tolist(), "radius": r}},
                    chord=CHORD)
    assert s.surface_names == ("cylinder0.bottom", "cylinder0.top", "cylinder0.side")
    # faceted: regular n-gon prism
    assert rel(s.volume, ngon_area(r, n) * length) < 1e-12
    # smooth: the n-gon contains the circle of radius r cos(pi/n) >= r - chord
    smooth = math.pi * r * r * length
    assert 0 < smooth - s.volume <= math.pi * (r * r - (r - CHORD) ** 2) * length
    assert rel(s.area("top"), ngon_area(r, n)) < 1e-12
    assert rel(s.area("bottom"), ngon_area(r, n)) < 1e-12
    assert rel(s.area("side"), ngon_perimeter(r, n) * length) < 1e-12
    np.testing.assert_allclose(normals(s, "top"), np.tile(e, (n, 1)), atol=1e-14)
    np.testing.assert_allclose(normals(s, "bottom"), np.tile(-e, (n, 1)), atol=1e-14)
    ns = normals(s, "side")
    assert np.max(np.abs(ns @ e)) < 1e-14
    cent = s.vertices[s.triangles[s.surface("side")]].mean(axis=1) - base
    radial = cent - np.outer(cent @ e, e)
    assert np.all(np.einsum("ij,ij->i", radial, ns) > 0)      # outward
    # inertia of a regular n-gon prism: centroidal in-plane second moment of
    # the n-gon I_c = (A/24)(6 r² - a²), a = side (Roark, Table A.1);
    # I_axis = 2 I_c L, I_transverse = I_c L + A L³/12
    area, side = ngon_area(r, n), 2 * r * math.sin(math.pi / n)
    ic = area / 24 * (6 * r * r - side * side)
    want = (ic * length + area * length ** 3 / 12) * (np.eye(3) - np.outer(e, e)) \
        + 2 * ic * length * np.outer(e, e)
    vol, cen, inertia = s.mass_properties()
    np.testing.assert_allclose(cen, base + axis / 2, rtol=0, atol=1e-15)
    np.testing.assert_allclose(inertia, want, rtol=0, atol=1e-12 * np.abs(want).max())


def test_sphere_volume_and_area_of_its_latitude_bands():
    r, c = 0.05, np.array([0.2, -0.1, 0.3])
    s = build_solid({"sphere": {"center": c.tolist(), "radius": r}}, chord=CHORD)
    n = sphere_segments(r, CHORD)
    m = n // 2
    phi = np.pi * np.arange(m + 1) / m
    rho, z = r * np.sin(phi), r * np.cos(phi)
    a_ring = 0.5 * n * rho ** 2 * math.sin(2 * math.pi / n)
    h = z[:-1] - z[1:]
    # every band is a frustum of a regular n-gon pyramid:
    # V = h/3 (A1 + A2 + sqrt(A1 A2)) (frustum formula)
    vol = np.sum(h / 3 * (a_ring[:-1] + a_ring[1:] + np.sqrt(a_ring[:-1] * a_ring[1:])))
    assert rel(s.volume, vol) < 1e-12
    # its faces are isosceles trapezoids (triangles at the poles): parallel sides
    # 2 rho sin(pi/n), apothems rho cos(pi/n)
    edge = 2 * rho * math.sin(math.pi / n)
    slant = np.hypot(h, (rho[:-1] - rho[1:]) * math.cos(math.pi / n))
    assert rel(s.area("surface"), n * np.sum(0.5 * (edge[:-1] + edge[1:]) * slant)) < 1e-12
    # the facets are at least r - chord from the centre: ball of r - chord inside
    assert 4 / 3 * math.pi * (r - CHORD) ** 3 <= s.volume < 4 / 3 * math.pi * r ** 3
    vol_, cen, inertia = s.mass_properties()
    np.testing.assert_allclose(cen, c, rtol=0, atol=1e-15)
    # solid sphere 2/5 m r² (per unit density), faceted within the chord
    assert np.allclose(inertia, np.eye(3) * 0.4 * vol * r * r, rtol=0,
                       atol=5 * CHORD / r * 0.4 * vol * r * r)


L_PANEL = [[0, 0], [0.5, 0], [0.5, 0.25], [0.25, 0.25], [0.25, 0.5], [0, 0.5]]


@pytest.mark.parametrize("reverse", [False, True])
def test_l_panel_prism_sides_named_by_input_edge(reverse):
    poly = L_PANEL[::-1] if reverse else L_PANEL
    t0, t1 = -0.01, 0.04
    s = build_solid({"prism": {"polygon": poly, "axis": "z", "from": t0, "to": t1},
                     "name": "panel"}, chord=CHORD)
    length = t1 - t0
    assert rel(s.volume, shoelace(poly) * length) < 1e-12
    assert rel(s.area("panel.top"), shoelace(poly)) < 1e-12
    assert rel(s.area("bottom"), shoelace(poly)) < 1e-12
    p = np.asarray(poly, float)
    for i in range(len(p)):
        a, b = p[i], p[(i + 1) % len(p)]
        name = f"panel.side{i}"
        assert rel(s.area(name), np.linalg.norm(b - a) * length) < 1e-12
        # the side lies on the vertical plane through the edge, facing out of the panel
        d = (b - a) / np.linalg.norm(b - a)
        nrm = np.array([d[1], -d[0], 0.0])
        if reverse:
            nrm = -nrm                    # the reversed list runs clockwise
        np.testing.assert_allclose(normals(s, name), np.tile(nrm, (2, 1)), atol=1e-15)
        v = s.vertices[s.triangles[s.surface(name)]].reshape(-1, 3)
        assert np.max(np.abs(np.cross(np.c_[v[:, :2] - a, np.zeros(len(v))],
                                      np.r_[d, 0])[:, 2])) < 1e-15


@pytest.mark.parametrize("axis,perm", [("x", (1, 2, 0)), ("y", (2, 0, 1)), ("z", (0, 1, 2))])
def test_prism_with_a_hole_along_each_axis(axis, perm):
    outer = [[0, 0], [0.4, 0], [0.4, 0.2], [0, 0.2]]
    hole = [[0.1, 0.05], [0.1, 0.15], [0.3, 0.15], [0.3, 0.05]]      # either orientation
    s = build_solid({"prism": {"polygon": outer, "holes": [hole], "axis": axis,
                               "from": 0.0, "to": 0.1}}, chord=CHORD)
    assert rel(s.volume, (shoelace(outer) - shoelace(hole)) * 0.1) < 1e-12
    lo, hi = np.zeros(3), np.zeros(3)
    lo[list(perm)] = [0, 0, 0.0]
    hi[list(perm)] = [0.4, 0.2, 0.1]
    np.testing.assert_array_equal(s.bounds, [lo, hi])
    h = np.asarray(hole, float)
    centre = np.zeros(3)
    centre[list(perm)] = [0.2, 0.1, 0.05]
    for i in range(4):
        name = f"hole0.side{i}"
        assert rel(s.area(name), np.linalg.norm(h[(i + 1) % 4] - h[i]) * 0.1) < 1e-12
        c = s.vertices[s.triangles[s.surface(name)]].mean(axis=1)
        assert np.all(np.einsum("ij,ij->i", centre - c, normals(s, name)) > 0)  # into the hole
    assert rel(s.area("top"), shoelace(outer) - shoelace(hole)) < 1e-12


# -- booleans ------------------------------------------------------------------------

def notched_beam():
    return {"difference": [
        {"box": [[0, 0, 0], [0.5, 0.1, 0.1]], "name": "beam"},
        {"box": [[0.248, -0.01, 0.0], [0.252, 0.11, 0.03]], "name": "notch"}]}


def test_notched_beam_faces_of_the_notch():
    s = build_solid(notched_beam(), chord=CHORD)
    w, d = 0.004, 0.03
    assert rel(s.volume, 0.5 * 0.1 * 0.1 - w * 0.1 * d) < 1e-12
    for name, area, n in [("notch.xmin", 0.1 * d, [1, 0, 0]), ("notch.xmax", 0.1 * d, [-1, 0, 0]),
                          ("notch.zmax", 0.1 * w, [0, 0, -1]),
                          ("beam.zmin", 0.5 * 0.1 - w * 0.1, [0, 0, -1]),
                          ("beam.ymin", 0.5 * 0.1 - w * d, [0, -1, 0]),
                          ("beam.ymax", 0.5 * 0.1 - w * d, [0, 1, 0]),
                          ("beam.xmin", 0.1 * 0.1, [-1, 0, 0])]:
        assert rel(s.area(name), area) < 1e-12, name
        assert np.all(normals(s, name) @ n > 1 - 1e-15), name
    # the notch's own bottom is flush with the beam's: removed with its sides
    assert set(s.removed_surfaces) == {"notch.ymin", "notch.ymax", "notch.zmin"}
    # the box's area, less the notch's mouth (bottom) and its two ends (y faces),
    # plus its walls and roof
    assert rel(s.area(None), 2 * (0.5 * 0.1 + 0.5 * 0.1 + 0.1 * 0.1) - w * 0.1 - 2 * w * d
               + 2 * 0.1 * d + w * 0.1) < 1e-12
    np.testing.assert_array_equal(face_id(s), s.tri_surface)
    # bare names: zmin is the beam's alone; xmin is two faces
    assert np.array_equal(s.surface("zmin"), s.surface("beam.zmin"))
    assert np.array_equal(s.surface("notch"), s.surface("notch.xmin") | s.surface("notch.xmax")
                          | s.surface("notch.zmax"))
    with pytest.raises(GeometryError, match=r"'xmin' is ambiguous: beam.xmin, notch.xmin"):
        s.surface("xmin")
    with pytest.raises(GeometryError, match=r"not on the solid's surface \(notch.zmin removed"):
        s.surface("notch.zmin")
    with pytest.raises(GeometryError, match=r"no surface 'top'; surfaces: beam.xmin"):
        s.surface("top")
    # planar faces stay exactly planar (merging into polygons later)
    for i, name in enumerate(s.surface_names):
        v = s.vertices[np.unique(s.triangles[s.tri_surface == i])]
        n = s.triangle_normals[s.tri_surface == i][0]
        assert np.ptp(v @ n) <= 1e-16, name


def test_plate_with_a_hole():
    t, r = 0.01, 0.02
    s = build_solid({"difference": [
        {"box": [[0, 0, 0], [0.2, 0.1, t]]},
        {"cylinder": {"base": [0.1, 0.05, -t], "axis": [0, 0, 3 * t], "radius": r},
         "name": "hole"}]}, chord=CHORD)
    n = circle_segments(r, CHORD)
    assert s.surface_names == ("box0.xmin", "box0.xmax", "box0.ymin", "box0.ymax", "box0.zmin",
                               "box0.zmax", "hole.side")
    assert set(s.removed_surfaces) == {"hole.bottom", "hole.top"}
    assert rel(s.volume, (0.2 * 0.1 - ngon_area(r, n)) * t) < 1e-12
    assert rel(s.area("hole.side"), ngon_perimeter(r, n) * t) < 1e-12
    assert rel(s.area("zmax"), 0.2 * 0.1 - ngon_area(r, n)) < 1e-12
    ns = normals(s, "side")
    c = s.vertices[s.triangles[s.surface("side")]].mean(axis=1)
    assert np.all(np.abs(ns[:, 2]) < 1e-15)
    assert np.all(np.einsum("ij,ij->i", ns, [0.1, 0.05, 0] - c * [1, 1, 0]) > 0)   # to the axis


def test_thick_walled_pipe_with_flush_ends():
    a, b, length = 0.05, 0.1, 0.3
    cyl = {"base": [0, 0, 0], "axis": [0, 0, length]}
    s = build_solid({"difference": [{"cylinder": {**cyl, "radius": b}, "name": "outer"},
                                    {"cylinder": {**cyl, "radius": a}, "name": "inner"}]},
                    chord=CHORD)
    nb, na = circle_segments(b, CHORD), circle_segments(a, CHORD)
    ring = ngon_area(b, nb) - ngon_area(a, na)
    assert rel(s.volume, ring * length) < 1e-12
    assert s.surface_names == ("outer.bottom", "outer.top", "outer.side", "inner.side")
    assert rel(s.area("outer.top"), ring) < 1e-12
    assert rel(s.area("bottom"), ring) < 1e-12
    assert rel(s.area("outer.side"), ngon_perimeter(b, nb) * length) < 1e-12
    assert rel(s.area("inner.side"), ngon_perimeter(a, na) * length) < 1e-12
    c = s.vertices[s.triangles[s.surface("inner.side")]].mean(axis=1)
    assert np.all(np.einsum("ij,ij->i", normals(s, "inner.side"), -c * [1, 1, 0]) > 0)
    # smooth annulus within the chord bound of each circle
    assert 0 < math.pi * b * b * length - ngon_area(b, nb) * length \
        <= math.pi * (b * b - (b - CHORD) ** 2) * length


def test_union_and_intersection_of_boxes():
    a = {"box": [[0, 0, 0], [0.2, 0.1, 0.1]]}
    b = {"box": [[0.1, 0.05, -0.05], [0.3, 0.2, 0.05]]}
    overlap = 0.1 * 0.05 * 0.05
    u = build_solid({"union": [a, b]}, chord=CHORD)
    i = build_solid({"intersection": [a, b]}, chord=CHORD)
    assert rel(u.volume, 0.2 * 0.1 * 0.1 + 0.2 * 0.15 * 0.1 - overlap) < 1e-12
    assert rel(i.volume, overlap) < 1e-12
    assert u.surface_names[0] == "box0.xmin"
    assert i.surface_names == ("box0.xmax", "box0.ymax", "box0.zmin", "box1.xmin", "box1.ymin",
                               "box1.zmax")
    # the intersection's top is box1's zmax, its xmin box1's xmin, its xmax box0's
    np.testing.assert_allclose(i.bounds, [[0.1, 0.05, 0], [0.2, 0.1, 0.05]])
    assert rel(i.area("box1.zmax"), 0.1 * 0.05) < 1e-12
    assert rel(i.area("box0.xmax"), 0.05 * 0.05) < 1e-12


# -- selectors ------------------------------------------------------------------

def test_surface_selectors_on_a_node_and_on_the_solid():
    spec = {"box": [[0, 0, 0], [0.4, 0.1, 0.1]], "name": "beam",
            "surfaces": {"top": {"plane": {"point": [0, 0, 0.1], "normal": [0, 0, 1]}},
                         "ends": {"normal": [1, 0, 0], "angle": 90.0, "box": [[0.3, -1, -1],
                                                                              [1, 1, 1]]}}}
    s = build_solid(spec, chord=CHORD)
    assert s.surface_names == ("beam.xmin", "beam.ymin", "beam.ymax", "beam.zmin",
                               "beam.top", "beam.ends")
    assert rel(s.area("top"), 0.4 * 0.1) < 1e-12
    assert rel(s.area("beam.ends"), 0.1 * 0.1) < 1e-12       # the xmax face
    assert np.array_equal(s.surface({"normal": [0, 0, 1]}), s.surface("top"))
    assert not s.surface({"plane": {"point": [0, 0, 0.05], "normal": [0, 0, 1]}}).any()
    with pytest.raises(GeometryError, match=r"surfaces.nothing: selects no triangles"):
        build_solid({"box": [[0, 0, 0], [1, 1, 1]],
                     "surfaces": {"nothing": {"box": [[2, 2, 2], [3, 3, 3]]}}}, chord=CHORD)


def test_selector_on_a_boolean_names_the_boolean_node():
    spec = notched_beam()
    spec["name"] = "specimen"
    spec["surfaces"] = {"bottom": {"normal": [0, 0, -1]}}
    s = build_solid(spec, chord=CHORD)
    assert "specimen.bottom" in s.surface_names
    # the first selector takes beam.zmin and the notch's roof, which both face down
    assert rel(s.area("specimen.bottom"), 0.5 * 0.1) < 1e-12
    assert "beam.zmin" in s.removed_surfaces and "notch.zmax" in s.removed_surfaces
    np.testing.assert_array_equal(face_id(s), s.tri_surface)


# -- point location -------------------------------------------------------------

def test_contains_on_lattice_points_through_edges_and_vertices():
    # (x, y) on the projections of the box's edges, vertices and face diagonals
    s = build_solid({"box": [[0, 0, 0], [1, 1, 1]]}, chord=CHORD)
    g = np.linspace(-0.25, 1.25, 7)                       # includes 0, 0.5, 1
    x, y, z = np.meshgrid(g, g, np.linspace(-0.3, 1.3, 9), indexing="ij")
    p = np.stack([x, y, z], axis=-1).reshape(-1, 3)
    on_surface = np.any((p == 0) | (p == 1), axis=1)
    inside = np.all((p > 0) & (p < 1), axis=1)
    got = s.contains(p)
    assert np.array_equal(got[~on_surface], inside[~on_surface])


@pytest.mark.parametrize("spec", [
    {"cylinder": {"base": [0.1, 0, 0], "axis": [0.1, 0.2, 0.3], "radius": 0.05}},
    {"sphere": {"center": [0, 0, 0], "radius": 0.1}},
    {"prism": {"polygon": L_PANEL, "axis": "y", "from": 0, "to": 0.1}},
    notched_beam(),
])
def test_contains_points_just_off_the_surface(spec):
    s = build_solid(spec, chord=1e-3)
    c = s.vertices[s.triangles].mean(axis=1)
    eps = 1e-9
    inner = s.contains(c - eps * s.triangle_normals)
    outer = s.contains(c + eps * s.triangle_normals)
    assert inner.all() and not outer.any()


def test_contains_against_the_faceted_halfspaces_of_a_convex_solid():
    s = build_solid({"cylinder": {"base": [0, 0, 0], "axis": [0.3, 0.1, -0.2], "radius": 0.07}},
                    chord=1e-4)
    p = np.random.default_rng(1).uniform(*s.bounds, size=(20000, 3))
    v0 = s.vertices[s.triangles[:, 0]]
    # convex: inside iff behind every facet plane
    dist = np.einsum("tj,tj->t", s.triangle_normals, v0)[None, :] - p @ s.triangle_normals.T
    want = np.all(dist > 0, axis=1)
    clear = np.min(np.abs(dist), axis=1) > 1e-12
    assert np.array_equal(s.contains(p)[clear], want[clear])
    assert s.contains(p.reshape(100, 200, 3)).shape == (100, 200)


# -- files -----------------------------------------------------------------------

def write(solid, path, **kw):
    import trimesh
    trimesh.Trimesh(solid.vertices, solid.triangles, process=False).export(str(path), **kw)
    return str(path)


def test_stl_of_a_primitive_reads_back_the_same_solid(tmp_path):
    # STL stores float32: dyadic coordinates are exact in it
    spec = {"prism": {"polygon": [[0, 0], [0.5, 0], [0.5, 0.25], [0.25, 0.25], [0.25, 0.5],
                                  [0, 0.5]], "axis": "x", "from": -0.125, "to": 0.375}}
    prim = build_solid(spec, chord=CHORD)
    f = build_solid({"file": write(prim, tmp_path / "panel.stl")}, chord=CHORD)
    assert rel(f.volume, prim.volume) < 1e-12
    np.testing.assert_allclose(f.bounds, prim.bounds, rtol=0, atol=1e-12)
    assert f.surface_names == ("file0.surface",)
    assert np.array_equal(f.surface("surface"), np.ones(len(f.triangles), bool))
    assert np.array_equal(f.surface("file0"), f.surface("surface"))
    assert rel(f.area(), prim.area()) < 1e-12
    # in millimetres, scaled to metres
    mm = build_solid({"box": [[0, 0, 0], [500, 100, 125]]}, chord=CHORD)
    f = build_solid({"file": write(mm, tmp_path / "beam_mm.stl"), "scale": 1e-3,
                     "name": "beam"}, chord=CHORD)
    assert rel(f.volume, 0.5 * 0.1 * 0.125) < 1e-12
    assert f.surface_names == ("beam.surface",)


def test_obj_of_a_cylinder_reads_back_with_named_regions(tmp_path):
    spec = {"cylinder": {"base": [0.1, 0.2, 0.3], "axis": [0.3, 0.1, 0.5], "radius": 0.05}}
    prim = build_solid(spec, chord=CHORD)
    path = write(prim, tmp_path / "c.obj", digits=17)         # full float64 digits
    f = build_solid({"file": path, "name": "roller", "surfaces": {
        "top": {"normal": [0.3, 0.1, 0.5]},
        "bottom": {"plane": {"point": [0.1, 0.2, 0.3], "normal": [0.3, 0.1, 0.5]}}}},
        chord=CHORD)
    assert rel(f.volume, prim.volume) < 1e-12
    np.testing.assert_allclose(f.bounds, prim.bounds, rtol=0, atol=1e-12)
    assert f.surface_names == ("roller.surface", "roller.top", "roller.bottom")
    assert rel(f.area("top"), prim.area("top")) < 1e-12
    assert rel(f.area("roller.bottom"), prim.area("bottom")) < 1e-12
    assert rel(f.area("roller.surface"), prim.area("side")) < 1e-12


def test_difference_with_a_file(tmp_path):
    hole = build_solid({"cylinder": {"base": [0.1, 0.05, -0.01], "axis": [0, 0, 0.03],
                                     "radius": 0.02}}, chord=CHORD)
    path = write(hole, tmp_path / "hole.off", digits=17)
    s = build_solid({"difference": [{"box": [[0, 0, 0], [0.2, 0.1, 0.01]]},
                                    {"file": path, "name": "drill"}]}, chord=CHORD)
    n = circle_segments(0.02, CHORD)
    assert rel(s.volume, (0.02 - ngon_area(0.02, n)) * 0.01) < 1e-12
    assert rel(s.area("drill.surface"), ngon_perimeter(0.02, n) * 0.01) < 1e-12


def test_open_and_non_manifold_files_are_refused(tmp_path):
    import trimesh
    box = build_solid({"box": [[0, 0, 0], [1, 1, 1]]}, chord=CHORD)
    trimesh.Trimesh(box.vertices, box.triangles[1:], process=False).export(tmp_path / "open.stl")
    with pytest.raises(GeometryError, match=r"^union\[1\]\.file: open.stl is not a closed "
                                            r"surface: 3 edges border only one triangle"):
        build_solid({"union": [{"box": [[0, 0, 0], [1, 1, 1]]}, {"file": str(tmp_path / "open.stl")}]},
                    chord=CHORD)
    # two cubes sharing one edge: four triangles on it
    other = box.vertices + [1, 1, 0]
    trimesh.Trimesh(np.vstack([box.vertices, other]),
                    np.vstack([box.triangles, box.triangles + 8]),
                    process=False).export(tmp_path / "edge.stl")
    with pytest.raises(GeometryError, match=r"^file: edge.stl is not manifold: 1 edges"):
        build_solid({"file": str(tmp_path / "edge.stl")}, chord=CHORD)
    with pytest.raises(GeometryError, match=r"^file: file not found: .*nothere.stl"):
        build_solid({"file": str(tmp_path / "nothere.stl")}, chord=CHORD)


def test_files_with_flipped_triangles_are_oriented_outward(tmp_path):
    import trimesh
    box = build_solid({"box": [[0, 0, 0], [0.5, 0.25, 0.125]]}, chord=CHORD)
    inward = box.triangles[:, ::-1]
    one_flipped = box.triangles.copy()
    one_flipped[3] = one_flipped[3, ::-1]
    for name, tris in [("inward.off", inward), ("one_flipped.off", one_flipped)]:
        trimesh.Trimesh(box.vertices, tris, process=False).export(tmp_path / name)
        s = build_solid({"file": str(tmp_path / name)}, chord=CHORD)
        assert s.volume == 0.5 * 0.25 * 0.125
        assert s.contains([[0.25, 0.125, 0.0625]]).all()


def test_relative_file_paths_read_from_base_dir(tmp_path):
    box = build_solid({"box": [[0, 0, 0], [1, 2, 4]]}, chord=CHORD)
    write(box, tmp_path / "b.stl")
    s = build_solid({"file": "b.stl"}, chord=CHORD, base_dir=tmp_path)
    assert s.volume == 8.0


def test_meshio_formats_with_gmsh_physical_groups(tmp_path, monkeypatch):
    # a meshio stand-in (deterministic: meshio is optional): a box mesh with two
    # gmsh physical surfaces
    box = build_solid({"box": [[0, 0, 0], [1, 1, 1]]}, chord=CHORD)
    top = box.surface("zmax")
    tags = np.where(top, 1, 2)
    fake = types.SimpleNamespace(read=lambda path: types.SimpleNamespace(
        points=box.vertices, cells=[types.SimpleNamespace(type="triangle", data=box.triangles),
                                    types.SimpleNamespace(type="line", data=np.zeros((1, 2)))],
        cell_data={"gmsh:physical": [tags, np.zeros(1)]},
        field_data={"loaded": np.array([1, 2]), "rest": np.array([2, 2]),
                    "curve": np.array([1, 1])}))
    monkeypatch.setitem(sys.modules, "meshio", fake)
    (tmp_path / "box.msh").write_text("stand-in")
    s = build_solid({"file": str(tmp_path / "box.msh")}, chord=CHORD)
    assert s.surface_names == ("file0.loaded", "file0.rest")
    assert s.area("loaded") == 1.0 and s.area("rest") == 5.0
    monkeypatch.setitem(sys.modules, "meshio", None)         # not installed
    with pytest.raises(GeometryError, match=r"^file: cannot read '.msh' files: trimesh reads "
                                            r".*stl.*install meshio"):
        build_solid({"file": str(tmp_path / "box.msh")}, chord=CHORD)


def test_step_without_gmsh_names_the_extra(tmp_path, monkeypatch):
    monkeypatch.setitem(sys.modules, "gmsh", None)           # import gmsh -> ImportError
    (tmp_path / "part.step").write_text("ISO-10303-21;")
    with pytest.raises(GeometryError, match=r"^difference\[0\]\.file: reading .step \(CAD\) "
                                            r"files needs gmsh.*pip install rbsm_dyn\[cad\]"):
        build_solid({"difference": [{"file": str(tmp_path / "part.step")},
                                    {"box": [[0, 0, 0], [1, 1, 1]]}]}, chord=CHORD)


# -- errors --------------------------------------------------------------------------

@pytest.mark.parametrize("spec,path,message", [
    ({"difference": [{"box": [[0, 0, 0], [1, 1, 1]]},
                     {"cylinder": {"base": [0, 0, 0], "axis": [0, 0, 1], "radius": -0.1}}]},
     ("difference", 1, "cylinder", "radius"), "must be > 0 (got -0.1)"),
    ({"box": [[0, 0, 0], [1, 0, 1]]}, ("box",), "degenerate box: y1 must be > y0"),
    ({"box": [[0, 0, 0], [1, "1e-5", 1]]}, ("box", 1, 1), "must be a number (got '1e-5')"),
    ({"prism": {"polygon": [[0, 0], [1, 1], [1, 0], [0, 1]], "axis": "z", "from": 0, "to": 1}},
     ("prism", "polygon"), "self-intersecting polygon: edges 0 and 2 cross"),
    ({"prism": {"polygon": [[0, 0], [1, 0], [1, 1]], "holes": [[[2, 2], [3, 2], [3, 3]]],
                "axis": "z", "from": 0, "to": 1}},
     ("prism", "holes", 0), "hole lies outside the polygon"),
    ({"prism": {"polygon": [[0, 0], [2, 0], [2, 2], [0, 2]],
                "holes": [[[0.5, 0.5], [2, 0.5], [1, 1.5]]], "axis": "z", "from": 0, "to": 1}},
     ("prism", "holes", 0), "edge 0 touches edge 1 of the polygon"),
    ({"prism": {"polygon": [[0, 0], [4, 0], [4, 4], [0, 4]],
                "holes": [[[1, 1], [3, 1], [3, 3], [1, 3]], [[1.5, 1.5], [2, 1.5], [2, 2]]],
                "axis": "z", "from": 0, "to": 1}},
     ("prism", "holes", 1), "hole lies inside hole 0"),
    ({"prism": {"polygon": [[0, 0], [1, 0], [1, 1]], "axis": "w", "from": 0, "to": 1}},
     ("prism", "axis"), "must be x, y or z (got 'w')"),
    ({"prism": {"polygon": [[0, 0], [1, 0], [1, 1]], "axis": "z", "from": 1, "to": 1}},
     ("prism", "to"), "must be > from"),
    ({"intersection": [{"box": [[0, 0, 0], [1, 1, 1]]}, {"box": [[2, 0, 0], [3, 1, 1]]}]},
     ("intersection",), "empty result: the bodies do not overlap"),
    ({"difference": [{"box": [[0, 0, 0], [1, 1, 1]]}, {"box": [[-1, -1, -1], [2, 2, 2]]}]},
     ("difference",), "empty result"),
    ({"union": [{"cone": {"radius": 1}}]}, ("union", 0, "cone"), "unknown geometry kind"),
    ({"box": [[0, 0, 0], [1, 1, 1]], "colour": "red"}, ("colour",), "unknown key for a box"),
    ({"box": [[0, 0, 0], [1, 1, 1]], "sphere": {}}, (), "one geometry kind per node"),
    ({"sphere": {"center": [0, 0, 0], "radius": 1, "segments": 8}}, ("sphere", "segments"),
     "unknown key"),
    ({"cylinder": {"base": [0, 0, 0], "axis": [0, 0, 0], "radius": 1}}, ("cylinder", "axis"),
     "zero length"),
    ({"union": [{"box": [[0, 0, 0], [1, 1, 1]], "name": "a"},
                {"box": [[0, 0, 0], [2, 1, 1]], "name": "a"}]}, ("union", 1, "name"),
     "node name 'a' is used twice (also at union[0])"),
    ({"box": [[0, 0, 0], [1, 1, 1]], "name": "a.b"}, ("name",), "without dots"),
    ({"sphere": {"center": [0, 0, 0], "radius": 100.0}}, ("sphere", "radius"),
     "is the chord in metres?"),
])
def test_errors_name_the_path(spec, path, message):
    with pytest.raises(GeometryError) as err:
        build_solid(spec, chord=1e-4)
    assert err.value.path == path
    assert message in err.value.message
    assert str(err.value) == f"{format_path(path)}: {err.value.message}" if path \
        else str(err.value) == err.value.message


def test_error_text_uses_the_case_path_style():
    with pytest.raises(GeometryError) as err:
        build_solid({"difference": [{"box": [[0, 0, 0], [1, 1, 1]]},
                                    {"cylinder": {"base": [0, 0, 0], "axis": [0, 0, 1],
                                                  "radius": -2}}]}, chord=1e-3)
    assert str(err.value) == "difference[1].cylinder.radius: must be > 0 (got -2)"


def test_default_names_are_depth_first_post_order():
    s = build_solid({"union": [
        {"difference": [{"box": [[0, 0, 0], [1, 1, 1]]},
                        {"box": [[0.4, 0.4, 0.5], [0.6, 0.6, 2]]}]},
        {"sphere": {"center": [2, 0.5, 0.5], "radius": 0.5}}]}, chord=0.05)
    assert s.surface_names[:6] == tuple(f"box0.{f}" for f in
                                        ("xmin", "xmax", "ymin", "ymax", "zmin", "zmax"))
    assert s.surface_names[6:] == ("box1.xmin", "box1.xmax", "box1.ymin", "box1.ymax",
                                   "box1.zmin", "sphere3.surface")


def test_import_does_not_load_the_geometry_libraries():
    import subprocess
    code = ("import sys, rbsm_dyn.geometry; "
            "print(any(m in sys.modules for m in ('manifold3d', 'trimesh', 'numba')))")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert out.stdout.strip() == "False"
