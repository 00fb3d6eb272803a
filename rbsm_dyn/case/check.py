"""Rules across fields of a validated case (names that must exist, box
bounds, mesh sizes, keys of the solver's mode, ...): :func:`_check`."""
from __future__ import annotations

import math
from typing import Any

from pydantic import BaseModel

from .boundary import FaceSupport, GroupFix, GroupDisplacement, GroupVelocity, Gravity, SurfaceLoad
from .errors import KeyPath, _show
from .output import Probe, RelativeProbe
from .parts import (ScenePart, _box_size, part_solid, scene_parts, surface_indices,
                    surface_part)
from .scene import GEOMETRY_KINDS
from .solver import DYNAMIC_KEYS, MODAL_KEYS, STATIC_KEYS, continuum_yield, default_static_method
from .top import Case

MAX_CELLS = 5e6          # a mesh with more cells than this is refused
NUMBER_LIMIT = 1e30      # every number is 0 or of magnitude in [1/limit, limit]
FAR_CELLS_VORONOI = 1e4  # the domain lies within this many cell sizes of the origin
FAR_CELLS_BLOCKS = 1e8   # (round-off; see _check)


def _numbers(node: Any, path: KeyPath):
    """(key path, value) of every number in a validated model, YAML key names."""
    if isinstance(node, BaseModel):
        for name, f in type(node).model_fields.items():
            yield from _numbers(getattr(node, name), path + (f.alias or name,))
    elif isinstance(node, list):
        for i, v in enumerate(node):
            yield from _numbers(v, path + (i,))
    elif isinstance(node, dict):
        for k, v in node.items():
            yield from _numbers(v, path + (k,))
    elif isinstance(node, (int, float)) and not isinstance(node, bool):
        yield path, node


def _check_part(case: Case, part: ScenePart):
    """Geometry and mesh of one part: (lower corner, upper corner, volume)."""
    err = case.error
    g, m, gp, mp = part.geometry, part.mesh, part.path, part.mesh_path
    kind = g.kind()
    if kind is None:
        given = [k for k in ("box",) + GEOMETRY_KINDS if getattr(g, k) is not None]
        raise err(gp, "give one geometry: box or one of " + ", ".join(GEOMETRY_KINDS)
                  + (f" (got {', '.join(given)})" if given else ""))
    if kind == "box":
        for axis, name in enumerate("xyz"):
            lo, hi = g.box[0][axis], g.box[1][axis]
            if not hi > lo:
                raise err(gp + ("box",), f"max must be > min along {name} "
                                         f"(got {_show(lo)} .. {_show(hi)})")
        for key in ("name", "scale", "surfaces"):
            if g.given(key):
                raise err(gp + (key,), "not used with box (the box's surfaces are "
                          "xmin ... zmax)")
    if kind == "box" and m.kind != "rigid":
        (x0, y0, z0), (x1, y1, z1) = g.box
        volume = (x1 - x0) * (y1 - y0) * (z1 - z0)
    else:
        solid = part_solid(case, part)
        (x0, y0, z0), (x1, y1, z1) = solid.bounds
        volume = solid.volume

    def only(keys, why):
        for key in keys:
            if m.given(key):
                raise err(mp + (key,), f"not used {why}")

    if m.kind == "voronoi":
        if m.size is None:
            raise err(mp + ("size",), "required key missing (kind voronoi)")
        only(["divisions"], "with kind voronoi")
        # a plane model's cells are prisms through its thickness
        cells = volume / (m.size ** 3 if case.plane is None
                          else m.size ** 2 * case.plane.thickness)
        if cells > MAX_CELLS:
            raise err(mp + ("size",), f"too small: {cells:.3g} cells "
                      f"(at most {MAX_CELLS:g}; check the units)")
    elif m.kind == "blocks":
        if m.divisions is None:
            raise err(mp + ("divisions",), "required key missing (kind blocks)")
        only(["size", "seed", "min_spacing"], "with kind blocks")
        cells = math.prod(m.divisions)
        if cells > MAX_CELLS:
            raise err(mp + ("divisions",), f"too many cells: {cells} "
                      f"(at most {MAX_CELLS:g})")
    else:
        only(["divisions", "seed", "min_spacing", "spring_points"], "with kind rigid "
             "(one body)")
    # Round-off: coordinates far from the origin leave too few digits for
    # the cells (qhull fails beyond ~1e5 Voronoi cell sizes; blocks last longer).
    if m.kind != "rigid":
        if m.kind == "voronoi":
            h, reach = m.size, FAR_CELLS_VORONOI
        else:
            h, reach = _box_size(((x0, y0, z0), (x1, y1, z1)), m.divisions), FAR_CELLS_BLOCKS
        far = max(abs(c) for c in (x0, y0, z0, x1, y1, z1))
        if far > reach * h:
            raise err(gp + (kind,), f"too far from the origin for cells of {h:.3g}: "
                      f"{far:.3g} away, at most {reach:g} cell sizes (the mesh would lose "
                      "precision); move the domain nearer to the origin")
    return (x0, y0, z0), (x1, y1, z1), volume


