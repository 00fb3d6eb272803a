"""A domain of any shape (issue 12): `domain:` takes a geometry node
(rbsm_dyn/geometry), its cells are clipped to the solid (mesh/clip.py) and
supports act on its named surfaces (`boundary: [{surface: name, fix}]`)."""
import textwrap

import numpy as np
import pytest

from rbsm_dyn.case import CaseError, load_case_text
from rbsm_dyn.model import build_mesh

E, P = 30.0e9, 1.0e5
R, L = 0.05, 0.2


def column(mesh="{kind: voronoi, size: 0.025, seed: 3}", units="", scale=1.0, support="bottom",
           extra=""):
    s = scale
    return f"""
    name: column
    {units}
    domain: {{cylinder: {{base: [0, 0, 0], axis: [0, 0, {L * s}], radius: {R * s}}}}}
    mesh: {mesh}
    materials:
      c: {{density: {2.4e-9 if units else 2400}, young: {E / (1e6 if units else 1)}, poisson: 0.0}}
    groups:
      top: {{box: [[{-s}, {-s}, {0.175 * s}], [{s}, {s}, {s}]]}}
      a: {{box: [[{-s}, {-s}, {0.05 * s}], [{s}, {s}, {0.075 * s}]]}}
      b: {{box: [[{-s}, {-s}, {0.125 * s}], [{s}, {s}, {0.15 * s}]]}}
    boundary: [{{surface: {support}, fix: all}}]
    loads: [{{group: top, force: [0, 0, {-P}]}}]
    solver: {{mode: linear}}
    output:
      probes:
        ab: {{groups: [a, b], quantity: relative_displacement, component: z}}
    {extra}
    """


def test_cylinder_mesh_fills_the_faceted_solid():
    """The cells of a Voronoi and a block cylinder fill the faceted
    cylinder: volumes sum to the n-gon prism's (n/2) r² sin(2π/n) L, to
    1e-9, with n the chord rule's segment count (chord 0.05 × the cell)."""
    from rbsm_dyn.geometry import circle_segments
    for mesh, h in (("{kind: voronoi, size: 0.025, seed: 3}", 0.025),
                    ("{kind: blocks, divisions: [4, 4, 8]}", 0.025)):
        case = load_case_text(column(mesh))
        m = build_mesh(case)
        n = circle_segments(R, 0.05 * h)
        assert m.cell_volume.sum() == pytest.approx(n / 2 * R ** 2 * np.sin(2 * np.pi / n) * L,
                                                    rel=1e-9)
        assert m.surface_names == case.domain._solid.surface_names
        bottom = m.bface_side == case.domain._solid.surface_ids("bottom")[0]
        assert m.bface_area[bottom].sum() == pytest.approx(n / 2 * R ** 2 * np.sin(2 * np.pi / n),
                                                           rel=1e-9)


def test_column_on_its_bottom_surface_strains_as_the_bar(run_case):
    """A Voronoi column (ν = 0) standing on a support on its surface
    `bottom`, pushed down at its top: the strain between two layers in its
    middle, from a relative_displacement probe over their mean centroid
    distance, is −P/(E A) within 3 % (A the faceted section; the calibrated
    Voronoi lattice reproduces E within 1-2 %, docs/calibration.md; 8 cells
    across, 760 cells)."""
    from rbsm_dyn.geometry import circle_segments
    h = run_case(column("{kind: voronoi, size: 0.0125, seed: 3}"))
    ref = h.static["particles/bodies/reference_position"]
    za = ref[(ref[:, 2] >= 0.05) & (ref[:, 2] <= 0.075), 2].mean()
    zb = ref[(ref[:, 2] >= 0.125) & (ref[:, 2] <= 0.15), 2].mean()
    n = circle_segments(R, 0.05 * 0.0125)
    area = n / 2 * R ** 2 * np.sin(2 * np.pi / n)
    strain = h.observables["ab"][-1] / (zb - za)
    assert strain == pytest.approx(-P / (E * area), rel=0.03)


