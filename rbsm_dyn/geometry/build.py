"""build_solid: a geometry description (dicts and lists, as parsed from
YAML) -> a closed, faceted :class:`Solid` with named surfaces.

How names survive the booleans: every face of every node gets a global
surface id, written into manifold3d's per-triangle ``face_id`` of the input
mesh.  manifold3d carries ``face_id`` through its booleans (a triangle of
the result keeps the id of the input face it lies on; the faces of a
subtracted body keep theirs, turned inside out), so the result's
``MeshGL64.face_id`` names every triangle.  At the end the ids still on the
surface are renumbered 0..k-1 in order of first appearance (depth-first,
children before their parent) and written back into the manifold.

Node names: ``name:`` if given, else the kind and a depth-first post-order
index over all nodes (children first): ``difference: [box, cylinder]``
names box0, cylinder1, difference2.  Names are unique, without dots.
"""
from __future__ import annotations

from collections.abc import Mapping
from pathlib import Path

import numpy as np

from .errors import GeometryError, format_path
from .primitives import (MAX_TRIANGLES, Facets, box_facets, circle_segments,
                         cylinder_facets, prism_facets, sphere_facets,
                         sphere_segments)
from .select import number, select_triangles, vector
from .solid import Solid

__all__ = ["build_solid", "KINDS"]

PRIMITIVES = ("box", "cylinder", "sphere", "prism")
BOOLEANS = ("union", "difference", "intersection")
KINDS = PRIMITIVES + BOOLEANS + ("file",)
_COMMON = ("name", "surfaces")
_EXTRA = {"file": ("scale",)}


def build_solid(spec: Mapping, *, chord: float, base_dir=None) -> Solid:
    """Build the solid a geometry description names.

    ``spec``: one geometry node (module docstring of rbsm_dyn.geometry);
    ``chord``: the largest distance [m] allowed between a curved surface
    and its facets; ``base_dir``: directory that relative ``file:`` paths
    are read from (default: the working directory).

    Raises :class:`GeometryError` (with the key path into ``spec``) for a
    bad description, a file that cannot be read or is not closed, or a
    boolean with an empty result.
    """
    if isinstance(chord, bool) or not isinstance(chord, (int, float, np.integer, np.floating)) \
            or not np.isfinite(chord) or not chord > 0:
        raise ValueError(f"chord must be a number > 0 [m] (got {chord!r})")
    b = _Builder(float(chord), base_dir)
    man = b.node(spec, ())
    return b.finish(man)


