"""A material's compressive strength -> the mixed-mode law's shear strength.

The mixed-mode law's envelope (physics/laws/rupture.py) is open in pure
compression (its `cap` bounds the normal traction only): a lattice
specimen under uniaxial compression fails by its faces inclined to the
load, in shear under compression and, across the load, in tension
(the splitting of a cylinder on frictionless platens).  Its strength is
therefore set by the shear-to-tensile strength ratio r = f_s/f_t of the
envelope τ² = f_s² (1 − σ/f_t), as in Cusatis's LDPM, whose ratio σ_s/σ_t is
among the parameters fitted to unconfined compression tests (Cusatis,
Mencarelli, Pelessone & Baylot 2011, "Lattice Discrete Particle Model
(LDPM) for failure behavior of concrete. II: Calibration and validation",
Cem. Concr. Compos. 33, 891).  `rupture.compressive_strength` f_c picks r from
the measured ratio f_c/f_t of the lattice:

    VORONOI_COMPRESSION: (r, f_c/f_t) of a Voronoi prism b × b × 2b between
    rigid frictionless platens, 7 and 10 cells across b, ν = 0.2, the
    concrete of `{model: concrete, fc: 40e6}` (brittleness l_ch/Δ = 76-107),
    measured by benchmarks/compression.py (docs/calibration.md,
    "Compression").

The strength grows with r up to about 16.6 f_t (r = 6; on the table's
springs; per ν: compression_column): beyond it the
specimen splits in tension whatever its shear strength (the compressive
cap, which bounds the faces' compression, does not raise it).  An f_c
outside the table's range takes the nearest end and a note says so.
Blocks (and plane meshes) have no such calibration: a block lattice loaded
along its axes has no inclined faces and never fails in uniaxial
compression; there r stays 2 and a note says so.
"""
import numpy as np

# r = f_s/f_t, f_c/f_t: the mean of 7 and 10 cells across b (50 mm prisms
# of 7 and 5 mm cells, seed 1; 10 cells across is 3-7 % stronger than 7,
# docs/calibration.md, "Compression", has each); beyond r = 6 the
# strength no longer grows (r = 8: 16.2 f_t)
VORONOI_COMPRESSION = np.array([
    [2.0, 8.08],
    [2.5, 9.87],
    [3.0, 11.86],
    [3.3, 12.55],
    [4.0, 14.57],
    [5.0, 15.93],
    [6.0, 16.64],
])

DEFAULT_RATIO = 2.0      # f_s/f_t without a compressive strength (docs/case_file.md)

# The table's f_t is the material's: its springs had f_t/F_T with F_T =
# 1.280, the ν = 0 direct-tension ratio then used for ν = 0.2 (held at
# β = 9.5 and above).  The strength of a specimen scales with its springs'
# f_s = r f_t/F_T, so a material whose F_T differs (fracture_calibration.
# VORONOI_TENSION: 1.18 at ν = 0.2 and the table's brittleness) reads the
# table at f_c/f_t × F_T/1.280.
TABLE_TENSION_RATIO = 1.280
TABLE_BRITTLENESS = 90.0     # β = l_ch/Δ of the table's specimens (76-107)

# The table is ν = 0.2's (its springs' α = k_s/k_n = 0.2662).  Other α: the
# scaling by F_T above misses how the shear springs share the compression
# (it gives a constant 0.89 at ν = 0.1, 1.10 at ν = 0.25): f_c/f_t measured
# on one prism (40 mm, 6 cells across, seed 1, the C40 preset with
# shear_strength = r f_t given) at ν = 0.1 and 0.25 over that at ν = 0.2,
# per r (2026-11-28; docs/calibration.md, "Compression"), multiplies ν =
# 0.2's column: linear in r, then in α; held beyond ν = 0.1 and 0.25 (ν <
# 0.1 is not measured).  Not with the Poisson correction (ν > 0.25), which
# keeps the F_T scaling.
TABLE_ALPHA = 0.2662
COMPRESSION_ALPHA_FACTOR = {
    # α: [[r, f_c(ν)/f_c(ν = 0.2)], ...]
    0.5815: np.array([[2.0, 0.837], [3.0, 0.943], [4.0, 1.108], [6.0, 1.372]]),  # ν = 0.1
    TABLE_ALPHA: np.array([[2.0, 1.0], [6.0, 1.0]]),                              # ν = 0.2
    0.1496: np.array([[2.0, 1.047], [3.0, 0.959], [4.0, 0.886], [6.0, 0.828]]),  # ν = 0.25
}


