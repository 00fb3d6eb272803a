"""Closed surface meshes from files.

* STL, OBJ, PLY, OFF, GLB ... (what trimesh reads) through trimesh, loaded
  without processing; vertices with exactly equal coordinates are merged
  (STL stores every triangle's corners separately), nothing is snapped.
* other mesh formats (.msh, .vtk, .vtu, .med, ...) through meshio when it
  is installed; gmsh physical surface groups become named regions.
* STEP / IGES / BREP through gmsh's OpenCASCADE kernel when gmsh is
  installed (``pip install rbsm_dyn[cad]``); the surface is meshed with
  gmsh's curvature-based size so that a circle of radius up to half the
  model's diagonal keeps the chord tolerance (the circle rule of
  rbsm_dyn.geometry.primitives).

The surface must be closed (every edge shared by exactly two triangles)
and manifold; triangles are oriented consistently and outward (positive
volume).  Otherwise a GeometryError says what is wrong.
"""
from __future__ import annotations

from pathlib import Path

import numpy as np

from .errors import GeometryError
from .primitives import Facets, circle_segments

__all__ = ["read_surface", "CAD_SUFFIXES"]

CAD_SUFFIXES = (".step", ".stp", ".iges", ".igs", ".brep")


def read_surface(filename, *, path=(), chord=None) -> Facets:
    """Read a closed triangle surface; regions: gmsh physical groups when the
    file has them, else one region ``surface``."""
    p = Path(filename)
    path = tuple(path)
    if not p.is_file():
        raise GeometryError(path, f"file not found: {p}")
    suffix = p.suffix.lower()
    if suffix in CAD_SUFFIXES:
        vertices, triangles, region, names = _read_cad(p, path, chord)
    else:
        vertices, triangles, region, names = _read_mesh(p, path)
    return _closed(vertices, triangles, region, names, path, p)


def _read_mesh(p, path):
    import trimesh
    suffix = p.suffix.lower().lstrip(".")
    if suffix in trimesh.available_formats():
        try:
            mesh = trimesh.load(str(p), force="mesh", process=False)
        except Exception as exc:            # a parser's own message
            raise GeometryError(path, f"cannot read {p.name}: {exc}") from None
        v = np.asarray(mesh.vertices, dtype=np.float64)
        f = np.asarray(mesh.faces, dtype=np.int64).reshape(-1, 3)
        return v, f, np.zeros(len(f), np.int64), ("surface",)
    try:
        import meshio
    except ImportError:
        raise GeometryError(path, f"cannot read '.{suffix}' files: trimesh reads "
                                  f"{', '.join(sorted(trimesh.available_formats()))}; "
                                  f"install meshio for more formats") from None
    try:
        mesh = meshio.read(str(p))
    except Exception as exc:
        raise GeometryError(path, f"cannot read {p.name}: {exc}") from None
    return _from_meshio(mesh, path)


def _from_meshio(mesh, path):
    """Triangles (quads split) of a meshio Mesh; gmsh physical surface groups
    (cell data 'gmsh:physical', names in field_data) become regions."""
    v = np.asarray(mesh.points, dtype=np.float64)
    if v.shape[1] == 2:
        raise GeometryError(path, "a 2D mesh is not a closed surface")
    tags = mesh.cell_data.get("gmsh:physical") if hasattr(mesh, "cell_data") else None
    names_of = {int(val[0]): name for name, val in getattr(mesh, "field_data", {}).items()
                if len(val) > 1 and int(val[1]) == 2}
    tris, tri_tag = [], []
    for b, block in enumerate(mesh.cells):
        data = np.asarray(block.data, dtype=np.int64)
        if block.type == "triangle":
            t = data
        elif block.type == "quad":
            t = np.vstack([data[:, [0, 1, 2]], data[:, [0, 2, 3]]])
        else:
            continue
        tris.append(t)
        if tags is not None:
            tg = np.asarray(tags[b], dtype=np.int64)
            tri_tag.append(tg if block.type == "triangle" else np.concatenate([tg, tg]))
        else:
            tri_tag.append(np.full(len(t), -1, np.int64))
    if not tris:
        raise GeometryError(path, "the file has no triangles or quads (a surface mesh is needed)")
    t = np.vstack(tris)
    uniq, inv = np.unique(np.concatenate(tri_tag), return_inverse=True)
    labels = [names_of.get(int(x), "surface") for x in uniq]
    names = tuple(dict.fromkeys(labels))
    region = np.array([names.index(lab) for lab in labels], np.int64)[inv.reshape(-1)]
    return v, t, region, names


