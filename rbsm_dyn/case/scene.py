"""The scene: ``domain`` + ``mesh`` (one part) or ``parts``, their
``interfaces``, ``cuts`` and ``contact``."""
from __future__ import annotations

from typing import Annotated, Any, Literal, Optional, Union

from pydantic import Field, PrivateAttr

from .base import Box, Vec3, _Node, _length


GEOMETRY_KINDS = ("cylinder", "sphere", "prism", "union", "difference", "intersection", "file")


class Domain(_Node):
    """The solid that is cut into cells: a box ``box = [[x0, y0, z0], [x1,
    y1, z1]]``, or one geometry node (docs/case_file.md, "geometry"):
    ``cylinder``, ``sphere``, ``prism``, ``union``, ``difference``,
    ``intersection`` or ``file`` (+ ``name``, ``scale``, ``surfaces``),
    checked by rbsm_dyn.geometry when the case is loaded."""
    box: Optional[Box] = None
    cylinder: Optional[dict] = None
    sphere: Optional[dict] = None
    prism: Optional[dict] = None
    union: Optional[list] = None
    difference: Optional[list] = None
    intersection: Optional[list] = None
    file: Optional[str] = None
    name: Optional[str] = None
    scale: Optional[float] = Field(default=None, gt=0)
    surfaces: Optional[dict] = None

    _solid: Any = PrivateAttr(default=None)

    def kind(self) -> Optional[str]:
        """The geometry kind given ('box', 'cylinder', ...), None if none."""
        given = [k for k in ("box",) + GEOMETRY_KINDS if getattr(self, k) is not None]
        return given[0] if len(given) == 1 else None

    def spec(self) -> dict:
        """The geometry node as a plain dict (rbsm_dyn.geometry.build_solid)."""
        return {k: getattr(self, k) for k in ("box",) + GEOMETRY_KINDS
                + ("name", "scale", "surfaces") if getattr(self, k) is not None}


class Mesh(_Node):
    """``kind: voronoi`` (size, seed, min_spacing), ``kind: blocks``
    (divisions) or, for a part only, ``kind: rigid`` (one body; ``size``
    optional: the length the chord of its curved faces refers to)."""
    kind: Literal["voronoi", "blocks", "rigid"]
    size: Optional[float] = Field(default=None, gt=0)
    seed: int = Field(default=0, ge=0)
    min_spacing: float = Field(default=0.5, ge=0, le=0.9)
    divisions: Optional[Annotated[list[Annotated[int, Field(ge=1)]],
                                  _length(3, "[nx, ny, nz]")]] = None
    spring_points: Literal["moment", "centroid", "three"] = "moment"
    chord: float = Field(default=0.05, gt=0, le=0.5)   # faceting: chord error / cell size


class Part(_Node):
    """One part of a scene (DESIGN.md §6): ``geometry`` (a box or a geometry
    node, as ``domain``), ``mesh`` (voronoi, blocks or rigid) and the name
    of its ``material``."""
    geometry: Domain
    mesh: Mesh
    material: str


class Interface(_Node):
    """How two touching parts are joined over their shared faces:
    ``law: bonded`` (springs with the law of ``material``, default the
    weaker of the two parts' laws; with ``thickness`` t the material's
    layer adds its compliance t/E in series) or ``law: contact``
    (compression only, Coulomb ``friction`` μ, default 0: the law of a
    broken face)."""
    parts: Annotated[list[str], _length(2, "[part_a, part_b]")]
    law: Literal["bonded", "contact"]
    material: Optional[str] = None
    thickness: Optional[float] = Field(default=None, gt=0)
    friction: Optional[float] = Field(default=None, ge=0)


class Cut(_Node):
    """Pre-broken springs: crossing the plane (point, normal) inside
    ``within``; ``planar`` (default): the Voronoi seeds mirrored across the
    plane over the patch, so that the notch is a plane of cell faces
    (mesh/cut_seeds.py); false: the faces of the seed's cells as they are."""
    point: Vec3
    normal: Vec3
    within: Box
    planar: bool = True


class Ground(_Node):
    """A rigid half-space that cells may land on: the plane through
    ``point`` with the outward unit ``normal`` (the ground lies on the
    side the normal points away from); it moves with the case's
    ``ground_motion``, if any, and stays put otherwise."""
    point: Vec3 = [0.0, 0.0, 0.0]
    normal: Vec3 = [0.0, 0.0, 1.0]


class Contact(_Node):
    """Contact between any cells (DESIGN.md §8, physics/collide.py):
    ``between: all`` (every pair of cells that are not tied by springs),
    ``[part_a, part_b]`` or a list of such pairs (a part may be paired with
    itself: its fragments meet); Coulomb ``friction`` μ; ``stiffness``: a
    factor on the penalty (default 1: two half-cells in series, l_a/E_a +
    l_b/E_b); ``damping``: the ratio ζ of a normal dashpot to its critical
    2√(k m*) (default 0: an elastic bounce); ``skin`` [m]: the margin of the neighbour search (default a
    fifth of the smallest cell size); ``ground``: a rigid half-space (moving
    with a ``ground_motion``)."""
    between: Union[Literal["all"], list[str], list[list[str]]] = "all"
    friction: float = Field(default=0.0, ge=0)
    stiffness: float = Field(default=1.0, gt=0)
    damping: float = Field(default=0.0, ge=0, le=1)
    skin: Optional[float] = Field(default=None, gt=0)
    ground: Optional[Ground] = None
