"""Meshes of several parts: a rigid body as one cell, the concatenation of
the meshes of several parts, and faces tying cells of different parts.

``rigid_mesh`` turns a closed, outward-oriented triangle surface (a
:class:`rbsm_dyn.geometry.Solid`) into a Mesh of one cell whose polygons are
the triangles; ``merge_meshes`` concatenates the meshes of the parts into one
Mesh (``cell_part``, ``part_names``, ``face_interface``, mesh/_core.py);
``add_interface_faces`` appends internal faces between cells of different
parts.  Everything is numpy concatenation and CSR arithmetic (the only loop
runs over the list of parts).
"""
from __future__ import annotations

import dataclasses

import numpy as np

from ._core import Mesh, _gather, assemble
from .spring_points import polygon_properties

__all__ = ["rigid_mesh", "merge_meshes", "add_interface_faces"]

#: triangles with |(p1 − p0) × (p2 − p0)| below this times (bounding-box
#: diagonal)² have no reliable normal (area ~ round-off) and are left out
_DEGENERATE = 1e-12


def _i64(a):
    return np.ascontiguousarray(a, dtype=np.int64)


def _f64(a):
    return np.ascontiguousarray(a, dtype=np.float64)


def rigid_mesh(vertices, triangles, tri_surface, surface_names, box=None) -> Mesh:
    """A Mesh of one cell bounded by a closed triangle surface.

    vertices (V, 3); triangles (T, 3), counter-clockwise seen from outside;
    tri_surface (T,) index into surface_names (a Solid's fields:
    ``rigid_mesh(s.vertices, s.triangles, s.tri_surface, s.surface_names)``).
    The cell may be non-convex.  No internal faces; every triangle is a
    boundary face (bface_side = tri_surface, bface_normal its outward unit
    normal), except degenerate triangles (area at round-off level: no
    normal; they add nothing to areas or moments), which are left out.
    ``box`` defaults to the bounds of the vertices.

    Mass properties: rbsm_dyn.mesh.polyhedron.cells_mass_properties (Tonon
    2004 tetrahedron moments).  It sums *signed* tetrahedra
    (det[r1 r2 r3] / 6 without abs) closed at a reference point, i.e. the
    divergence theorem over the oriented surface: exact for any closed,
    outward-oriented surface, convex or not, whatever the reference point
    (here the bounding-box centre, to keep digits).

    Raises ValueError when the surface is not closed and consistently
    oriented (every directed edge once, each matched by its reverse) or
    encloses a non-positive volume (inward-oriented).
    """
    xyz = _f64(vertices)
    tri = _i64(triangles)
    side = _i64(tri_surface)
    names = tuple(str(n) for n in surface_names)
    if xyz.ndim != 2 or xyz.shape[1] != 3 or not np.all(np.isfinite(xyz)):
        raise ValueError(f"vertices must be a finite (V, 3) array (got shape {xyz.shape})")
    if tri.ndim != 2 or tri.shape[1] != 3 or len(tri) < 4:
        raise ValueError(f"triangles must be a (T, 3) array with T >= 4 (got shape {tri.shape})")
    if tri.min() < 0 or tri.max() >= len(xyz):
        raise ValueError("triangles index vertices out of range")
    if side.shape != (len(tri),) or side.min() < 0 or side.max() >= len(names):
        raise ValueError("tri_surface must be (T,) indices into surface_names")

    # closed and consistently oriented: the directed edges are unique and
    # their set equals the set of reversed edges
    nv = len(xyz)
    e0 = tri.ravel()
    e1 = tri[:, [1, 2, 0]].ravel()
    key = np.sort(e0 * nv + e1)
    rkey = np.sort(e1 * nv + e0)
    if np.any(key[1:] == key[:-1]) or not np.array_equal(key, rkey):
        raise ValueError("the triangle surface is not closed and consistently oriented "
                         "(every edge must be used once in each direction)")

    used = xyz[np.unique(tri)]
    lo, hi = used.min(axis=0), used.max(axis=0)
    p = xyz[tri]
    cr = np.cross(p[:, 1] - p[:, 0], p[:, 2] - p[:, 0])
    norm = np.linalg.norm(cr, axis=1)
    keep = norm > _DEGENERATE * float(np.sum((hi - lo) ** 2))
    tri, side = tri[keep], side[keep]
    normal = cr[keep] / norm[keep, None]
    T = len(tri)
    if T < 4:
        raise ValueError("the triangle surface has fewer than 4 non-degenerate triangles")

    box = np.stack([lo, hi]) if box is None else _f64(box)
    if box.shape != (2, 3):
        raise ValueError(f"box must be (2, 3) (got shape {box.shape})")
    ref = 0.5 * (lo + hi)
    mesh = assemble(
        box, xyz,
        np.zeros((0, 2), np.int64), np.zeros(1, np.int64), np.zeros(0, np.int64), np.zeros((0, 3)),
        np.zeros(T, np.int64), side, np.arange(0, 3 * T + 1, 3, dtype=np.int64), tri.ravel(), 1,
        ref=ref[None, :], b_normal=normal, surface_names=names,
    )
    if not mesh.cell_volume[0] > 0:
        raise ValueError(f"the triangle surface encloses volume {mesh.cell_volume[0]!r} <= 0 "
                         "(triangles must be counter-clockwise seen from outside)")
    return mesh


