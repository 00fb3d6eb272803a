"""Cell and face geometry of a history, moved with the bodies (for drawing).

The history stores the mesh once, in the reference configuration
(docs/history.md, "Geometry"):

* ``particles/bodies/geometry/``: ``vertices (V, 3)`` (per-cell copies:
  cell c owns rows ``cell_vertex_ptr[c]:cell_vertex_ptr[c+1]``), polygons
  ``p = cell_poly_ptr[c]:cell_poly_ptr[c+1]`` of cell c with vertex ids
  ``poly_vertex[poly_ptr[p]:poly_ptr[p+1]]``, counter-clockwise seen from
  outside the cell;
* ``springs/faces/``: internal face polygons (``vertex_ptr``,
  ``vertex_xyz``, ``cells``), the face of spring s being ``springs/face[s]``
  when >= 0;
* ``springs/boundary_faces/`` (files written since this module exists): the
  support faces, face ``-1 - springs/face[s]`` of a support spring.

Each cell is rigid, so a point r fixed to body i is at
``x_i(t) + R(Δq_i) (r - x_i(0))`` with ``Δq_i = q_i(t) q_i(0)⁻¹``
(DESIGN.md §1).  A face between cells a and b is drawn at the mean of its
positions moved with a and with b.  Without orientations in the history the
cells are only translated (said by :attr:`CellGeometry.rotations`).
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .history_layout import MissingData

__all__ = ["CellGeometry", "quat_to_matrix", "rotation_vectors", "frame_state",
           "face_largest", "FACE_STATE_NAMES"]

GEOM = "particles/bodies/geometry"
FACE_STATE_NAMES = {0: "elastic", 1: "yielded", 2: "broken", 3: "contact"}


def quat_to_matrix(q: np.ndarray) -> np.ndarray:
    """Rotation matrices (..., 3, 3) of quaternions (..., 4), scalar first
    (w, x, y, z); the quaternions are normalised first."""
    from ..physics.rotation import quat_matrix_np
    q = np.asarray(q, dtype=np.float64)
    return quat_matrix_np(q / np.linalg.norm(q, axis=-1, keepdims=True))


def rotation_vectors(q: np.ndarray, q0: np.ndarray) -> np.ndarray:
    """World rotation vectors (axis × angle, (N, 3) [rad]) of Δq = q q0⁻¹,
    angles in [0, π]."""
    q = np.asarray(q, np.float64)
    q0 = np.asarray(q0, np.float64)
    w1, v1 = q[:, :1], q[:, 1:]
    w2, v2 = q0[:, :1], -q0[:, 1:]                       # conjugate of q0
    w = w1 * w2 - np.sum(v1 * v2, axis=1, keepdims=True)
    v = w1 * v2 + w2 * v1 + np.cross(v1, v2)
    sign = np.where(w < 0, -1.0, 1.0)
    w, v = w * sign, v * sign
    s = np.linalg.norm(v, axis=1)
    ang = 2.0 * np.arctan2(s, w[:, 0])
    with np.errstate(invalid="ignore", divide="ignore"):
        fac = np.where(s > 1e-300, ang / s, 2.0)
    return v * fac[:, None]


def _ptr_owner(ptr: np.ndarray) -> np.ndarray:
    """Row -> segment index for a CSR pointer array."""
    ptr = np.asarray(ptr, dtype=np.int64)
    return np.repeat(np.arange(len(ptr) - 1), np.diff(ptr))


def frame_state(spring_state: np.ndarray | None, spring_face: np.ndarray,
                n_faces: int, n_bfaces: int):
    """Per-face state of one frame: the largest spring state on the face
    (0 elastic, 1 yielded, 2 broken, 3 contact) and the fraction of its
    springs that are broken or in contact (>= 2).  Returns
    ``(face_state (F,), face_broken (F,), bface_state (B,), bface_broken (B,))``."""
    face = np.asarray(spring_face, dtype=np.int64)
    st = (np.zeros(face.shape, np.int8) if spring_state is None
          else np.asarray(spring_state, dtype=np.int8))
    out = []
    for sel, ids, n in ((face >= 0, face, n_faces), (face < 0, -1 - face, n_bfaces)):
        ids = ids[sel]
        s = st[sel]
        m = max(n, int(ids.max()) + 1 if len(ids) else 0)  # faces the file cannot draw
        state = np.zeros(m, np.int8)
        np.maximum.at(state, ids, s)
        cnt = np.bincount(ids, minlength=m).astype(np.float64)
        brk = np.bincount(ids, weights=(s >= 2).astype(np.float64), minlength=m)
        frac = brk / np.maximum(cnt, 1.0)
        out += [state[:n], frac[:n]]
    return tuple(out)


def face_largest(values: np.ndarray, spring_face: np.ndarray, n_faces: int, n_bfaces: int):
    """Largest of a per-spring quantity ``values`` (S,) (the damage,
    field spring_damage) over the spring points of each face: ``(face
    (F,), bface (B,))``, 0 on a face without spring points."""
    face = np.asarray(spring_face, dtype=np.int64)
    v = np.asarray(values, dtype=np.float64)
    out = []
    for sel, ids, n in ((face >= 0, face, n_faces), (face < 0, -1 - face, n_bfaces)):
        ids = ids[sel]
        m = max(n, int(ids.max()) + 1 if len(ids) else 0)
        big = np.zeros(m)
        np.maximum.at(big, ids, v[sel])
        out.append(big[:n])
    return tuple(out)


@dataclass
class CellGeometry:
    """The mesh of a history (reference configuration) and the rigid motion
    of each cell.  Build with :meth:`from_history`.

    vertices (V, 3) [m]; vertex_cell (V,) owning cell; poly_ptr, poly_vertex,
    cell_poly_ptr as in the file; face_ptr (F+1,), face_xyz (Kf, 3),
    face_cells (F, 2); bface_ptr, bface_xyz, bface_cell (B,) (empty when the
    file has no boundary faces); x0 (N, 3) reference centroids, q0 (N, 4)
    reference orientations (None when not in the file)."""

    vertices: np.ndarray
    vertex_cell: np.ndarray
    cell_vertex_ptr: np.ndarray
    poly_ptr: np.ndarray
    poly_vertex: np.ndarray
    cell_poly_ptr: np.ndarray
    face_ptr: np.ndarray
    face_xyz: np.ndarray
    face_cells: np.ndarray
    bface_ptr: np.ndarray
    bface_xyz: np.ndarray
    bface_cell: np.ndarray
    x0: np.ndarray
    q0: np.ndarray | None

    @property
    def n_cells(self) -> int:
        return len(self.cell_vertex_ptr) - 1

    @property
    def n_faces(self) -> int:
        return len(self.face_ptr) - 1

    @property
    def n_bfaces(self) -> int:
        return len(self.bface_ptr) - 1

    @classmethod
    def from_history(cls, h) -> "CellGeometry":
        """From a :class:`rbsm_dyn.io.history.History`.  Raises KeyError
        naming what is missing when the file has no cell geometry."""
        need = [f"{GEOM}/{k}" for k in ("vertices", "cell_vertex_ptr", "poly_ptr",
                                         "poly_vertex", "cell_poly_ptr")]
        missing = [p for p in need if p not in h.static]
        if missing:
            raise MissingData(f"{h.path}: no cell geometry in the history (missing /"
                           + ", /".join(missing) + ")")
        s = h.static
        cvp = np.asarray(s[f"{GEOM}/cell_vertex_ptr"], np.int64)
        if "particles/bodies/reference_position" in s:
            x0 = np.asarray(s["particles/bodies/reference_position"], np.float64)
        elif h.position is not None and h.position0 is not None:
            x0 = np.asarray(h.position0, np.float64)
        else:
            raise MissingData(f"{h.path}: no reference positions of the bodies")
        q0 = s.get("particles/bodies/reference_orientation")
        if q0 is None and h.orientation is not None and h.orientation0 is not None:
            q0 = h.orientation0
        fptr = np.asarray(s.get("springs/faces/vertex_ptr", np.zeros(1, np.int64)), np.int64)
        fxyz = np.asarray(s.get("springs/faces/vertex_xyz", np.zeros((0, 3))), np.float64)
        fcells = np.asarray(s.get("springs/faces/cells", np.zeros((0, 2), np.int64)), np.int64)
        bptr = np.asarray(s.get("springs/boundary_faces/vertex_ptr", np.zeros(1, np.int64)),
                          np.int64)
        bxyz = np.asarray(s.get("springs/boundary_faces/vertex_xyz", np.zeros((0, 3))),
                          np.float64)
        bcell = np.asarray(s.get("springs/boundary_faces/cell", np.zeros(0, np.int64)), np.int64)
        return cls(vertices=np.asarray(s[f"{GEOM}/vertices"], np.float64),
                   vertex_cell=_ptr_owner(cvp), cell_vertex_ptr=cvp,
                   poly_ptr=np.asarray(s[f"{GEOM}/poly_ptr"], np.int64),
                   poly_vertex=np.asarray(s[f"{GEOM}/poly_vertex"], np.int64),
                   cell_poly_ptr=np.asarray(s[f"{GEOM}/cell_poly_ptr"], np.int64),
                   face_ptr=fptr, face_xyz=fxyz, face_cells=fcells,
                   bface_ptr=bptr, bface_xyz=bxyz, bface_cell=bcell,
                   x0=x0, q0=None if q0 is None else np.asarray(q0, np.float64))

    # ------------------------------------------------------------ motion
    def rotations(self, q: np.ndarray | None) -> np.ndarray | None:
        """R(q q0⁻¹) (N, 3, 3) for orientations q (N, 4); None (no rotation)
        when q or the reference orientation is missing."""
        if q is None or self.q0 is None:
            return None
        return quat_to_matrix(q) @ np.swapaxes(quat_to_matrix(self.q0), -1, -2)

    def move_points(self, pts: np.ndarray, cell: np.ndarray, x: np.ndarray,
                    R: np.ndarray | None, scale: float = 1.0) -> np.ndarray:
        """Points ``pts`` (K, 3) fixed to cells ``cell`` (K,), in the
        configuration of centroids x (N, 3) and rotations R (N, 3, 3); the
        displacement is multiplied by ``scale``."""
        r = pts - self.x0[cell]
        moved = x[cell] + (r if R is None else np.einsum("kij,kj->ki", R[cell], r))
        if scale != 1.0:
            moved = pts + scale * (moved - pts)
        return moved

    def cell_points(self, x, q=None, scale: float = 1.0) -> np.ndarray:
        """Vertices (V, 3) of every cell at centroids x (N, 3), orientations
        q (N, 4) or None."""
        return self.move_points(self.vertices, self.vertex_cell, x, self.rotations(q), scale)

    def face_points(self, x, q=None, scale: float = 1.0, R=None):
        """Internal face polygon vertices (Kf, 3), each face at the mean of
        its positions moved with its two cells."""
        if R is None:
            R = self.rotations(q)
        owner = _ptr_owner(self.face_ptr)
        a = self.move_points(self.face_xyz, self.face_cells[owner, 0], x, R, scale)
        b = self.move_points(self.face_xyz, self.face_cells[owner, 1], x, R, scale)
        return 0.5 * (a + b)

    def bface_points(self, x, q=None, scale: float = 1.0, R=None):
        """Boundary (support) face vertices (Kb, 3), moved with their cell."""
        if R is None:
            R = self.rotations(q)
        owner = _ptr_owner(self.bface_ptr)
        return self.move_points(self.bface_xyz, self.bface_cell[owner], x, R, scale)

    def polyhedron_cells(self) -> np.ndarray:
        """VTK legacy cell array of the cells as polyhedra (VTK_POLYHEDRON):
        per cell ``[n_words, n_faces, n_0, ids_0..., n_1, ids_1..., ...]``."""
        nv = np.diff(self.poly_ptr)                          # vertices per polygon
        poly_cell = _ptr_owner(self.cell_poly_ptr)
        n_faces = np.diff(self.cell_poly_ptr)
        words = 1 + np.bincount(poly_cell, weights=1 + nv, minlength=self.n_cells).astype(np.int64)
        total = int(np.sum(words + 1))
        out = np.empty(total, dtype=np.int64)
        cell_start = np.concatenate([[0], np.cumsum(words + 1)[:-1]])
        out[cell_start] = words
        out[cell_start + 1] = n_faces
        # position of each polygon's count word
        within = np.concatenate([[0], np.cumsum(1 + nv)[:-1]]) - \
            np.concatenate([[0], np.cumsum(1 + nv)])[self.cell_poly_ptr[:-1]][poly_cell]
        poly_start = cell_start[poly_cell] + 2 + within
        out[poly_start] = nv
        vpos = np.repeat(poly_start + 1, nv) + (np.arange(len(self.poly_vertex))
                                                - np.repeat(self.poly_ptr[:-1], nv))
        out[vpos] = self.poly_vertex
        return out
