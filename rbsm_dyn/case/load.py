"""Reading a case: :func:`load_case` (a file) and :func:`load_case_text`
(text or bytes): parse, validate the schema, check, convert to SI, fill
the defaults that depend on other values, warn of unit mix-ups."""
from __future__ import annotations

import math
import re
from pathlib import Path

from pydantic import ValidationError

from .check import _check
from .errors import CaseError, _nearest_line, _show
from .output import _PROBE_TAG, _RELATIVE_TAG
from .parse import _parse
from .parts import scene_parts
from .presets import expand_presets
from .plane import lift_plane
from .top import Case
from .units import UNIT_FACTORS, _to_si

_TAGS = {"FaceSupport", "GroupFix", "GroupVelocity", "GroupDisplacement",
         "Gravity", "GroupLoad", "SurfaceLoad", _PROBE_TAG, _RELATIVE_TAG}


# ------------------------------------------------------------- validation ---

def _message(err: dict) -> str:
    """A pydantic error dict -> a message in the case file's terms."""
    kind, ctx, got = err["type"], err.get("ctx") or {}, _show(err.get("input"))
    bound = {"greater_than": ">", "greater_than_equal": ">=",
             "less_than": "<", "less_than_equal": "<="}
    if kind in bound:
        limit = next(iter(ctx.values()))
        return f"must be {bound[kind]} {limit:g} (got {got})"
    if kind == "literal_error":
        options = re.findall(r"'([^']*)'", ctx.get("expected", ""))
        return f"must be one of {', '.join(options)} (got {got})"
    simple = {
        "missing": "required key missing",
        "float_type": f"expected a number (got {got})",
        "int_type": f"expected an integer (got {got})",
        "string_type": f"expected a string (got {got})",
        "bool_type": f"expected true or false (got {got})",
        "list_type": f"expected a list (got {got})",
        "dict_type": f"expected a mapping of keys (got {got})",
        "model_type": f"expected a mapping of keys (got {got})",
        "model_attributes_type": f"expected a mapping of keys (got {got})",
        "finite_number": f"must be a finite number (got {got})",
        "string_too_short": "must not be empty",
        "too_short": f"expected at least {ctx.get('min_length')} item(s) "
                     f"(got {ctx.get('actual_length')})",
        "too_long": f"expected at most {ctx.get('max_length')} item(s) "
                    f"(got {ctx.get('actual_length')})",
    }
    # "case", "form" and "unknown_key" errors carry the user's message already
    return simple.get(kind, err["msg"])


def _schema_errors(ex: ValidationError, file: str, lines: dict) -> list[CaseError]:
    out = []
    for err in ex.errors():
        loc = [p for p in err["loc"] if not (isinstance(p, str) and p in _TAGS)]
        message = _message(err)
        if loc and loc[-1] == "[key]":      # a bad mapping key: loc[-2] is it
            loc = loc[:-1]
            message = f"keys must be strings (got {_show(loc[-1])})"
        if err["type"] == "unknown_key":
            loc.append(err["ctx"]["key"])
        out.append(CaseError(file, _nearest_line(lines, loc), tuple(loc), message))
    return out


# -------------------------------------------------------------- public API ---

#: Largest case file read [bytes]: a case is a few KB (the shipped ones 1-5 KB);
#: the YAML parser takes ~25 s and ~300 MB per MiB of short values, so a
#: larger file is refused by its size before it is parsed (issue 14: a 40 MB
#: file took 438 s and 9.4 GB before it was refused).
MAX_CASE_BYTES = 1 << 20


def _too_large(file: str, size: int) -> CaseError:
    return CaseError(file, None, (), f"the file is {size} bytes ({size / 2**20:.1f} MiB), "
                     f"more than the {MAX_CASE_BYTES} bytes (1 MiB) a case file may have "
                     "(a case is a few KB: large data belong in files it names, such as a "
                     "geometry's file:)")


