"""Materials given by their engineering values (issue 31): ``materials.NAME:
{model: concrete, fc: 48.0e6}`` gets its density, Young's modulus,
Poisson's ratio, tensile strength and fracture energy from the fib Model
Code 2010 (fib Bulletin 65, Vol. 1, §5.1), each overridable by giving it.

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


_SOURCE = {"compressive_strength": "f_cm, through the shear strength",
           "young": "eq. 5.1-21", "poisson": "§5.1.7.3", "tensile_strength": "eq. 5.1-3",
           "fracture_energy": "eq. 5.1-9", "density": "normal-weight concrete"}
_DIMENSION = {"compressive_strength": "stress", "young": "stress", "tensile_strength": "stress",
              "fracture_energy": "energy/area", "density": "density"}
_SI_UNIT = {"compressive_strength": "Pa", "young": "Pa", "tensile_strength": "Pa",
            "fracture_energy": "J/m²",
            "density": "kg/m³", "poisson": ""}


def expand_presets(data: dict, lines: dict, filename: str) -> list[str]:
    """Fill in the values of every material with ``model: concrete`` that
    the file does not give (in the file's units); returns one note per such
    material naming the values derived and their clauses.  CaseError for a
    preset without ``fc`` or an ``fc`` outside the Model Code's range."""
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
        if mat["model"] != "concrete":
            raise fail("model", f"unknown material model {mat['model']!r} (concrete)")
        fc = mat.get("fc")
        if fc is None:
            raise fail(None, "model: concrete needs fc, the mean cylinder compressive "
                             "strength f_cm [Pa; MPa in mm-N-s]")
        if isinstance(fc, bool) or not isinstance(fc, (int, float)):
            raise fail("fc", f"fc must be a number, not {fc!r}")
        fcm = fc * factors.get("stress", 1.0)
        lo, hi = FC_RANGE
        if not lo * 1e6 <= fcm <= hi * 1e6:
            raise fail("fc", f"fc = {_show(fc)} is f_cm = {fcm / 1e6:.4g} MPa, outside the "
                             f"Model Code's {lo:g}-{hi:g} MPa (grades C12-C120); "
                             "fc is in Pa (MPa in mm-N-s)")
        values = concrete(fcm)
        rupture = mat.get("rupture")
        derived = []
        for key in ("density", "young", "poisson"):
            if key not in mat:
                mat[key] = values[key] / factors.get(_DIMENSION.get(key), 1.0)
                derived.append(key)
        if rupture is None:
            rupture = mat["rupture"] = {}
        if isinstance(rupture, dict) and "strain" not in rupture:
            for key in ("tensile_strength", "fracture_energy"):
                if key not in rupture:
                    rupture[key] = values[key] / factors.get(_DIMENSION[key], 1.0)
                    derived.append(key)
            if "shear_strength" not in rupture and "compressive_strength" not in rupture \
                    and rupture.get("law", "mixed_mode") == "mixed_mode" \
                    and rupture.get("values", "material") == "material":
                # the specimen fails at f_cm (compression_calibration.py)
                rupture["compressive_strength"] = fc
                derived.append("compressive_strength")
        shown = ", ".join(f"{k} {_fmt(values[k], k)} ({_SOURCE[k]})" for k in derived)
        notes.append(f"materials.{name}: concrete of f_cm = {fcm / 1e6:.4g} MPa by the fib "
                     f"Model Code 2010: {shown or 'every value given'}")
    return notes


def _fmt(v, key):
    unit = _SI_UNIT[key]
    if unit == "Pa":
        return f"{v / 1e9:.4g} GPa" if v >= 1e9 else f"{v / 1e6:.4g} MPa"
    return f"{v:.4g} {unit}".strip()
