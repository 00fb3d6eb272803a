"""Materials given by their engineering values (issue 31): ``materials.NAME:
{model: concrete, fc: 48.0e6}`` gets its density, Young's modulus,
Poisson's ratio, tensile strength and fracture energy from the fib Model
Code 2010 (fib Bulletin 65, Vol. 1, §5.1); ``{model: rock, rock: granite,
ucs: 150.0e6}`` gets them from the intact rock's uniaxial compressive
strength by the Hoek–Brown criterion and published ratios (``rock``
below); ``{model: brick, fb: 20.0e6}`` (a masonry unit) and ``{model:
mortar, fm: 5.0e6}`` (a mortar joint: the ``material`` of a bonded
interface) from the unit's and the mortar's compressive strengths
(``brick`` and ``mortar`` below, each value's source beside it).  Each
value is overridable by giving it.

Applied to the raw case data before validation (like plane.lift_plane), in
the file's units; the values filled in are kept as notes that `check` and
`info` print."""
from __future__ import annotations

import math

from .errors import CaseError, _nearest_line, _show
from .units import UNIT_FACTORS

#: mean cylinder compressive strength f_cm [MPa] the Model Code's relations
#: cover: grades C12 to C120 (Table 5.1-1), f_cm = f_ck + 8 MPa
FC_RANGE = (20.0, 128.0)
DELTA_F = 8.0           # MPa, f_cm = f_ck + Δf (eq. 5.1-1)
E_C0 = 21.5e3           # MPa (eq. 5.1-21, α_E = 1: quartzite aggregate)
POISSON = 0.2           # §5.1.7.3: 0.14-0.26, 0.2 for design
DENSITY = 2400.0        # kg/m³, plain normal-weight concrete (taken, not the Model Code's)


def concrete(fcm):
    """{young [Pa], poisson, tensile_strength [Pa], fracture_energy [J/m²],
    density [kg/m³], compressive_strength [Pa] (f_cm itself)} of a concrete
    of mean cylinder strength fcm [Pa] (fib Model Code 2010): E_ci = E_c0
    α_E (f_cm/10)^(1/3) (eq. 5.1-21, the tangent modulus at the origin);
    f_ctm = 0.3 f_ck^(2/3) up to C50
    (eq. 5.1-3a), 2.12 ln(1 + 0.1 f_cm) above (eq. 5.1-3b); G_F = 73
    f_cm^0.18 (eq. 5.1-9); ν = 0.2 (§5.1.7.3); density 2400 kg/m³ (a
    normal-weight concrete's, taken)."""
    f = fcm / 1e6
    fck = f - DELTA_F
    fctm = 0.3 * fck ** (2.0 / 3.0) if fck <= 50.0 else 2.12 * math.log(1.0 + 0.1 * f)
    return {"young": E_C0 * (f / 10.0) ** (1.0 / 3.0) * 1e6, "poisson": POISSON,
            "tensile_strength": fctm * 1e6, "fracture_energy": 73.0 * f ** 0.18,
            "density": DENSITY, "compressive_strength": fcm}


#: intact rock types: (modulus ratio MR = E_i/σ_ci, Hoek & Diederichs 2006,
#: Int J Rock Mech Min Sci 43, Table 3 after Deere 1968: the middle of each
#: range; Hoek–Brown m_i, Marinos & Hoek 2000 / Hoek 2007 "Practical Rock
#: Engineering" Table 11.1: the middle; density [kg/m³], typical, taken)
ROCKS = {
    "granite": (425.0, 32.0, 2650.0), "granodiorite": (425.0, 29.0, 2700.0),
    "diorite": (325.0, 25.0, 2800.0), "gabbro": (450.0, 27.0, 2950.0),
    "andesite": (400.0, 25.0, 2600.0), "basalt": (350.0, 25.0, 2850.0),
    "dolerite": (350.0, 16.0, 2900.0), "gneiss": (525.0, 28.0, 2700.0),
    "quartzite": (375.0, 20.0, 2650.0), "marble": (850.0, 9.0, 2700.0),
    "slate": (500.0, 7.0, 2750.0), "schist": (675.0, 12.0, 2750.0),
    "sandstone": (275.0, 17.0, 2350.0), "siltstone": (375.0, 7.0, 2500.0),
    "claystone": (250.0, 4.0, 2400.0), "shale": (200.0, 6.0, 2500.0),
    "limestone": (700.0, 10.0, 2600.0), "dolomite": (425.0, 9.0, 2750.0),
}
UCS_RANGE = (1.0, 400.0)   # MPa: ISRM's "extremely weak" to beyond "extremely strong" intact rock
ROCK_POISSON = 0.25        # Gercek 2007 (Int J Rock Mech Min Sci 44): most intact rocks 0.15-0.35; taken
ZHANG_RATIO = 6.88         # σ_t [MPa] = 6.88 K_IC [MPa √m] (Zhang 2002, Int J Rock Mech Min Sci 39)


