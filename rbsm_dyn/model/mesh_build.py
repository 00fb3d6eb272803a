"""The cells of the scene: one part's mesh (part_mesh), or the parts'
meshes merged with their interfaces' faces (build_mesh)."""
import numpy as np

from ..mesh import block_mesh, voronoi_mesh, voronoi_seeds
from ..mesh.cut_seeds import mirror_across_cuts
from ..mesh.voronoi_plane import plane_voronoi_mesh


def build_mesh(case):
    """Cells of the scene (DESIGN.md §6).  One part (the ``domain`` +
    ``mesh`` shorthand): its mesh (part_mesh).  Several parts: each part's
    mesh, merged (mesh/merge.py), and the overlaps of touching parts'
    boundary faces (mesh/interface.py) added as internal faces that carry
    the index of their interface (Mesh.face_interface); parts that touch
    with no interface in the case are an error unless the case's
    ``contact`` covers them (then they share no face: contact alone acts)."""
    from ..case import scene_parts
    parts = scene_parts(case)
    if not case.parts:
        return part_mesh(case, parts[0])
    from ..mesh.interface import face_overlaps
    from ..mesh.merge import add_interface_faces, merge_meshes
    mesh = merge_meshes([part_mesh(case, p) for p in parts], [p.name for p in parts])
    diag = float(np.linalg.norm(mesh.box[1] - mesh.box[0]))
    try:
        ov = face_overlaps(mesh.bface_vertex_ptr, mesh.bface_vertex_xyz, mesh.bface_normal,
                           mesh.bface_cell, mesh.cell_part, length_tol=1e-9 * diag)
    except ValueError as exc:
        raise case.error(("interfaces",), str(exc)) from None
    names = list(case.parts)
    pair_of = {}
    for i, it in enumerate(case.interfaces):
        pa, pb = (names.index(x) for x in it.parts)
        pair_of[(min(pa, pb), max(pa, pb))] = i
    pa = mesh.cell_part[ov.cells[:, 0]]
    pb = mesh.cell_part[ov.cells[:, 1]]
    lo, hi = np.minimum(pa, pb), np.maximum(pa, pb)
    iface = np.full(len(lo), -1, dtype=np.int64)
    for (p0, p1), i in pair_of.items():
        iface[(lo == p0) & (hi == p1)] = i
    # touching parts without an interface: left to the case's contact
    # between cells (physics/collide.py) when it covers them, else an error
    covered = np.zeros(len(lo), dtype=bool)
    if case.contact is not None:
        if case.contact.between == "all":
            covered[:] = True
        else:
            for na, nb_ in case.contact.between:
                p0, p1 = sorted((names.index(na), names.index(nb_)))
                covered |= (lo == p0) & (hi == p1)
    if np.any((iface < 0) & ~covered):
        k = int(np.argmax((iface < 0) & ~covered))
        p0, p1 = names[lo[k]], names[hi[k]]
        area = float(ov.area[(lo == lo[k]) & (hi == hi[k])].sum())
        raise case.error(("interfaces",), f"parts {p0} and {p1} touch ({area:.4g} m² of "
                         f"shared faces): say how they are joined, e.g. interfaces: "
                         f"[{{parts: [{p0}, {p1}], law: bonded}}] or law: contact, or "
                         f"leave them to contact: {{between: [{p0}, {p1}]}}")
    keep = iface >= 0
    if not np.any(keep):
        return mesh
    rows = np.repeat(keep, np.diff(ov.vertex_ptr))
    ptr = np.concatenate(([0], np.cumsum(np.diff(ov.vertex_ptr)[keep])))
    return add_interface_faces(mesh, ov.cells[keep], ptr, ov.vertex_xyz[rows],
                               ov.normal[keep], iface[keep])


def part_mesh(case, part):
    """Cells of one part: a box cut directly (blocks, Voronoi clipped by
    mirrors), any other geometry by clipping the cells of a box around it
    to the solid (mesh/clip.py): Voronoi cells of the seeds inside the
    solid, or blocks over its bounds; a rigid part is one cell bounded by
    its solid's triangles (mesh/merge.py rigid_mesh)."""
    from ..case import part_solid
    m = part.mesh
    if m.kind == "rigid":
        from ..mesh.merge import rigid_mesh
        solid = part_solid(case, part)
        return rigid_mesh(solid.vertices, solid.triangles, solid.tri_surface,
                          solid.surface_names)
    if part.geometry.kind() == "box":
        box = np.asarray(part.geometry.box, dtype=float)
        if m.kind == "blocks":
            return block_mesh(box, tuple(m.divisions))
        plane = case.plane is not None
        seeds = voronoi_seeds(box, m.size, seed=m.seed, min_spacing=m.min_spacing, plane=plane)
        # a cut's plane made of cell faces (mesh/cut_seeds.py); a box of one
        # cell is the box itself, cut or not
        seeds = mirror_across_cuts(seeds, case.cuts, m.size, m.min_spacing, box)
        if plane:
            return plane_voronoi_mesh(box, m.size, seeds)
        if len(seeds) < 2:
            return block_mesh(box, (1, 1, 1))
        return voronoi_mesh(box, m.size, seeds=seeds)
    from ..mesh.clip import clip_to_solid
    solid = part_solid(case, part)
    lo, hi = solid.bounds
    if m.kind == "blocks":
        cells = block_mesh(np.array([lo, hi]), tuple(m.divisions))
    else:
        # a margin of half a cell: no side of the box on the solid's surface
        # (a plane model's slab: none in z, its cells are prisms through it)
        plane = case.plane is not None
        margin = np.array([0.5, 0.5, 0.0 if plane else 0.5]) * m.size
        box = np.array([lo - margin, hi + margin])
        seeds = voronoi_seeds(box, m.size, seed=m.seed, min_spacing=m.min_spacing, plane=plane)
        seeds = mirror_across_cuts(seeds, case.cuts, m.size, m.min_spacing, box)
        seeds = seeds[solid.contains(seeds)]
        if len(seeds) == 0:
            raise case.error(part.mesh_path + ("size",), "no cell seed falls inside the "
                             "solid: make the cells smaller than the solid")
        if plane:
            cells = plane_voronoi_mesh(box, m.size, seeds)
        else:
            from ..mesh.voronoi import voronoi_cells
            cells = voronoi_cells(seeds, m.size, box)
    try:
        return clip_to_solid(cells, solid.vertices, solid.triangles, solid.tri_surface,
                             solid.surface_names, box=np.array([lo, hi]),
                             contains=solid.contains)
    except ValueError as exc:
        raise case.error(part.mesh_path, str(exc)) from None
