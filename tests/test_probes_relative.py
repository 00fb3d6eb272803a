"""Probe ``quantity: relative_displacement``: the displacement of group (or
point) b minus that of a, as a component, the magnitude or along a
direction (CMOD, crack opening, an LVDT over a base length).

Facts checked, each against a formula:

* across a bar of blocks in tension (ν = 0) the stretch between two groups
  is F ℓ/(E A), ℓ the distance between their mean centroids (VERIFICATION
  A1: the lattice reproduces uniform strain exactly);
* a point probe reads the displacement of the material point of the body
  whose cell holds it, rotation included: in pure bending two points on
  the top and bottom faces above one another separate along the axis by
  θ h = M x h/(E I), twice what their cells' centroids do;
* the schema: every existing probe stays valid; bad input names its key.
"""
import textwrap

import numpy as np
import pytest

from rbsm_dyn.case import CaseError, load_case_text
from rbsm_dyn.model import build_model
from rbsm_dyn.solvers.output import point_body

E = 2.0e11


def bar(probes, F=1.0e4, units="SI"):
    """A 0.1 × 0.1 × 1 bar of 2 × 2 × 10 blocks clamped at z = 0, pulled by
    F at its top layer's centroids; groups a (centroids at z = 0.25) and
    b (z = 0.75)."""
    return textwrap.dedent(f"""\
        name: bar
        units: {units}
        domain: {{box: [[0, 0, 0], [0.1, 0.1, 1.0]]}}
        mesh: {{kind: blocks, divisions: [2, 2, 10]}}
        materials:
          steel: {{density: 7800, young: {E}, poisson: 0.0}}
        groups:
          top: {{box: [[-1, -1, 0.9], [1, 1, 2]]}}
          a: {{box: [[-1, -1, 0.2], [1, 1, 0.3]]}}
          b: {{box: [[-1, -1, 0.7], [1, 1, 0.8]]}}
        boundary: [{{face: zmin, fix: all}}]
        loads: [{{group: top, force: [0, 0, {F}]}}]
        solver: {{mode: linear}}
        output:
          probes:
        """) + textwrap.indent(textwrap.dedent(probes), "    ")


def test_stretch_between_two_groups_of_a_bar_in_tension_is_F_l_over_EA(run_case):
    F, A = 1.0e4, 0.01
    h = run_case(bar("""\
        ab: {quantity: relative_displacement, groups: [a, b], component: z}
        ba: {quantity: relative_displacement, groups: [b, a], direction: [0, 0, 3]}
        mag: {quantity: relative_displacement, groups: [a, b], component: magnitude}
        side: {quantity: relative_displacement, groups: [a, b], component: x}
        pts: {quantity: relative_displacement, points: [[0.02, 0.03, 0.24], [0.07, 0.08, 0.77]],
              direction: [0, 0, 1]}
        old: {group: b, quantity: displacement, component: z, reduce: mean}
        """))
    x0 = h.static["particles/bodies/reference_position"]
    za = x0[(x0[:, 2] > 0.2) & (x0[:, 2] < 0.3), 2].mean()
    zb = x0[(x0[:, 2] > 0.7) & (x0[:, 2] < 0.8), 2].mean()
    ref = F * (zb - za) / (E * A)
    assert zb - za == pytest.approx(0.5)
    obs = h.observables
    assert h.units["observables/ab"] == "m"
    assert obs["ab"][0] == 0.0                              # frame 0: undeformed
    assert obs["ab"][-1] == pytest.approx(ref, rel=1e-6)
    assert obs["ba"][-1] == pytest.approx(-ref, rel=1e-6)   # b − a, along the unit direction
    assert obs["mag"][-1] == pytest.approx(ref, rel=1e-6)
    assert abs(obs["side"][-1]) < 1e-9 * ref
    # points: the material points of the cells holding them, here cells that
    # translate only: the stretch between the points' heights 0.24 and 0.77
    # (cells centred at 0.25 and 0.75: u is uniform within a cell)
    assert obs["pts"][-1] == pytest.approx(ref, rel=1e-6)
    # the existing probes are unchanged: u_z(b) = F z_b/(EA)
    assert obs["old"][-1] == pytest.approx(F * zb / (E * A), rel=1e-6)


