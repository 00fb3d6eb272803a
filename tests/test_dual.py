"""Voronoi ridges as the Delaunay dual (mesh/dual.py) against
scipy.spatial.Voronoi, and on the most degenerate seed set there is."""
import numpy as np
from scipy.spatial import Voronoi

from rbsm_dyn.mesh.dual import voronoi_ridges
from rbsm_dyn.mesh.voronoi import voronoi_mesh


def test_ridges_are_scipys_voronoi_ridges():
    rng = np.random.default_rng(7)
    P = rng.uniform(0.0, 1.0, (600, 3))
    V, rp, ptr, vid = voronoi_ridges(P)
    vor = Voronoi(P)
    ref = {}
    for (a, b), rv in zip(vor.ridge_points, vor.ridge_vertices):
        ref[(min(a, b), max(a, b))] = None if -1 in rv else vor.vertices[rv]
    mine = {}
    for i, (a, b) in enumerate(rp):
        v = vid[ptr[i]:ptr[i + 1]]
        mine[(a, b)] = None if v[0] < 0 else V[v]
    # every ridge of scipy's is found (qhull may leave out some unbounded ones
    # at the hull: those are marked unbounded here)
    assert set(ref) <= set(mine)
    assert all(mine[k] is None for k in set(mine) - set(ref))
    for k, r in ref.items():
        m = mine[k]
        assert (r is None) == (m is None), k
        if r is None:
            continue
        # the same polygon: each vertex of one within round-off of the other's
        # (circumcentres of unit-scale tetrahedra: 1e-9 covers qhull's own)
        d = np.linalg.norm(r[:, None] - m[None], axis=2)
        assert d.min(axis=1).max() < 1e-9 and d.min(axis=0).max() < 1e-9, k


def test_seeds_on_a_grid_give_cubes():
    # every Delaunay tetrahedron of a cubic grid is degenerate (8 cospherical
    # points per cube): the cells must still be the grid's cubes exactly
    h = 0.1
    g = (np.arange(5) + 0.5) * h
    seeds = np.stack(np.meshgrid(g, g, g, indexing="ij"), -1).reshape(-1, 3)
    seeds += 1e-13 * np.random.default_rng(1).standard_normal(seeds.shape)
    mesh = voronoi_mesh([[0, 0, 0], [0.5, 0.5, 0.5]], h, seeds=seeds)
    assert mesh.n_cells == 125
    np.testing.assert_allclose(mesh.cell_volume, h ** 3, rtol=1e-9)
    # each cube has its 6 faces of area h²: internal faces of area h² only
    assert len(mesh.face_cells) == 3 * 4 * 25
    np.testing.assert_allclose(mesh.face_area, h * h, rtol=1e-9)