def rock(ucs, mi, mr, density):
    """{young, poisson, tensile_strength, fracture_energy, density,
    compressive_strength} [SI] of an intact rock of uniaxial compressive
    strength ucs [Pa]: E_i = MR σ_ci (Hoek & Diederichs 2006, eq. 3); the
    uniaxial tensile strength of the Hoek–Brown criterion for intact rock
    (s = 1, a = ½), σ_t = σ_ci (√(m_i² + 4) − m_i)/2 (Hoek & Brown 1997,
    Int J Rock Mech Min Sci 34, with the sign of a strength); K_IC =
    σ_t/6.88 (Zhang 2002) and G_f = K_IC² (1 − ν²)/E (Irwin, plane strain);
    ν = 0.25 (taken)."""
    ft = ucs * (math.sqrt(mi * mi + 4.0) - mi) / 2.0
    young = mr * ucs
    kic = ft / ZHANG_RATIO                     # Pa √m (the ratio is the same in MPa and MPa √m)
    gf = kic * kic * (1.0 - ROCK_POISSON ** 2) / young
    return {"young": young, "poisson": ROCK_POISSON, "tensile_strength": ft,
            "fracture_energy": gf, "density": density, "compressive_strength": ucs}


#: masonry units (bricks) and mortar (issue 31): each constant's source beside it;
#: "read" marks a source whose text was read, "taken" a typical value of no source
FB_RANGE = (3.0, 170.0)    # MPa: hand-made Indian bricks from 30 kg/cm² (about 3 MPa) to
                           # 170 N/mm², the top of clay bricks' typical 20-170 N/mm² (two
                           # building-construction web pages, read)
FM_RANGE = (0.5, 30.0)     # MPa: lime mortars to the strongest cement mortars (taken)
BRICK_MODULUS_RATIO = 300.0   # E_b = 300 f_b: Kaushik, Rai & Jain 2007 (J. Mater. Civ. Eng.
                              # 19(9), 728; abstract read, the factor as the brief
                              # quotes it); Vermeltfoort's clay bricks (British Masonry
                              # Society paper, abstract read): about 400 f_b
MORTAR_MODULUS_RATIO = 200.0  # E_m = 200 f_m: Kaushik, Rai & Jain 2007, as above
BRICK_POISSON = 0.15       # taken
MORTAR_POISSON = 0.2       # taken
BRICK_DENSITY = 1800.0     # kg/m³, a solid fired-clay brick (taken)
MORTAR_DENSITY = 2000.0    # kg/m³, a cement-sand mortar (taken)
BRICK_TENSION_RATIO = 0.1  # f_tb = 0.1 f_b, the top of the 0.05-0.1 f_b the issue quotes (taken)
BRICK_DUCTILITY = 0.025e-3  # m, G_f = 0.025 mm × f_tb: 50 J/m² at f_b = 20 MPa, as measured on
                            # clay bricks, 47.4 and 58.2 J/m² (Mohammed, Hughes & Danraka,
                            # IJMER, abstract read); the ratio itself is taken
JOINT_TENSION_RATIO = 0.05  # bond f_t = 0.05 f_m (taken: the bond is no fixed share of the
                            # mortar's strength: Fried & Law, British Masonry Society
                            # paper, abstract read)
JOINT_COHESION_RATIO = 1.4  # c = 1.4 f_t, attributed to Lourenço's recommendations (not read:
                            # taken); the envelope's slope at σ = 0 is then c/(2 f_t) = 0.7
JOINT_DUCTILITY_I = 0.018e-3 / 0.2  # m, G_f^I/f_t = 0.09 mm: the Lourenço-Rots model's example in
                                    # OOFEM's manual (f_t 0.2 MPa, G_f^I 0.018 N/mm; read)