def test_the_same_column_in_millimetres():
    """units mm-N-s scales the geometry's lengths: the same cells."""
    a = build_mesh(load_case_text(column()))
    b = build_mesh(load_case_text(column("{kind: voronoi, size: 25.0, seed: 3}",
                                         units="units: mm-N-s", scale=1e3)))
    assert b.n_cells == a.n_cells
    assert b.cell_volume.sum() == pytest.approx(a.cell_volume.sum(), rel=1e-9)


@pytest.mark.parametrize("text, key, words", [
    (column(support="rim"), "boundary[0].surface", "no surface 'rim'"),
    (column().replace("{surface: bottom, fix: all}", "{face: zmin, fix: all}"),
     "boundary[0].face", "use surface"),
    (column().replace("radius: 0.05", "radius: -0.05"), "domain.cylinder.radius", ""),
    (column().replace("{surface: bottom, fix: all}", "{surface: side, fix: [z]}"),
     "boundary[0].fix", "only fix: all"),
])
def test_bad_geometry_input_names_the_key(text, key, words):
    """Bad input is a CaseError naming the key (at load, or when the model
    is built for a support on a curved surface)."""
    from rbsm_dyn.model import build_model
    with pytest.raises(CaseError) as exc:
        build_model(load_case_text(text))
    assert key in str(exc.value)
    assert words in str(exc.value)


def test_check_lists_surfaces_groups_and_conflicts(tmp_path, capsys):
    """`check` lists the domain's surfaces with their face count and area
    (the faceted disc's area on top) and each group's body count, and warns
    when two items prescribe one component of the same bodies."""
    from rbsm_dyn.__main__ import main
    from rbsm_dyn.geometry import circle_segments
    text = column("{kind: voronoi, size: 0.025, seed: 3}").replace(
        "boundary: [{surface: bottom, fix: all}]",
        "boundary: [{surface: bottom, fix: all}, {group: top, fix: [x]},\n"
        "               {group: all, velocity: [0.1, null, null]}]").replace(
        "solver: {mode: linear}", "solver: {mode: dynamic, end_time: 1.0e-5}")
    path = tmp_path / "c.yaml"
    path.write_text(textwrap.dedent(text))
    assert main(["check", str(path)]) == 0
    out, err = capsys.readouterr()
    n = circle_segments(R, 0.05 * 0.025)
    top = [ln for ln in out.splitlines() if "surface cylinder0.top:" in ln]
    assert len(top) == 1
    assert float(top[0].split(",")[1].split()[0]) == pytest.approx(
        n / 2 * R ** 2 * np.sin(2 * np.pi / n), rel=1e-5)
    assert any(ln.strip().startswith("group top:") for ln in out.splitlines())
    assert "boundary[2] (velocity) and boundary[1] both prescribe x" in err


def test_an_stl_of_a_primitive_gives_the_primitives_mesh(tmp_path):
    """An L-shaped prism written as an STL by trimesh (coordinates that
    single precision holds exactly) and read back with `file:` gives the
    same cells as the prism itself: same count, volumes and face pairs
    (to 1e-9), and volumes summing to the L's area × depth."""
    import trimesh
    from rbsm_dyn.geometry import build_solid
    prism = {"prism": {"polygon": [[0, 0], [0.25, 0], [0.25, 0.125], [0.125, 0.125],
                                   [0.125, 0.25], [0, 0.25]], "axis": "z", "from": 0,
                       "to": 0.0625}}
    solid = build_solid(prism, chord=1e-3)
    stl = tmp_path / "l_panel.stl"
    trimesh.Trimesh(solid.vertices, solid.triangles, process=False).export(stl)
    meshes = []
    for domain in ("{prism: {polygon: [[0, 0], [0.25, 0], [0.25, 0.125], [0.125, 0.125], "
                   "[0.125, 0.25], [0, 0.25]], axis: z, from: 0, to: 0.0625}}",
                   f"{{file: {stl}}}"):
        text = f"""
        name: l_panel
        domain: {domain}
        mesh: {{kind: voronoi, size: 0.02, seed: 4}}
        materials: {{c: {{density: 2400, young: 3.0e10, poisson: 0.0}}}}
        solver: {{mode: dynamic, end_time: 1.0e-5}}
        """
        meshes.append(build_mesh(load_case_text(textwrap.dedent(text))))
    a, b = meshes
    area = 0.25 * 0.25 - 0.125 * 0.125
    assert a.cell_volume.sum() == pytest.approx(area * 0.0625, rel=1e-12)
    assert a.n_cells == b.n_cells and a.n_faces == b.n_faces
    np.testing.assert_allclose(b.cell_volume, a.cell_volume, rtol=1e-9)
    np.testing.assert_array_equal(b.face_cells, a.face_cells)


