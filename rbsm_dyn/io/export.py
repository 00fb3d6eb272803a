"""Export a history to VTK files that ParaView and pyvista open.

    python -m rbsm_dyn export RUN.h5 [--every N] [--out DIR]

writes, in DIR (default ``RUN/vtk/`` beside RUN.h5: run_folder):

* ``cells.pvd`` + ``cells/frame_NNNNNN.vtu``: the cells as polyhedra
  (VTK_POLYHEDRON), vertices moved rigidly with their body (position and
  rotation; docs/history.md "Geometry").  Point data ``displacement`` [m]
  (of each vertex, from the reference configuration), ``velocity`` [m/s]
  (v + ω × r when both are in the history, v alone without angular
  velocity; absent when the history has no velocities), ``body_id``.  Cell
  data ``body_id``, ``material``, ``displacement`` and ``velocity`` of the
  centroid, ``rotation`` [rad] (rotation vector, when orientations are in
  the history); with the ``cell_stress`` field (docs/history.md) the cell
  stress [Pa]: ``stress`` (9 components, a tensor to ParaView), ``sxx``,
  ``syy``, ``szz``, ``sxy``, ``syz``, ``sxz``, ``von_mises`` and the
  principal stresses ``principal_max`` ≥ ``principal_mid`` ≥
  ``principal_min`` (tension positive; :func:`stress_measures`); with the
  ``spring_damage`` field ``damage`` (largest damage of the spring points
  on the cell's faces, 0..1).
* ``faces.pvd`` + ``faces/frame_NNNNNN.vtp``: the faces that are not
  elastic (a spring on them yielded, broke or is in contact, or, with the
  ``spring_damage`` field, softened: damage > 0) as polygons, drawn between
  their two cells (a support face on its cell).  Cell data ``state``
  (largest spring state on the face: 0 elastic but damaged, 1 yielded,
  2 broken, 3 contact), ``broken_fraction`` (share of the face's spring
  points that are broken or in contact), ``face_id`` (internal face id, or
  -1 - boundary face id), ``cell_a``, ``cell_b`` (-1 for the ground of a
  support); with the ``spring_damage`` field ``damage`` (largest damage of
  the face's spring points: 0 intact .. 1 broken).  An elastic frame gives
  an empty file.

A history without any of the fields the cells are drawn from (position,
orientation, velocity, angular_velocity, cell_stress, spring_damage) has the
same cells at every frame: they are written once (the first frame's file,
listed once in ``cells.pvd``), and so are the faces without the
spring_state and spring_damage fields; export says so.

Every file carries field data ``time``, ``step`` and ``frame`` (frame index
in the history).  The ``.pvd`` collections hold the time of each frame
(the load factor in static mode, the mode number in modal mode).  Points
are the deformed configuration; ``displacement`` is there to magnify it
(ParaView: Warp By Vector with scale factor s - 1 shows displacements × s).
"""
from __future__ import annotations

import os
from pathlib import Path
from xml.sax.saxutils import quoteattr

import numpy as np

from .geometry import CellGeometry, face_largest, frame_state, rotation_vectors
from .history import History, input_problem, open_history, require_rbsm_history

__all__ = ["export", "cells_mesh", "faces_mesh", "write_pvd", "stress_measures",
           "spring_damage", "STRESS_MEASURES"]

#: scalar measures of the cell stress tensor (cell data, render --color)
STRESS_MEASURES = ("sxx", "syy", "szz", "sxy", "syz", "sxz", "von_mises",
                   "principal_max", "principal_mid", "principal_min")

#: frames read from the file at a time (memory bound for long histories)
BLOCK_FRAMES = 32

#: series the cells' files are drawn from (without any, every frame's is the same)
CELL_SERIES = ("particles/bodies/position", "particles/bodies/orientation",
               "particles/bodies/velocity", "particles/bodies/angular_velocity",
               "particles/bodies/stress", "springs/damage")
#: the series the faces' files are drawn from
FACE_SERIES = ("springs/state", "springs/damage")
#: the damage of each spring point (field spring_damage, solvers/output.py)
DAMAGE_SERIES = "springs/damage"



def run_folder(path):
    """The folder beside a history RUN.h5 where what is made from it lands
    by default: RUN/ (export's vtk/, render's frameK.png, plot's
    plot.png), so that a working directory holds one file and one folder
    per run (issue 17)."""
    path = Path(path)
    return path.with_name(path.stem)