def _cat_ptr(ptrs, offsets):
    """Concatenate CSR pointer arrays whose targets are concatenated with
    the given offsets."""
    return _i64(np.concatenate([np.zeros(1, np.int64)]
                               + [np.asarray(p[1:], np.int64) + o for p, o in zip(ptrs, offsets)]))


def _offsets(counts):
    return np.concatenate([[0], np.cumsum(counts)[:-1]]).astype(np.int64)


def _one_part(m):
    """True when Mesh ``m`` holds a single part without interface faces."""
    if len(m.part_names) > 1:
        return False
    if m.cell_part is not None and np.any(np.asarray(m.cell_part) != 0):
        return False
    return m.face_interface is None or bool(np.all(np.asarray(m.face_interface) == -1))


def _sort_faces(fields, order):
    """Permute the internal-face fields (a dict of Mesh field values) by
    ``order``; the polygon CSR with _gather."""
    out = dict(fields)
    out["face_vertex_ptr"], out["face_vertex_xyz"] = _gather(
        fields["face_vertex_ptr"], fields["face_vertex_xyz"], order)
    for k in ("face_cells", "face_normal", "face_area", "face_centroid", "face_interface"):
        out[k] = fields[k][order]
    return out


def merge_meshes(meshes, part_names) -> Mesh:
    """Concatenate the meshes of several parts into one Mesh.

    Cells come in the order of the parts (part k's cells are
    ``cell_part == k``); every index array is offset, internal faces stay
    sorted by (a, b) and boundary faces by (side, cell).  Surface names
    become ``"<part>.<name>"`` (bface_side offset by the surface names of
    the earlier parts); box = the bounds of all boxes; face_interface is −1
    for every face (add_interface_faces adds the faces between parts).

    Each mesh must be a single part (a mesh from merge_meshes with more than
    one part, or with interface faces, is refused).  Part names must be
    unique, non-empty and without ".".
    """
    meshes = list(meshes)
    part_names = tuple(str(n) for n in part_names)
    if not meshes or len(meshes) != len(part_names):
        raise ValueError(f"need one part name per mesh (got {len(meshes)} meshes, "
                         f"{len(part_names)} names)")
    if len(set(part_names)) != len(part_names) or any(not n or "." in n for n in part_names):
        raise ValueError(f"part names must be unique, non-empty and without '.': {part_names}")
    for name, m in zip(part_names, meshes):
        if not isinstance(m, Mesh):
            raise TypeError(f"part {name!r}: expected a Mesh, got {type(m).__name__}")
        if not _one_part(m):
            raise ValueError(f"part {name!r}: the mesh already has several parts or interface faces")

    n_cells = np.array([m.n_cells for m in meshes], np.int64)
    c_off = _offsets(n_cells)
    v_off = _offsets([len(m.vertices) for m in meshes])
    p_off = _offsets([len(m.poly_ptr) - 1 for m in meshes])
    pv_off = _offsets([len(m.poly_vertex) for m in meshes])
    fv_off = _offsets([len(m.face_vertex_xyz) for m in meshes])
    bv_off = _offsets([len(m.bface_vertex_xyz) for m in meshes])
    s_off = _offsets([len(m.surface_names) for m in meshes])

    def cat(field, offsets=None):
        arrs = [np.asarray(getattr(m, field)) for m in meshes]
        if offsets is not None:
            arrs = [a + o for a, o in zip(arrs, offsets)]
        return np.concatenate(arrs)

    fields = dict(
        cell_volume=_f64(cat("cell_volume")),
        cell_centroid=_f64(cat("cell_centroid")),
        cell_inertia=_f64(cat("cell_inertia")),
        vertices=_f64(cat("vertices")),
        cell_vertex_ptr=_cat_ptr([m.cell_vertex_ptr for m in meshes], v_off),
        poly_ptr=_cat_ptr([m.poly_ptr for m in meshes], pv_off),
        poly_vertex=_i64(cat("poly_vertex", v_off)),
        cell_poly_ptr=_cat_ptr([m.cell_poly_ptr for m in meshes], p_off),
        face_cells=_i64(cat("face_cells", c_off)).reshape(-1, 2),
        face_normal=_f64(cat("face_normal")).reshape(-1, 3),
        face_area=_f64(cat("face_area")),
        face_centroid=_f64(cat("face_centroid")).reshape(-1, 3),
        face_vertex_ptr=_cat_ptr([m.face_vertex_ptr for m in meshes], fv_off),
        face_vertex_xyz=_f64(cat("face_vertex_xyz")).reshape(-1, 3),
        bface_cell=_i64(cat("bface_cell", c_off)),
        bface_side=_i64(cat("bface_side", s_off)),
        bface_normal=_f64(cat("bface_normal")).reshape(-1, 3),
        bface_area=_f64(cat("bface_area")),
        bface_centroid=_f64(cat("bface_centroid")).reshape(-1, 3),
        bface_vertex_ptr=_cat_ptr([m.bface_vertex_ptr for m in meshes], bv_off),
        bface_vertex_xyz=_f64(cat("bface_vertex_xyz")).reshape(-1, 3),
    )
    fields["face_interface"] = np.full(len(fields["face_cells"]), -1, np.int64)

    # the offsets grow with the part, so both orders normally survive the
    # concatenation; re-sort (stable) if an input was not sorted
    fc = fields["face_cells"]
    fo = np.lexsort((fc[:, 1], fc[:, 0]))
    if np.any(fo != np.arange(len(fo))):
        fields = _sort_faces(fields, fo)
    bo = np.lexsort((fields["bface_cell"], fields["bface_side"]))
    if np.any(bo != np.arange(len(bo))):
        fields["bface_vertex_ptr"], fields["bface_vertex_xyz"] = _gather(
            fields["bface_vertex_ptr"], fields["bface_vertex_xyz"], bo)
        for k in ("bface_cell", "bface_side", "bface_normal", "bface_area", "bface_centroid"):
            fields[k] = fields[k][bo]

    boxes = np.stack([np.asarray(m.box, np.float64) for m in meshes])
    box = np.stack([boxes[:, 0].min(axis=0), boxes[:, 1].max(axis=0)])
    surface_names = tuple(f"{part}.{name}" for part, m in zip(part_names, meshes)
                          for name in m.surface_names)
    return Mesh(
        **fields, box=_f64(box), surface_names=surface_names,
        cell_part=_i64(np.repeat(np.arange(len(meshes), dtype=np.int64), n_cells)),
        part_names=part_names,
    )