def _mesh_kinds(case, material):
    """The mesh kinds of the parts of `material` (the one-part shorthand's)."""
    if case.parts:
        return {p.mesh.kind for p in case.parts.values() if p.material == material}
    return {case.mesh.kind} if case.mesh is not None else set()


def _check_viscoelastic(case: Case, path: KeyPath, mat) -> None:
    """The keys of a material's viscoelastic law and what it combines with."""
    err = case.error
    v, vp = mat.viscoelastic, path + ("viscoelastic",)
    need = {"kelvin": ("tau",), "maxwell": ("tau",), "standard": ("tau", "relaxed"),
            "prony": ("terms",)}[v.kind]
    for key in need:
        if getattr(v, key) is None:
            raise err(vp + (key,), f"required key missing (kind {v.kind})")
    for key in ("tau", "relaxed", "terms"):
        if key not in need and v.given(key):
            raise err(vp + (key,), f"not used with kind {v.kind}")
    if v.kind == "standard" and not v.relaxed < mat.young:
        raise err(vp + ("relaxed",), f"the relaxed modulus must be below young = "
                  f"{_show(mat.young)} Pa, the instantaneous one (got {_show(v.relaxed)})")
    if v.kind == "prony":
        if not v.terms:
            raise err(vp + ("terms",), "give at least one term [E_i, tau_i]")
        for i, (e, tau) in enumerate(v.terms):
            if not (e > 0 and tau > 0):
                raise err(vp + ("terms", i), f"E_i [Pa] and tau_i [s] must be > 0 "
                          f"(got {_show(e)}, {_show(tau)})")
        total = sum(e for e, _ in v.terms)
        if total > mat.young:
            raise err(vp + ("terms",), f"the terms' moduli sum to {_show(total)} Pa, above "
                      f"young = {_show(mat.young)} Pa (the instantaneous modulus; the "
                      "long-term one, young − Σ E_i, must not be negative)")
    if v.kind != "kelvin":
        for key, given in (("yield", mat.yield_), ("rupture", mat.rupture)):
            if given is not None:
                raise err(vp + ("kind",), f"kind {v.kind} does not combine with {key}: the "
                          f"springs judge {key} on the instantaneous force E δ, not on the "
                          "relaxed force of the Maxwell branches (kind kelvin, a dashpot "
                          "beside the spring, does combine)")