def spring_damage(h: History, k: int):
    """The damage (S,) of row ``k`` of ``h`` (field spring_damage: 0 intact
    .. 1 broken), or None when the history does not have it."""
    d = h.series.get(DAMAGE_SERIES)
    return None if d is None else np.asarray(d[k], np.float64)


def _pv():
    import pyvista as pv
    return pv


def stress_measures(sigma) -> dict:
    """Scalar measures of stress tensors sigma (..., 3, 3) [Pa], symmetric:
    the six components, the von Mises stress √(3/2 s:s) (s the deviator)
    and the principal stresses (eigenvalues, largest first): a dict of
    arrays (...) named as STRESS_MEASURES."""
    sig = np.asarray(sigma, dtype=float)
    out = {"sxx": sig[..., 0, 0], "syy": sig[..., 1, 1], "szz": sig[..., 2, 2],
           "sxy": sig[..., 0, 1], "syz": sig[..., 1, 2], "sxz": sig[..., 0, 2]}
    dev = sig - np.trace(sig, axis1=-2, axis2=-1)[..., None, None] / 3.0 * np.eye(3)
    out["von_mises"] = np.sqrt(1.5 * np.einsum("...ij,...ij->...", dev, dev))
    p = np.linalg.eigvalsh(sig)                       # ascending
    out["principal_max"], out["principal_mid"], out["principal_min"] = \
        p[..., 2], p[..., 1], p[..., 0]
    return out


def cells_mesh(h: History, k: int, geom: CellGeometry | None = None, scale: float = 1.0,
               template=None):
    """The cells of row ``k`` of ``h`` as a pyvista UnstructuredGrid of
    polyhedra, displacements multiplied by ``scale`` (1: the true
    configuration).  ``template``: a grid from an earlier call, whose
    topology is reused."""
    pv = _pv()
    geom = geom or h.geometry()
    x = h.position[k] if h.position is not None else geom.x0
    q = h.orientation[k] if h.orientation is not None else None
    R = geom.rotations(q)
    pts = geom.move_points(geom.vertices, geom.vertex_cell, x, R, scale)
    if template is None:
        cells = geom.polyhedron_cells()
        types = np.full(geom.n_cells, pv.CellType.POLYHEDRON, dtype=np.uint8)
        grid = pv.UnstructuredGrid(cells, types, pts)
    else:
        grid = template.copy(deep=False)
        grid.points = pts
    vc = geom.vertex_cell
    grid.point_data["displacement"] = pts - geom.vertices
    grid.point_data["body_id"] = vc.astype(np.int32)
    ids = np.arange(geom.n_cells, dtype=np.int32)
    grid.cell_data["body_id"] = ids
    mat = h.static.get("particles/bodies/material")
    if mat is not None:
        grid.cell_data["material"] = np.asarray(mat, np.int32)
    grid.cell_data["displacement"] = scale * (x - geom.x0)
    v = h.velocity[k] if h.velocity is not None else None
    if v is not None:
        pv_ = v[vc].copy()
        w = h.angular_velocity[k] if h.angular_velocity is not None else None
        if w is not None:
            pv_ += np.cross(w[vc], pts - (geom.x0 + scale * (x - geom.x0))[vc])
        grid.point_data["velocity"] = pv_
        grid.cell_data["velocity"] = v
    g = h.ground_displacement
    if g is not None:
        # a case with a ground_motion: the fields relative to the ground
        grid.cell_data["displacement_relative_to_ground"] = scale * (x - geom.x0 - g[k])
        if v is not None:
            grid.cell_data["velocity_relative_to_ground"] = v - h.ground_velocity[k]
    if q is not None and geom.q0 is not None:
        grid.cell_data["rotation"] = rotation_vectors(q, geom.q0)
    sig = h.cell_stress[k] if h.cell_stress is not None else None
    if sig is not None:
        grid.cell_data["stress"] = sig.reshape(-1, 9)
        for name, val in stress_measures(sig).items():
            grid.cell_data[name] = val
    dmg = spring_damage(h, k)
    if dmg is not None:
        cd = np.zeros(geom.n_cells)
        ends = np.asarray(h.static["connectivity/springs"], np.int64)
        for j in (0, 1):
            own = ends[:, j] < geom.n_cells          # (not the ground of a support)
            np.maximum.at(cd, ends[own, j], dmg[own])
        grid.cell_data["damage"] = cd
    _field_data(grid, h, k)
    return grid


