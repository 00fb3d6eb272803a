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
springs; per ν: compression_column): beyond it the ν = 0.2
specimen splits in tension whatever its shear strength (the compressive
cap, which bounds the faces' compression, does not raise it); at ν ≤ 0.1
and with the Poisson correction (ν > 0.25) the strength still grows at
r = 6, where the calibration ends.  An f_c outside the calibrated range
takes the nearest end and a note says so.
Blocks (and plane meshes) have no such calibration: a block lattice loaded
along its axes has no inclined faces and never fails in uniaxial
compression; there r stays 2 and a note says so.
"""
import numpy as np

from .fracture_calibration import ALPHA_NU0

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
# shear_strength = r f_t given, 0.5 /s) at ν = 0.1 and 0.25 over that at
# ν = 0.2, per r (2026-11-28; docs/calibration.md, "Compression"), and at
# ν = 0 the same way (2026-11-29; benchmarks/compression.py poisson),
# multiplies ν = 0.2's column: linear in r, then in α; held beyond α of
# ν = 0 and ν = 0.25 (the α table's ends within 0 ≤ ν ≤ 0.25).
TABLE_ALPHA = 0.2662
COMPRESSION_ALPHA_FACTOR = {
    # α: [[r, f_c(ν)/f_c(ν = 0.2)], ...]
    # ν = 0: 5.85, 10.18, 15.25, 26.83 f_t at r = 2, 3, 4, 6 (ν = 0.2: 8.39,
    # 12.20, 15.09, 17.72); seed 2: see docs/calibration.md
    ALPHA_NU0: np.array([[2.0, 0.697], [3.0, 0.834], [4.0, 1.011], [6.0, 1.514]]),  # ν = 0
    0.5815: np.array([[2.0, 0.837], [3.0, 0.943], [4.0, 1.108], [6.0, 1.372]]),  # ν = 0.1
    TABLE_ALPHA: np.array([[2.0, 1.0], [6.0, 1.0]]),                              # ν = 0.2
    0.1496: np.array([[2.0, 1.047], [3.0, 0.959], [4.0, 0.886], [6.0, 0.828]]),  # ν = 0.25
}
# With the Poisson correction (ν > 0.25, or stiffness: homogeneous: α = 1 and
# the auxiliary cell stress; calibration.py) the lattice is another one, so
# its factor is keyed by ν, as VORONOI_TENSION_AUX is: the same prism (40 mm,
# 6 cells across, seed 1, the C40 preset at ν with shear_strength = r f_t
# given, 0.5 /s; 2026-11-29; benchmarks/compression.py poisson), f_c/f_t
# at r = 2, 3, 4, 6: ν = 0.3: 4.34, 6.54, 9.11, 15.10; ν = 0.4: 4.06, 5.45,
# 7.45, 11.45; over ν = 0.2's column as above.  Linear in r, then in ν; held
# beyond 0.3 and 0.4 (the F_T scaling alone, used before, gave 0.638 at
# ν = 0.3 and 0.551 at 0.4 at every r; docs/calibration.md, "Compression").
COMPRESSION_AUX_FACTOR = {
    # ν: [[r, f_c(ν)/f_c(ν = 0.2)], ...]
    0.3: np.array([[2.0, 0.517], [3.0, 0.536], [4.0, 0.604], [6.0, 0.852]]),
    0.4: np.array([[2.0, 0.484], [3.0, 0.447], [4.0, 0.494], [6.0, 0.646]]),
}


def _factor(key, tables):
    """The factor of {key: rows} at each of the table's r: linear in r within
    each row set, then linear in the key; held beyond the ends."""
    keys = np.array(sorted(tables))
    return np.array([np.interp(key, keys, [np.interp(r, *tables[k].T) for k in keys])
                     for r in VORONOI_COMPRESSION[:, 0]])


def compression_column(tension_ratio=TABLE_TENSION_RATIO, alpha=None, aux_poisson=None):
    """f_c/f_t of VORONOI_COMPRESSION's rows for a material whose F_T at
    the table's brittleness is `tension_ratio` and whose springs have α =
    k_s/k_n (COMPRESSION_ALPHA_FACTOR), or which has the Poisson correction
    at ν = `aux_poisson` (COMPRESSION_AUX_FACTOR); neither: the F_T scaling
    alone."""
    if alpha is None and aux_poisson is None:
        return VORONOI_COMPRESSION[:, 1] * (TABLE_TENSION_RATIO / tension_ratio)
    from .fracture_calibration import voronoi_tension_ratio
    base = VORONOI_COMPRESSION[:, 1] * (TABLE_TENSION_RATIO
                                        / voronoi_tension_ratio(TABLE_BRITTLENESS, TABLE_ALPHA))
    if aux_poisson is not None:
        return base * _factor(aux_poisson, COMPRESSION_AUX_FACTOR)
    return base * _factor(alpha, COMPRESSION_ALPHA_FACTOR)


def shear_ratio(mesh_kind, compressive_strength, tensile_strength,
                tension_ratio=TABLE_TENSION_RATIO, alpha=None, aux_poisson=None):
    """(r = f_s/f_t, note or None) for a material of compressive strength
    f_c and tensile strength f_t [Pa] on a mesh kind: interpolated in the
    measured table (VORONOI_COMPRESSION), its ends beyond it (with a note);
    DEFAULT_RATIO with a note on other mesh kinds.  `tension_ratio`: the
    material's F_T at the table's brittleness (its springs' f_t = f_t/F_T);
    `alpha` its springs' k_s/k_n, `aux_poisson` its ν with the Poisson
    correction (compression_column)."""
    ratio = compressive_strength / tensile_strength
    if mesh_kind != "voronoi":
        return DEFAULT_RATIO, (
            f"compressive_strength is not a failure criterion on {mesh_kind} meshes (only "
            f"Voronoi cells are calibrated: docs/calibration.md, \"Compression\"); the shear "
            f"strength stays {DEFAULT_RATIO:g} f_t")
    r_tab = VORONOI_COMPRESSION[:, 0]
    c_tab = compression_column(tension_ratio, alpha, aux_poisson)
    r = float(np.interp(ratio, c_tab, r_tab))
    note = None
    if ratio > c_tab[-1]:
        note = (f"compressive_strength = {ratio:.3g} f_t is above what the calibrated Voronoi "
                f"lattice reaches at this ν ({c_tab[-1]:.3g} f_t, at f_s = {r_tab[-1]:g} f_t, "
                f"the calibration's end); a specimen fails near {c_tab[-1]:.3g} f_t = "
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
