"""The top level of the case file: the :class:`Case` model, made of the
section models (scene, materials, boundary, solver, output)."""
from __future__ import annotations

from typing import Literal, Optional

from pydantic import Field, PrivateAttr

from .base import _Node
from .boundary import BoundaryItem, GroundMotion, Group, InitialVelocity, LoadItem
from .errors import CaseError, KeyPath, _nearest_line
from .materials import Material
from .output import Output
from .plane import Plane
from .scene import Contact, Cut, Domain, Interface, Mesh, Part
from .solver import Solver


class Case(_Node):
    """The validated case, values in SI, defaults filled.

    ``source_text`` is the YAML verbatim, ``source_file`` its file name,
    ``input_units`` the ``units:`` the file was written in (``units`` itself
    is ``SI`` after loading, since every value has been converted).
    """
    name: str = Field(min_length=1)
    description: Optional[str] = None
    units: Literal["SI", "mm-N-s"] = "SI"
    plane: Optional[Plane] = None
    domain: Optional[Domain] = None
    mesh: Optional[Mesh] = None
    parts: dict[str, Part] = {}
    interfaces: list[Interface] = []
    materials: dict[str, Material]
    groups: dict[str, Group] = {}
    boundary: list[BoundaryItem] = []
    initial: list[InitialVelocity] = []
    loads: list[LoadItem] = []
    ground_motion: Optional[GroundMotion] = None
    cuts: list[Cut] = []
    contact: Optional[Contact] = None
    solver: Solver
    output: Output = Output()

    _source_text: str = PrivateAttr(default="")
    _source_file: str = PrivateAttr(default="<string>")
    _lines: dict = PrivateAttr(default_factory=dict)
    _input_units: str = PrivateAttr(default="SI")
    _warnings: list = PrivateAttr(default_factory=list)
    _material_notes: list = PrivateAttr(default_factory=list)

    @property
    def material_notes(self) -> list:
        """What case/presets.py derived for materials given by their
        engineering values (printed by check and info)."""
        return self._material_notes

    @property
    def warnings(self) -> list:
        """Messages for the user about a case that loads but looks wrong
        (file:line: key: ..., as an error's; printed as warnings)."""
        return self._warnings

    @property
    def source_text(self) -> str:
        return self._source_text

    @property
    def source_file(self) -> str:
        return self._source_file

    @property
    def input_units(self) -> str:
        return self._input_units

    def resolved(self) -> dict:
        """The validated case (SI, defaults filled) as a JSON-able dict."""
        return self.model_dump(mode="json", by_alias=True)

    def line_of(self, path: KeyPath) -> Optional[int]:
        """Line (1-based) of the YAML key or list item at ``path``, or None."""
        return self._lines.get(tuple(path))

    def error(self, path: KeyPath, message: str) -> CaseError:
        """A CaseError at ``path`` (line of the nearest key the file has)."""
        return CaseError(self._source_file, _nearest_line(self._lines, path),
                         tuple(path), message)