def _read_cad(p, path, chord):
    try:
        import gmsh
    except ImportError:
        raise GeometryError(path, f"reading {p.suffix} (CAD) files needs gmsh, which is not "
                                  f"installed: pip install rbsm_dyn[cad]") from None
    started = False
    try:
        gmsh.initialize(interruptible=False)
        started = True
        gmsh.option.setNumber("General.Terminal", 0)
        gmsh.option.setString("Geometry.OCCTargetUnit", "M")      # metres, whatever the file
        gmsh.model.add("rbsm_dyn")
        gmsh.model.occ.importShapes(str(p))
        gmsh.model.occ.synchronize()
        lo = np.array(gmsh.model.getBoundingBox(-1, -1)[:3])
        hi = np.array(gmsh.model.getBoundingBox(-1, -1)[3:])
        diag = float(np.linalg.norm(hi - lo))
        if chord is not None:
            n = circle_segments(0.5 * diag, chord)
            gmsh.option.setNumber("Mesh.MeshSizeFromCurvature", n)
        gmsh.option.setNumber("Mesh.MeshSizeMax", diag / 8)
        gmsh.model.mesh.generate(2)
        tags, coords, _ = gmsh.model.mesh.getNodes()
        v = np.asarray(coords, dtype=np.float64).reshape(-1, 3)
        tags = np.asarray(tags, dtype=np.int64)
        index = np.full(int(tags.max()) + 1, -1, np.int64)      # node tag -> row of v
        index[tags] = np.arange(len(tags))
        physical = {}
        for dim, ptag in gmsh.model.getPhysicalGroups(2):
            name = gmsh.model.getPhysicalName(dim, ptag) or f"physical{ptag}"
            for ent in gmsh.model.getEntitiesForPhysicalGroup(dim, ptag):
                physical[int(ent)] = name
        names = list(dict.fromkeys(["surface"] + list(physical.values())))
        tris, region = [], []
        for _, ent in gmsh.model.getEntities(2):
            etypes, _, enodes = gmsh.model.mesh.getElements(2, ent)
            for et, nodes in zip(etypes, enodes):
                if et != 2:                   # 3-node triangles only
                    continue
                t = index[np.asarray(nodes, dtype=np.int64)].reshape(-1, 3)
                tris.append(t)
                region.append(np.full(len(t), names.index(physical.get(int(ent), "surface"))))
    except GeometryError:
        raise
    except Exception as exc:
        raise GeometryError(path, f"gmsh could not read or mesh {p.name}: {exc}") from None
    finally:
        if started:
            gmsh.finalize()
    if not tris:
        raise GeometryError(path, f"{p.name} has no surfaces")
    return v, np.vstack(tris), np.concatenate(region).astype(np.int64), tuple(names)


def _closed(v, t, region, names, path, p) -> Facets:
    """Merge equal vertices, check the surface is closed and manifold, orient
    it outward; drop regions without triangles."""
    if len(t) == 0:
        raise GeometryError(path, f"{p.name} has no triangles")
    if not np.all(np.isfinite(v)):
        raise GeometryError(path, f"{p.name} has non-finite vertex coordinates")
    v, inv = np.unique(v, axis=0, return_inverse=True)
    t = inv.reshape(-1)[t]
    keep = (t[:, 0] != t[:, 1]) & (t[:, 1] != t[:, 2]) & (t[:, 2] != t[:, 0])
    t, region = t[keep], region[keep]
    used = np.unique(t)
    remap = np.full(len(v), -1, np.int64)
    remap[used] = np.arange(len(used))
    v, t = v[used], remap[t]
    # edges: each undirected edge must border exactly two triangles
    e = np.concatenate([t[:, [0, 1]], t[:, [1, 2]], t[:, [2, 0]]])
    und = np.sort(e, axis=1)
    _, count = np.unique(und, axis=0, return_counts=True)
    open_edges = int(np.count_nonzero(count == 1))
    if open_edges:
        raise GeometryError(path, f"{p.name} is not a closed surface: {open_edges} edges "
                                  f"border only one triangle")
    multi = int(np.count_nonzero(count > 2))
    if multi:
        raise GeometryError(path, f"{p.name} is not manifold: {multi} edges are shared by "
                                  f"more than two triangles")
    _, dcount = np.unique(e, axis=0, return_counts=True)
    if np.any(dcount > 1):                  # neighbours disagree on the orientation
        import trimesh
        mesh = trimesh.Trimesh(v, t, process=False)
        trimesh.repair.fix_winding(mesh)
        t = np.asarray(mesh.faces, dtype=np.int64)
        e = np.concatenate([t[:, [0, 1]], t[:, [1, 2]], t[:, [2, 0]]])
        _, dcount = np.unique(e, axis=0, return_counts=True)
        if np.any(dcount > 1):
            raise GeometryError(path, f"{p.name}: the triangles cannot be oriented "
                                      f"consistently (a one-sided surface?)")
    r = v[t] - 0.5 * (v.min(axis=0) + v.max(axis=0))
    vol = np.einsum("ij,ij->i", r[:, 0], np.cross(r[:, 1], r[:, 2])).sum() / 6.0
    if vol < 0:
        t = t[:, ::-1].copy()
    elif vol == 0:
        raise GeometryError(path, f"{p.name} encloses no volume")
    present = np.unique(region)
    rmap = np.full(len(names), -1, np.int64)
    rmap[present] = np.arange(len(present))
    return Facets(v, np.ascontiguousarray(t), rmap[region], tuple(names[i] for i in present))