def add_interface_faces(mesh, cells, vertex_ptr, vertex_xyz, normal, interface) -> Mesh:
    """A new Mesh with internal faces between cells of different parts
    appended.

    cells (K, 2) with a < b, the two cells of each face (of different
    parts); face k is the polygon vertex_xyz[vertex_ptr[k]:vertex_ptr[k+1]]
    counter-clockwise about normal[k] (K, 3), which points from a to b (it
    is normalised here); interface (K,) int64 >= 0, the index of the
    interface (pair of parts) of each face.  face_area and face_centroid
    come from polygon_properties.  All internal faces are then re-sorted by
    (a, b), stably (the existing faces first within a pair, then the new
    ones in the given order), face_interface permuted the same way.  The
    cells' drawing polygons, boundary faces and mass properties are kept as
    they are (the interface polygons are already the cells' polygons).

    Several faces may join the same pair of cells (e.g. a non-convex rigid
    cell touching a cell over separate patches).
    """
    if not isinstance(mesh, Mesh):
        raise TypeError(f"expected a Mesh, got {type(mesh).__name__}")
    cells = _i64(cells).reshape(-1, 2)
    K = len(cells)
    ptr = _i64(vertex_ptr)
    xyz = _f64(vertex_xyz).reshape(-1, 3)
    nrm = _f64(normal).reshape(-1, 3)
    iface = _i64(interface).reshape(-1)
    if ptr.shape != (K + 1,) or ptr[0] != 0 or ptr[-1] != len(xyz) or np.any(np.diff(ptr) < 3):
        raise ValueError("vertex_ptr must be (K+1,) from 0 to len(vertex_xyz), >= 3 vertices a face")
    if nrm.shape != (K, 3) or iface.shape != (K,):
        raise ValueError("normal must be (K, 3) and interface (K,)")
    if K and (cells.min() < 0 or cells.max() >= mesh.n_cells or np.any(cells[:, 0] >= cells[:, 1])):
        raise ValueError("cells must be (K, 2) cell indices with a < b")
    if np.any(iface < 0):
        raise ValueError("interface indices must be >= 0")
    part = np.zeros(mesh.n_cells, np.int64) if mesh.cell_part is None else np.asarray(mesh.cell_part)
    if np.any(part[cells[:, 0]] == part[cells[:, 1]]):
        raise ValueError("an interface face must join cells of different parts")
    ln = np.linalg.norm(nrm, axis=1)
    if not np.all(ln > 0):
        raise ValueError("face normals must be non-zero")
    nrm = nrm / ln[:, None]
    area, cen = polygon_properties(ptr, xyz, nrm)
    if not np.all(area > 0):
        raise ValueError("interface polygons must be counter-clockwise about their normals "
                         "(non-positive area)")

    old_iface = (np.full(mesh.n_faces, -1, np.int64) if mesh.face_interface is None
                 else _i64(mesh.face_interface))
    fields = dict(
        face_cells=_i64(np.concatenate([mesh.face_cells, cells])),
        face_normal=_f64(np.concatenate([mesh.face_normal, nrm])),
        face_area=_f64(np.concatenate([mesh.face_area, area])),
        face_centroid=_f64(np.concatenate([mesh.face_centroid, cen])),
        face_vertex_ptr=_cat_ptr([mesh.face_vertex_ptr, ptr], [0, len(mesh.face_vertex_xyz)]),
        face_vertex_xyz=_f64(np.concatenate([mesh.face_vertex_xyz, xyz])),
        face_interface=_i64(np.concatenate([old_iface, iface])),
    )
    fc = fields["face_cells"]
    fields = _sort_faces(fields, np.lexsort((fc[:, 1], fc[:, 0])))  # lexsort is stable
    fields = {k: (_i64(v) if v.dtype.kind == "i" else _f64(v)) for k, v in fields.items()}
    return dataclasses.replace(mesh, **fields)