class _Builder:
    def __init__(self, chord, base_dir):
        self.chord = chord
        self.base_dir = Path(base_dir) if base_dir is not None else None
        self.names: list[str] = []                 # global surface names
        self.node_paths: dict[str, tuple] = {}     # node name -> its path
        self.count = 0                              # post-order node index
        self.removed: tuple = ()                    # names no longer on the surface

    # -- naming -------------------------------------------------------------
    def _node_name(self, spec, kind, path):
        index = self.count
        self.count += 1
        if "name" in spec:
            name = spec["name"]
            if not isinstance(name, str) or not name or "." in name \
                    or not name.isprintable() or name.strip() != name:
                raise GeometryError(path + ("name",),
                                    f"must be a non-empty name without dots or spaces at "
                                    f"its ends (got {name!r})")
        else:
            name = f"{kind}{index}"
        if name in self.node_paths:
            other = self.node_paths[name]
            raise GeometryError(path + (("name",) if "name" in spec else ()),
                                f"node name '{name}' is used twice (also at "
                                f"{format_path(other) or 'the top'})")
        self.node_paths[name] = path
        return name

    def _register(self, node, faces):
        first = len(self.names)
        self.names += [f"{node}.{f}" for f in faces]
        return first

    # -- nodes ----------------------------------------------------------------
    def node(self, spec, path):
        if not isinstance(spec, Mapping):
            raise GeometryError(path, f"a geometry node must be a mapping with one of "
                                      f"{', '.join(KINDS)} (got {spec!r})")
        kinds = [k for k in spec if k in KINDS]
        if len(kinds) > 1:
            raise GeometryError(path, f"one geometry kind per node (got {', '.join(kinds)}; "
                                      f"combine them with union, difference or intersection)")
        if not kinds:
            others = [k for k in spec if k not in _COMMON]
            if others:
                raise GeometryError(path + (others[0],), f"unknown geometry kind "
                                                         f"(one of {', '.join(KINDS)})")
            raise GeometryError(path, f"no geometry kind (one of {', '.join(KINDS)})")
        kind = kinds[0]
        allowed = (kind,) + _COMMON + _EXTRA.get(kind, ())
        for k in spec:
            if k not in allowed:
                raise GeometryError(path + (k,), f"unknown key for a {kind} node "
                                                 f"(allowed: {', '.join(allowed)})")
        q = path + (kind,)
        if kind in BOOLEANS:
            return self._boolean(spec, kind, q, path)
        if kind == "file":
            facets = self._file(spec, q, path)
        else:
            facets = getattr(self, "_" + kind)(spec[kind], q)
        name = self._node_name(spec, kind, path)
        vertices, triangles = facets.vertices, facets.triangles
        faces = list(facets.face_names)
        tri_face = facets.tri_face.copy()
        if "surfaces" in spec:
            tri_face, faces = self._select(spec["surfaces"], path + ("surfaces",), vertices,
                                           triangles, tri_face, faces)
        first = self._register(name, faces)
        return self._manifold(vertices, triangles, first + tri_face, path)

    def _manifold(self, vertices, triangles, face_id, path):
        import manifold3d
        mesh = manifold3d.Mesh64(
            vert_properties=np.array(vertices, dtype=np.float64, order="C"),   # copies:
            tri_verts=np.array(triangles, dtype=np.uint64, order="C"),         # manifold3d
            face_id=np.array(face_id, dtype=np.uint64, order="C"))             # wants writable
        man = manifold3d.Manifold(mesh)
        status = man.status()
        if status != manifold3d.Error.NoError:
            raise GeometryError(path, f"not a closed manifold surface ({status.name})")
        if man.is_empty():
            raise GeometryError(path, "empty solid")
        return man

    def _select(self, surfaces, path, vertices, triangles, tri_face, faces):
        """Move the triangles each selector picks into a new face (in the
        order given; a triangle goes to the first selector that picks it)."""
        if not isinstance(surfaces, Mapping) or not surfaces:
            raise GeometryError(path, f"must be a mapping of surface name to selector "
                                      f"(got {surfaces!r})")
        tri_face = tri_face.copy()
        taken = np.zeros(len(triangles), dtype=bool)
        faces = list(faces)
        for sname, sel in surfaces.items():
            if not isinstance(sname, str) or not sname or "." in sname or not sname.isprintable():
                raise GeometryError(path + (sname,), "a surface name must be a non-empty "
                                                     "string without dots")
            if sname in faces:
                raise GeometryError(path + (sname,), f"'{sname}' is already a face of this node "
                                                     f"(faces: {', '.join(faces)})")
            mask = select_triangles(vertices, triangles, sel, path + (sname,)) & ~taken
            if not mask.any():
                raise GeometryError(path + (sname,), "selects no triangles of this node's surface")
            tri_face[mask] = len(faces)
            faces.append(sname)
            taken |= mask
        return tri_face, faces

    # -- primitives -------------------------------------------------------------
    def _box(self, s, q):
        if isinstance(s, (str, bytes, Mapping)) or not hasattr(s, "__len__") or len(s) != 2:
            raise GeometryError(q, f"must be [[x0, y0, z0], [x1, y1, z1]] (got {s!r})")
        lo, hi = vector(s[0], 3, q + (0,)), vector(s[1], 3, q + (1,))
        for i, c in enumerate("xyz"):
            if not hi[i] > lo[i]:
                raise GeometryError(q, f"degenerate box: {c}1 must be > {c}0 "
                                       f"(got {c}0 = {lo[i]:g}, {c}1 = {hi[i]:g})")
        return box_facets(lo, hi)

    @staticmethod
    def _keys(s, q, keys, required):
        if not isinstance(s, Mapping):
            raise GeometryError(q, f"must be a mapping with {', '.join(keys)} (got {s!r})")
        for k in s:
            if k not in keys:
                raise GeometryError(q + (k,), f"unknown key (allowed: {', '.join(keys)})")
        for k in required:
            if k not in s:
                raise GeometryError(q, f"missing key '{k}'")

    def _segments(self, rule, radius, q, per):
        n = rule(radius, self.chord)
        if per(n) > MAX_TRIANGLES:
            raise GeometryError(q + ("radius",), f"chord {self.chord:g} m needs {n} segments "
                                                 f"for radius {radius:g} m (over "
                                                 f"{MAX_TRIANGLES} triangles): "
                                                 f"is the chord in metres?")
        return n

    def _cylinder(self, s, q):
        self._keys(s, q, ("base", "axis", "radius"), ("base", "axis", "radius"))
        base = vector(s["base"], 3, q + ("base",))
        axis = vector(s["axis"], 3, q + ("axis",))
        r = number(s["radius"], q + ("radius",), positive=True)
        length = float(np.linalg.norm(axis))
        if not length > 1e-12 * max(r, float(np.max(np.abs(base)))):
            raise GeometryError(q + ("axis",), "zero length: the axis is the vector from the "
                                              "base centre to the top centre")
        n = self._segments(circle_segments, r, q, lambda n: 4 * n)
        return cylinder_facets(base, axis, r, n)

    def _sphere(self, s, q):
        self._keys(s, q, ("center", "radius"), ("center", "radius"))
        c = vector(s["center"], 3, q + ("center",))
        r = number(s["radius"], q + ("radius",), positive=True)
        n = self._segments(sphere_segments, r, q, lambda n: n * n)
        return sphere_facets(c, r, n)

    def _prism(self, s, q):
        self._keys(s, q, ("polygon", "holes", "axis", "from", "to"),
                   ("polygon", "axis", "from", "to"))

        def ring(x, p):
            if isinstance(x, (str, bytes, Mapping)) or not hasattr(x, "__len__"):
                raise GeometryError(p, f"must be a list of [u, v] points (got {x!r})")
            pts = np.array([vector(v, 2, p + (i,)) for i, v in enumerate(x)]).reshape(-1, 2)
            if len(pts) > 3 and np.array_equal(pts[0], pts[-1]):
                pts = pts[:-1]                 # a closing point repeating the first
            if len(pts) < 3:
                raise GeometryError(p, f"a polygon needs at least 3 points (got {len(pts)})")
            same = np.all(pts == np.roll(pts, -1, axis=0), axis=1)
            if same.any():
                i = int(np.argmax(same))
                raise GeometryError(p + ((i + 1) % len(pts),), f"repeats point {i}")
            return pts

        outer = ring(s["polygon"], q + ("polygon",))
        holes = s.get("holes", [])
        if holes is None:
            holes = []
        if isinstance(holes, (str, bytes, Mapping)) or not hasattr(holes, "__len__"):
            raise GeometryError(q + ("holes",), f"must be a list of polygons (got {holes!r})")
        holes = [ring(h, q + ("holes", i)) for i, h in enumerate(holes)]
        axis = s["axis"]
        if axis not in ("x", "y", "z"):
            raise GeometryError(q + ("axis",), f"must be x, y or z (got {axis!r})")
        w0 = number(s["from"], q + ("from",))
        w1 = number(s["to"], q + ("to",))
        if not w1 > w0:
            raise GeometryError(q + ("to",), f"must be > from (got from = {w0:g}, to = {w1:g})")
        return prism_facets(outer, holes, axis, w0, w1, q)

    def _file(self, spec, q, path):
        from .files import read_surface
        fname = spec["file"]
        if not isinstance(fname, (str, Path)) or not str(fname):
            raise GeometryError(q, f"must be a file path (got {fname!r})")
        scale = number(spec.get("scale", 1.0), path + ("scale",), positive=True)
        p = Path(fname)
        if not p.is_absolute() and self.base_dir is not None:
            p = self.base_dir / p
        facets = read_surface(p, path=q, chord=self.chord / scale)
        if scale != 1.0:
            facets = Facets(facets.vertices * scale, facets.triangles, facets.tri_face,
                            facets.face_names)
        return facets

    # -- booleans ---------------------------------------------------------------
    def _boolean(self, spec, kind, q, path):
        import manifold3d
        items = spec[kind]
        if isinstance(items, (str, bytes, Mapping)) or not hasattr(items, "__len__") \
                or len(items) == 0:
            raise GeometryError(q, f"must be a non-empty list of geometry nodes (got {items!r})")
        parts = [self.node(g, q + (i,)) for i, g in enumerate(items)]
        op = {"union": manifold3d.OpType.Add, "difference": manifold3d.OpType.Subtract,
              "intersection": manifold3d.OpType.Intersect}[kind]
        man = manifold3d.Manifold.batch_boolean(parts, op) if len(parts) > 1 else parts[0]
        name = self._node_name(spec, kind, path)
        if man.is_empty() or not man.volume() > 0:
            why = {"difference": "the bodies subtracted cover the first one",
                   "intersection": "the bodies do not overlap",
                   "union": "no volume"}[kind]
            raise GeometryError(q, f"empty result: {why}")
        if "surfaces" in spec:
            m = man.to_mesh64()
            v = np.asarray(m.vert_properties)[:, :3]
            t = np.asarray(m.tri_verts, dtype=np.int64)
            fid = np.asarray(m.face_id, dtype=np.int64)
            local, faces = self._select(spec["surfaces"], path + ("surfaces",), v, t,
                                        np.full(len(t), -1, np.int64), [])
            first = self._register(name, faces)
            fid = np.where(local >= 0, first + local, fid)
            man = self._manifold(v, t, fid, path)
        return man

    # -- result -----------------------------------------------------------------
    def finish(self, man) -> Solid:
        """Renumber the surface ids still on the solid 0..k-1 and wrap it."""
        for _ in range(3):
            m = man.to_mesh64()
            fid = np.asarray(m.face_id, dtype=np.int64)
            present = np.unique(fid)
            if np.array_equal(present, np.arange(len(present))) and \
                    len(present) == len(self.names):
                break
            remap = np.full(len(self.names), -1, np.int64)
            remap[present] = np.arange(len(present))
            self.removed += tuple(n for i, n in enumerate(self.names) if remap[i] < 0)
            self.names = [self.names[i] for i in present]
            man = self._manifold(np.asarray(m.vert_properties)[:, :3],
                                 np.asarray(m.tri_verts, dtype=np.int64), remap[fid], ())
        else:
            raise RuntimeError("surface ids did not settle")     # pragma: no cover
        return Solid(
            vertices=np.array(np.asarray(m.vert_properties)[:, :3], dtype=np.float64, order="C"),
            triangles=np.array(m.tri_verts, dtype=np.int64),
            tri_surface=np.array(fid, dtype=np.int64),
            surface_names=tuple(self.names),
            manifold=man,
            removed_surfaces=self.removed,
        )
