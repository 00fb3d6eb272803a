"""The scene of a validated case as the mesher sees it: its parts
(:class:`ScenePart`; the one-part shorthand is the part "domain"), their
solids, cell sizes and named surfaces."""
from __future__ import annotations

from pathlib import Path
from typing import NamedTuple, Optional

from .base import FACES
from .errors import KeyPath
from .scene import Domain, Mesh
from .top import Case


class ScenePart(NamedTuple):
    """A part of the scene as the mesher sees it: the one-part shorthand
    ``domain`` + ``mesh`` is the part named "domain" (DESIGN.md §6)."""
    name: str
    geometry: Domain
    mesh: Mesh
    material: Optional[str]
    path: KeyPath               # of the geometry: ("domain",) or ("parts", name, "geometry")
    mesh_path: KeyPath          # ("mesh",) or ("parts", name, "mesh")


def scene_parts(case: Case) -> list[ScenePart]:
    """The parts of a case in order (the shorthand: one part)."""
    if case.parts:
        return [ScenePart(n, p.geometry, p.mesh, p.material, ("parts", n, "geometry"),
                          ("parts", n, "mesh")) for n, p in case.parts.items()]
    return [ScenePart("domain", case.domain, case.mesh, None, ("domain",), ("mesh",))]


def _box_size(box, divisions):
    return min(float(box[1][i] - box[0][i]) / divisions[i] for i in range(3))


def part_cell_size(case: Case, part: ScenePart) -> float:
    """The length the chord of a part's curved faces refers to: the Voronoi
    size, the blocks' smallest edge, or for a rigid part its ``mesh.size``,
    else the smallest cell of the other parts."""
    m = part.mesh
    if m.kind == "voronoi" and m.size is not None:
        return m.size
    if m.kind == "blocks" and m.divisions is not None:
        if part.geometry.kind() == "box":
            return _box_size(part.geometry.box, m.divisions)
        from ..geometry import GeometryError, build_solid
        try:
            lo, hi = build_solid(part.geometry.spec(), chord=1e9, base_dir=_case_dir(case)).bounds
        except GeometryError as exc:
            raise case.error(part.path + tuple(exc.path), exc.message) from None
        return _box_size((lo, hi), m.divisions)
    if m.size is not None:
        return m.size
    others = [part_cell_size(case, p) for p in scene_parts(case) if p.mesh.kind != "rigid"]
    return min(others) if others else 1.0


def part_solid(case: Case, part: ScenePart, cell_size: Optional[float] = None):
    """A part's geometry as an rbsm_dyn.geometry Solid (built once, kept on
    the geometry node), faceted to the chord ``mesh.chord`` × the part's
    cell size (part_cell_size).  GeometryError → CaseError at its key path
    under the part's geometry."""
    d = part.geometry
    if d._solid is not None:
        return d._solid
    from ..geometry import GeometryError, build_solid
    if cell_size is None:
        cell_size = part_cell_size(case, part)
    chord = part.mesh.chord * cell_size
    try:
        d._solid = build_solid(d.spec(), chord=chord, base_dir=_case_dir(case))
    except GeometryError as exc:
        raise case.error(part.path + tuple(exc.path), exc.message) from None
    return d._solid


def domain_solid(case: Case, cell_size: Optional[float] = None):
    """The one-part domain's Solid (part_solid of the shorthand's part)."""
    return part_solid(case, scene_parts(case)[0], cell_size)


def part_surface_names(case: Case, part: ScenePart) -> tuple:
    """The names of a part's surfaces as its mesh carries them: a box cut
    into cells: xmin ... zmax; else the solid's (rbsm_dyn.geometry)."""
    if part.geometry.kind() == "box" and part.mesh.kind != "rigid":
        return FACES
    return part_solid(case, part).surface_names


def surface_indices(case: Case, name: str) -> tuple:
    """Indices into the scene mesh's surface_names of a named surface: for
    one part, a name of the domain's (xmin ... zmax of a box, or the
    geometry's naming rules); with parts, ``<part>.<surface>``.  Raises
    ValueError with the reason when the name selects nothing."""
    parts = scene_parts(case)
    if not case.parts:
        part, local = parts[0], name
    else:
        head, dot, local = name.partition(".")
        found = [p for p in parts if p.name == head]
        if not dot or not found:
            raise ValueError(f"unknown surface {name!r}: with parts, a surface is "
                             f"<part>.<surface> (parts: {', '.join(case.parts)})")
        part = found[0]
    offset = 0
    for p in parts:
        if p.name == part.name:
            break
        offset += len(part_surface_names(case, p))
    if part.geometry.kind() == "box" and part.mesh.kind != "rigid":
        if local not in FACES:
            raise ValueError(f"unknown surface {local!r} of the box"
                             + (f" of part {part.name}" if case.parts else "")
                             + f" (its surfaces: {', '.join(FACES)})")
        return (offset + FACES.index(local),)
    from ..geometry import GeometryError
    try:
        return tuple(offset + i for i in part_solid(case, part).surface_ids(local))
    except GeometryError as exc:
        raise ValueError(exc.message + (f" (part {part.name})" if case.parts else "")) from None


def surface_part(case: Case, name: str) -> ScenePart:
    """The part a surface name belongs to."""
    if not case.parts:
        return scene_parts(case)[0]
    head = name.partition(".")[0]
    return next(p for p in scene_parts(case) if p.name == head)


def _case_dir(case: Case):
    f = case._source_file
    return Path(f).parent if f and not f.startswith("<") else Path.cwd()