def test_a_large_build_announces_itself(tmp_path, capsys):
    """A build of more than 2·10⁴ cells says so on stderr (it takes seconds
    to minutes); --quiet keeps it silent."""
    from rbsm_dyn.__main__ import main
    path = tmp_path / "blocks.yaml"
    path.write_text(textwrap.dedent("""
        name: blocks
        domain: {box: [[0, 0, 0], [1, 1, 1]]}
        mesh: {kind: blocks, divisions: [30, 30, 30]}
        materials: {c: {density: 2400, young: 3.0e10, poisson: 0.0}}
        solver: {mode: dynamic, end_time: 1.0e-6}
        """))
    assert main(["check", str(path)]) == 0
    assert "building about 2.7e+04 cells (blocks, domain box)" in capsys.readouterr().err
    assert main(["check", str(path), "--quiet"]) == 0
    assert "building" not in capsys.readouterr().err


def test_a_displacement_prescribed_on_a_surface_moves_its_cells(run_case):
    """`{surface: top, displacement: [0, 0, d]}` prescribes the cells with a
    face on the surface: exactly those move by d (linear solve), the
    others less, and the column strains by d over the height of their
    centroids above the supported bottom (ν = 0; within 3 % as the column
    test)."""
    d = -1.0e-5
    text = column("{kind: voronoi, size: 0.0125, seed: 3}").replace(
        "boundary: [{surface: bottom, fix: all}]",
        f"boundary: [{{surface: bottom, fix: all}}, {{surface: top, displacement: [0, 0, {d}]}}]"
    ).replace("loads: [{group: top, force: [0, 0, -100000.0]}]", "")
    h = run_case(text)
    from rbsm_dyn.model import build_model
    model = build_model(load_case_text(textwrap.dedent(text)))
    mesh = model.mesh
    top = np.unique(mesh.bface_cell[mesh.bface_side == mesh.surface_names.index("cylinder0.top")])
    u = h.position[-1] - h.position[0]
    np.testing.assert_allclose(u[top, 2], d, rtol=1e-9)
    others = np.setdiff1d(np.arange(model.n_bodies), top)
    assert np.all(np.abs(u[others, 2]) < abs(d))
    ref = h.static["particles/bodies/reference_position"]
    za = ref[(ref[:, 2] >= 0.05) & (ref[:, 2] <= 0.075), 2].mean()
    zb = ref[(ref[:, 2] >= 0.125) & (ref[:, 2] <= 0.15), 2].mean()
    strain = h.observables["ab"][-1] / (zb - za)
    # the bar from the support (z = 0) to the prescribed cells' centroids
    assert strain == pytest.approx(d / mesh.cell_centroid[top, 2].mean(), rel=0.03)