def _check(case: Case) -> None:
    """Rules across fields.  Raises the first CaseError found."""
    err = case.error

    # Numbers far outside any physical range are unit mistakes, and their
    # products (k/m, end_time/dt, h^5 rho) would overflow or underflow.
    for path, x in _numbers(case, ()):
        if path == ("mesh", "seed") or (path[:1] == ("parts",) and path[-2:] == ("mesh", "seed")):
            continue
        if x != 0 and not (1 / NUMBER_LIMIT <= abs(x) <= NUMBER_LIMIT):
            raise err(path, f"must be 0 or of magnitude between {1 / NUMBER_LIMIT:g} and "
                            f"{NUMBER_LIMIT:g} (got {_show(x)}; check the units)")
    groups = set(case.groups) | {"all"} | set(case.parts)

    def check_box(box, path, strict):
        for axis, name in enumerate("xyz"):
            lo, hi = box[0][axis], box[1][axis]
            if hi < lo or (strict and hi == lo):
                rel = ">" if strict else ">="
                raise err(path, f"max must be {rel} min along {name} "
                                f"(got {_show(lo)} .. {_show(hi)})")

    def check_group(name, path):
        if name not in groups:
            raise err(path, f"unknown group {name!r} (defined: "
                            f"{', '.join(sorted(groups))})")

    def check_history(hist, path):
        if hist is None:
            return
        for i in range(1, len(hist)):
            if hist[i][0] <= hist[i - 1][0]:
                raise err(path + (i,), "history times must increase "
                          f"(got {_show(hist[i][0])} after {_show(hist[i - 1][0])})")

    def check_only(obj, keys, path, why):
        for key in keys:
            if obj.given(key):
                raise err(path + (key,), f"not used {why}")

    if case.parts:
        for key in ("domain", "mesh"):
            if getattr(case, key) is not None:
                raise err((key,), "give parts, or domain + mesh (the one-part shorthand), "
                                  "not both")
    else:
        for key in ("domain", "mesh"):
            if getattr(case, key) is None:
                raise err((key,), "required key missing (or give parts: a scene of several)")
        if case.mesh.kind == "rigid":
            raise err(("mesh", "kind"), "rigid is a part's mesh kind (parts: ...): the "
                      "domain is cut into cells, voronoi or blocks")
        if case.interfaces:
            raise err(("interfaces",), "interfaces join parts: give parts")
    lows, highs = [], []
    for part in scene_parts(case):
        x0y0z0, x1y1z1, _ = _check_part(case, part)
        lows.append(x0y0z0)
        highs.append(x1y1z1)
    x0, y0, z0 = (min(c) for c in zip(*lows))
    x1, y1, z1 = (max(c) for c in zip(*highs))
    kind = scene_parts(case)[0].geometry.kind() if not case.parts else "parts"
    for name, part in case.parts.items():
        path = ("parts", name)
        if name == "all" or "." in name or not name:
            raise err(path, f"a part name must not be empty, 'all' or contain a dot (got "
                            f"{name!r}: surfaces are named <part>.<surface>)")
        if name in case.groups:
            raise err(("groups", name), f"the name of part {name!r} (each part is a group "
                      "of its bodies): rename the group")
        if part.material not in case.materials:
            raise err(path + ("material",), f"unknown material {part.material!r} "
                      f"(defined: {', '.join(case.materials)})")
    pairs = set()
    for i, it in enumerate(case.interfaces):
        path = ("interfaces", i)
        for k, pn in enumerate(it.parts):
            if pn not in case.parts:
                raise err(path + ("parts", k), f"unknown part {pn!r} "
                          f"(parts: {', '.join(case.parts)})")
        if it.parts[0] == it.parts[1]:
            raise err(path + ("parts", 1), "the same part twice (an interface joins two parts)")
        pair = frozenset(it.parts)
        if pair in pairs:
            raise err(path + ("parts",), f"parts {it.parts[0]} and {it.parts[1]} are joined "
                      "twice")
        pairs.add(pair)
        if all(case.parts[pn].mesh.kind == "rigid" for pn in it.parts):
            raise err(path + ("parts",), "both parts are rigid: springs between two rigid "
                      "bodies would be infinitely stiff (make one of them voronoi or blocks)")
        if it.law == "bonded":
            check_only(it, ["friction"], path, "with law bonded (the friction of a broken "
                       "bonded face is its material's)")
            if it.material is not None and it.material not in case.materials:
                raise err(path + ("material",), f"unknown material {it.material!r} "
                          f"(defined: {', '.join(case.materials)})")
            if it.thickness is not None and it.material is None:
                raise err(path + ("thickness",), "is the thickness of a layer of the "
                          "interface's material: give material too")
        else:
            check_only(it, ["material", "thickness"], path, "with law contact (give friction)")

    if not case.materials:
        raise err(("materials",), "at least one material is required")
    for name, mat in case.materials.items():
        path = ("materials", name)
        y = mat.yield_
        if y is not None:
            yp = path + ("yield",)
            if y.criterion == "mohr_coulomb":
                for key in ("cohesion", "friction_angle"):
                    if getattr(y, key) is None:
                        raise err(yp + (key,), "required key missing "
                                  "(criterion mohr_coulomb needs cohesion and friction_angle)")
                check_only(y, ["stress"], yp, "with criterion mohr_coulomb")
            else:
                if y.stress is None:
                    raise err(yp + ("stress",), "required key missing "
                              f"(criterion {y.criterion})")
                check_only(y, ["cohesion", "friction_angle"], yp,
                           f"with criterion {y.criterion} (only mohr_coulomb)")
            if y.model == "continuum" and y.criterion not in ("tresca", "von_mises"):
                raise err(yp + ("model",), f"continuum yield is for tresca and von_mises "
                          f"materials, not {y.criterion} (an interface criterion)")
        if mat.viscoelastic is not None:
            _check_viscoelastic(case, path, mat)
        r = mat.rupture
        if r is not None:
            rp = path + ("rupture",)
            energy = r.fracture_energy is not None or r.tensile_strength is not None
            if r.strain is not None and energy:
                raise err(rp, "give either strain or (fracture_energy and "
                              "tensile_strength), not both")
            if r.strain is None:
                for key in ("fracture_energy", "tensile_strength"):
                    if getattr(r, key) is None:
                        raise err(rp + (key,), "required key missing (rupture "
                                  "needs strain or fracture_energy and tensile_strength)")
            else:
                check_only(r, ["law", "shear_strength", "compressive_strength",
                               "shear_fracture_energy", "values", "rate", "cap"],
                           rp,
                           "with rupture strain (only with fracture_energy and "
                           "tensile_strength)")
            if r.law == "tension":
                check_only(r, ["shear_strength", "compressive_strength",
                               "shear_fracture_energy", "rate"], rp,
                           "with law tension (only mixed_mode)")
            if r.shear_strength is not None and r.compressive_strength is not None:
                raise err(rp + ("compressive_strength",),
                          "give shear_strength or compressive_strength, not both (the "
                          "compressive strength sets the shear strength: docs/calibration.md, "
                          "\"Compression\")")
            if r.compressive_strength is not None and r.values == "spring":
                raise err(rp + ("compressive_strength",),
                          "compressive_strength is a specimen's strength: it needs values: "
                          "material (the default), not spring")

    for name, g in case.groups.items():
        path = ("groups", name)
        if name == "all":
            raise err(path, "the group name 'all' is reserved (it selects every body)")
        check_box(g.box, path + ("box",), strict=False)
        if g.material is not None and g.material not in case.materials:
            raise err(path + ("material",), f"unknown material {g.material!r} "
                      f"(defined: {', '.join(case.materials)})")

    def check_surface(name, path):
        try:
            surface_indices(case, name)
        except ValueError as exc:       # unknown or ambiguous name
            raise err(path, str(exc)) from None

    for i, b in enumerate(case.boundary):
        path = ("boundary", i)
        if isinstance(b, (GroupVelocity, GroupDisplacement)):
            if (b.group is None) == (b.surface is None):
                raise err(path, "give group (bodies) or surface (the cells with a face on a "
                          "named surface), not both")
            if b.surface is not None:
                check_surface(b.surface, path + ("surface",))
        if isinstance(b, FaceSupport):
            if (b.face is None) == (b.surface is None):
                raise err(path, "give face (a box side) or surface (a named surface), not both")
            if b.face is not None and kind != "box":
                raise err(path + ("face",), "face selects a side of a box domain; this "
                          + (f"domain is a {kind}: use surface: <name>" if kind != "parts"
                             else "case has parts: use surface: <part>.<surface>"))
            if b.surface is not None:
                check_surface(b.surface, path + ("surface",))
                if surface_part(case, b.surface).mesh.kind == "rigid":
                    raise err(path + ("surface",), f"{b.surface} is a surface of a rigid part: "
                              f"fix the part as a group ({{group: "
                              f"{surface_part(case, b.surface).name}, fix: all}})")
        if not isinstance(b, FaceSupport) and b.group is not None:
            check_group(b.group, path + ("group",))
        if isinstance(b, (FaceSupport, GroupFix)):
            if not b.fix:
                raise err(path + ("fix",), "must not be empty")
            for j, c in enumerate(b.fix):
                if c in b.fix[:j]:
                    raise err(path + ("fix", j), f"component {c} listed twice")
        else:
            key = "velocity" if isinstance(b, GroupVelocity) else "displacement"
            if all(v is None for v in getattr(b, key)):
                raise err(path + (key,), "all components are null (nothing prescribed)")
            check_history(b.history, path + ("history",))

    _check_contradictions(case, err)

    for i, item in enumerate(case.initial):
        path = ("initial", i)
        if not (item.given("velocity") or item.given("angular_velocity") or item.rigid):
            raise err(path, "required key missing: velocity, angular_velocity or rigid")
        if item.rigid is not None and item.given("angular_velocity"):
            raise err(path + ("angular_velocity",), "give the angular velocity in rigid (the "
                      "group turns as one body) or here (each cell spins about its own "
                      "centroid), not both")
        check_group(item.group, path + ("group",))

    if case.contact is not None:
        _check_contact(case, err)

    gravity = 0
    for i, load in enumerate(case.loads):
        path = ("loads", i)
        if isinstance(load, Gravity):
            gravity += 1
            if gravity > 1:
                raise err(path, "gravity given twice")
            continue
        if isinstance(load, SurfaceLoad):
            check_surface(load.surface, path + ("surface",))
            if (load.pressure is None) == (load.traction is None):
                raise err(path, "give pressure or traction, not both" if load.pressure
                          is not None else "required key missing: pressure or traction")
            if load.follower is True and case.solver.mode == "static":
                raise err(path + ("follower",), "a follower load needs solver.mode dynamic "
                          "(or linear, where it keeps its reference direction); static "
                          "mode takes dead loads only")
            check_history(load.history, path + ("history",))
            continue
        check_group(load.group, path + ("group",))
        if not (load.given("force") or load.given("moment")):
            raise err(path, "required key missing: force or moment")
        check_history(load.history, path + ("history",))

    for i, cut in enumerate(case.cuts):
        path = ("cuts", i)
        if not any(cut.normal):
            raise err(path + ("normal",), "must not be the zero vector")
        check_box(cut.within, path + ("within",), strict=False)

    s = case.solver
    if s.mode == "dynamic":
        if s.end_time is None:
            raise err(("solver", "end_time"), "required key missing (mode dynamic)")
        check_only(s, STATIC_KEYS, ("solver",), "in mode dynamic")
    else:
        check_only(s, DYNAMIC_KEYS, ("solver",), f"in mode {s.mode}")
        if s.mode != "static":
            check_only(s, STATIC_KEYS, ("solver",), f"in mode {s.mode}")
    if s.mode != "modal":
        check_only(s, MODAL_KEYS, ("solver",), f"in mode {s.mode}")
    if case.ground_motion is not None and s.mode != "dynamic":
        raise err(("ground_motion",), f"a ground motion needs solver.mode dynamic (got {s.mode}): "
                  "a record is a history in time")
    visco = [n for n, m in case.materials.items() if m.viscoelastic is not None]
    if visco and s.mode == "static" and s.time is None:
        raise err(("materials", visco[0], "viscoelastic"), "a viscoelastic material in mode "
                  "static needs solver.time, the instants of a static run in time (creep; "
                  "docs/case_file.md, solver)")
    if s.time is not None and s.mode == "static":
        tp = ("solver", "time")
        if s.given("method") and s.method != "newton":
            raise err(("solver", "method"), "a static run in time (solver.time) is solved by "
                      "newton")
        if s.control is not None:
            raise err(("solver", "control"), "not used with solver.time (the instants drive "
                      "the run)")
        if isinstance(s.time, list):
            if not s.time:
                raise err(tp, "give at least one instant [s]")
            t = [0.0] + list(s.time)
            for i in range(1, len(t)):
                if not t[i] > t[i - 1]:
                    raise err(tp + (i - 1,), f"the instants must be > 0 and increasing (got "
                              f"{_show(t[i])} after {_show(t[i - 1])})")
        elif not s.time.end > s.time.first:
            raise err(tp + ("end",), f"must be > first = {_show(s.time.first)} "
                      f"(got {_show(s.time.end)})")
    d = s.damping
    if d.rayleigh is not None:
        dp = ("solver", "damping")
        check_only(d, ["alpha", "beta"], dp, "with rayleigh (it gives both)")
        f1, f2 = d.rayleigh.frequencies
        if not (f1 > 0 and f2 > 0 and f1 != f2):
            raise err(dp + ("rayleigh", "frequencies"), f"two different positive frequencies "
                      f"[Hz] (got {_show(f1)}, {_show(f2)})")
    if s.mode == "static" and not s.given("method"):
        s.method = default_static_method(case)
        s._method_default = True
    voronoi = [name for name in continuum_yield(case) if "voronoi" in _mesh_kinds(case, name)]
    if s.mode == "static" and voronoi:
        raise err(("solver", "mode"), "static runs do not follow continuum yield on Voronoi "
                  f"cells (materials {', '.join(voronoi)}): Newton's plastic set cycles there "
                  "(docs/theory.md, Yield); run it as a slow dynamic run with damping "
                  "(mode: dynamic, a displacement history or a velocity, damping: {local: 0.7}: "
                  "cases/punch.yaml), or on blocks (mesh.kind blocks)")
    if s.control is not None and continuum_yield(case):
        raise err(("solver", "control"), "indirect control does not follow continuum yield "
                  f"(materials {', '.join(continuum_yield(case))}: yield.model continuum): "
                  "prescribe the displacement (load_steps) instead")
    if s.given("damage_update") and s.mode == "static" and s.method != "newton":
        raise err(("solver", "damage_update"), "chooses how newton updates the damage of "
                  "softening springs: it needs solver.method: newton")
    if s.control is not None:
        cp = ("solver", "control")
        if s.method != "newton":
            raise err(cp, "indirect displacement control needs solver.method: newton")
        probe = case.output.probes.get(s.control.probe)
        if probe is None:
            raise err(cp + ("probe",), f"unknown probe {s.control.probe!r} (output.probes: "
                      f"{', '.join(case.output.probes) or 'none'})")
        if not isinstance(probe, RelativeProbe):
            raise err(cp + ("probe",), f"probe {s.control.probe!r} is not a "
                      "relative_displacement probe")
        if probe.component == "magnitude":
            raise err(cp + ("probe",), f"probe {s.control.probe!r} has component magnitude: "
                      "a control needs a component x, y, z or a direction")
        if s.control.end == 0:
            raise err(cp + ("end",), "must not be 0 (the probe starts at 0)")

    out = case.output
    if out.interval is not None:
        if s.mode != "dynamic":
            raise err(("output", "interval"), "used only in mode dynamic")
        if out.interval > s.end_time:
            raise err(("output", "interval"), f"must be <= solver.end_time "
                      f"(got {_show(out.interval)} > {_show(s.end_time)})")
    if out.checkpoint_interval is not None and s.mode != "dynamic":
        raise err(("output", "checkpoint_interval"), "used only in mode dynamic")
    for j, f in enumerate(out.fields):
        if f in out.fields[:j]:
            raise err(("output", "fields", j), f"{f} listed twice")
    if out.file is not None and not out.file.strip():
        raise err(("output", "file"), "must not be empty")
    if out.file is not None and not out.file.isprintable():
        raise err(("output", "file"), f"must not contain control characters (got {out.file!r})")
    for name, probe in out.probes.items():
        path = ("output", "probes", name)
        if isinstance(probe, Probe):
            if (probe.group is None) == (probe.surface is None):
                raise err(path, "give group or surface, not both" if probe.group is not None
                          else "required key missing: group or surface")
            if probe.surface is not None:
                check_surface(probe.surface, path + ("surface",))
            else:
                check_group(probe.group, path + ("group",))
            if probe.relative_to is not None:
                if case.ground_motion is None:
                    raise err(path + ("relative_to",), "relative to the ground needs "
                              "ground_motion (without it the ground does not move)")
                if probe.quantity not in ("displacement", "velocity"):
                    raise err(path + ("relative_to",), "for quantity displacement or "
                              f"velocity (got {probe.quantity})")
            continue
        # relative_displacement: two groups or two points, a component or a direction
        if probe.groups is None and probe.points is None:
            raise err(path, "required key missing: groups or points "
                            "(quantity relative_displacement)")
        if probe.groups is not None and probe.points is not None:
            raise err(path + ("points",), "give either groups or points, not both")
        if probe.component is None and probe.direction is None:
            raise err(path, "required key missing: component or direction "
                            "(quantity relative_displacement)")
        if probe.component is not None and probe.direction is not None:
            raise err(path + ("direction",), "give either component or direction, not both")
        if probe.direction is not None and not any(probe.direction):
            raise err(path + ("direction",), "must not be the zero vector")
        if probe.groups is not None:
            for k, g in enumerate(probe.groups):
                check_group(g, path + ("groups", k))
            if probe.groups[0] == probe.groups[1]:
                raise err(path + ("groups", 1), f"the same group as groups[0] "
                          f"({probe.groups[0]!r}: the relative displacement would be 0)")
        else:
            # (x0 .. z1: the domain's bounds, above; the body holding a point
            # is found when the run starts, solvers/output.py point_body)
            lo, hi = (x0, y0, z0), (x1, y1, z1)
            for k, pt in enumerate(probe.points):
                if not all(a <= c <= b for c, a, b in zip(pt, lo, hi)):
                    raise err(path + ("points", k), "lies outside the domain "
                              f"[{', '.join(_show(c) for c in lo)}] .. "
                              f"[{', '.join(_show(c) for c in hi)}] "
                              f"(got [{', '.join(_show(c) for c in pt)}])")
            if probe.points[0] == probe.points[1]:
                raise err(path + ("points", 1), "the same point as points[0] "
                          "(the relative displacement would be 0)")


