"""Spring stiffness from (E, ν): Kawai's eq. 13 and the calibrated pair.

k_n = E0/h, k_s = α·E0/h per unit area (h = centroid distance projected on
the face normal; for two materials the two half-lengths act in series).

* `kawai` (Kawai 1978, eq. 13): E0 = E' = (1−ν)E/((1+ν)(1−2ν)), α = G/E'.
* `calibrated` (default): α and E0 such that the mesh reproduces the target
  E and ν, from a table measured per mesh generator (docs/calibration.md,
  made by benchmarks/calibrate.py):
  - blocks: uniaxial stress sees only k_n, so E0 = E (ν_eff = 0 whatever
    α); pure shear of the cubic lattice gives G = α·E0/2, so α = 2G/E =
    1/(1+ν) reproduces the shear modulus.
  - voronoi: measured E/E0 and ν as functions of α on 1 000-cell blocks
    (uniaxial stress, roller ends); α is interpolated for the target ν and
    E0 = E / (E/E0)(α).  ν beyond the table's reach (≈ 0.25) is an error.
"""
import numpy as np

# Voronoi (mesh/voronoi.py, min_spacing 0.5): measured (α, E_eff/E0, ν_eff).
# Filled by benchmarks/calibrate.py; affine estimate where not yet measured.
VORONOI_TABLE = np.array([
    # alpha, E/E0, nu
    [1.00, 1.000, 0.000],
    [0.80, 0.9167, 0.0417],
    [0.60, 0.8261, 0.0870],
    [0.40, 0.7273, 0.1364],
    [0.20, 0.6190, 0.1905],
    [0.00, 0.5000, 0.2500],
])


def kawai_pair(young, poisson):
    """(E0, α) of Kawai's eq. 13: k_n = E'/h, k_s = G/h."""
    e_prime = (1 - poisson) * young / ((1 + poisson) * (1 - 2 * poisson))
    shear = young / (2 * (1 + poisson))
    return e_prime, shear / e_prime


def calibrated_pair(mesh_kind, young, poisson):
    """(E0, α) that make a mesh of this kind reproduce E and ν.

    Raises ValueError (with the reachable range) when ν cannot be reached."""
    if mesh_kind == "blocks":
        return young, 1.0 / (1.0 + poisson)
    table = VORONOI_TABLE[np.argsort(VORONOI_TABLE[:, 2])]
    nu = table[:, 2]
    if not (nu[0] - 1e-12 <= poisson <= nu[-1] + 1e-12):
        raise ValueError(f"the calibrated Voronoi lattice reaches ν in [{nu[0]:.3f}, "
                         f"{nu[-1]:.3f}] (got {poisson}); the Poisson correction is not "
                         "implemented yet")
    alpha = float(np.interp(poisson, nu, table[:, 0]))
    ratio = float(np.interp(poisson, nu, table[:, 1]))
    return young / ratio, alpha


def stiffness_pair(rule, mesh_kind, young, poisson):
    if rule == "kawai":
        return kawai_pair(young, poisson)
    return calibrated_pair(mesh_kind, young, poisson)
