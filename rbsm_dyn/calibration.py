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
    (uniform end tractions; E from the strain fitted over the central half
    of the length, ν over the central half along every axis, the interior;
    mean of 6 seeds × 3 load axes); α is interpolated for the target ν and
    E0 = E / (E/E0)(α), for 0 ≤ ν ≤ NU_TABLE_MAX = 0.25.  The table spans
    α = 0.1 … 1.2, i.e. ν from −0.036 to 0.274 (α = 0 is a mechanism: with
    k_s = 0 the Voronoi lattice has three zero-energy "spin" modes
    u_i = W s_i, θ_i = 0, because every face is normal to the line of its
    two seeds).
  - voronoi, ν > NU_TABLE_MAX (0.25) up to 0.45: the elastically homogeneous
    lattice (α = 1) plus the auxiliary volumetric stress λ tr(ε_c) per cell
    (physics/poisson.py; Asahina et al. 2017, Eliáš 2017/2020), with
    β = λ/E0 and E0 = E / (E/E0)(β) interpolated in a second table measured
    the same way (VORONOI_AUX_TABLE).  Below 0.25 the α table is kept: it
    costs nothing per step and existing models keep their results.  ν above
    0.45 is an error that names the range (ν_eff(β) flattens towards 0.47).
* `homogeneous`: the α = 1 lattice plus the auxiliary stress for any ν in
  [0, 0.45] (ν = 0: no auxiliary stress; near 0.5 λ and the wave speed
  grow without bound).  Voronoi: β and E0 from
  VORONOI_AUX_TABLE.  Blocks: exact for a uniform strain (the cubic α = 1
  lattice has μ = E0/2, λ = 0 and the least-squares strain is exact), so
  E0 = 2μ = E/(1+ν) and λ = Eν/((1+ν)(1−2ν)) (Lamé).

