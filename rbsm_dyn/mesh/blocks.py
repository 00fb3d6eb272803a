"""Structured mesh of equal cuboids."""
from __future__ import annotations

import numpy as np

from ._core import Mesh, assemble, check_box

__all__ = ["block_mesh"]


def block_mesh(box, divisions) -> Mesh:
    """Cut ``box`` [[xmin, ymin, zmin], [xmax, ymax, zmax]] into
    ``divisions = (nx, ny, nz)`` equal cuboids.

    Cell (i, j, k) has index ``(i * ny + j) * nz + k`` (z fastest).  Internal
    faces join face-neighbours only (nx−1)·ny·nz + nx·(ny−1)·nz + nx·ny·(nz−1)
    of them); boundary faces are the 2(ny nz + nx nz + nx ny) cell faces on
    the six sides.  Same layout as ``voronoi_mesh``.
    """
    box = check_box(box)
    div = np.asarray(divisions)
    if div.shape != (3,) or not np.all(div == np.round(div)) or np.any(div < 1):
        raise ValueError(f"divisions must be three positive integers, got {divisions!r}")
    div = div.astype(np.int64)
    nx, ny, nz = (int(d) for d in div)
    axes = [np.linspace(box[0, a], box[1, a], div[a] + 1) for a in range(3)]
    axes = [np.concatenate([[box[0, a]], ax[1:-1], [box[1, a]]]) for a, ax in enumerate(axes)]
    X, Y, Z = np.meshgrid(*axes, indexing="ij")
    xyz = np.stack([X.ravel(), Y.ravel(), Z.ravel()], axis=1)
    vshape = (nx + 1, ny + 1, nz + 1)
    cshape = (nx, ny, nz)

    def quad(a, idx):
        """Vertex ids of the quad normal to axis a at lattice index idx (3, M),
        counter-clockwise about +e_a."""
        b, c = (a + 1) % 3, (a + 2) % 3
        corners = []
        for db, dc in ((0, 0), (1, 0), (1, 1), (0, 1)):
            p = [idx[0].copy(), idx[1].copy(), idx[2].copy()]
            p[b] = p[b] + db
            p[c] = p[c] + dc
            corners.append(np.ravel_multi_index(p, vshape))
        return np.stack(corners, axis=1)

    f_cells, f_quads, f_normal = [], [], []
    b_cell, b_side, b_quads = [], [], []
    for a in range(3):
        e = np.zeros(3)
        e[a] = 1.0
        # internal faces: cells (.., i_a, ..) and (.., i_a + 1, ..)
        rng = [np.arange(n) for n in cshape]
        rng[a] = np.arange(cshape[a] - 1)
        idx = [g.ravel() for g in np.meshgrid(*rng, indexing="ij")]
        ca = np.ravel_multi_index(idx, cshape)
        nb = list(idx)
        nb[a] = nb[a] + 1
        cb = np.ravel_multi_index(nb, cshape)
        vidx = list(idx)
        vidx[a] = vidx[a] + 1
        f_cells.append(np.stack([ca, cb], axis=1))
        f_quads.append(quad(a, vidx))
        f_normal.append(np.tile(e, (len(ca), 1)))
        # boundary faces on sides 2a (min, normal −e_a) and 2a+1 (max, +e_a)
        for s, (ci, vi) in enumerate(((0, 0), (cshape[a] - 1, cshape[a]))):
            rng = [np.arange(n) for n in cshape]
            rng[a] = np.array([ci])
            idx = [g.ravel() for g in np.meshgrid(*rng, indexing="ij")]
            cells = np.ravel_multi_index(idx, cshape)
            vidx = list(idx)
            vidx[a] = np.full_like(idx[a], vi)
            q = quad(a, vidx)
            if s == 0:
                q = q[:, ::-1]
            b_cell.append(cells)
            b_side.append(np.full(len(cells), 2 * a + s))
            b_quads.append(q)

    f_cells = np.concatenate(f_cells)
    f_quads = np.concatenate(f_quads)
    b_quads = np.concatenate(b_quads)
    return assemble(
        box, xyz,
        f_cells, np.arange(0, 4 * len(f_quads) + 1, 4), f_quads.ravel(), np.concatenate(f_normal),
        np.concatenate(b_cell), np.concatenate(b_side), np.arange(0, 4 * len(b_quads) + 1, 4), b_quads.ravel(),
        n_cells=nx * ny * nz,
    )
