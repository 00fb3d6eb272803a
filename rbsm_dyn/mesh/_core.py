"""The Mesh container and the assembly shared by the mesh generators."""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .polyhedron import cells_mass_properties
from .spring_points import polygon_properties

SIDES = ("xmin", "xmax", "ymin", "ymax", "zmin", "zmax")


@dataclass(frozen=True, eq=False)
class Mesh:
    """Convex cells tiling a box, their shared faces and their boundary faces.

    Cells (N):
      cell_volume (N,) [m³]; cell_centroid (N, 3) [m];
      cell_inertia (N, 3, 3) [m⁵] = ∫(|r|² 1 − r rᵀ) dV about the centroid
      (multiply by the density for kg·m²).
    Drawing geometry:
      vertices (V, 3) — cell c owns rows cell_vertex_ptr[c]:cell_vertex_ptr[c+1];
      polygons p = cell_poly_ptr[c]:cell_poly_ptr[c+1] of cell c have the
      vertex ids poly_vertex[poly_ptr[p]:poly_ptr[p+1]] (rows of ``vertices``
      owned by c), counter-clockwise seen from outside the cell.
    Internal faces (F), one per pair of cells sharing a face, sorted by (a, b):
      face_cells (F, 2) with a < b; face_normal (F, 3) unit, from a to b;
      face_area (F,); face_centroid (F, 3) area centroid;
      face_vertex_ptr (F+1,), face_vertex_xyz (Kf, 3): polygon,
      counter-clockwise about face_normal.
    Boundary faces (B) on the box sides, sorted by (side, cell):
      bface_cell (B,); bface_side (B,) in 0..5 = xmin, xmax, ymin, ymax,
      zmin, zmax; bface_normal (B, 3) outward; bface_area, bface_centroid,
      bface_vertex_ptr, bface_vertex_xyz as for internal faces.
    box (2, 3): [[xmin, ymin, zmin], [xmax, ymax, zmax]] (the bounds).
    surface_names: the names of the boundary surfaces; bface_side indexes
      them (a box: SIDES; a clipped solid, mesh/clip.py: its named surfaces,
      bface_normal then the true outward normals of the facets).
    Parts (mesh/merge.py: merge_meshes, add_interface_faces; a rigid_mesh
    cell is one closed, possibly non-convex, triangle surface):
      cell_part (N,) int64: the part index of each cell (None: one part,
      all 0); part_names: the names of the parts (empty for a one-part
      mesh); face_interface (F,) int64: −1 for a face between two cells of
      one part, else the index of the interface (a pair of parts) the face
      belongs to (None: all −1).

    Index arrays are int64, coordinates float64.  The arrays are not locked
    (write flags stay on so that Numba sees ordinary arrays): treat them as
    read-only.
    """

    cell_volume: np.ndarray
    cell_centroid: np.ndarray
    cell_inertia: np.ndarray
    vertices: np.ndarray
    cell_vertex_ptr: np.ndarray
    poly_ptr: np.ndarray
    poly_vertex: np.ndarray
    cell_poly_ptr: np.ndarray
    face_cells: np.ndarray
    face_normal: np.ndarray
    face_area: np.ndarray
    face_centroid: np.ndarray
    face_vertex_ptr: np.ndarray
    face_vertex_xyz: np.ndarray
    bface_cell: np.ndarray
    bface_side: np.ndarray
    bface_normal: np.ndarray
    bface_area: np.ndarray
    bface_centroid: np.ndarray
    bface_vertex_ptr: np.ndarray
    bface_vertex_xyz: np.ndarray
    box: np.ndarray
    surface_names: tuple = SIDES
    cell_part: np.ndarray = None
    part_names: tuple = ()
    face_interface: np.ndarray = None

    @property
    def n_cells(self) -> int:
        return int(self.cell_volume.shape[0])

    @property
    def n_faces(self) -> int:
        return int(self.face_cells.shape[0])

    @property
    def n_bfaces(self) -> int:
        return int(self.bface_cell.shape[0])

    def __repr__(self) -> str:
        lo, hi = self.box
        return (
            f"Mesh({self.n_cells} cells, {self.n_faces} internal faces, "
            f"{self.n_bfaces} boundary faces, box {lo.tolist()}..{hi.tolist()})"
        )


def _gather(ptr, vid, sel, rev=None):
    """CSR subset of polygons ``sel`` (optionally each reversed)."""
    n = np.diff(ptr)[sel]
    out_ptr = np.zeros(len(n) + 1, dtype=np.int64)
    np.cumsum(n, out=out_ptr[1:])
    j = np.arange(out_ptr[-1], dtype=np.int64) - np.repeat(out_ptr[:-1], n)
    if rev is not None:
        nn = np.repeat(n, n)
        j = np.where(np.repeat(rev, n), nn - 1 - j, j)
    return out_ptr, vid[np.repeat(ptr[sel], n) + j]


def check_box(box):
    box = np.array(box, dtype=np.float64)
    if box.shape != (2, 3) or not np.all(np.isfinite(box)) or not np.all(box[1] > box[0]):
        raise ValueError(f"box must be [[xmin, ymin, zmin], [xmax, ymax, zmax]] with max > min, got {box.tolist()}")
    return box


