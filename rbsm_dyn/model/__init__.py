"""The model of a run: Model (immutable structure-of-arrays), State (what
changes each step), and how they are built.

Built from a validated Case and its Mesh: bodies with real mass and full
principal inertia, spring points between neighbouring cells, support springs
to the ground (body index `n_bodies`), constraints, loads.  Kernels in
physics/ take these arrays; nothing here is read by a kernel as an object.

Index type: int32 throughout (DESIGN.md §5); state float64.

Modules:
  core.py         Model (MeshSummary: its mesh while a run steps)
  state.py        State, new_state
  mesh_build.py   build_mesh, part_mesh: the cells of the scene
  laws.py         law rows of a material (material_law_row, ...), the law
                  table of a build (law slots)
  loads.py        groups, surfaces, surface loads, constraints, loads,
                  amplitude tables
  springs.py      internal and support springs, their arms, the face table
  build.py        build_model: the steps of a build, in order
  initial.py      apply_initial: initial velocities
  stable_step.py  row sums of the stiffness, omega_max_bound (Model.stable_dt)
  contact.py      contact between any cells: ContactModel, ContactState
"""
from .build import build_model
from .core import IDX, MeshSummary, Model
from .initial import apply_initial
from .laws import elastic_law_row, material_law_row, strength_of, unbreakable
from .loads import COMPONENTS, FACES, surface_ids, surface_load
from .mesh_build import build_mesh, part_mesh
from .stable_step import (STABLE_DT_SWEEPS, _scaled_row_sums, dof_row_sums,  # noqa: F401
                          omega_max_bound, scaled_row_sums)
from .state import State, new_state

__all__ = ["COMPONENTS", "FACES", "IDX", "MeshSummary", "Model", "STABLE_DT_SWEEPS", "State", "apply_initial",
           "build_mesh", "build_model", "dof_row_sums", "elastic_law_row", "material_law_row",
           "new_state", "omega_max_bound", "part_mesh", "scaled_row_sums", "strength_of",
           "surface_ids", "surface_load", "unbreakable"]