def faces_mesh(h: History, k: int, geom: CellGeometry | None = None, scale: float = 1.0,
               min_state: int = 1):
    """The faces of row ``k`` whose largest spring state is >= ``min_state``
    (1: yielded, broken or in contact; 2: cracks only) as a pyvista PolyData
    of polygons (see the module docstring for the data); with min_state <= 1
    and the spring_damage field, also the faces with damage > 0 (softening
    before they break).  Each polygon has its own points, in face order."""
    pv = _pv()
    geom = geom or h.geometry()
    x = h.position[k] if h.position is not None else geom.x0
    q = h.orientation[k] if h.orientation is not None else None
    R = geom.rotations(q)
    st = h.spring_state[k] if h.spring_state is not None else None
    fstate, fbroken, bstate, bbroken = frame_state(
        st, h.static["springs/face"], geom.n_faces, geom.n_bfaces)
    dmg = spring_damage(h, k)
    if dmg is not None:
        fdmg, bdmg = face_largest(dmg, h.static["springs/face"], geom.n_faces, geom.n_bfaces)
    on_f, on_b = fstate >= min_state, bstate >= min_state
    if dmg is not None and min_state <= 1:
        on_f, on_b = on_f | (fdmg > 0), on_b | (bdmg > 0)
    sel_f = np.nonzero(on_f)[0]
    sel_b = np.nonzero(on_b)[0]
    pts_list, faces_list = [], []
    offset = 0
    for sel, ptr, xyz_fn in ((sel_f, geom.face_ptr, geom.face_points),
                             (sel_b, geom.bface_ptr, geom.bface_points)):
        if len(sel) == 0:
            continue
        allpts = xyz_fn(x, q, scale, R=R)
        n = ptr[sel + 1] - ptr[sel]
        rows = np.concatenate([np.arange(ptr[i], ptr[i + 1]) for i in sel])
        pts_list.append(allpts[rows])
        conn = np.arange(offset, offset + len(rows))
        starts = np.concatenate([[0], np.cumsum(n)[:-1]])
        block = np.empty(len(rows) + len(sel), dtype=np.int64)
        hdr = starts + np.arange(len(sel))
        block[hdr] = n
        mask = np.ones(len(block), bool)
        mask[hdr] = False
        block[mask] = conn
        faces_list.append(block)
        offset += len(rows)
    if pts_list:
        poly = pv.PolyData(np.concatenate(pts_list), faces=np.concatenate(faces_list))
    else:
        poly = pv.PolyData()
    fc = geom.face_cells
    poly.cell_data["state"] = np.concatenate([fstate[sel_f], bstate[sel_b]]).astype(np.int8)
    poly.cell_data["broken_fraction"] = np.concatenate([fbroken[sel_f], bbroken[sel_b]])
    poly.cell_data["face_id"] = np.concatenate([sel_f, -1 - sel_b]).astype(np.int64)
    poly.cell_data["cell_a"] = np.concatenate([fc[sel_f, 0] if len(fc) else sel_f,
                                               geom.bface_cell[sel_b]]).astype(np.int64)
    poly.cell_data["cell_b"] = np.concatenate([fc[sel_f, 1] if len(fc) else sel_f,
                                               np.full(len(sel_b), -1)]).astype(np.int64)
    if dmg is not None:
        poly.cell_data["damage"] = np.concatenate([fdmg[sel_f], bdmg[sel_b]])
    _field_data(poly, h, k)
    return poly


def _field_data(ds, h: History, k: int) -> None:
    ds.field_data["time"] = np.array([h.time[k]], np.float64)
    ds.field_data["step"] = np.array([h.step[k]], np.int64)
    ds.field_data["frame"] = np.array([h.frame_index[k]], np.int64)


def write_pvd(path, entries) -> None:
    """A ParaView collection file: ``entries`` = [(time, relative file)]."""
    lines = ['<?xml version="1.0"?>',
             '<VTKFile type="Collection" version="0.1" byte_order="LittleEndian">',
             "  <Collection>"]
    for t, f in entries:
        lines.append(f'    <DataSet timestep="{float(t):.17g}" group="" part="0" '
                     f"file={quoteattr(str(f))}/>")
    lines += ["  </Collection>", "</VTKFile>", ""]
    Path(path).write_text("\n".join(lines), encoding="utf-8")