def load_case_text(text: str | bytes, filename: str = "<string>") -> Case:
    """Validate the YAML ``text`` of a case; ``filename`` is used in errors."""
    n = len(text if isinstance(text, bytes) else text.encode("utf-8", "surrogatepass"))
    if n > MAX_CASE_BYTES:
        raise _too_large(filename, n)
    if isinstance(text, bytes):
        try:
            text = text.decode("utf-8-sig")
        except UnicodeDecodeError as ex:
            line = text[:ex.start].count(b"\n") + 1
            raise CaseError(filename, line, (),
                            f"not UTF-8 text (byte 0x{text[ex.start]:02x})") from None
    data, lines = _parse(text, filename)
    notes = []
    if isinstance(data, dict):
        lift_plane(data, lines, filename)     # a plane case's 2D input, as its slab's
        notes = expand_presets(data, lines, filename)   # materials by engineering values
    try:
        case = Case.model_validate(data)
    except ValidationError as ex:
        errors = _schema_errors(ex, filename, lines)
        first = min(errors, key=lambda e: e.line if e.line is not None else 1 << 30)
        first.others = errors
        raise first from None
    case._source_text = text
    case._source_file = filename
    case._lines = lines
    case._input_units = case.units
    case._material_notes = notes
    _check(case)

    _to_si(case, UNIT_FACTORS[case.units])
    if UNIT_FACTORS[case.units]:
        for part in scene_parts(case):
            part.geometry._solid = None      # checked in the file's units: rebuilt in SI
    case.units = "SI"
    if case.output.file is None:      # in the working directory, whatever the name holds
        safe = "".join("_" if c in "/\\" or not c.isprintable() else c for c in case.name)
        case.output.file = f"{safe}.h5"
    if case.solver.mode == "dynamic" and case.output.interval is None:
        case.output.interval = case.solver.end_time / 100
    case._warnings.extend(_unit_traps(case))
    case._warnings.extend(_planar_default(case))
    return case


def _planar_default(case: Case) -> list[str]:
    """A note for cuts on Voronoi cells that take the default `planar: true`
    (a plane of cell faces, since 2026-11-27): a case written before meshed
    the cells of its seed as they were, which `planar: false` still does."""
    implicit = [i for i, cut in enumerate(case.cuts) if "planar" not in cut.model_fields_set]
    if not implicit or not any(p.mesh.kind == "voronoi" for p in scene_parts(case)):
        return []
    more = f" (and cuts {', '.join(map(str, implicit[1:]))})" if len(implicit) > 1 else ""
    return [str(case.error(("cuts", implicit[0]),
                           f"a cut on Voronoi cells is a plane of cell faces{more}, the default "
                           "since 2026-11-27 (seeds mirrored across it, docs/case_file.md "
                           "cuts); a case written before meshed its seed's cells as they were: "
                           "give `planar: false` for that, `planar: true` to silence this "
                           "note"))]


#: the bar wave speed sqrt(E/ρ) of any real solid lies in this range [m/s]
#: (rubber ~ 30, foams ~ 100, steel 5 100, diamond 17 500); outside it a
#: value is in the wrong units (a warning)
WAVE_SPEED_RANGE = (10.0, 20_000.0)


def _unit_traps(case: Case) -> list[str]:
    """Warnings for materials whose bar wave speed sqrt(E/ρ) (SI) lies
    outside WAVE_SPEED_RANGE: the usual cause is a value in the other
    system of units (a density of 7.85e-9 in SI is steel's in t/mm³)."""
    lo, hi = WAVE_SPEED_RANGE
    out = []
    for name, mat in case.materials.items():
        c = math.sqrt(mat.young / mat.density)
        if lo <= c <= hi:
            continue
        given = case.input_units
        f = UNIT_FACTORS[given]
        rho, e = mat.density / f.get("density", 1.0), mat.young / f.get("stress", 1.0)
        if given == "SI":
            hint = ("in SI a density is in kg/m³ (steel 7850) and young in Pa (steel 2.1e11)"
                    + (f"; density {_show(rho)} looks like a value in t/mm³ (units: mm-N-s)"
                       if rho < 1.0 else "")
                    + (f"; young {_show(e)} looks like a value in MPa (units: mm-N-s)"
                       if e < 1e7 else ""))
        else:
            hint = ("in mm-N-s a density is in t/mm³ (steel 7.85e-9) and young in MPa "
                    "(steel 2.1e5)"
                    + (f"; density {_show(rho)} looks like a value in kg/m³ (SI)"
                       if rho > 1e-3 else "")
                    + (f"; young {_show(e)} looks like a value in Pa (SI)" if e > 1e8 else ""))
        out.append(str(case.error(("materials", name),
                                  f"bar wave speed sqrt(E/ρ) = {c:.3g} m/s lies outside "
                                  f"{lo:g}-{hi:g} m/s: a mix-up of units? ({hint}; a filler "
                                  "made soft or stiff on purpose, such as a notch's, is "
                                  "fine)")))
    return out


def load_case(path: str | Path) -> Case:
    """Read and validate a case file.  Raises CaseError (never a traceback
    the user must read): unreadable file, bad YAML, bad schema, bad values."""
    path = Path(path)
    try:
        size = path.stat().st_size
        if size > MAX_CASE_BYTES:      # by its size, before reading or parsing it
            raise _too_large(str(path), size)
        with open(path, "rb") as f:    # (a file that grows meanwhile: read no more)
            raw = f.read(MAX_CASE_BYTES + 1)
    except OSError as ex:
        raise CaseError(str(path), None, (), f"cannot read the file "
                        f"({ex.strerror or ex})") from None
    return load_case_text(raw, str(path))