def _check_contradictions(case: Case, err) -> None:
    """The same group (or surface) given a component twice over in
    ``boundary``: fixed by one item and prescribed (velocity, displacement)
    by another, or prescribed by two: an error naming both items (which
    one holds would depend on their order).  Fixed twice is harmless; the
    items of different groups that share bodies are left to the model (a
    warning there).  Fixing some components and prescribing others stays
    allowed (fix: [x] and velocity [null, null, v] on one group)."""
    seen: dict = {}          # (selector, name) -> {component: (item index, what)}
    for j, b in enumerate(case.boundary):
        if isinstance(b, FaceSupport):
            continue
        sel = ("group", b.group) if b.group is not None else ("surface", b.surface)
        if isinstance(b, GroupFix):
            comps, what, key = list(b.fix), "fix", "fix"
        else:
            key = "velocity" if isinstance(b, GroupVelocity) else "displacement"
            comps = [c for c, v in zip("xyz", getattr(b, key)) if v is not None]
            what = key
        mine = seen.setdefault(sel, {})
        for c in comps:
            if c in mine:
                k, other = mine[c]
                if not (what == "fix" and other == "fix"):
                    desc = {"fix": "fixed", "velocity": "given a velocity",
                            "displacement": "given a displacement"}
                    raise err(("boundary", j, key),
                              f"{c} of {sel[0]} {sel[1]} is {desc[what]} here and "
                              f"{desc[other]} by boundary[{k}]: boundary[{k}] and "
                              f"boundary[{j}] contradict each other (a component of a "
                              "group is free, fixed or prescribed: by one item only)")
            else:
                mine[c] = (j, what)


