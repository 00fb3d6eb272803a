"""`python -m rbsm_dyn export RUN.h5`: the VTK series opens in pyvista,
holds one polyhedron per body moved rigidly with it, and the non-elastic
faces with their spring state (rbsm_dyn/io/export.py)."""
import numpy as np
import pytest
import pyvista as pv

import rbsm_dyn
from rbsm_dyn.__main__ import main
from rbsm_dyn.io.geometry import quat_to_matrix, rotation_vectors

from post_case import run_beam

EVERY = 3


@pytest.fixture(scope="module")
def exported(tmp_path_factory):
    folder = tmp_path_factory.mktemp("export")
    h5 = run_beam(folder)
    out = folder / "vtk"
    assert main(["export", str(h5), "--every", str(EVERY), "--out", str(out), "--quiet"]) == 0
    return rbsm_dyn.open_history(h5), out


def frames_written(h):
    idx = list(range(0, h.frames, EVERY))
    return idx if idx[-1] == h.frames - 1 else idx + [h.frames - 1]


def test_pvd_series_has_every_nth_frame_and_the_last_with_their_times(exported):
    h, out = exported
    idx = frames_written(h)
    for name in ("cells", "faces"):
        reader = pv.PVDReader(str(out / f"{name}.pvd"))
        assert len(reader.time_values) == len(idx)
        np.testing.assert_allclose(reader.time_values, h.time[idx], rtol=1e-15)
    reader = pv.PVDReader(str(out / "cells.pvd"))
    reader.set_active_time_point(len(idx) - 1)
    grid = reader.read()[0]
    assert grid.n_cells == h.n_bodies
    assert int(grid.field_data["frame"][0]) == h.frames - 1


def test_cells_are_polyhedra_moved_rigidly_with_their_bodies(exported):
    """Blocks: each cell's 8 vertices average to its centroid, its volume and
    edge lengths are those of the reference cell (a rigid motion), and the
    cell data is the history's displacement and velocity (1e-12)."""
    h, out = exported
    k = h.frames - 1
    grid = pv.read(out / "cells" / f"frame_{k:06d}.vtu")
    N = h.n_bodies
    assert grid.n_cells == N == 36
    assert grid.n_points == 8 * N
    assert set(np.unique(grid.celltypes)) == {pv.CellType.POLYHEDRON}
    np.testing.assert_array_equal(grid.cell_data["body_id"], np.arange(N))
    np.testing.assert_allclose(grid.cell_data["displacement"], h.displacement[k], atol=1e-15)
    np.testing.assert_allclose(grid.cell_data["velocity"], h.velocity[k], atol=1e-15)
    geom = h.geometry()
    rot = rotation_vectors(h.orientation[k], geom.q0)
    np.testing.assert_allclose(grid.cell_data["rotation"], rot, atol=1e-15)
    assert np.abs(rot).max() > 1e-3                       # the cells did turn
    pts = grid.points.reshape(N, 8, 3)                   # vertices owned per cell, in order
    np.testing.assert_allclose(pts.mean(axis=1), h.position[k], atol=1e-12)
    ref = geom.vertices.reshape(N, 8, 3)
    d_ref = np.linalg.norm(ref[:, :, None] - ref[:, None], axis=-1)
    d_now = np.linalg.norm(pts[:, :, None] - pts[:, None], axis=-1)
    np.testing.assert_allclose(d_now, d_ref, atol=1e-12)
    vol = grid.compute_cell_sizes(length=False, area=False)["Volume"]
    np.testing.assert_allclose(vol, h.static["particles/bodies/volume"], rtol=1e-9)
    # point data: the vertex displacement, and v + ω × r
    np.testing.assert_allclose(grid.point_data["displacement"], grid.points - geom.vertices,
                               atol=1e-15)
    r = pts - h.position[k][:, None]
    v = h.velocity[k][:, None] + np.cross(h.angular_velocity[k][:, None], r)
    np.testing.assert_allclose(grid.point_data["velocity"].reshape(N, 8, 3), v, atol=1e-12)


def test_vertex_positions_follow_the_rotation_of_the_body(exported):
    """x + R(q q0⁻¹)(r - x0) for a vertex of the tip cell, written by hand."""
    h, out = exported
    k = h.frames - 1
    grid = pv.read(out / "cells" / f"frame_{k:06d}.vtu")
    geom = h.geometry()
    c = int(np.argmax(np.abs(h.displacement[k][:, 2])))
    v0 = geom.vertices[8 * c]
    R = quat_to_matrix(h.orientation[k][c]) @ quat_to_matrix(geom.q0[c]).T
    expect = h.position[k][c] + R @ (v0 - geom.x0[c])
    np.testing.assert_allclose(grid.points[8 * c], expect, atol=1e-14)


def test_faces_are_the_non_elastic_faces_with_their_state(exported):
    """Each written frame holds exactly the faces on which some spring is
    not elastic (internal and support faces), with the largest state."""
    h, out = exported
    face = h.static["springs/face"]
    for k in frames_written(h):
        poly = pv.read(out / "faces" / f"frame_{k:06d}.vtp")
        st = h.spring_state[k]
        expect = {}
        for f, s in zip(face[st >= 1], st[st >= 1]):
            expect[int(f)] = max(expect.get(int(f), 0), int(s))
        got = dict(zip(poly.cell_data["face_id"].tolist(), poly.cell_data["state"].tolist())) \
            if poly.n_cells else {}
        assert got == expect, k
    last = pv.read(out / "faces" / f"frame_{h.frames - 1:06d}.vtp")
    states = set(last.cell_data["state"].tolist())
    assert 1 in states and (2 in states or 3 in states)     # yielded and cut faces
    assert np.any(last.cell_data["face_id"] < 0)           # a support face yielded
    # the cut faces lie in the plane x = 0.06 of the reference, moved with the cells
    cut = last.extract_cells(np.nonzero(last.cell_data["state"] >= 2)[0])
    assert cut.n_cells >= 1
    assert abs(cut.points[:, 0].mean() - 0.06) < 0.003


def test_export_of_a_missing_file_exits_2(tmp_path, capsys):
    assert main(["export", str(tmp_path / "none.h5")]) == 2
    err = capsys.readouterr().err
    assert "none.h5" in err and "Traceback" not in err
