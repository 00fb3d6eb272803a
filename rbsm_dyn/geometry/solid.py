"""Solid: a closed, faceted solid with named surfaces (the result of
:func:`rbsm_dyn.geometry.build_solid`)."""
from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass
from functools import cached_property

import numpy as np

from .errors import GeometryError
from .select import select_triangles

__all__ = ["Solid"]


@dataclass(frozen=True, eq=False)
class Solid:
    """A closed, oriented triangle surface and the solid it bounds.

    Surface selection (:meth:`surface`), in this order:

    1. an exact full name, ``"beam.zmin"``;
    2. a bare face name, ``"zmin"``, ``"side"``, ``"hole0.side2"``, when
       exactly one node has that face on the solid's surface;
    3. a node name, ``"notch"``: all of that node's faces still on the
       surface;
    4. a selector mapping (``plane``, ``box``, ``normal`` + ``angle``;
       rbsm_dyn.geometry.select).

    A name matching several faces, or both a face and a node, is an error
    listing the candidates, as is a name not on the surface (a face a
    boolean removed is named as such).
    """

    #: (V, 3) float64 [m]
    vertices: np.ndarray
    #: (T, 3) int64, counter-clockwise seen from outside
    triangles: np.ndarray
    #: (T,) int64 index into surface_names
    tri_surface: np.ndarray
    #: the names of the surfaces on the solid, "<node>.<face>"
    surface_names: tuple
    #: manifold3d.Manifold of the solid; its to_mesh64().face_id == tri_surface
    manifold: object
    #: surfaces of the description that no longer reach the solid's surface
    removed_surfaces: tuple = ()

    # -- measures ------------------------------------------------------------
    @cached_property
    def _ref(self):
        """Reference point for the moment sums (the bounding box centre):
        sums relative to it keep their digits far from the origin."""
        return 0.5 * (self.vertices.min(axis=0) + self.vertices.max(axis=0))

    @cached_property
    def volume(self) -> float:
        """Volume [m³] of the faceted solid: Σ det[r0 r1 r2]/6 over the
        triangles closed into tetrahedra at a reference point (divergence
        theorem), exact up to round-off."""
        r = self.vertices[self.triangles] - self._ref
        return float(np.einsum("ij,ij->i", r[:, 0], np.cross(r[:, 1], r[:, 2])).sum() / 6.0)

    @property
    def bounds(self) -> np.ndarray:
        """(2, 3) lower and upper corner of the bounding box [m]."""
        return np.stack([self.vertices.min(axis=0), self.vertices.max(axis=0)])

    def mass_properties(self):
        """(volume [m³], centroid (3,) [m], inertia (3, 3) per unit density
        about the centroid [m⁵]): exact for the faceted solid (Tonon's
        tetrahedron moments, rbsm_dyn.mesh.polyhedron, summed with signs)."""
        from ..mesh.polyhedron import cells_mass_properties
        t = len(self.triangles)
        vol, cen, inertia = cells_mass_properties(
            self.vertices, np.arange(0, 3 * t + 1, 3), self.triangles.ravel(),
            np.array([0, t]), ref=self._ref[None, :])
        return float(vol[0]), cen[0], inertia[0]

    @cached_property
    def triangle_areas(self) -> np.ndarray:
        """(T,) area of each triangle [m²]."""
        p = self.vertices[self.triangles]
        return 0.5 * np.linalg.norm(np.cross(p[:, 1] - p[:, 0], p[:, 2] - p[:, 0]), axis=1)

    @cached_property
    def triangle_normals(self) -> np.ndarray:
        """(T, 3) outward unit normal of each triangle."""
        p = self.vertices[self.triangles]
        n = np.cross(p[:, 1] - p[:, 0], p[:, 2] - p[:, 0])
        return n / np.linalg.norm(n, axis=1)[:, None]

    def area(self, selection=None) -> float:
        """Area [m²] of the whole surface, or of a selection (:meth:`surface`)."""
        if selection is None:
            return float(self.triangle_areas.sum())
        return float(self.triangle_areas[self.surface(selection)].sum())

    # -- surfaces -------------------------------------------------------------
    def surface_ids(self, name: str) -> tuple:
        """Indices into surface_names that a name selects (class docstring)."""
        names = self.surface_names
        if not isinstance(name, str):
            raise GeometryError((), f"a surface is selected by a name or a selector mapping "
                                    f"(got {name!r})")
        if name in names:
            return (names.index(name),)
        node = [n.split(".", 1)[0] for n in names]
        face = [n.split(".", 1)[1] for n in names]
        bare = [i for i, f in enumerate(face) if f == name]
        whole = [i for i, n in enumerate(node) if n == name]
        if bare and whole:
            raise GeometryError((), f"surface '{name}' is ambiguous: the face of "
                                    f"{', '.join(names[i] for i in bare)} or the node "
                                    f"'{name}' ({', '.join(names[i] for i in whole)}); "
                                    f"use a full name")
        if len(bare) == 1:
            return tuple(bare)
        if len(bare) > 1:
            raise GeometryError((), f"surface '{name}' is ambiguous: "
                                    f"{', '.join(names[i] for i in bare)}; use a full name")
        if whole:
            return tuple(whole)
        gone = [n for n in self.removed_surfaces
                if n == name or n.split(".", 1)[1] == name or n.split(".", 1)[0] == name]
        if gone:
            raise GeometryError((), f"surface '{name}' is not on the solid's surface "
                                    f"({', '.join(gone)} removed by a boolean or taken by a "
                                    f"selector); surfaces: {', '.join(names)}")
        raise GeometryError((), f"no surface '{name}'; surfaces: {', '.join(names)}")

    def surface(self, selection) -> np.ndarray:
        """(T,) bool mask of the triangles a name or a selector picks."""
        if isinstance(selection, Mapping):
            return select_triangles(self.vertices, self.triangles, selection)
        return np.isin(self.tri_surface, np.asarray(self.surface_ids(selection), np.int64))

    # -- inside -------------------------------------------------------------------
    @cached_property
    def _contains_index(self):
        from ._contains import ContainsIndex
        return ContainsIndex(self.vertices, self.triangles)

    def contains(self, points) -> np.ndarray:
        """Bool (P,) (or the leading shape of ``points``): which points lie
        inside the solid.

        Winding number along one ray per point, triangles binned in a
        uniform grid (rbsm_dyn.geometry._contains: Numba, serial).  Measured
        for 10⁵ random points in the bounding box (2-core machine shared with
        other jobs; CPU time, wall time about twice that):

        ==============================  =========  ======  ===========
        solid                           triangles  index   10⁵ points
        ==============================  =========  ======  ===========
        sphere r = 0.1, chord 1e-4       9 800     8 ms    22 ms
        pipe along z (b/a = 2)           9 596     14 ms   25 ms
        pipe, oblique axis              12 448     51 ms   86 ms
        notched beam (box - box)            28     0.1 ms  8 ms
        ==============================  =========  ======  ===========

        The index is built on the first call and kept; the kernels compile
        once (about 5 s, then cached on disk; loading them and Numba takes
        about 1 s per process).  Casting manifold3d rays instead
        (Manifold.ray_cast, one Python call per point) costs 5-200 µs per
        point, 0.5-20 s for 10⁵; trimesh's contains needs rtree and is not
        vectorised either.  Points on the surface (within rounding) may go
        either way."""
        pts = np.asarray(points, dtype=np.float64)
        if pts.shape[-1] != 3:
            raise ValueError(f"points must have shape (P, 3) (got {pts.shape})")
        flat = pts.reshape(-1, 3)
        return self._contains_index(flat).reshape(pts.shape[:-1])
