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
# mixed_mode at its default shear values, ν = 0, double-edge-notched and
# direct tension prisms 8 cells wide: (β, F_T, F_G) against the
# material's brittleness β = l_ch/Δ = E G_f/(f_t² Δ) (Hillerborg's
# characteristic length over the cell size), measured by
# benchmarks/calibrate_fracture.py (docs/calibration.md, "Fracture").
VORONOI_FRACTURE = np.array([
    # beta, F_T, F_G     (β_s = 1, 2, 3, 10; F_T: seeds 1-2 (β_s 2: seed 1);
    [1.83, 0.999, 1.826],   # F_G: the mean of 64 meshes (seeds 1-16, 101-148),
    [2.83, 1.089, 1.679],   # one specimen scatters by ±9-13 % (one standard
    [3.80, 1.140, 1.646],   # deviation), the mean by ±1.2-1.7 %;
    [9.48, 1.280, 1.553],   # docs/calibration.md, "Fracture")
])


# Plane Voronoi (mesh/voronoi_plane.py, min_spacing 0.5, moment spring
# points), the same law and measure on plane-stress specimens 16 cells wide
# (tension_specimen(plane=True), pulled by the whole top edge): measured by
# benchmarks/calibrate_fracture.py --plane on 2026-11-26 (F_T: seeds 1-16,
# ±0.014-0.017 one specimen; F_G: the mean of 64 meshes, seeds 1-64, one
# specimen scatters by ±0.27-0.37 (skewed: a crack that wanders or branches
# dissipates up to twice the median), the mean by ±0.033-0.046; the last
# row's F_G the mean of 256 meshes (seeds 1-64, 229-420; 2026-11-28), ±0.018;
# docs/calibration.md, "Fracture")
PLANE_VORONOI_FRACTURE = np.array([
    # beta, F_T, F_G
    [1.76, 0.940, 1.554],
    [3.00, 0.992, 1.474],
    [4.17, 1.019, 1.444],
    [12.2, 1.083, 1.434],
])