def test_cells_wrapped_round_a_notch_tip_keep_positive_springs():
    """A 2 mm notch cut (difference) into a beam of 10 mm Voronoi cells
    leaves cells wrapped round its tip, non-convex, their centroids behind
    some of their faces.  Every spring stays positive (k > 0, h > 0: a
    positive stiffness, the condition for a stable explicit step), and the
    model's stable step is within a factor 2 of the un-notched beam's
    (DESIGN.md §6: no cell wrecks the step)."""
    from rbsm_dyn.model import build_model
    text = """
    name: notched
    domain:
      difference:
        - {box: [[0, 0, 0], [0.44, 0.1, 0.04]]}
        - {box: [[0.219, -0.01, -0.01], [0.221, 0.05, 0.05]], name: notch}
    mesh: {kind: voronoi, size: 0.01, seed: 1}
    materials: {c: {density: 2400, young: 3.0e10, poisson: 0.2}}
    boundary: [{surface: ymin, fix: all}]
    solver: {mode: linear}
    """
    m = build_model(load_case_text(textwrap.dedent(text)))
    mesh = m.mesh
    f, n = mesh.face_cells, mesh.face_normal
    behind = np.einsum("ij,ij->i", mesh.face_centroid - mesh.cell_centroid[f[:, 0]], n) <= 0
    assert behind.any()             # the case this test is about
    assert np.all(m.spring_h > 0) and np.all(m.spring_k[~m.is_support] > 0)
    plain = build_model(load_case_text(textwrap.dedent(text).replace(
        "- {box: [[0.219, -0.01, -0.01], [0.221, 0.05, 0.05]], name: notch}",
        "- {box: [[1.219, -0.01, -0.01], [1.221, 0.05, 0.05]], name: notch}")))
    assert m.stable_dt() > 0.5 * plain.stable_dt()


def test_reaction_on_a_supported_surface_balances_the_load(run_case):
    """A probe on a surface (`{surface: bottom, quantity: reaction}`) sums
    the support reactions of the cells with a face on it: the column's
    bottom carries the top load P (1e-9, a linear solve), and the cells of
    the top surface, unsupported, none (1e-9 P)."""
    text = column().replace(
        "ab: {groups: [a, b], quantity: relative_displacement, component: z}",
        "ab: {groups: [a, b], quantity: relative_displacement, component: z}\n"
        "        R: {surface: bottom, quantity: reaction, component: z, reduce: sum}\n"
        "        S: {surface: top, quantity: reaction, component: magnitude, reduce: max}")
    h = run_case(text)
    assert h.observables["R"][-1] == pytest.approx(P, rel=1e-9)
    assert h.observables["S"][-1] == pytest.approx(0.0, abs=1e-9 * P)


def test_check_says_when_two_items_prescribe_different_components_of_a_body(tmp_path, capsys):
    """A corner cell in `top` (z) and in `right` (x): it takes both, and
    check says so (issue 30: this passed without a word)."""
    from rbsm_dyn.__main__ import main
    text = textwrap.dedent("""
        name: corner
        domain: {box: [[0, 0, 0], [0.04, 0.01, 0.02]]}
        mesh: {kind: blocks, divisions: [4, 1, 2]}
        materials: {c: {density: 2400, young: 3.0e10, poisson: 0.0}}
        groups:
          top: {box: [[0, 0, 0.01], [0.04, 0.01, 0.02]]}
          right: {box: [[0.03, 0, 0], [0.04, 0.01, 0.02]]}
        boundary: [{face: zmin, fix: all}, {group: top, displacement: [null, null, -1.0e-5]},
                   {group: right, displacement: [1.0e-5, null, null]}]
        solver: {mode: static}
    """)
    path = tmp_path / "corner.yaml"
    path.write_text(text)
    assert main(["check", str(path)]) == 0
    err = capsys.readouterr().err
    assert "boundary[1] (z) and boundary[2] (x) share 1 body" in err, err
    assert "boundary[0]" not in err, err        # the base shares no body with them
    # two items of one group (held in x, driven in z) are meant: no warning
    path.write_text(text.replace("{group: right, displacement: [1.0e-5, null, null]}",
                                 "{group: top, fix: [x]}"))
    assert main(["check", str(path)]) == 0
    assert "share" not in capsys.readouterr().err