`stiffness_rule(rule, mesh_kind, E, ν) -> (E0, α, λ_aux)`; λ_aux = 0 means
no correction (a scene where every material has λ_aux = 0 runs no extra
pass and holds no extra arrays).
"""
import numpy as np

# Voronoi (mesh/voronoi.py, min_spacing 0.5, default spring points): measured
# (α, E_eff/E0, ν_eff) by benchmarks/calibrate.py alpha --interior --seeds
# 1 2 3 4 5 6 on 2026-11-27: unit cube of 1 000 cells, uniaxial stress along
# x, y and z (rbsm_dyn.stiffness.uniaxial_moduli); mean of the 18 samples.
# E/E0 from the strain fitted over the middle half of the length, all cells
# across (± 0.003–0.007); ν from the cells in the middle half along every
# axis (interior=True, ± 0.0005–0.009): the bulk lattice's lateral
# contraction, without the clipped cells of the free surface, which
# contract more (issue 30: the section's ν, the table of 2026-11-23, is
# 0.005 higher at α = 0.3, and the interior of a specimen came out below
# the target; docs/calibration.md "Interior of a specimen").
VORONOI_TABLE = np.array([
    # alpha, E/E0, nu
    [1.20, 1.0938, -0.0357],
    [1.10, 1.0573, -0.0170],
    [1.00, 1.0187, 0.0028],
    [0.90, 0.9776, 0.0236],
    [0.80, 0.9337, 0.0458],
    [0.70, 0.8866, 0.0694],
    [0.60, 0.8356, 0.0949],
    [0.50, 0.7799, 0.1225],
    [0.40, 0.7181, 0.1529],
    [0.30, 0.6484, 0.1868],
    [0.20, 0.5670, 0.2259],
    [0.10, 0.4655, 0.2737],
])


# ν above which the calibrated Voronoi rule switches from the α table to the
# auxiliary-stress correction, and the largest ν either reaches
NU_TABLE_MAX = 0.25
NU_MAX = 0.45

# Voronoi, α = 1 plus the auxiliary stress λ = β E0 (physics/poisson.py):
# measured (β, E_eff/E0, ν_eff) by benchmarks/calibrate.py aux on 2026-11-23
# (same specimens, seeds and method as VORONOI_TABLE; docs/calibration.md).
VORONOI_AUX_TABLE = np.array([
    # beta, E/E0, nu               (± over 3 seeds × 3 axes)
    [0.00, 1.0183, 0.0023],   # ± 0.0040, ± 0.0003
    [0.10, 1.0965, 0.0825],   # ± 0.0040, ± 0.0004
    [0.20, 1.1510, 0.1380],   # ± 0.0040, ± 0.0005
    [0.30, 1.1913, 0.1790],   # ± 0.0040, ± 0.0006
    [0.40, 1.2225, 0.2107],   # ± 0.0040, ± 0.0006
    [0.50, 1.2473, 0.2359],   # ± 0.0040, ± 0.0007
    [0.60, 1.2676, 0.2564],   # ± 0.0040, ± 0.0007
    [0.80, 1.2989, 0.2881],   # ± 0.0040, ± 0.0008
    [1.00, 1.3219, 0.3114],   # ± 0.0040, ± 0.0009
    [1.25, 1.3434, 0.3331],   # ± 0.0040, ± 0.0010
    [1.50, 1.3596, 0.3494],   # ± 0.0040, ± 0.0010
    [2.00, 1.3826, 0.3725],   # ± 0.0040, ± 0.0012
    [2.50, 1.3981, 0.3881],   # ± 0.0041, ± 0.0012
    [3.00, 1.4093, 0.3993],   # ± 0.0041, ± 0.0013
    [3.50, 1.4178, 0.4078],   # ± 0.0041, ± 0.0014
    [4.00, 1.4245, 0.4145],   # ± 0.0041, ± 0.0014
    [4.50, 1.4299, 0.4199],   # ± 0.0041, ± 0.0014
    [5.00, 1.4343, 0.4243],   # ± 0.0041, ± 0.0015
    [5.50, 1.4380, 0.4280],   # ± 0.0041, ± 0.0015
    [6.00, 1.4412, 0.4311],   # ± 0.0041, ± 0.0015
    [7.00, 1.4464, 0.4362],   # ± 0.0041, ± 0.0016
    [8.00, 1.4504, 0.4401],   # ± 0.0041, ± 0.0016
    [10.00, 1.4562, 0.4458],   # ± 0.0041, ± 0.0016
    [11.00, 1.4583, 0.4479],   # ± 0.0041, ± 0.0017
    [12.00, 1.4602, 0.4497],   # ± 0.0041, ± 0.0017
    [13.00, 1.4618, 0.4512],   # ± 0.0041, ± 0.0017
    [14.00, 1.4631, 0.4526],   # ± 0.0041, ± 0.0017
    [16.00, 1.4654, 0.4547],   # ± 0.0041, ± 0.0017
])


def kawai_pair(young, poisson):
    """(E0, α) of Kawai's eq. 13: k_n = E'/h, k_s = G/h."""
    e_prime = (1 - poisson) * young / ((1 + poisson) * (1 - 2 * poisson))
    shear = young / (2 * (1 + poisson))
    return e_prime, shear / e_prime


def _aux_rule(young, poisson):
    """(E0, 1, λ) of the α = 1 lattice plus auxiliary stress, from VORONOI_AUX_TABLE."""
    table = VORONOI_AUX_TABLE
    nu = table[:, 2]
    if not (0.0 <= poisson <= min(nu[-1], NU_MAX) + 1e-12):
        raise ValueError(f"the corrected Voronoi lattice reaches ν in [0, "
                         f"{min(nu[-1], NU_MAX):.2f}] (got {poisson})")
    if poisson <= nu[0]:
        # below the α = 1 lattice's own ν (0.002): no auxiliary stress
        return young / table[0, 1], 1.0, 0.0
    beta = float(np.interp(poisson, nu, table[:, 0]))
    e0 = young / float(np.interp(poisson, nu, table[:, 1]))
    return e0, 1.0, beta * e0


def calibrated_pair(mesh_kind, young, poisson):
    """(E0, α) of the α table that make a mesh of this kind reproduce E and ν
    (no auxiliary stress).

    Raises ValueError (with the reachable range) when ν cannot be reached."""
    if mesh_kind == "blocks":
        return young, 1.0 / (1.0 + poisson)
    table = VORONOI_TABLE[np.argsort(VORONOI_TABLE[:, 2])]
    nu = table[:, 2]
    if not (nu[0] - 1e-12 <= poisson <= nu[-1] + 1e-12):
        raise ValueError(f"the calibrated Voronoi lattice reaches ν in [{nu[0]:.3f}, "
                         f"{nu[-1]:.3f}] (got {poisson}) without the Poisson correction")
    alpha = float(np.interp(poisson, nu, table[:, 0]))
    ratio = float(np.interp(poisson, nu, table[:, 1]))
    return young / ratio, alpha


def stiffness_rule(rule, mesh_kind, young, poisson):
    """(E0, α, λ_aux) of a material: k_n = E0/h, k_s = α E0/h and the
    auxiliary Lamé constant λ_aux [Pa] (0: no Poisson correction).

    Raises ValueError (with the reachable range) when ν cannot be reached."""
    if rule == "kawai":
        return kawai_pair(young, poisson) + (0.0,)
    if rule == "homogeneous":
        if mesh_kind == "blocks":
            if poisson > NU_MAX + 1e-12:
                raise ValueError(f"the corrected block lattice takes ν in [0, {NU_MAX}] "
                                 f"(got {poisson})")
            # Lamé: 2μ = E/(1+ν), λ = Eν/((1+ν)(1−2ν))
            return (young / (1 + poisson), 1.0,
                    young * poisson / ((1 + poisson) * (1 - 2 * poisson)))
        return _aux_rule(young, poisson)
    if mesh_kind == "blocks" or poisson <= NU_TABLE_MAX:
        return calibrated_pair(mesh_kind, young, poisson) + (0.0,)
    return _aux_rule(young, poisson)


def stiffness_pair(rule, mesh_kind, young, poisson):
    """(E0, α) of stiffness_rule (without λ_aux)."""
    return stiffness_rule(rule, mesh_kind, young, poisson)[:2]


def plane_moduli(kind, young, poisson):
    """(E*, ν*) of the in-plane elasticity: plane stress (E, ν); plane
    strain (E/(1 − ν²), ν/(1 − ν)) (Timoshenko & Goodier, Theory of
    Elasticity, §16: ε_z = 0 turns the 3D law into the 2D one with these
    constants; the shear modulus G = E*/(2(1 + ν*)) is unchanged)."""
    if kind == "stress":
        return young, poisson
    return young / (1.0 - poisson ** 2), poisson / (1.0 - poisson)


def plane_stiffness_rule(rule, mesh_kind, young, poisson, kind):
    """(E0, α, λ_aux) of a material in a plane model (`kind` strain or
    stress), from its in-plane moduli (E*, ν*) (plane_moduli):

    * `kawai`: k_n = E*/(1 − ν*²)/h, k_s = G/h (Kawai & Toi 1977, eq. 13:
      in plane strain E(1 − ν)/((1 + ν)(1 − 2ν)), the 3D rule's E').
    * `calibrated` on blocks: uniaxial stress in the plane sees only k_n,
      E0 = E*; shear of the square lattice G = α E0/2 gives α = 1/(1 + ν*)
      (the 3D blocks' rule with E*, ν*: a one-cell slab of blocks in plane
      stress is the plane model).
    * `calibrated` on Voronoi: α for ν* and E0 = E*/(E/E0)(α) from
      PLANE_VORONOI_TABLE (ν* from −0.045 to 0.436: plane stress up to
      ν = 0.43, plane strain up to 0.30; no auxiliary stress needed).

    Raises ValueError for a ν* outside the table and for `homogeneous`
    (the plane auxiliary stress is not built yet)."""
    es, nus = plane_moduli(kind, young, poisson)
    if rule == "kawai":
        e0 = es / (1.0 - nus ** 2)
        return e0, es / (2.0 * (1.0 + nus)) / e0, 0.0
    if rule == "calibrated":
        if mesh_kind == "blocks":
            return es, 1.0 / (1.0 + nus), 0.0
        table = PLANE_VORONOI_TABLE[np.argsort(PLANE_VORONOI_TABLE[:, 2])]
        nu = table[:, 2]
        if not (nu[0] - 1e-12 <= nus <= nu[-1] + 1e-12):
            raise ValueError(f"the plane Voronoi lattice reaches an in-plane ν* in "
                             f"[{nu[0]:.3f}, {nu[-1]:.3f}] (got ν* = {nus:.4g} of ν = "
                             f"{poisson} in plane {kind})")
        alpha = float(np.interp(nus, nu, table[:, 0]))
        return es / float(np.interp(nus, nu, table[:, 1])), alpha, 0.0
    raise ValueError(f"stiffness: {rule} is not available in a plane model yet "
                     f"(calibrated or kawai)")


# Plane Voronoi (mesh/voronoi_plane.py, min_spacing 0.5, moment spring
# points): (α, E*/E0, ν*) measured by benchmarks/calibrate_plane.py on
# 2026-11-26: unit square of ~1 000 cells, seeds 1, 2, 3, uniaxial stress
# along x and y; mean of the 6 samples (spread ±0.0014–0.0043 in E/E0,
# ±0.0005–0.0069 in ν*; docs/calibration.md)
PLANE_VORONOI_TABLE = np.array([
    # alpha, E/E0, nu*
    [1.20, 1.0573, -0.0454],
    [1.10, 1.0347, -0.0228],
    [1.00, 1.0101, 0.0016],
    [0.90, 0.9834, 0.0283],
    [0.80, 0.9539, 0.0576],
    [0.70, 0.9213, 0.0901],
    [0.60, 0.8848, 0.1265],
    [0.50, 0.8433, 0.1678],
    [0.40, 0.7952, 0.2157],
    [0.30, 0.7379, 0.2724],
    [0.20, 0.6667, 0.3425],
    [0.10, 0.5709, 0.4356],
])