def _check_contact(case: Case, err) -> None:
    """contact: dynamic mode only; ``between`` names parts (a one-part
    scene takes ``all``); the ground's normal is not zero.  ``between`` is
    left as ``all`` or a list of [part_a, part_b] pairs."""
    c = case.contact
    path = ("contact",)
    if case.solver.mode != "dynamic":
        raise err(path, f"contact acts in solver.mode dynamic only (got {case.solver.mode})")
    if c.between != "all":
        pairs = c.between
        if pairs and all(isinstance(x, str) for x in pairs):
            pairs = [pairs]
        for k, pair in enumerate(pairs):
            kp = path + ("between",) + ((k,) if pairs is not c.between else ())
            if len(pair) != 2:
                raise err(kp, f"expected all, [part_a, part_b] or a list of such pairs "
                          f"(got {len(pair)} names)")
            for j, name in enumerate(pair):
                if name not in case.parts:
                    raise err(kp + (j,), f"unknown part {name!r} (parts: "
                              f"{', '.join(case.parts) or 'none: a one-part scene takes all'})")
        if not pairs:
            raise err(path + ("between",), "must not be empty (all, or [part_a, part_b])")
        c.between = [list(p) for p in pairs]
    if c.ground is not None and not any(c.ground.normal):
        raise err(path + ("ground", "normal"), "must not be the zero vector")
