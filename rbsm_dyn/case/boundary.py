"""``groups``, ``boundary`` (supports, prescribed velocities and
displacements), ``initial`` (velocities at t = 0) and ``loads``; the
discriminated unions of the boundary and load items."""
from __future__ import annotations

from typing import Annotated, Any, Literal, Optional, Union

from pydantic import BaseModel, Discriminator, Field, Tag

from .base import (Box, Component, Face, FaceComponent, History, Vec3, Vec3Free,
                   _fix_list, _Node)


class Group(_Node):
    """Bodies whose centroid lies in ``box`` (bounds included)."""
    box: Box
    material: Optional[str] = None


class FaceSupport(_Node):
    """``{face: xmin, fix: all}``: springs to the ground on a domain face;
    ``{surface: name, fix: ...}`` on a named surface of the domain's
    geometry (the box's faces are the surfaces xmin ... zmax)."""
    face: Optional[Face] = None
    surface: Optional[str] = None
    fix: Annotated[list[FaceComponent], _fix_list(("x", "y", "z"))]
    breakable: bool = False


class GroupFix(_Node):
    """``{group: g, fix: [x, z, ry]}``: fixed components of a group's bodies."""
    group: str
    fix: Annotated[list[Component], _fix_list(("x", "y", "z", "rx", "ry", "rz"))]


class GroupVelocity(_Node):
    """``{group: g, velocity: [vx, vy, vz], history}``; None = free component.
    ``surface: name`` instead of ``group``: the cells with a face on it."""
    group: Optional[str] = None
    surface: Optional[str] = None
    velocity: Vec3Free
    history: Optional[History] = None


class GroupDisplacement(_Node):
    """``{group: g, displacement: [ux, uy, uz], history}``; None = free.
    ``surface: name`` instead of ``group``: the cells with a face on it."""
    group: Optional[str] = None
    surface: Optional[str] = None
    displacement: Vec3Free
    history: Optional[History] = None


class RigidMotion(_Node):
    """``rigid: {angular_velocity: [wx, wy, wz], center: [x, y, z]}`` of an
    initial item: the group turns as one rigid body about ``center``
    (default: the group's centre of mass)."""
    angular_velocity: Vec3
    center: Optional[Vec3] = None


class InitialVelocity(_Node):
    """``{group: g, velocity, angular_velocity}`` at t = 0: each cell of the
    group translates at ``velocity`` and spins at ``angular_velocity`` about
    its own centroid.  ``{group: g, velocity, rigid: {angular_velocity,
    center}}``: the group moves as one rigid body, each cell at v + ω × (x_c
    − center) and spinning at ω (model.apply_initial)."""
    group: str = "all"
    velocity: Vec3 = [0.0, 0.0, 0.0]
    angular_velocity: Vec3 = [0.0, 0.0, 0.0]
    rigid: Optional[RigidMotion] = None


class GroupLoad(_Node):
    """Total force (and moment) on a group, shared in proportion to volume."""
    group: str
    force: Vec3 = [0.0, 0.0, 0.0]
    moment: Vec3 = [0.0, 0.0, 0.0]
    history: Optional[History] = None


class SurfaceLoad(_Node):
    """``{surface: name, pressure: p}`` (force −p n A on each boundary face
    of the surface, n its outward normal: p > 0 pushes into the solid) or
    ``{surface: name, traction: [tx, ty, tz]}`` (force t A per face), at
    each face's area centroid; optional ``history``.  ``follower: true``:
    it turns with the face's cell (mode dynamic; linear takes its reference
    value); ``false``: a dead load, fixed in space.  By default a
    pressure follows in mode dynamic, as a fluid's does, and is dead in
    the other modes; a traction is dead."""
    surface: str
    pressure: Optional[float] = None
    traction: Optional[Vec3] = None
    follower: Optional[bool] = None
    history: Optional[History] = None

    def turns(self, mode):
        """Whether the load turns with its cells in a run of solver `mode`.
        A fluid's pressure stays normal to the face it pushes: a dead
        pressure on a solid free to turn drives the turn (a prism on
        frictionless platens under a lateral dead pressure of 0.3 f_c spun
        about its axis from round-off and failed at 60 MPa; as a follower
        it reaches 85 MPa, Richart's f_c + 4.1 σ_3 = 86 MPa)."""
        if self.follower is not None:
            return self.follower
        return self.pressure is not None and mode == "dynamic"


class GroundMotion(_Node):
    """``ground_motion: {file: record.csv, units: g, direction: [1, 0, 0]}``:
    the ground moves with an acceleration record (a text file of time and
    acceleration columns, or one column with ``dt``), integrated to its
    displacement (rbsm_dyn/records.py); every ``{group, fix}`` support
    moves with it along ``direction``."""
    file: str
    columns: Annotated[list[Annotated[int, Field(ge=0)]], Field(min_length=2, max_length=2)] = [0, 1]
    dt: Optional[float] = Field(default=None, gt=0)
    skip: int = Field(default=0, ge=0)
    units: Literal["m/s2", "g"] = "m/s2"
    scale: float = 1.0
    direction: Vec3 = [1.0, 0.0, 0.0]
    baseline: Literal["linear", "none"] = "linear"


class Gravity(_Node):
    """``{gravity: [gx, gy, gz]}``: acceleration on every body."""
    gravity: Vec3


def _form_of(forms: dict[str, str]):
    """Discriminator by keys present: the first key of ``forms`` found.
    (A model instance, when serializing, is tagged by its class name.)"""
    def pick(value: Any) -> Optional[str]:
        if isinstance(value, BaseModel):
            return type(value).__name__
        if isinstance(value, dict):
            for key, tag in forms.items():
                if key in value:
                    return tag
        return None
    return pick


_BOUNDARY_FORMS = ("{face, fix}, {surface, fix}, {group, fix}, "
                   "{group|surface, velocity[, history]}, "
                   "{group|surface, displacement[, history]}")
_LOAD_FORMS = ("{group, force[, moment][, history]}, {surface, pressure[, history]}, "
               "{surface, traction[, history]}, {gravity}")

BoundaryItem = Annotated[
    Union[Annotated[FaceSupport, Tag("FaceSupport")],
          Annotated[GroupFix, Tag("GroupFix")],
          Annotated[GroupVelocity, Tag("GroupVelocity")],
          Annotated[GroupDisplacement, Tag("GroupDisplacement")]],
    Discriminator(_form_of({"velocity": "GroupVelocity", "displacement": "GroupDisplacement",
                            "face": "FaceSupport", "surface": "FaceSupport",
                            "fix": "GroupFix"}),
                  custom_error_type="form",
                  custom_error_message=f"expected one of {_BOUNDARY_FORMS}")]
LoadItem = Annotated[
    Union[Annotated[Gravity, Tag("Gravity")],
          Annotated[GroupLoad, Tag("GroupLoad")],
          Annotated[SurfaceLoad, Tag("SurfaceLoad")]],
    Discriminator(_form_of({"gravity": "Gravity", "group": "GroupLoad",
                            "surface": "SurfaceLoad", "force": "GroupLoad",
                            "moment": "GroupLoad", "pressure": "SurfaceLoad",
                            "traction": "SurfaceLoad"}),
                  custom_error_type="form",
                  custom_error_message=f"expected one of {_LOAD_FORMS}")]