def compression_column(tension_ratio=TABLE_TENSION_RATIO, alpha=None):
    """f_c/f_t of VORONOI_COMPRESSION's rows for a material whose F_T at
    the table's brittleness is `tension_ratio` and whose springs have α =
    k_s/k_n (None: the F_T scaling alone, as with the Poisson correction)."""
    r_tab = VORONOI_COMPRESSION[:, 0]
    if alpha is None:
        return VORONOI_COMPRESSION[:, 1] * (TABLE_TENSION_RATIO / tension_ratio)
    from .fracture_calibration import voronoi_tension_ratio
    base = VORONOI_COMPRESSION[:, 1] * (TABLE_TENSION_RATIO
                                        / voronoi_tension_ratio(TABLE_BRITTLENESS, TABLE_ALPHA))
    keys = np.array(sorted(COMPRESSION_ALPHA_FACTOR))
    factor = np.array([[np.interp(r, *COMPRESSION_ALPHA_FACTOR[k].T) for k in keys]
                       for r in r_tab])
    return base * np.array([np.interp(alpha, keys, f) for f in factor])


def shear_ratio(mesh_kind, compressive_strength, tensile_strength,
                tension_ratio=TABLE_TENSION_RATIO, alpha=None):
    """(r = f_s/f_t, note or None) for a material of compressive strength
    f_c and tensile strength f_t [Pa] on a mesh kind: interpolated in the
    measured table (VORONOI_COMPRESSION), its ends beyond it (with a note);
    DEFAULT_RATIO with a note on other mesh kinds.  `tension_ratio`: the
    material's F_T at the table's brittleness (its springs' f_t = f_t/F_T);
    `alpha` its springs' k_s/k_n (compression_column)."""
    ratio = compressive_strength / tensile_strength
    if mesh_kind != "voronoi":
        return DEFAULT_RATIO, (
            f"compressive_strength is not a failure criterion on {mesh_kind} meshes (only "
            f"Voronoi cells are calibrated: docs/calibration.md, \"Compression\"); the shear "
            f"strength stays {DEFAULT_RATIO:g} f_t")
    r_tab = VORONOI_COMPRESSION[:, 0]
    c_tab = compression_column(tension_ratio, alpha)
    r = float(np.interp(ratio, c_tab, r_tab))
    note = None
    if ratio > c_tab[-1]:
        note = (f"compressive_strength = {ratio:.3g} f_t is above what the Voronoi lattice "
                f"reaches ({c_tab[-1]:.3g} f_t, at f_s = {r_tab[-1]:g} f_t: it then splits in "
                f"tension); a specimen fails near {c_tab[-1]:.3g} f_t = "
                f"{c_tab[-1] * tensile_strength / 1e6:.4g} MPa")
    elif ratio < c_tab[0]:
        note = (f"compressive_strength = {ratio:.3g} f_t is below the calibrated range "
                f"({c_tab[0]:.3g}-{c_tab[-1]:.3g} f_t): f_s = {r_tab[0]:g} f_t, a specimen fails "
                f"near {c_tab[0]:.3g} f_t")
    return r, note