# The direct-tension strength ratio F_T of the 3D Voronoi lattice depends on
# its shear-to-normal stiffness ratio α = k_s/k_n, which the elastic
# calibration sets from ν (calibration.py: α = 1.01, 0.58, 0.27, 0.15 at
# ν = 0, 0.1, 0.2, 0.25): a material at ν = 0.2 with the ν = 0 ratios failed
# at 0.93 f_t (issue 31).  Rows (β, F_T) per α, the same direct-tension prisms
# (8 cells of 2 mm across) at ν = 0, 0.1, 0.2, 0.25, β_s = 1, 3, 10, 30, 100
# (the ν = 0 rows below 25: VORONOI_FRACTURE's), seeds 1-2 (± 0.001-0.03
# between them); benchmarks/calibrate_fracture.py --tension-only --poisson ν,
# 2026-11-28.  β = β_s F_G/F_T² with the F_G of the same α and β_s (below).
# F_T is interpolated in α and log β, held beyond the ends.
ALPHA_NU0 = 1.0141       # k_s/k_n of the calibrated Voronoi springs at ν = 0 (calibration.py)
# The fracture-energy ratio F_G per α likewise: the lattice's fracture
# dissipation per projected crack area grows as α falls (softer shear
# springs: the crack's inclined faces open more in shear), +3-10 % at
# ν = 0.2 and +8-21 % at ν = 0.25 against ν = 0 for β_s ≤ 10, +2-5 % at
# β_s = 30-100.  F_G on the double-edge-notched prisms of VORONOI_FRACTURE,
# β_s = 1, 3, 10, 30, 100, the mean of 16 meshes (seeds 1-16: one specimen
# scatters by ±7-17 %, the mean by ±1.8-2.8 %), 64 at ν = 0.2 and β_s ≤ 10
# (seeds 1-16, 101-148: ±1.1-2.1 %), 15 at ν = 0.2, β_s = 100; ν = 0 below
# β 25: VORONOI_FRACTURE's 64; benchmarks/calibrate_fracture.py
# --notched-only --poisson ν, 2026-11-28.  F_G is interpolated as F_T.
VORONOI_LATTICE = {
    # α: [[β, F_T, F_G], ...]
    # ν = 0: VORONOI_FRACTURE and two rows beyond its end
    ALPHA_NU0: np.vstack([VORONOI_FRACTURE, [[24.5, 1.355, 1.499], [73.6, 1.416, 1.475]]]),
    0.5815: np.array([[2.49, 0.878, 1.917], [4.60, 1.060, 1.723], [11.3, 1.189, 1.600],
                      [28.3, 1.269, 1.520], [84.5, 1.329, 1.493]]),
    0.2662: np.array([[3.55, 0.752, 2.010], [4.61, 1.065, 1.742], [14.1, 1.068, 1.609],
                      [35.7, 1.144, 1.557], [108., 1.194, 1.533]]),
    0.1496: np.array([[4.90, 0.671, 2.205], [5.31, 1.026, 1.864], [12.6, 1.156, 1.682],
                      [42.8, 1.053, 1.580], [128., 1.092, 1.529]]),
}
VORONOI_TENSION = {a: rows[:, :2] for a, rows in VORONOI_LATTICE.items()}      # (β, F_T)
VORONOI_ENERGY = {a: rows[:, [0, 2]] for a, rows in VORONOI_LATTICE.items()}   # (β, F_G)
# With the Poisson correction (ν > 0.25, or stiffness: homogeneous; α = 1 and
# an auxiliary cell stress λ tr(ε), which does not soften) the cells carry
# part of the tension beside the springs: F_T rows per ν (the same prisms and
# seeds; their energy balance closes within 0.3-1.1 %), interpolated in ν.
VORONOI_TENSION_AUX = {
    # ν: [[β, F_T], ...]
    0.3: np.array([[1.33, 1.172], [2.51, 1.404], [5.9, 1.623], [15.1, 1.755], [45.0, 1.859]]),
    0.4: np.array([[1.17, 1.248], [2.08, 1.541], [4.37, 1.885], [10.1, 2.150]]),
}


def brittleness(young, fracture_energy, tensile_strength, cell_size):
    """β = l_ch/Δ, l_ch = E G_f/f_t² (Hillerborg, Modéer & Petersson 1976)."""
    return young * fracture_energy / (tensile_strength ** 2 * cell_size)


def fracture_ratios(mesh_kind, young, fracture_energy, tensile_strength, cell_size,
                    alpha=None, aux_poisson=None):
    """(F_T, F_G) of a mesh kind for a material (E, G_f, f_t) cut into cells
    of `cell_size`: interpolated at its brittleness β (in log β) in the
    measured table, held constant beyond its ends.  Blocks (and plane
    blocks): (1, 1): a crack along a plane of block faces has no tortuosity
    and a uniaxial stress along an axis loads the faces normal to it
    uniformly (Griffith test in tests/test_fracture.py).  `plane_voronoi`:
    the plane Voronoi lattice's own table (PLANE_VORONOI_FRACTURE).
    Voronoi: F_T from VORONOI_TENSION and F_G from VORONOI_ENERGY at the
    springs' α = k_s/k_n (None: ν = 0's), or F_T from VORONOI_TENSION_AUX
    at ν = `aux_poisson` with the Poisson correction (whose springs have
    α = 1: F_G of ν = 0)."""
    if mesh_kind not in ("voronoi", "plane_voronoi"):
        return 1.0, 1.0
    beta = brittleness(young, fracture_energy, tensile_strength, cell_size)
    x = np.log(beta)
    if mesh_kind == "plane_voronoi":
        data = PLANE_VORONOI_FRACTURE
        return _log_interp(x, data[:, [0, 1]]), _log_interp(x, data[:, [0, 2]])
    alpha = ALPHA_NU0 if alpha is None or aux_poisson is not None else alpha
    f_g = _table_interp(x, alpha, VORONOI_ENERGY)
    return voronoi_tension_ratio(beta, alpha, aux_poisson), f_g


