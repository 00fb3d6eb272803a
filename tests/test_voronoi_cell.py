"""The Voronoi cells built one at a time (mesh/voronoi_cell.py, voro++'s
method) against the dual of qhull's Delaunay triangulation (the fallback,
mesh/voronoi.py delaunay_mesh): a Voronoi tessellation is unique, so two
algorithms must give the same cells, faces and areas to round-off."""
import numba
import numpy as np
import pytest

from rbsm_dyn.mesh.voronoi import delaunay_mesh, voronoi_mesh, voronoi_seeds
from rbsm_dyn.mesh.voronoi_cell import box_voronoi_mesh


def _same(a, b, L):
    """Same cells, faces and boundary faces; geometry to 1e-11 of the box."""
    assert np.array_equal(a.face_cells, b.face_cells)
    assert np.array_equal(a.bface_cell, b.bface_cell)
    assert np.array_equal(a.bface_side, b.bface_side)
    assert np.array_equal(np.diff(a.face_vertex_ptr), np.diff(b.face_vertex_ptr))
    tol = 1e-11
    assert np.allclose(a.cell_volume, b.cell_volume, rtol=0, atol=tol * L**3)
    assert np.allclose(a.cell_centroid, b.cell_centroid, rtol=0, atol=tol * L)
    assert np.allclose(a.cell_inertia, b.cell_inertia, rtol=0, atol=tol * L**5)
    assert np.allclose(a.face_area, b.face_area, rtol=0, atol=tol * L**2)
    assert np.allclose(a.face_centroid, b.face_centroid, rtol=0, atol=tol * L)
    assert np.allclose(a.bface_area, b.bface_area, rtol=0, atol=tol * L**2)
    assert np.array_equal(a.face_normal, b.face_normal) or np.allclose(a.face_normal,
                                                                      b.face_normal, atol=1e-15)


@pytest.mark.parametrize("min_spacing", [0.5, 0.0])
def test_cells_equal_the_delaunay_dual(min_spacing):
    box = np.array([[0.0, 0.0, 0.0], [6.0, 5.0, 4.0]])
    seeds = voronoi_seeds(box, 0.5, seed=3, min_spacing=min_spacing)
    a = box_voronoi_mesh(seeds, box, 0.5)
    b = delaunay_mesh(box, 0.5, seeds)
    _same(a, b, 6.0)
    assert a.cell_volume.sum() == pytest.approx(120.0, rel=1e-12)


def test_lattice_seeds_give_cubes():
    """Seeds on a cubic lattice: every cell the unit cube, though every
    vertex is shared by eight cospherical seeds (the degenerate case)."""
    box = np.array([[0.0, 0.0, 0.0], [4.0, 3.0, 2.0]])
    g = np.stack(np.meshgrid(np.arange(4) + 0.5, np.arange(3) + 0.5, np.arange(2) + 0.5,
                             indexing="ij"), -1).reshape(-1, 3)
    m = box_voronoi_mesh(g, box, 1.0)
    assert np.allclose(m.cell_volume, 1.0, rtol=1e-14)
    assert np.allclose(m.cell_centroid, g, atol=1e-14)
    assert np.allclose(m.cell_inertia, np.eye(3) / 6.0, atol=1e-14)
    # faces between lattice neighbours only: 3·4·3·2 − (3·2 + 4·2 + 4·3) = 46
    assert m.n_faces == 46 and np.allclose(m.face_area, 1.0, rtol=1e-14)
    assert m.n_bfaces == 2 * (4 * 3 + 3 * 2 + 4 * 2)


def test_threads_give_the_same_cells():
    box = np.array([[0.0, 0.0, 0.0], [8.0, 8.0, 8.0]])
    seeds = voronoi_seeds(box, 1.0, seed=5)
    prev = numba.get_num_threads()
    try:
        numba.set_num_threads(1)
        a = voronoi_mesh(box, 1.0, seeds=seeds)
        numba.set_num_threads(min(2, numba.config.NUMBA_NUM_THREADS))
        b = voronoi_mesh(box, 1.0, seeds=seeds)
    finally:
        numba.set_num_threads(prev)
    for k in ("vertices", "poly_vertex", "face_vertex_xyz", "cell_inertia", "face_area"):
        assert np.array_equal(getattr(a, k), getattr(b, k)), k


def test_chunks_and_retries_do_not_change_the_cells():
    """Cells left open by too few neighbours are built again with more
    (k0 = 4 leaves nearly all open), in chunks: the same arrays."""
    from rbsm_dyn.mesh.voronoi_cell import cells_of_box
    box = np.array([[0.0, 0.0, 0.0], [5.0, 5.0, 5.0]])
    seeds = voronoi_seeds(box, 1.0, seed=7)
    a = cells_of_box(seeds, box, 1.0)
    b = cells_of_box(seeds, box, 1.0, chunk=17, k0=4)
    for x, y in zip(a, b):
        assert np.array_equal(x, y)


@pytest.mark.parametrize("reach", [0.5, 1.5, np.inf])
def test_the_first_search_reach_does_not_change_the_cells(monkeypatch, reach):
    """The first neighbour search lists the seeds within REACH cell sizes; a
    cell it cannot close (REACH 0.5 and 1.5: most or some) goes again,
    unbounded: the same arrays as the default's (REACH 3) and an unbounded
    first search's."""
    import rbsm_dyn.mesh.voronoi_cell as vc
    box = np.array([[0.0, 0.0, 0.0], [6.0, 4.0, 5.0]])
    seeds = voronoi_seeds(box, 1.0, seed=8)
    a = vc.cells_of_box(seeds, box, 1.0)
    monkeypatch.setattr(vc, "REACH", reach)
    b = vc.cells_of_box(seeds, box, 1.0)
    for x, y in zip(a, b):
        assert np.array_equal(x, y)
