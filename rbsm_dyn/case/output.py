"""``output``: the history file, its fields and the probes."""
from __future__ import annotations

from typing import Annotated, Any, Literal, Optional, Union

from pydantic import BaseModel, Discriminator, Field, Tag

from .base import Vec3, _length, _Node


class Probe(_Node):
    """``{group, quantity, component, reduce}``: one number from a group's
    bodies; ``surface: name`` instead of ``group``: the cells with a face on
    that named surface (the reaction on a supported surface).
    ``relative_to: ground``: a displacement or velocity less the ground's
    (a case with ground_motion)."""
    group: Optional[str] = None
    surface: Optional[str] = None
    # (relative_displacement is read as a RelativeProbe: listed here so that
    # a bad quantity's message names every quantity)
    quantity: Literal["displacement", "rotation", "velocity", "force", "reaction",
                      "relative_displacement"]
    component: Literal["x", "y", "z", "magnitude"]
    reduce: Literal["mean", "sum", "max", "min"]
    relative_to: Optional[Literal["ground"]] = None


class RelativeProbe(_Node):
    """``{quantity: relative_displacement, groups: [a, b] | points: [p_a, p_b],
    component | direction}``: displacement of b minus that of a (the mean of
    each group's bodies, or of the material point p of the body whose cell
    holds it), as a component, the magnitude, or along ``direction``."""
    quantity: Literal["relative_displacement"]
    groups: Optional[Annotated[list[str], _length(2, "[group_a, group_b]")]] = None
    points: Optional[Annotated[list[Vec3], _length(2, "[[x, y, z], [x, y, z]]")]] = None
    component: Optional[Literal["x", "y", "z", "magnitude"]] = None
    direction: Optional[Vec3] = None


def _probe_form(value: Any) -> str:
    """Discriminator of a probe: by its quantity."""
    if isinstance(value, BaseModel):
        return _RELATIVE_TAG if isinstance(value, RelativeProbe) else _PROBE_TAG
    if isinstance(value, dict) and value.get("quantity") == "relative_displacement":
        return _RELATIVE_TAG
    return _PROBE_TAG


# tags of the two probe forms (never shown: _schema_errors drops them from
# key paths; characters no probe name in a sane case has)
_PROBE_TAG, _RELATIVE_TAG = "<probe>", "<relative probe>"
ProbeItem = Annotated[
    Union[Annotated[Probe, Tag(_PROBE_TAG)], Annotated[RelativeProbe, Tag(_RELATIVE_TAG)]],
    Discriminator(_probe_form)]


FieldName = Literal["position", "orientation", "velocity", "angular_velocity",
                    "spring_state", "spring_force", "cell_stress", "spring_damage"]


class Output(_Node):
    file: Optional[str] = None              # default <name>.h5
    interval: Optional[float] = Field(default=None, gt=0)  # default end_time/100
    checkpoint_interval: Optional[float] = Field(default=None, gt=0)  # s; solvers/checkpoint.py
    flush_interval: float = Field(default=1.0, ge=0, le=3600)  # s of wall time; io/history_writer.py
    fields: list[FieldName] = ["position", "orientation"]
    probes: dict[str, ProbeItem] = {}
