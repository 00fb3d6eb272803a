"""Units: the dimension of every dimensional field (``DIMENSIONS``), the
factors to SI of each system of units and the conversion of a validated
case to SI."""
from __future__ import annotations

from typing import Any, Optional

from pydantic import BaseModel

from .boundary import (Gravity, Group, GroupDisplacement, GroupLoad, GroupVelocity,
                       InitialVelocity, RigidMotion, SurfaceLoad)
from .materials import Cap, Material, Rupture, Yield
from .output import Output, RelativeProbe
from .plane import Plane
from .scene import Contact, Cut, Domain, Ground, Interface, Mesh
from .solver import Control, Damping, Solver


#: Dimension of every dimensional field, by (model, field).  History tables
#: are [time, amplitude] pairs: only the time column has a dimension.
DIMENSIONS: dict[tuple[type, str], str] = {
    (Domain, "box"): "length",
    **{(Domain, k): "geometry" for k in ("cylinder", "sphere", "prism", "union", "difference",
                                         "intersection")},
    (Domain, "scale"): "geometry_scale",
    (Domain, "surfaces"): "geometry",
    (Mesh, "size"): "length",
    (Plane, "thickness"): "length",
    (Interface, "thickness"): "length",
    (Material, "density"): "density",
    (Material, "young"): "stress",
    (Material, "fc"): "stress",
    (Material, "ucs"): "stress",
    (Material, "fb"): "stress",
    (Material, "fm"): "stress",
    (Yield, "stress"): "stress",
    (Yield, "cohesion"): "stress",
    (Yield, "tension"): "stress",
    (Rupture, "fracture_energy"): "energy/area",
    (Rupture, "tensile_strength"): "stress",
    (Rupture, "shear_strength"): "stress",
    (Rupture, "compressive_strength"): "stress",
    (Rupture, "shear_fracture_energy"): "energy/area",
    (Cap, "stress"): "stress",
    (Group, "box"): "length",
    (GroupVelocity, "velocity"): "velocity",
    (GroupVelocity, "history"): "history",
    (GroupDisplacement, "displacement"): "length",
    (GroupDisplacement, "history"): "history",
    (InitialVelocity, "velocity"): "velocity",
    (InitialVelocity, "angular_velocity"): "1/time",
    (RigidMotion, "angular_velocity"): "1/time",
    (RigidMotion, "center"): "length",
    (GroupLoad, "force"): "force",
    (GroupLoad, "moment"): "moment",
    (GroupLoad, "history"): "history",
    (SurfaceLoad, "pressure"): "stress",
    (SurfaceLoad, "traction"): "stress",
    (SurfaceLoad, "history"): "history",
    (Gravity, "gravity"): "acceleration",
    (Cut, "point"): "length",
    (Cut, "within"): "length",
    (Contact, "skin"): "length",
    (Ground, "point"): "length",
    (Damping, "alpha"): "1/time",
    (Solver, "end_time"): "time",
    (Solver, "dt"): "time",
    (Control, "increment"): "length",
    (Control, "end"): "length",
    (RelativeProbe, "points"): "length",
    (Output, "interval"): "time",
    (Output, "checkpoint_interval"): "time",
}

#: SI value = factor * value in the case's units.
UNIT_FACTORS: dict[str, dict[str, float]] = {
    "SI": {},
    "mm-N-s": {"length": 1e-3, "time": 1.0, "1/time": 1.0, "velocity": 1e-3,
               "acceleration": 1e-3, "force": 1.0, "moment": 1e-3,
               "stress": 1e6, "density": 1e12, "energy/area": 1e3},
}


def _scale(value: Any, factor: float) -> Any:
    if value is None:
        return None
    if isinstance(value, list):
        return [_scale(v, factor) for v in value]
    return value * factor


#: keys of geometry nodes that are lengths (docs/case_file.md, "geometry")
_GEOMETRY_LENGTHS = {"box", "base", "axis", "radius", "center", "polygon", "holes", "from",
                     "to", "point", "tol"}


def _geometry_to_si(node: Any, f: float, key: Optional[str] = None) -> Any:
    """A geometry node's lengths times f (a file's coordinates: its scale)."""
    if f == 1.0:
        return node
    if isinstance(node, dict):
        out = {}
        for k, v in node.items():
            if k in _GEOMETRY_LENGTHS:
                out[k] = _scale(v, f)
            elif k == "file":
                out[k] = v
                out["scale"] = node.get("scale", 1.0) * f
            elif k == "scale":
                continue
            else:
                out[k] = _geometry_to_si(v, f, k)
        if "scale" in node and "file" not in node:
            out["scale"] = node["scale"]
        return out
    if isinstance(node, list):
        return [_geometry_to_si(v, f, key) for v in node]
    return node


def _to_si(node: Any, factors: dict[str, float]) -> None:
    """Convert every field named in DIMENSIONS, in place, recursively."""
    if isinstance(node, list):
        for item in node:
            _to_si(item, factors)
    elif isinstance(node, dict):
        for item in node.values():
            _to_si(item, factors)
    elif isinstance(node, BaseModel):
        for name in type(node).model_fields:
            value = getattr(node, name)
            dim = DIMENSIONS.get((type(node), name))
            if dim == "geometry" and value is not None:
                setattr(node, name, _geometry_to_si(value, factors.get("length", 1.0)))
            elif dim == "geometry_scale":
                if factors.get("length", 1.0) != 1.0 and (value is not None or node.file):
                    setattr(node, name, (1.0 if value is None else value) * factors["length"])
            elif dim == "history" and value is not None:
                f = factors.get("time", 1.0)
                setattr(node, name, [[t * f, a] for t, a in value])
            elif dim is not None:
                setattr(node, name, _scale(value, factors.get(dim, 1.0)))
            else:
                _to_si(value, factors)
