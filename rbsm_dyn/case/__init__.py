"""The case file: YAML 1.2 text -> validated :class:`Case` (SI units).

Reading goes in four steps, each of which raises :class:`CaseError` naming
the file, the line and the key path (``case.yaml:12: materials.steel.young:
must be > 0 (got -7e+10)``):

1. ``_parse``: ruamel.yaml round-trip loader (YAML 1.2, so ``1e-5`` is a
   float and ``yes`` is a string).  Syntax errors, duplicate keys, non-UTF-8
   bytes, an empty document, a top level that is not a mapping and any tag
   outside the YAML core schema are rejected.  The tree is copied into plain
   Python objects while the line of every key and list item is recorded.
2. Schema: the pydantic v2 models below (unknown keys forbidden, numbers are
   numbers: no strings, no booleans, no NaN or infinity).
3. ``_check``: cross-field rules (names that must exist, box bounds, ...).
4. ``_to_si``: unit conversion driven by the single table ``DIMENSIONS``,
   then the defaults that depend on other values (output file, interval).

docs/case_file.md is the user's description of the schema.

The modules of this package, in the order data flows through them (each
imports only those before it):

* errors.py: CaseError, key paths, values as messages show them;
* base.py: _Node, the base of every model, and the shared value types
  (Vec3, Box, History, Face, ...);
* the sections of the case file: scene.py (domain, mesh, parts,
  interfaces, cuts, contact), materials.py, boundary.py (groups,
  boundary, initial, loads), solver.py, output.py (fields, probes);
* top.py: the top-level Case model, made of the section models;
* units.py: DIMENSIONS, UNIT_FACTORS and the conversion to SI;
* parse.py: step 1 (_parse);
* parts.py: the parts of a validated case's scene (scene_parts,
  part_solid, surface_indices, ...);
* check.py: step 3 (_check) and the limits it enforces (MAX_CELLS, ...);
* load.py: load_case, load_case_text and the schema's error messages.

Everything is imported from here (``from rbsm_dyn.case import X``).  A
limit that a test lowers (``MAX_CELLS``, ``MAX_ALIAS_VALUES``) must be
set on the module that uses it (rbsm_dyn.case.check, .parse): the names
here are copies.
"""
from __future__ import annotations

from .errors import DOCUMENT, CaseError, KeyPath, _show, format_path
from .base import (FACES, Box, Component, Face, FaceComponent, History, Vec3, Vec3Free,
                   _Node)
from .scene import (GEOMETRY_KINDS, Contact, Cut, Domain, Ground, Interface, Mesh,
                    Part)
from .materials import Material, Rupture, Yield
from .boundary import (BoundaryItem, FaceSupport, Gravity, Group, GroupDisplacement,
                       GroupFix, GroupLoad, GroupVelocity, InitialVelocity, LoadItem,
                       RigidMotion, SurfaceLoad)
from .solver import (DT_SAFETY_MAX, DYNAMIC_KEYS, MODAL_KEYS, RELAXATION_KEYS,
                     STATIC_KEYS, Control, Damping, Solver, default_static_method)
from .output import FieldName, Output, Probe, ProbeItem, RelativeProbe
from .top import Case
from .units import DIMENSIONS, UNIT_FACTORS
from .parse import MAX_ALIAS_VALUES, MAX_FLOW_DEPTH
from .parts import (ScenePart, _case_dir, domain_solid, part_cell_size, part_solid,
                    part_surface_names, scene_parts, surface_indices, surface_part)
from .check import FAR_CELLS_BLOCKS, FAR_CELLS_VORONOI, MAX_CELLS, NUMBER_LIMIT
from .load import MAX_CASE_BYTES, WAVE_SPEED_RANGE, load_case, load_case_text

__all__ = [
    "CaseError", "load_case", "load_case_text", "Case", "Domain", "Mesh",
    "Material", "Yield", "Rupture", "Group", "FaceSupport", "GroupFix",
    "GroupVelocity", "GroupDisplacement", "InitialVelocity", "RigidMotion", "GroupLoad",
    "SurfaceLoad", "Gravity", "Cut", "Contact", "Ground", "Damping", "Solver", "Probe", "RelativeProbe", "Output",
    "DIMENSIONS",
    "MAX_CELLS", "NUMBER_LIMIT",
]
