"""Plane problems (``plane: {kind: strain | stress, thickness: t}``): the
:class:`Plane` section, and the lift of a plane case's 2D input to the 3D
forms the rest of the schema reads (a slab z ∈ [−t/2, t/2] one cell thick).

A plane case is written in the x–y plane: points and vectors ``[x, y]``,
boxes ``[[x0, y0], [x1, y1]]``, ``divisions: [nx, ny]``, an angular
velocity or a moment as one number (about z), geometry as ``box``,
``circle: {center, radius}`` and ``polygon: {points, holes}`` with their
booleans.  :func:`lift_plane` turns that raw YAML data into the 3D case
(z = 0, the slab's thickness in z, one cell through it) before the schema
sees it, so every section keeps one model; the kernels of the plane mode
(physics/plane.py) move the cells in x–y only.
"""
from __future__ import annotations

from typing import Any, Literal

from pydantic import Field

from .base import _Node
from .errors import CaseError, _nearest_line


class Plane(_Node):
    """``kind``: ``strain`` (ε_z = 0) or ``stress`` (σ_z = 0); ``thickness``
    t [length] > 0: the depth of the slab (mass, areas and loads per cell
    are those of the prism of depth t)."""
    kind: Literal["strain", "stress"]
    thickness: float = Field(gt=0)


# keys whose 2-vectors become [x, y, 0]: points, directions, forces ...
_VECTORS = {"velocity", "displacement", "force", "traction", "gravity", "point", "normal",
            "center", "direction"}
# keys whose 2D boxes become the slab's ([[x0, y0, -t], [x1, y1, t]]: any cell's centroid)
_BOXES = {"box", "within"}
# keys whose number is the z component of a 3-vector
_ABOUT_Z = {"angular_velocity", "moment"}
_GEOMETRY_3D = ("cylinder", "sphere", "prism", "file")


def _num(v):
    return isinstance(v, (int, float)) and not isinstance(v, bool)


def _vec2(v):
    """True for [a, b] with numbers or nulls."""
    return isinstance(v, list) and len(v) == 2 and all(_num(x) or x is None for x in v)


def _box2(v):
    return isinstance(v, list) and len(v) == 2 and all(
        isinstance(c, list) and len(c) == 2 and all(_num(x) for x in c) for c in v)


def lift_plane(data: dict, lines: dict, filename: str) -> None:
    """Rewrite a plane case's raw data (parse.py's dicts and lists) in
    place to the 3D case of its slab; CaseError for what cannot be read as
    plane input.  A case without ``plane`` is left alone."""
    plane = data.get("plane")
    if not isinstance(plane, dict) or not _num(plane.get("thickness")) \
            or not plane["thickness"] > 0:
        return                    # the schema reports a bad plane section
    t = float(plane["thickness"])

    def fail(path, message):
        return CaseError(filename, _nearest_line(lines, path), tuple(path), message)

    for key in ("domain",):
        if isinstance(data.get(key), dict):
            data[key] = _geometry(data[key], (key,), t, fail)
    if isinstance(data.get("mesh"), dict):
        _mesh(data["mesh"], ("mesh",), fail)
    parts = data.get("parts")
    if isinstance(parts, dict):
        for name, p in parts.items():
            if not isinstance(p, dict):
                continue
            if isinstance(p.get("geometry"), dict):
                p["geometry"] = _geometry(p["geometry"], ("parts", name, "geometry"), t, fail)
            if isinstance(p.get("mesh"), dict):
                _mesh(p["mesh"], ("parts", name, "mesh"), fail)
    for key in ("groups", "boundary", "initial", "loads", "cuts", "contact", "output"):
        if key in data:
            data[key] = _vectors(data[key], t, path=(key,), fail=fail)


def _mesh(m, path, fail):
    d = m.get("divisions")
    if isinstance(d, list) and len(d) == 2:
        m["divisions"] = list(d) + [1]
    elif isinstance(d, list) and len(d) == 3 and d[2] != 1:
        raise fail(path + ("divisions",), f"a plane case has one cell through its thickness: "
                   f"give [nx, ny] (got {d})")


def _vectors(node: Any, t: float, key: str = "", path: tuple = (), fail=None) -> Any:
    """Lift the 2D vectors, boxes and scalar moments of a section; a
    3-vector with a z component, or a moment as a vector, is refused
    (CaseError by `fail`): the plane's cells do not move in z, so such a
    load would go to the held z and be lost without a word."""
    if isinstance(node, dict):
        return {k: _vectors(v, t, k, path + (k,), fail) for k, v in node.items()}
    if key in _BOXES and _box2(node):
        return [[node[0][0], node[0][1], -t], [node[1][0], node[1][1], t]]
    if key in _VECTORS and _vec2(node):
        return list(node) + [None if any(x is None for x in node) else 0.0]
    if fail is not None and key in _VECTORS and isinstance(node, list) and len(node) == 3 \
            and all(_num(x) or x is None for x in node) and node[2] not in (None, 0, 0.0):
        raise fail(path, f"a plane case's {key} is [x, y] (the x–y plane; got {node}, "
                   f"whose z component {node[2]} the plane's cells cannot take)")
    if key in _ABOUT_Z and _num(node):
        return [0.0, 0.0, node]
    if fail is not None and key in _ABOUT_Z and isinstance(node, list):
        raise fail(path, f"a plane case's {key} is one number, about z (got {node})")
    if key == "points" and isinstance(node, list) and all(_vec2(p) for p in node):
        return [list(p) + [0.0] for p in node]
    if isinstance(node, list):
        return [_vectors(v, t, key, path + (i,), fail) for i, v in enumerate(node)]
    return node


def _geometry(node: Any, path: tuple, t: float, fail) -> Any:
    """A 2D geometry node as the 3D node of its prism of depth t."""
    if not isinstance(node, dict):
        return node
    out = {}
    for k, v in node.items():
        p = path + (k,)
        if k == "box":
            if not _box2(v):
                raise fail(p, "in a plane case a box is [[x0, y0], [x1, y1]]")
            out[k] = [[v[0][0], v[0][1], -0.5 * t], [v[1][0], v[1][1], 0.5 * t]]
        elif k == "circle":
            if not isinstance(v, dict) or set(v) - {"center", "radius"} \
                    or not _vec2(v.get("center")):
                raise fail(p, "a circle is {center: [x, y], radius: r}")
            c = v["center"]
            out["cylinder"] = {"base": [c[0], c[1], -0.5 * t], "axis": [0.0, 0.0, t],
                               "radius": v.get("radius")}
        elif k == "polygon":
            if not isinstance(v, dict) or set(v) - {"points", "holes"} or "points" not in v:
                raise fail(p, "a polygon is {points: [[x, y], ...], holes: [[[x, y], ...], "
                           "...]} (holes optional)")
            out["prism"] = {"polygon": v["points"], "holes": v.get("holes", []), "axis": "z",
                            "from": -0.5 * t, "to": 0.5 * t}
        elif k in ("union", "difference", "intersection"):
            if not isinstance(v, list):
                out[k] = v
            else:
                out[k] = [_geometry(x, p + (i,), t, fail) for i, x in enumerate(v)]
        elif k in _GEOMETRY_3D:
            raise fail(p, f"a plane case's geometry is 2D: box [[x0, y0], [x1, y1]], circle, "
                       f"polygon and their union, difference, intersection (not {k})")
        elif k == "surfaces" and isinstance(v, dict):
            out[k] = _vectors(v, t)
        else:
            out[k] = v
    return out