def voronoi_tension_ratio(beta, alpha, aux_poisson=None):
    """F_T of the 3D Voronoi lattice at brittleness β and spring ratio α
    (VORONOI_TENSION), or at ν = `aux_poisson` with the Poisson correction
    (VORONOI_TENSION_AUX)."""
    x = np.log(beta)
    if aux_poisson is not None:
        return _table_interp(x, aux_poisson, VORONOI_TENSION_AUX)
    return _table_interp(x, alpha, VORONOI_TENSION)


def _table_interp(x, key, tables):
    """F_T at log β = x and `key` (α or ν) of {key: rows}: linear in log β
    within each table, then linear in the key; held beyond the ends."""
    keys = np.array(sorted(tables))
    return float(np.interp(key, keys, [_log_interp(x, tables[k]) for k in keys]))


def _log_interp(x, rows):
    """rows[:, 1] at log β = x, linear in log β, held beyond the ends."""
    rows = rows[np.argsort(rows[:, 0])]
    return float(np.interp(x, np.log(rows[:, 0]), rows[:, 1]))


def tension_specimen(*, cell, cells_across=8, notch=0.5, young=30.0e9, density=2400.0,
                     poisson=0.0, tensile_strength=3.0e6, fracture_energy=None, beta=None,
                     values="material", seed=1, rate=0.25, extra="", plane=False, ramps=3,
                     frames=150):
    """YAML text of the calibration specimens (docs/calibration.md,
    "Fracture"): a Voronoi prism W × W × 2W (W = cells_across × cell) on a
    support on zmin holding z, pulled along z at its top cell layer at a
    constant velocity (ramped over 10 wave transits), with two edge notches
    cut half-way up, `notch` × W deep in all (0: direct tension).  Give the
    fracture energy or the brittleness β = l_ch/Δ.  The velocity is `rate`
    × f_t/(ρ c0), a quarter of the particle velocity of a stress wave of f_t,
    so that the specimen is loaded quasi-statically; the run ends after the
    opening 2 G_f/f_t of a face has been applied twice over, and not before
    `ramps` ramp times (3, the calibration's; a notched specimen has
    dissipated 99.2-99.9 % of its fracture energy after 2, measured on
    seeds 17 and 18 at 2 mm and 17 at 1.6 mm).  `frames`: output frames
    (each synchronises the state and writes; a test reading the last one
    needs a few).  Probes: F (z
    reaction on the support, negative in tension) and u (top displacement).
    `plane`: the plane-stress specimen W × 2W of thickness `cell` (a
    plane model, pulled along y), the same notches as edge cuts.
    Returns (text, ligament area [m²], G_f)."""
    if fracture_energy is None:
        fracture_energy = beta * cell * tensile_strength ** 2 / young
    if plane:
        return _plane_specimen(cell, cells_across, notch, young, density, poisson,
                               tensile_strength, fracture_energy, values, seed, rate, extra,
                               ramps, frames)
    W = cells_across * cell
    L = 2 * W
    c0 = (young / density) ** 0.5
    v = rate * tensile_strength / (density * c0)
    ramp = 10 * L / c0
    t_end = max(2.0 * (2 * fracture_energy / tensile_strength
                       + L * tensile_strength / young) / v, ramps * ramp)
    cut = ""
    if notch > 0:
        # two edge notches, notch/2 × W deep each, at mid-height: a symmetric
        # ligament (no bending), cut across a band of one cell either side
        # of the plane (a Voronoi face crossing it has its points there);
        # planar: false, the cells of the seed as the tables were measured on
        z0, z1, d = L / 2 - cell, L / 2 + cell, notch * W / 2
        cut = (f"cuts: [{{point: [0, 0, {L / 2!r}], normal: [0, 0, 1], within: [[-1, -1, "
               f"{z0!r}], [{d!r}, 1, {z1!r}]], planar: false}},\n"
               f"       {{point: [0, 0, {L / 2!r}], normal: [0, 0, 1], within: [[{W - d!r}, "
               f"-1, {z0!r}], [1, 1, {z1!r}]], planar: false}}]")
    text = f"""\
name: tension-specimen
domain: {{box: [[0, 0, 0], [{W!r}, {W!r}, {L!r}]]}}
mesh: {{kind: voronoi, size: {cell!r}, seed: {seed}}}
materials:
  m: {{density: {density!r}, young: {young!r}, poisson: {poisson!r},
      rupture: {{fracture_energy: {fracture_energy!r}, tensile_strength: {tensile_strength!r},
                values: {values}{extra}}}}}
groups:
  top: {{box: [[-1, -1, {L - 0.5 * cell!r}], [1, 1, 1]]}}
  bottom: {{box: [[-1, -1, -1], [1, 1, {1.5 * cell!r}]]}}
boundary:
  - {{face: zmin, fix: [z]}}
  - {{group: top, velocity: [0, 0, {v!r}], history: [[0, 0], [{ramp!r}, 1], [{t_end!r}, 1]]}}
{cut}
solver: {{mode: dynamic, end_time: {t_end!r}}}
output:
  interval: {t_end / frames!r}
  fields: [position]
  probes:
    F: {{group: bottom, quantity: reaction, component: z, reduce: sum}}
    u: {{group: top, quantity: displacement, component: z, reduce: mean}}
"""
    return text, W * W * (1 - notch), fracture_energy