def assemble(box, xyz, f_cells, f_ptr, f_vid, f_normal, b_cell, b_side, b_ptr, b_vid, n_cells, ref=None,
             *, b_normal=None, surface_names=SIDES):
    """Build a Mesh from polygons given as ids into unique points ``xyz``.

    Internal polygons: f_cells (F, 2) with a < b, counter-clockwise about
    f_normal (from a to b).  Boundary polygons: counter-clockwise about the
    outward normal of side b_side.  ``ref`` (N, 3): a point inside each cell
    (reference for the tetrahedral decomposition; default the vertex mean).
    """
    box = np.asarray(box, dtype=np.float64)
    xyz = np.asarray(xyz, dtype=np.float64)
    f_cells = np.asarray(f_cells, dtype=np.int64).reshape(-1, 2)
    f_ptr = np.asarray(f_ptr, dtype=np.int64)
    f_vid = np.asarray(f_vid, dtype=np.int64)
    b_cell = np.asarray(b_cell, dtype=np.int64)
    b_side = np.asarray(b_side, dtype=np.int64)
    b_ptr = np.asarray(b_ptr, dtype=np.int64)
    b_vid = np.asarray(b_vid, dtype=np.int64)
    F, B = len(f_cells), len(b_cell)

    # sort internal faces by (a, b), boundary faces by (side, cell)
    fo = np.lexsort((f_cells[:, 1], f_cells[:, 0]))
    f_ptr, f_vid = _gather(f_ptr, f_vid, fo)
    f_cells = f_cells[fo]
    f_normal = np.asarray(f_normal, dtype=np.float64)[fo]
    bo = np.lexsort((b_cell, b_side))
    b_ptr, b_vid = _gather(b_ptr, b_vid, bo)
    b_cell, b_side = b_cell[bo], b_side[bo]
    if b_normal is None:
        axis = b_side // 2
        b_normal = np.zeros((B, 3))
        b_normal[np.arange(B), axis] = np.where(b_side % 2 == 0, -1.0, 1.0)
    else:
        b_normal = np.asarray(b_normal, dtype=np.float64)[bo]

    f_xyz = xyz[f_vid]
    b_xyz = xyz[b_vid]
    f_area, f_cen = polygon_properties(f_ptr, f_xyz, f_normal)
    b_area, b_cen = polygon_properties(b_ptr, b_xyz, b_normal)

    # cell polygons: internal faces seen from a (as is) and from b (reversed),
    # boundary faces; grouped by cell (stable: internal from a, from b, boundary)
    all_ptr = np.concatenate([f_ptr, f_ptr[-1] + b_ptr[1:]])
    all_vid = np.concatenate([f_vid, b_vid])
    src = np.concatenate([np.arange(F), np.arange(F), F + np.arange(B)])
    rev = np.concatenate([np.zeros(F, bool), np.ones(F, bool), np.zeros(B, bool)])
    pcell = np.concatenate([f_cells[:, 0], f_cells[:, 1], b_cell])
    order = np.argsort(pcell, kind="stable")
    poly_ptr, pv_global = _gather(all_ptr, all_vid, src[order], rev[order])
    pcell = pcell[order]
    cell_poly_ptr = np.zeros(n_cells + 1, dtype=np.int64)
    np.cumsum(np.bincount(pcell, minlength=n_cells), out=cell_poly_ptr[1:])
    if np.any(np.diff(cell_poly_ptr) < 4):
        raise RuntimeError("a cell has fewer than 4 faces")

    # per-cell copies of the vertices
    nV = len(xyz)
    key = np.repeat(pcell, np.diff(poly_ptr)) * nV + pv_global
    uniq, poly_vertex = np.unique(key, return_inverse=True)
    vertices = xyz[uniq % nV]
    cell_vertex_ptr = np.zeros(n_cells + 1, dtype=np.int64)
    np.cumsum(np.bincount(uniq // nV, minlength=n_cells), out=cell_vertex_ptr[1:])

    if ref is None:
        cnt = np.diff(cell_vertex_ptr).astype(np.float64)
        vc = np.repeat(np.arange(n_cells), np.diff(cell_vertex_ptr))
        ref = np.stack([np.bincount(vc, vertices[:, j], minlength=n_cells) for j in range(3)], 1) / cnt[:, None]
    vol, cen, inertia = cells_mass_properties(vertices, poly_ptr, poly_vertex, cell_poly_ptr, ref)

    i64 = lambda a: np.ascontiguousarray(a, dtype=np.int64)  # noqa: E731
    f64 = lambda a: np.ascontiguousarray(a, dtype=np.float64)  # noqa: E731
    return Mesh(
        cell_volume=f64(vol), cell_centroid=f64(cen), cell_inertia=f64(inertia),
        vertices=f64(vertices), cell_vertex_ptr=i64(cell_vertex_ptr), poly_ptr=i64(poly_ptr),
        poly_vertex=i64(poly_vertex), cell_poly_ptr=i64(cell_poly_ptr),
        face_cells=i64(f_cells), face_normal=f64(f_normal), face_area=f64(f_area),
        face_centroid=f64(f_cen), face_vertex_ptr=i64(f_ptr), face_vertex_xyz=f64(f_xyz),
        bface_cell=i64(b_cell), bface_side=i64(b_side), bface_normal=f64(b_normal),
        bface_area=f64(b_area), bface_centroid=f64(b_cen), bface_vertex_ptr=i64(b_ptr),
        bface_vertex_xyz=f64(b_xyz), box=f64(box), surface_names=tuple(surface_names),
    )