JOINT_DUCTILITY_II = 0.05e-3 / 0.8  # m, G_f^II/c = 0.0625 mm: the same example's (c 0.8 MPa,
                                    # G_f^II 0.05 N/mm; read)
JOINT_FRICTION = 0.75      # the residual tan φ_r of the same example (tan φ_0 1.0; read)


def brick(fb, mr=BRICK_MODULUS_RATIO, ft=None):
    """{young, poisson, tensile_strength, fracture_energy, density,
    compressive_strength} [SI] of a masonry unit of compressive strength fb
    [Pa]: E_b = MR f_b (MR 300: Kaushik, Rai & Jain 2007), ν = 0.15
    (taken), f_tb = 0.1 f_b (taken), G_f = 0.025 mm × f_tb (taken; 50 J/m²
    at f_b = 20 MPa, as measured on clay bricks), density 1800 kg/m³
    (taken).  ``ft`` [Pa]: a tensile strength given instead (G_f follows it)."""
    ft = BRICK_TENSION_RATIO * fb if ft is None else ft
    return {"young": mr * fb, "poisson": BRICK_POISSON, "tensile_strength": ft,
            "fracture_energy": BRICK_DUCTILITY * ft, "density": BRICK_DENSITY,
            "compressive_strength": fb}


def mortar(fm, mr=MORTAR_MODULUS_RATIO, ft=None, c=None):
    """{young, poisson, density, friction, tensile_strength,
    fracture_energy, shear_strength, shear_fracture_energy} [SI] of a
    mortar joint of mortar compressive strength fm [Pa]: E_m = MR f_m (MR
    200: Kaushik, Rai & Jain 2007), ν = 0.2 and 2000 kg/m³ (taken); the
    joint's bond f_t = 0.05 f_m (taken), G_f^I = 0.09 mm × f_t, cohesion c
    = 1.4 f_t (the shear strength of the mixed-mode law, taken), G_f^II =
    0.0625 mm × c and the broken joint's friction 0.75 (the Lourenço-Rots
    model's example values).  ``ft``, ``c`` [Pa]: values given instead
    (those derived from them follow)."""
    ft = JOINT_TENSION_RATIO * fm if ft is None else ft
    c = JOINT_COHESION_RATIO * ft if c is None else c
    return {"young": mr * fm, "poisson": MORTAR_POISSON, "density": MORTAR_DENSITY,
            "friction": JOINT_FRICTION, "tensile_strength": ft,
            "fracture_energy": JOINT_DUCTILITY_I * ft, "shear_strength": c,
            "shear_fracture_energy": JOINT_DUCTILITY_II * c}


_SOURCE = {"concrete": {"compressive_strength": "f_cm, through the shear strength",
                         "young": "eq. 5.1-21", "poisson": "§5.1.7.3",
                         "tensile_strength": "eq. 5.1-3", "fracture_energy": "eq. 5.1-9",
                         "density": "normal-weight concrete"},
           "rock": {"compressive_strength": "σ_ci, through the shear strength",
                    "young": "E_i = MR σ_ci, Hoek & Diederichs 2006", "poisson": "taken",
                    "tensile_strength": "Hoek-Brown, m_i", "fracture_energy":
                    "K_IC = σ_t/6.88 (Zhang 2002), G = K_IC² (1 - ν²)/E",
                    "density": "typical of the rock"},
           "brick": {"compressive_strength": "f_b, through the shear strength",
                     "young": "E = MR f_b, Kaushik et al. 2007", "poisson": "taken",
                     "tensile_strength": "0.1 f_b, taken",
                     "fracture_energy": "0.025 mm × f_t, taken", "density": "taken"},
           "mortar": {"young": "E = MR f_m, Kaushik et al. 2007", "poisson": "taken",
                      "density": "taken", "friction": "tan φ_r, Lourenço-Rots example",
                      "tensile_strength": "bond 0.05 f_m, taken",
                      "fracture_energy": "0.09 mm × f_t, Lourenço-Rots example",
                      "shear_strength": "cohesion 1.4 f_t, taken",
                      "shear_fracture_energy": "0.0625 mm × c, Lourenço-Rots example"}}
_DIMENSION = {"compressive_strength": "stress", "young": "stress", "tensile_strength": "stress",
              "fracture_energy": "energy/area", "density": "density",
              "shear_strength": "stress", "shear_fracture_energy": "energy/area"}
