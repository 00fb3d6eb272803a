"""Geometry: a description (plain dicts and lists, as parsed from YAML) ->
a closed, faceted, exact solid with named surfaces.

Stage "geometry" of case -> geometry -> mesh -> model; nothing here knows
cells, case files or the solver.  manifold3d does the booleans, trimesh
(or meshio, or gmsh for CAD) reads files; both are imported when first
needed.

    solid = build_solid({"difference": [
        {"box": [[0, 0, 0], [0.5, 0.1, 0.1]], "name": "beam"},
        {"box": [[0.248, -1, -1], [0.252, 1, 0.03]], "name": "notch"}]},
        chord=1e-4)
    solid.volume, solid.surface("beam.zmin"), solid.contains(points)

Nodes (a mapping with exactly one kind key, plus ``name`` and
``surfaces``, all lengths in metres):

* ``box: [[x0, y0, z0], [x1, y1, z1]]`` — faces xmin xmax ymin ymax zmin zmax;
* ``cylinder: {base, axis, radius}`` — axis = vector from the base centre to
  the top centre; faces bottom, top, side;
* ``sphere: {center, radius}`` — face surface;
* ``prism: {polygon, holes, axis: x|y|z, from, to}`` — polygon in (u, v) =
  (y, z), (z, x) or (x, y) for axis x, y, z, extruded from ``from`` to
  ``to``; faces bottom, top, side{i} (outer edge i -> i+1), hole{h}.side{i};
* ``union | difference | intersection: [node, ...]`` (difference: the
  first minus the rest);
* ``file: path`` (+ ``scale``) — a closed surface mesh; face surface (or
  the gmsh physical groups of the file);
* ``surfaces: {name: selector}`` on any node moves the triangles a
  selector picks (rbsm_dyn.geometry.select) into a face of that name.

Surface names are "<node name>.<face>"; a node's default name is its kind
and its depth-first post-order index (``difference: [box, cylinder]``:
box0, cylinder1, difference2).  Selection rules: Solid.surface.  Faceting
of curved surfaces: rbsm_dyn.geometry.primitives.  See docs/case_file.md
("geometry").
"""
from .build import KINDS, build_solid
from .errors import GeometryError
from .primitives import circle_segments, sphere_segments
from .solid import Solid

__all__ = ["build_solid", "Solid", "GeometryError", "KINDS", "circle_segments",
           "sphere_segments"]
