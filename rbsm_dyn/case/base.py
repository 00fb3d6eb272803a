"""The base of every case model (:class:`_Node`) and the value types the
sections share (vectors, boxes, histories, faces, components)."""
from __future__ import annotations

from typing import Annotated, Any, Literal, Optional, get_args

from pydantic import BaseModel, BeforeValidator, ConfigDict, Field, model_validator
from pydantic_core import PydanticCustomError

from .errors import _fail, _show


class _Node(BaseModel):
    """Base of every case model: strict numbers, unknown keys refused."""
    model_config = ConfigDict(extra="forbid", strict=True,
                              allow_inf_nan=False, populate_by_name=True)

    @model_validator(mode="before")
    @classmethod
    def _known_keys(cls, data: Any) -> Any:
        if isinstance(data, dict):
            allowed = [f.alias or n for n, f in cls.model_fields.items()]
            for key in data:
                if key not in allowed:
                    raise PydanticCustomError(
                        "unknown_key", "{message}",
                        {"key": key, "message": f"unknown key {_show(key)} "
                         f"(allowed: {', '.join(allowed)})"})
        return data

    def given(self, key: str) -> bool:
        """True when the YAML gave ``key`` (a field name or YAML alias)."""
        for name, f in type(self).model_fields.items():
            if key in (name, f.alias):
                return name in self.model_fields_set
        return False


def _length(n: int, form: str):
    """Before-validator: a list must have exactly ``n`` items."""
    def check(value: Any) -> Any:
        if isinstance(value, list) and len(value) != n:
            raise _fail(f"expected {n} values {form} (got {len(value)})")
        return value
    return BeforeValidator(check)


Vec3 = Annotated[list[float], _length(3, "[x, y, z]")]
Vec3Free = Annotated[list[Optional[float]], _length(3, "[x, y, z] (null = free)")]
Box = Annotated[list[Vec3], _length(2, "[[x0, y0, z0], [x1, y1, z1]]")]
History = Annotated[list[Annotated[list[float], _length(2, "[time, amplitude]")]],
                    Field(min_length=1)]
Face = Literal["xmin", "xmax", "ymin", "ymax", "zmin", "zmax"]
FACES = get_args(Face)          # the surfaces of a box domain
Component = Literal["x", "y", "z", "rx", "ry", "rz"]
FaceComponent = Literal["x", "y", "z"]


def _fix_list(components: tuple[str, ...]):
    """Before-validator: ``fix: all`` -> the explicit list of components."""
    def expand(value: Any) -> Any:
        if value == "all":
            return list(components)
        if isinstance(value, str):
            raise _fail(f"must be all or a list of {', '.join(components)} "
                        f"(got {value!r})")
        return value
    return BeforeValidator(expand)