_SI_UNIT = {"compressive_strength": "Pa", "young": "Pa", "tensile_strength": "Pa",
            "fracture_energy": "J/m²", "shear_strength": "Pa", "shear_fracture_energy": "J/m²",
            "density": "kg/m³", "poisson": "", "friction": ""}
#: the keys each preset takes beside ``model`` (the others' are refused)
_OWN_KEYS = {"concrete": ("fc",), "rock": ("ucs", "rock", "mi", "modulus_ratio"),
             "brick": ("fb", "modulus_ratio"), "mortar": ("fm", "modulus_ratio")}


def expand_presets(data: dict, lines: dict, filename: str) -> list[str]:
    """Fill in the values of every material with a ``model`` (concrete,
    rock, brick, mortar) that the file does not give (in the file's units);
    returns one note per such material naming the values derived and their
    sources.  CaseError naming the key for a preset without its strength, a
    strength outside the relations' range, an unknown rock or another
    preset's key."""
    mats = data.get("materials")
    if not isinstance(mats, dict):
        return []
    units = data.get("units", "SI")
    factors = UNIT_FACTORS.get(units if isinstance(units, str) else "SI", {})
    notes = []
    for name, mat in mats.items():
        if not isinstance(mat, dict) or mat.get("model") is None:
            continue
        where = ("materials", name)

        def fail(key, message, where=where):
            path = where + ((key,) if key else ())
            return CaseError(filename, _nearest_line(lines, path), path, message)
        model = mat["model"]
        if model not in _OWN_KEYS:
            raise fail("model", f"unknown material model {model!r} ({', '.join(_OWN_KEYS)})")
        others = {k for keys in _OWN_KEYS.values() for k in keys} - set(_OWN_KEYS[model])
        for key in sorted(others):
            if key in mat:
                owners = " or ".join(f"model: {m}" for m, keys in _OWN_KEYS.items() if key in keys)
                raise fail(key, f"{key} belongs to {owners}, not model: {model} "
                                f"(which takes {', '.join(_OWN_KEYS[model])})")
        rupture = mat.get("rupture")
        if rupture is None:
            rupture = mat["rupture"] = {}
        values_of = {"concrete": _concrete_values, "rock": _rock_values,
                     "brick": _brick_values, "mortar": _mortar_values}[model]
        fc, values, label = values_of(mat, factors, fail)
        derived = []
        for key in ("density", "young", "poisson", "friction"):
            if key in values and key not in mat:
                mat[key] = values[key] / factors.get(_DIMENSION.get(key), 1.0)
                derived.append(key)
        if isinstance(rupture, dict) and "strain" not in rupture:
            mixed = rupture.get("law", "mixed_mode") == "mixed_mode"
            for key in ("tensile_strength", "fracture_energy"):
                if key not in rupture:
                    rupture[key] = values[key] / factors.get(_DIMENSION[key], 1.0)
                    derived.append(key)
            if fc is not None and "shear_strength" not in rupture \
                    and "compressive_strength" not in rupture and mixed \
                    and rupture.get("values", "material") == "material":
                # the specimen fails at f_c (compression_calibration.py)
                rupture["compressive_strength"] = fc
                derived.append("compressive_strength")
            for key in ("shear_strength", "shear_fracture_energy"):
                # a joint's cohesion and mode-II energy (mortar); not with
                # law tension, nor beside a given compressive strength
                if key in values and key not in rupture and mixed \
                        and "compressive_strength" not in rupture:
                    rupture[key] = values[key] / factors.get(_DIMENSION[key], 1.0)
                    derived.append(key)
        shown = ", ".join(f"{k} {_fmt(values[k], k)} ({_SOURCE[model][k]})" for k in derived)
        notes.append(f"materials.{name}: {label}: {shown or 'every value given'}")
    return notes


def _given(section, key, factor):
    """A number the file gives at ``section[key]``, in SI (None if absent or
    not a number: the schema then names it)."""
    v = section.get(key) if isinstance(section, dict) else None
    if isinstance(v, bool) or not isinstance(v, (int, float)):
        return None
    return v * factor


def _ratio(mat, key, low, fail, high=2000.0):
    """``mat[key]`` if given, checked to be a number in [low, high]."""
    v = mat.get(key)
    if v is not None and (isinstance(v, bool) or not isinstance(v, (int, float))
                          or not low <= v <= high):
        raise fail(key, f"{key} must be a number in [{low:g}, {high:g}], not {v!r}")
    return v