def test_points_follow_the_rotation_of_their_cells_in_pure_bending(run_case):
    """A cantilever of 10 × 1 × 2 blocks (L = 1, b = h = 0.1, ν = 0)
    clamped at x = 0 under a tip moment M: the cell centred at x = 0.55 has
    rotated by θ = M x/(E I); two points on its column's bottom and top
    faces separate along x by θ h, the two cells' centroids (h/2 apart) by
    θ h/2."""
    M, b, hh = 1.0e3, 0.1, 0.1
    I = b * hh ** 3 / 12
    text = f"""
    name: bend
    domain: {{box: [[0, 0, 0], [1.0, {b}, {hh}]]}}
    mesh: {{kind: blocks, divisions: [10, 1, 2]}}
    materials:
      steel: {{density: 7800, young: {E}, poisson: 0.0}}
    groups:
      tip: {{box: [[0.9, -1, -1], [2, 1, 1]]}}
    boundary: [{{face: xmin, fix: all}}]
    loads: [{{group: tip, moment: [0, {M}, 0]}}]
    solver: {{mode: linear}}
    output:
      probes:
        lvdt: {{quantity: relative_displacement, points: [[0.55, 0.05, 0.0], [0.55, 0.05, 0.1]],
               direction: [1, 0, 0]}}
        centroids: {{quantity: relative_displacement,
                    points: [[0.55, 0.05, 0.025], [0.55, 0.05, 0.075]], component: x}}
    """
    h = run_case(text)
    theta = M * 0.55 / (E * I)
    assert h.observables["lvdt"][-1] == pytest.approx(theta * hh, rel=1e-6)
    assert h.observables["centroids"][-1] == pytest.approx(theta * hh / 2, rel=1e-6)


def test_a_point_is_read_on_the_cell_that_holds_it():
    """Random points of a Voronoi cube: the cell point_body returns (by
    winding numbers) has the point on the inner side of the plane of each of
    its polygons (the cells are convex; the plane by Newell's normal)."""
    text = """
    name: cube
    domain: {box: [[0, 0, 0], [0.1, 0.1, 0.1]]}
    mesh: {kind: voronoi, size: 0.02, seed: 5}
    materials:
      m: {density: 2400, young: 3.0e10, poisson: 0.2}
    solver: {mode: linear}
    """
    mesh = build_model(load_case_text(textwrap.dedent(text))).mesh
    rng = np.random.default_rng(0)
    for p in rng.uniform(0, 0.1, (20, 3)):
        c = point_body(mesh, p)
        for q in range(mesh.cell_poly_ptr[c], mesh.cell_poly_ptr[c + 1]):
            v = mesh.vertices[mesh.poly_vertex[mesh.poly_ptr[q]:mesh.poly_ptr[q + 1]]]
            normal = np.cross(v, np.roll(v, -1, axis=0)).sum(axis=0)   # outward
            assert (p - v.mean(axis=0)) @ normal <= 1e-12 * np.linalg.norm(normal)
    assert point_body(mesh, [0.2, 0.05, 0.05]) is None          # outside every cell


def test_a_point_outside_the_solid_lies_in_no_cell_and_the_run_says_so(run_case, tmp_path,
                                                                        capsys):
    """A notched beam (a box minus a notch): the notch's mouth corners on
    the bottom face belong to the cells beside the notch; a point in the
    notch, inside the bounds, to none, and a run with it exits 2 naming
    the point's key (the history says why it failed)."""
    from rbsm_dyn.__main__ import main
    text = textwrap.dedent("""\
        name: notch
        domain:
          difference:
            - {box: [[0, 0, 0], [0.2, 0.05, 0.05]], name: beam}
            - {box: [[0.095, -0.01, 0.0], [0.105, 0.06, 0.02]], name: notch}
        mesh: {kind: blocks, divisions: [8, 2, 2]}
        materials:
          c: {density: 2400, young: 3.0e10, poisson: 0.0}
        boundary: [{surface: beam.xmin, fix: all}]
        solver: {mode: linear}
        output:
          probes:
            cmod: {quantity: relative_displacement, points: [[0.095, 0.025, 0], [0.105, 0.025, 0]],
                   component: x}
        """)
    mesh = build_model(load_case_text(text)).mesh
    left, right = point_body(mesh, [0.095, 0.025, 0]), point_body(mesh, [0.105, 0.025, 0])
    assert mesh.cell_centroid[left, 0] < 0.095 < 0.105 < mesh.cell_centroid[right, 0]
    assert point_body(mesh, [0.1, 0.025, 0.01]) is None
    path = tmp_path / "void.yaml"
    path.write_text(text.replace("[0.095, 0.025, 0], [0.105", "[0.1, 0.025, 0.01], [0.105"))
    assert main([str(path), "--out", str(tmp_path / "void.h5"), "--quiet"]) == 2
    err = capsys.readouterr().err
    assert "output.probes.cmod.points[0]: lies in no cell" in err


