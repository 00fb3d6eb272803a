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
  - voronoi: measured E/E0 and ν as functions of α on a 1 000-cell cube
    (uniform end tractions, strain fitted over the central half; mean of 3
    seeds × 3 load axes); α is interpolated for the target ν and
    E0 = E / (E/E0)(α).  The table spans α = 0.1 … 1.2, i.e. ν from −0.037
    to 0.284; ν beyond that is an error that names the range (α = 0 is a
    mechanism: with k_s = 0 the Voronoi lattice has three zero-energy
    "spin" modes u_i = W s_i, θ_i = 0, because every face is normal to the
    line of its two seeds).
"""
import numpy as np

# Voronoi (mesh/voronoi.py, min_spacing 0.5, default spring points): measured
# (α, E_eff/E0, ν_eff) by benchmarks/calibrate.py alpha on 2026-11-23: unit
# cube of 1 000 cells, seeds 1, 2, 3, uniaxial stress along x, y and z
# (rbsm_dyn.stiffness.uniaxial_moduli); mean of the 9 samples, whose scatter
# is ±0.002–0.005 in E/E0 and ±0.0003–0.004 in ν (docs/calibration.md).
VORONOI_TABLE = np.array([
    # alpha, E/E0, nu
    [1.20, 1.0936, -0.0369],
    [1.10, 1.0570, -0.0178],
    [1.00, 1.0183, 0.0023],
    [0.90, 0.9770, 0.0237],
    [0.80, 0.9330, 0.0465],
    [0.70, 0.8856, 0.0710],
    [0.60, 0.8342, 0.0975],
    [0.50, 0.7781, 0.1263],
    [0.40, 0.7158, 0.1580],
    [0.30, 0.6454, 0.1936],
    [0.20, 0.5631, 0.2346],
    [0.10, 0.4606, 0.2840],
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