def _strength(mat, key, factors, fail, needs, lo, hi, what):
    """The preset's strength ``key`` in the file's units and in Pa, checked
    against [lo, hi] MPa."""
    value = mat.get(key)
    if value is None:
        raise fail(None, needs)
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        raise fail(key, f"{key} must be a number, not {value!r}")
    si = value * factors.get("stress", 1.0)
    if not lo * 1e6 <= si <= hi * 1e6:
        raise fail(key, f"{key} = {_show(value)} is {si / 1e6:.4g} MPa, outside the "
                        f"{lo:g}-{hi:g} MPa of {what}; {key} is in Pa (MPa in mm-N-s)")
    return value, si


def _concrete_values(mat, factors, fail):
    fc, fcm = _strength(mat, "fc", factors, fail,
                        "model: concrete needs fc, the mean cylinder compressive "
                        "strength f_cm [Pa; MPa in mm-N-s]", *FC_RANGE,
                        "the Model Code (grades C12-C120)")
    return fc, concrete(fcm), f"concrete of f_cm = {fcm / 1e6:.4g} MPa by the fib Model Code 2010"


def _rock_values(mat, factors, fail):
    ucs, sigma = _strength(mat, "ucs", factors, fail,
                           "model: rock needs ucs, the uniaxial compressive strength of the "
                           "intact rock σ_ci [Pa; MPa in mm-N-s]", *UCS_RANGE, "the relations used")
    kind = mat.get("rock")
    names = ", ".join(sorted(ROCKS))
    if kind is None and ("mi" not in mat or "modulus_ratio" not in mat):
        raise fail(None, f"model: rock needs rock (one of {names}) or both mi (the "
                         "Hoek-Brown m_i) and modulus_ratio (E/σ_ci)")
    if kind is not None and kind not in ROCKS:
        raise fail("rock", f"unknown rock {kind!r}; known: {names} (or give mi and "
                           "modulus_ratio instead)")
    mr, mi, density = ROCKS.get(kind, (None, None, 2650.0))
    for key, low in (("mi", 1.0), ("modulus_ratio", 50.0)):
        _ratio(mat, key, low, fail)
    mi = mat.get("mi", mi)
    mr = mat.get("modulus_ratio", mr)
    label = (f"{kind or 'rock'} of σ_ci = {sigma / 1e6:.4g} MPa (m_i {_show(mi)}, "
             f"E/σ_ci {_show(mr)})")
    return ucs, rock(sigma, mi, mr, density), label


def _brick_values(mat, factors, fail):
    fb, sigma = _strength(mat, "fb", factors, fail,
                          "model: brick needs fb, the masonry unit's compressive strength "
                          "f_b [Pa; MPa in mm-N-s]", *FB_RANGE, "fired-clay bricks")
    mr = _ratio(mat, "modulus_ratio", 50.0, fail)
    mr = BRICK_MODULUS_RATIO if mr is None else mr
    ft = _given(mat.get("rupture"), "tensile_strength", factors.get("stress", 1.0))
    return fb, brick(sigma, mr, ft), f"brick of f_b = {sigma / 1e6:.4g} MPa (E/f_b {_show(mr)})"


def _mortar_values(mat, factors, fail):
    _, sigma = _strength(mat, "fm", factors, fail,
                         "model: mortar needs fm, the mortar's compressive strength f_m "
                         "[Pa; MPa in mm-N-s]", *FM_RANGE, "masonry mortars")
    mr = _ratio(mat, "modulus_ratio", 50.0, fail)
    mr = MORTAR_MODULUS_RATIO if mr is None else mr
    stress = factors.get("stress", 1.0)
    rupture = mat.get("rupture")
    values = mortar(sigma, mr, _given(rupture, "tensile_strength", stress),
                    _given(rupture, "shear_strength", stress))
    # no compressive strength: a joint's shear strength is its cohesion
    return None, values, f"mortar joint of f_m = {sigma / 1e6:.4g} MPa (E/f_m {_show(mr)})"


def _fmt(v, key):
    unit = _SI_UNIT[key]
    if unit == "Pa":
        return f"{v / 1e9:.4g} GPa" if v >= 1e9 else f"{v / 1e6:.4g} MPa"
    return f"{v:.4g} {unit}".strip()
