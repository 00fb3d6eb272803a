"""Brazilian (splitting) test, elastic (issue 12): a Voronoi disc (D = 100 mm,
t = 5 mm, ν = 0) pressed by a pressure on two narrow strips of its rim
(named surfaces picked by their normals), restrained by supports on its
faces (y) and one body at its centre (x, z, ry).  The cell stress tensors
(Love–Weber average) averaged over the cells within two cell sizes of the
centre give the horizontal stress 2P/(πDt) and the vertical stress
−6P/(πDt) of a disc under diametral loads P (Hertz 1883; Timoshenko &
Goodier, Theory of Elasticity, §41) within 5 %.  The strips span ±2–6°:
Hondros's (1959) correction for a load spread over 2α,
(sin 2α − α)/sin α, is above 0.988 there."""
import numpy as np
import pytest

from rbsm_dyn.case import load_case_text
from rbsm_dyn.model import build_mesh

R, T, H, PRESSURE = 0.05, 0.005, 0.0025, 10.0e6


def disc(centre_box, seed):
    return f"""
    name: brazilian_disc
    domain:
      cylinder: {{base: [0, 0, 0], axis: [0, {T}, 0], radius: {R}}}
      surfaces:
        top_strip: {{normal: [0, 0, 1], angle: 3}}
        bottom_strip: {{normal: [0, 0, -1], angle: 3}}
    mesh: {{kind: voronoi, size: {H}, seed: {seed}, chord: 0.012}}
    materials:
      rock: {{density: 2600, young: 30.0e9, poisson: 0.0}}
    groups:
      centre: {{box: {centre_box}}}
    boundary:
      - {{surface: top, fix: [y]}}
      - {{surface: bottom, fix: [y]}}
      - {{group: centre, fix: [x, z, ry]}}
    loads:
      - {{surface: top_strip, pressure: {PRESSURE}}}
      - {{surface: bottom_strip, pressure: {PRESSURE}}}
    solver: {{mode: linear}}
    output:
      fields: [position, cell_stress]
    """


@pytest.mark.parametrize("seed", [1, 2, 3])
def test_centre_stresses_of_the_brazilian_disc(run_case, seed):
    import textwrap
    mesh = build_mesh(load_case_text(textwrap.dedent(disc("[[-1, -1, -1], [1, 1, 1]]", seed))))
    # the body at the centre, alone in its group
    c = mesh.cell_centroid[np.argmin(np.hypot(mesh.cell_centroid[:, 0],
                                              mesh.cell_centroid[:, 2]))].tolist()
    e = 1e-6
    box = f"[[{c[0] - e!r}, {c[1] - e!r}, {c[2] - e!r}], [{c[0] + e!r}, {c[1] + e!r}, {c[2] + e!r}]]"
    h = run_case(disc(box, seed))
    strip = mesh.bface_side == mesh.surface_names.index("cylinder0.top_strip")
    # the strips' half angle, and the resultant P of the pressure on them
    x = mesh.bface_vertex_xyz
    owner = np.repeat(np.arange(mesh.n_bfaces), np.diff(mesh.bface_vertex_ptr))
    alpha = np.arctan2(np.abs(x[strip[owner], 0]), x[strip[owner], 2]).max()
    assert np.radians(1.5) < alpha < np.radians(6.0)
    P = PRESSURE * np.sum(mesh.bface_area[strip] * mesh.bface_normal[strip, 2])
    ref = 2 * P / (np.pi * 2 * R * T)
    S = h.cell_stress[-1]
    pos = h.static["particles/bodies/reference_position"]
    near = np.hypot(pos[:, 0], pos[:, 2]) < 2 * H
    V = mesh.cell_volume[near]
    assert near.sum() >= 10
    sx = np.sum(S[near, 0, 0] * V) / V.sum()
    sz = np.sum(S[near, 2, 2] * V) / V.sum()
    assert sx == pytest.approx(ref, rel=0.05)
    assert sz == pytest.approx(-3 * ref, rel=0.05)
