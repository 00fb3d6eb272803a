"""Geometry → cells: Voronoi and block meshes of a box, exact polyhedron mass
properties, and spring points on faces.  See docs/modules.md ("mesh/")."""
from ._core import SIDES, Mesh
from .blocks import block_mesh
from .polyhedron import cells_mass_properties, mass_properties, principal_axes
from .spring_points import RULES, SpringPoints, polygon_properties, spring_points
from .voronoi import voronoi_mesh, voronoi_seeds

__all__ = [
    "Mesh",
    "SIDES",
    "voronoi_mesh",
    "voronoi_seeds",
    "block_mesh",
    "spring_points",
    "SpringPoints",
    "RULES",
    "polygon_properties",
    "mass_properties",
    "cells_mass_properties",
    "principal_axes",
]