def _plane_specimen(cell, cells_across, notch, young, density, poisson, tensile_strength,
                    fracture_energy, values, seed, rate, extra, ramps, frames=150):
    """tension_specimen's plane-stress twin (see there), pulled by the cells
    on its top edge (all of them: a group of the cells whose centroids lie
    near the edge leaves some edge cells behind, and the plane lattice then
    breaks beside them, at 0.6-1.1 f_t from mesh to mesh)."""
    W = cells_across * cell
    L = 2 * W
    c0 = (young / density) ** 0.5
    v = rate * tensile_strength / (density * c0)
    ramp = 10 * L / c0
    t_end = max(2.0 * (2 * fracture_energy / tensile_strength
                       + L * tensile_strength / young) / v, ramps * ramp)
    cut = ""
    if notch > 0:
        y0, y1, d = L / 2 - cell, L / 2 + cell, notch * W / 2
        cut = (f"cuts: [{{point: [0, {L / 2!r}], normal: [0, 1], within: [[-1, {y0!r}], "
               f"[{d!r}, {y1!r}]], planar: false}},\n"
               f"       {{point: [0, {L / 2!r}], normal: [0, 1], within: [[{W - d!r}, "
               f"{y0!r}], [1, {y1!r}]], planar: false}}]")
    text = f"""\
name: tension-specimen-plane
plane: {{kind: stress, thickness: {cell!r}}}
domain: {{box: [[0, 0], [{W!r}, {L!r}]]}}
mesh: {{kind: voronoi, size: {cell!r}, seed: {seed}}}
materials:
  m: {{density: {density!r}, young: {young!r}, poisson: {poisson!r},
      rupture: {{fracture_energy: {fracture_energy!r}, tensile_strength: {tensile_strength!r},
                values: {values}{extra}}}}}
groups:
  bottom: {{box: [[-1, -1], [1, {1.5 * cell!r}]]}}
boundary:
  - {{face: ymin, fix: [y]}}
  - {{surface: ymax, velocity: [0, {v!r}], history: [[0, 0], [{ramp!r}, 1], [{t_end!r}, 1]]}}
{cut}
solver: {{mode: dynamic, end_time: {t_end!r}}}
output:
  interval: {t_end / frames!r}
  fields: [position]
  probes:
    F: {{group: bottom, quantity: reaction, component: y, reduce: sum}}
    u: {{surface: ymax, quantity: displacement, component: y, reduce: mean}}
"""
    return text, W * cell * (1 - notch), fracture_energy