def test_points_in_mm_are_converted():
    case = load_case_text(bar("""\
        d: {quantity: relative_displacement, points: [[50, 50, 250], [50, 50, 750]],
            component: z}
        """).replace("[[0, 0, 0], [0.1, 0.1, 1.0]]", "[[0, 0, 0], [100, 100, 1000]]")
            .replace("0.2], [1, 1, 0.3]", "200], [1, 1, 300]").replace("0.7], [1, 1, 0.8]",
                                                                         "700], [1, 1, 800]")
            .replace("0.9], [1, 1, 2]", "900], [1, 1, 2000]").replace("units: SI",
                                                                     "units: mm-N-s")
            .replace(f"young: {E}", "young: 2.0e5").replace("density: 7800",
                                                           "density: 7.8e-9"))
    assert case.output.probes["d"].points == [[0.05, 0.05, 0.25], [0.05, 0.05, 0.75]]


@pytest.mark.parametrize("probe, key, message", [
    ("{quantity: relative_displacement, groups: [a], component: z}",
     "output.probes.d.groups", "expected 2 values [group_a, group_b] (got 1)"),
    ("{quantity: relative_displacement, groups: [a, c], component: z}",
     "output.probes.d.groups[1]", "unknown group 'c'"),
    ("{quantity: relative_displacement, groups: a, component: z}",
     "output.probes.d.groups", "expected a list"),
    ("{quantity: relative_displacement, component: z}",
     "output.probes.d", "required key missing: groups or points"),
    ("{quantity: relative_displacement, groups: [a, b]}",
     "output.probes.d", "required key missing: component or direction"),
    ("{quantity: relative_displacement, groups: [a, b], points: [[0, 0, 0], [0, 0, 1]],"
     " component: z}", "output.probes.d.points", "either groups or points"),
    ("{quantity: relative_displacement, groups: [a, b], component: z, direction: [0, 0, 1]}",
     "output.probes.d.direction", "either component or direction"),
    ("{quantity: relative_displacement, groups: [a, b], direction: [0, 0, 0]}",
     "output.probes.d.direction", "must not be the zero vector"),
    ("{quantity: relative_displacement, groups: [a, a], component: z}",
     "output.probes.d.groups[1]", "the same group"),
    ("{quantity: relative_displacement, points: [[0, 0, 0], [0, 0, 1.5]], component: z}",
     "output.probes.d.points[1]", "lies outside the domain"),
    ("{quantity: relative_displacement, points: [[0, 0, 0]], component: z}",
     "output.probes.d.points", "expected 2 values"),
    ("{quantity: relative_displacement, groups: [a, b], component: z, reduce: mean}",
     "output.probes.d.reduce", "unknown key 'reduce'"),
    ("{quantity: relative_displacement, group: a, component: z}",
     "output.probes.d.group", "unknown key 'group'"),
    ("{group: a, quantity: relative_displacment, component: z, reduce: mean}",
     "output.probes.d.quantity", "relative_displacement"),
    ("{group: a, quantity: displacement, component: z}",
     "output.probes.d.reduce", "required key missing"),
])
def test_bad_probes_name_the_key(probe, key, message):
    with pytest.raises(CaseError) as exc:
        load_case_text(bar(f"d: {probe}\n"), "case.yaml")
    e = exc.value
    assert e.path == key and message in e.message, str(e)
    assert e.line == 16                                  # the probe's line


def test_points_either_side_of_a_cut_in_cells_on_one_side_are_warned(tmp_path, capsys):
    """A crack-mouth probe whose two points lie either side of a cut's
    plane but in cells whose centroids lie on one side (the cut splits the
    springs by centroid side, so it measures no opening) gets a warning
    naming the probe and the cut; points a cell away from the plane do not."""
    from rbsm_dyn.__main__ import main
    text = """
    name: cut-probe
    domain: {box: [[0, 0, 0], [0.04, 0.01, 0.01]]}
    mesh: {kind: blocks, divisions: [4, 1, 1]}
    materials:
      m: {density: 2400, young: 30.0e9, poisson: 0.0}
    cuts:
      - {point: [0.015, 0, 0], normal: [1, 0, 0], within: [[0, -1, -1], [1, 1, 1]]}
    boundary:
      - {face: xmin, fix: all}
    solver: {mode: dynamic, end_time: 1.0e-6}
    output:
      probes:
        mouth: {quantity: relative_displacement, points: [[POINTS]], component: x}
    """
    for points, warned in (("0.012, 0.005, 0.005], [0.018, 0.005, 0.005", True),
                           ("0.005, 0.005, 0.005], [0.025, 0.005, 0.005", False)):
        path = tmp_path / "c.yaml"
        path.write_text(textwrap.dedent(text).replace("POINTS", points))
        assert main(["check", str(path)]) == 0
        err = capsys.readouterr().err
        assert ("output.probes.mouth: its points lie either side of cuts[0]" in err) == warned, err