def export(path, out_dir=None, *, every: int = 1, frames=None, log=None) -> dict:
    """Write the VTK time series of history ``path`` (module docstring).

    every : write every N-th frame (the last frame is always written);
    frames : an explicit selection instead (int, slice or list, as in
    :func:`rbsm_dyn.open_history`).  Returns a summary dict: ``out``,
    ``frames`` (file frame indices written), ``n_cells``, ``n_points``,
    ``faces`` (non-elastic faces per written frame), ``cells_pvd``,
    ``faces_pvd``."""
    path = Path(path)
    if every < 1:
        raise ValueError(f"--every must be >= 1 (got {every})")
    out = Path(out_dir) if out_dir is not None else run_folder(path) / "vtk"
    require_rbsm_history(path)
    head = open_history(path, frames=[])
    geom = head.geometry()
    T = head.frames_in_file
    if frames is None:
        idx = np.arange(0, T, every, dtype=np.int64)
        if T and idx[-1] != T - 1:
            idx = np.append(idx, T - 1)
    else:
        from .history import frame_indices
        idx = frame_indices(frames, T)
    (out / "cells").mkdir(parents=True, exist_ok=True)
    (out / "faces").mkdir(parents=True, exist_ok=True)
    # a history without the series the cells or the faces are drawn from
    # would give the same file at every frame: write it once (the .pvd
    # lists it once, ParaView shows it at every time) and say so
    cells_vary = any(p in head.series for p in CELL_SERIES)
    faces_vary = any(p in head.series for p in FACE_SERIES)
    notes = []
    if len(idx) > 1 and not cells_vary:
        notes.append("the history has none of the fields position, orientation, velocity, "
                     "angular_velocity, cell_stress, spring_damage: the cells are the same at "
                     "every frame, written once (reference configuration)")
    if len(idx) > 1 and not faces_vary:
        notes.append("the history has no spring_state or spring_damage field: the faces are "
                     "the same at every frame, written once")
    cell_entries, face_entries, n_faces = [], [], []
    template = None
    for b0 in range(0, len(idx), BLOCK_FRAMES):
        h = open_history(path, frames=idx[b0:b0 + BLOCK_FRAMES])
        for k in range(h.frames):
            fi = int(h.frame_index[k])
            if cells_vary or not cell_entries:
                grid = cells_mesh(h, k, geom, template=template)
                template = grid if template is None else template
                cf = f"cells/frame_{fi:06d}.vtu"
                grid.save(out / cf)
                cell_entries.append((h.time[k], cf))
            if faces_vary or not face_entries:
                faces = faces_mesh(h, k, geom)
                ff = f"faces/frame_{fi:06d}.vtp"
                faces.save(out / ff)
                face_entries.append((h.time[k], ff))
            n_faces.append(faces.n_cells)
            if log:
                log(f"frame {fi} (t = {h.time[k]:.6g}): {geom.n_cells} cells, "
                    f"{faces.n_cells} non-elastic faces")
    write_pvd(out / "cells.pvd", cell_entries)
    write_pvd(out / "faces.pvd", face_entries)
    return {"out": str(out), "frames": idx.tolist(), "n_cells": geom.n_cells,
            "n_points": len(geom.vertices), "faces": n_faces,
            "cells_pvd": str(out / "cells.pvd"), "faces_pvd": str(out / "faces.pvd"),
            "cell_files": len(cell_entries), "face_files": len(face_entries), "notes": notes,
            "bytes": sum(f.stat().st_size for f in out.rglob("*") if f.is_file())}


def add_arguments(p) -> None:
    p.add_argument("history", help="history file (RUN.h5)")
    p.add_argument("--every", type=int, default=1, metavar="N",
                   help="write every N-th frame (and the last); default 1")
    p.add_argument("--out", metavar="DIR", help="output folder (default RUN/vtk/ beside RUN.h5)")
    p.add_argument("--quiet", action="store_true", help="print nothing on success")


def main(args) -> int:
    """``python -m rbsm_dyn export`` on a parsed namespace."""
    import sys
    problem = input_problem(args.history)
    if problem:
        print(f"rbsm_dyn: export: {problem}", file=sys.stderr)
        return 2
    if args.every < 1:
        print(f"rbsm_dyn: export: --every must be >= 1 (got {args.every})", file=sys.stderr)
        return 2
    try:
        res = export(args.history, args.out, every=args.every)
    except (KeyError, ValueError, OSError) as exc:
        print(f"rbsm_dyn: export: {exc}", file=sys.stderr)
        return 2
    if not args.quiet:
        for note in res["notes"]:
            print(f"rbsm_dyn: export: note: {note}")
        nf = max(res["faces"]) if res["faces"] else 0
        print(f"rbsm_dyn: exported {len(res['frames'])} frames of {res['n_cells']} cells "
              f"(up to {nf} non-elastic faces) to {res['out']} "
              f"({res['bytes'] / 2**20:.1f} MiB): open cells.pvd and faces.pvd in ParaView")
    return 0