def compression_specimen(*, cell, width=0.05, height=None, fc=40.0e6, friction=0.0, seed=1,
                         rate=0.5, confinement=0.0, extra="", frames=300, uniform=False):
    """YAML text of the calibration specimen (docs/calibration.md,
    "Compression"): a Voronoi prism width × width × height (2 × width by
    default) of `{model: concrete, fc}` (+ `extra` inside the material's
    mapping) between two rigid steel platens joined to it by contact
    interfaces of Coulomb `friction` (0: frictionless), the bottom one
    fixed, the top one pushed down at `rate` × height per second (a strain
    rate [1/s]; ramped over 0.1 ms of strain 1e-4), `confinement` [Pa] a
    lateral pressure on the four sides (a follower, as a triaxial cell's
    fluid: the default of `pressure`) ramped over the same time.  The run
    ends at a strain of 0.3 % (0.6 % confined).  Probes: F (the top
    platen's z reaction, negative in compression) and d (its z
    displacement).  `uniform`: no ramp: the top platen moves from the
    start and every cell starts at the velocity of a uniform strain rate
    (−rate z, in bands one cell thick), so that no wave runs (the
    loading rate's tests)."""
    height = 2.0 * width if height is None else height
    v = rate * height
    ramp = 1.0e-4 / rate
    t_end = (6.0e-3 if confinement else 3.0e-3) / rate
    b, L, t = width, height, 0.01 * width / 0.05
    loads = ""
    history = f"[[0, 0], [{ramp!r}, 1], [1, 1]]"
    initial = ""
    if uniform:
        history = "[[0, 1], [1, 1]]"
        band = cell
        n = int(np.ceil(height / band))
        groups = "".join(f"  z{i}: {{box: [[-1, -1, {i * band!r}], "
                         f"[1, 1, {(i + 1) * band!r}]]}}\n" for i in range(n))
        initial = "groups:\n" + groups + "initial:\n" + "".join(
            f"  - {{group: z{i}, velocity: [0, 0, {-rate * (i + 0.5) * band!r}]}}\n"
            for i in range(n)) + f"  - {{group: top, velocity: [0, 0, {-v!r}]}}\n"
    if confinement:
        loads = "loads:\n" + "".join(
            f"  - {{surface: spec.{w}, pressure: {confinement!r}, history: [[0, 0], "
            f"[{ramp!r}, 1], [1, 1]]}}\n" for w in ("xmin", "xmax", "ymin", "ymax"))
    return f"""\
name: compression-specimen
parts:
  spec:
    geometry: {{box: [[0, 0, 0], [{b!r}, {b!r}, {L!r}]]}}
    mesh: {{kind: voronoi, size: {cell!r}, seed: {seed}}}
    material: concrete
  bot:
    geometry: {{box: [[{-t!r}, {-t!r}, {-t!r}], [{b + t!r}, {b + t!r}, 0]]}}
    mesh: {{kind: rigid}}
    material: steel
  top:
    geometry: {{box: [[{-t!r}, {-t!r}, {L!r}], [{b + t!r}, {b + t!r}, {L + t!r}]]}}
    mesh: {{kind: rigid}}
    material: steel
interfaces:
  - {{parts: [spec, bot], law: contact, friction: {friction!r}}}
  - {{parts: [spec, top], law: contact, friction: {friction!r}}}
materials:
  concrete: {{model: concrete, fc: {fc!r}{extra}}}
  steel: {{density: 7800, young: 2.0e11, poisson: 0.3}}
boundary:
  - {{group: bot, fix: all}}
  - {{group: top, fix: [x, y, rx, ry, rz]}}
  - {{group: top, velocity: [null, null, {-v!r}], history: {history}}}
{initial}{loads}solver: {{mode: dynamic, end_time: {t_end!r}}}
output:
  interval: {t_end / frames!r}
  probes:
    F: {{group: top, quantity: reaction, component: z, reduce: sum}}
    d: {{group: top, quantity: displacement, component: z, reduce: mean}}
"""
