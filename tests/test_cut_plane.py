"""A notch given as `cuts` with `planar: true` on Voronoi cells is a plane of cell faces
(mesh/cut_seeds.py, issue 30): the seeds are mirrored across the cut's
plane in a band around its patch, so that every point of the patch lies on
a face between a seed and its mirror.  Facts checked: every face that a
cut breaks, but those within a cell of its tip, lies in the cut's plane
(normal parallel to 1e-12, distance 1e-12 × size), the broken faces tile the patch (area within a strip one
cell wide along the tip: the faces there straddle it), and the seeds keep their minimum spacing."""
import textwrap

import numpy as np
import pytest

from rbsm_dyn.case import load_case_text
from rbsm_dyn.mesh.cut_seeds import mirror_across_cuts
from rbsm_dyn.model.mesh_build import build_mesh

SIZE = 0.004
CASE = textwrap.dedent("""
    name: cut-plane
    domain: {{box: [[0, 0, 0], [0.06, 0.012, 0.04]]}}
    mesh: {{kind: voronoi, size: {size}, seed: {seed}}}
    materials: {{c: {{density: 2400, young: 3.0e10, poisson: 0.2}}}}
    cuts: [{{point: [0, 0, 0.02], normal: {normal}, within: [[-1, -1, 0.015], [0.025, 1, 0.025]], planar: true}}]
    solver: {{mode: linear}}
""")


def broken_faces(mesh, case):
    cut = case.cuts[0]
    p, n = np.array(cut.point), np.array(cut.normal, float)
    n /= np.linalg.norm(n)
    box = np.array(cut.within)
    a, b = mesh.face_cells[:, 0], mesh.face_cells[:, 1]
    cen = mesh.cell_centroid
    cross = ((cen[a] - p) @ n) * ((cen[b] - p) @ n) < 0
    inside = np.all((mesh.face_centroid >= box[0]) & (mesh.face_centroid <= box[1]), axis=1)
    return cross & inside, p, n


@pytest.mark.parametrize("seed", [1, 7])
@pytest.mark.parametrize("normal", ["[0, 0, 1]", "[0.2, 0, 1]"])
def test_a_cut_is_a_plane_of_faces(seed, normal):
    case = load_case_text(CASE.format(size=SIZE, seed=seed, normal=normal))
    mesh = build_mesh(case)
    sel, p, n = broken_faces(mesh, case)
    assert sel.sum() >= 10
    # beyond the patch the cells are random (a crack from the tip as
    # tortuous as the calibration's): the faces within a cell of the tip
    # may tilt, all others lie in the plane
    away = sel & (mesh.face_centroid[:, 0] < 0.025 - SIZE)
    assert away.sum() >= 8
    assert np.all(np.abs(np.abs(mesh.face_normal[away] @ n) - 1.0) < 1e-12)
    assert np.all(np.abs((mesh.face_centroid[away] - p) @ n) < 1e-12 * SIZE)
    # the patch from the side x = 0 to the tip x = 0.025 (along the plane),
    # through the whole thickness: faces with their centroid short of the tip
    length = 0.025 * np.sqrt(1 + (n[0] / n[2]) ** 2)
    area = mesh.face_area[sel].sum()
    assert abs(area - length * 0.012) <= SIZE * 0.012


def test_mirrored_seeds_keep_their_spacing_and_the_box():
    case = load_case_text(CASE.format(size=SIZE, seed=3, normal="[0, 0, 1]"))
    from rbsm_dyn.mesh import voronoi_seeds
    box = np.array([[0, 0, 0], [0.06, 0.012, 0.04]])
    seeds = voronoi_seeds(box, SIZE, seed=3, min_spacing=0.5)
    out = mirror_across_cuts(seeds, case.cuts, SIZE, 0.5, box)
    from scipy.spatial import cKDTree
    d, _ = cKDTree(out).query(out, k=2)
    assert d[:, 1].min() >= 0.5 * SIZE * (1 - 1e-12)
    assert np.all((out > box[0]) & (out < box[1]))
    assert abs(len(out) - len(seeds)) <= 0.1 * len(seeds)


def test_a_cut_is_planar_by_default_and_planar_false_keeps_the_seeds():
    """A cut written without `planar` is a plane of cell faces (issue 30:
    a notch as users write it); `planar: false` breaks the faces of the
    seed's cells as they are (the meshes of cases written before)."""
    text = CASE.format(size=SIZE, seed=3, normal="[0, 0, 1]")
    implicit = load_case_text(text.replace(", planar: true", ""))
    assert implicit.cuts[0].planar is True
    # a case written before the default changed is told which key keeps its mesh
    assert any("planar: false" in w and "cuts" in w for w in implicit.warnings)
    assert not any("planar" in w for w in load_case_text(text).warnings)
    case = load_case_text(text.replace("planar: true", "planar: false"))
    assert case.cuts[0].planar is False
    from rbsm_dyn.mesh import voronoi_seeds
    box = np.array([[0, 0, 0], [0.06, 0.012, 0.04]])
    seeds = voronoi_seeds(box, SIZE, seed=3, min_spacing=0.5)
    assert np.array_equal(mirror_across_cuts(seeds, case.cuts, SIZE, 0.5, box), seeds)
