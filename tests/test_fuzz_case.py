"""Bad input, tried hard (issue 6, item 7).

A property-based test (hypothesis) mutates small valid case files: wrong
types, missing keys, negative, zero, NaN, infinite and huge values, empty
collections, groups that select nothing or overlap, unknown names, YAML
syntax errors, tags, alias bombs, non-UTF-8 bytes.  Every mutated file goes
through the command line's own entry, ``rbsm_dyn.__main__.main(argv)``, in
this process (no subprocess per example): ``check`` first, then for some of
the files it accepts ``info`` or a short run (``--max-steps 2``).  Each must
end with

* exit 2 and one line ``rbsm_dyn: FILE:LINE: KEY.PATH: message`` naming a
  key that is in the file (or the missing key under a parent that is), or
* exit 0, having built the model (and written only the file it was asked
  to write), or, for a short run that blew up, exit 1 with the step and
  time (DESIGN.md §4),

never a traceback and never a hang (a hard per-example time limit).  The
mesh limit ``rbsm_dyn.case.check.MAX_CELLS`` is lowered for the fuzz so that a
"huge size" is refused by the resource check (naming mesh.size or
mesh.divisions) instead of being built, and every accepted case stays
small.  A few deterministic tests run the real command in a subprocess.
"""
import ast
import contextlib
import copy
import io
import json
import math
import os
import re
import shutil
import signal
import subprocess
import sys
import tempfile
import textwrap
from pathlib import Path

import pytest
from hypothesis import HealthCheck, Phase, given, settings
from hypothesis import strategies as st
from ruamel.yaml import YAML

import rbsm_dyn
import rbsm_dyn.case.check as case_check
from rbsm_dyn.__main__ import main

# ------------------------------------------------------------------ bases ---
# Small valid cases (a few to a few dozen bodies), one per solver mode and
# most schema features, so that any mutation the schema accepts still builds
# in tens of milliseconds.

BASES = {
    "dynamic_blocks": """\
        name: fz-dyn
        description: dynamic, blocks, supports, loads with history
        domain: {box: [[0, 0, 0], [0.4, 0.1, 0.1]]}
        mesh: {kind: blocks, divisions: [4, 2, 2], spring_points: centroid}
        materials:
          steel: {density: 8000, young: 200.0e9, poisson: 0.0}
        groups:
          tip: {box: [[0.3, -1, -1], [1, 1, 1]]}
          root: {box: [[-1, -1, -1], [0.1, 1, 1]]}
        boundary:
          - {face: xmin, fix: all}
          - {group: tip, fix: [y, rx]}
        initial: [{group: tip, velocity: [0, 0, -1.0]}]
        loads:
          - {group: tip, force: [0, 0, -100.0], history: [[0, 0], [1.0e-5, 1]]}
          - {gravity: [0, 0, -9.81]}
        solver: {mode: dynamic, end_time: 1.0e-5, dt_safety: 0.8, damping: {alpha: 10.0}}
        output:
          file: fz-dyn.h5
          interval: 2.0e-6
          fields: [position, velocity, spring_state]
          probes:
            tip_z: {group: tip, quantity: displacement, component: z, reduce: mean}
            root_r: {group: root, quantity: reaction, component: x, reduce: sum}
        """,
    "static_voronoi": """\
        name: fz-static
        domain: {box: [[0, 0, 0], [0.2, 0.05, 0.05]]}
        mesh: {kind: voronoi, size: 0.025, seed: 3, min_spacing: 0.3}
        materials:
          concrete:
            density: 2400
            young: 30.0e9
            poisson: 0.2
            yield: {criterion: von_mises, stress: 30.0e6}
            rupture: {strain: 1.0e-3}
            friction: 0.5
        groups:
          end: {box: [[0.15, -1, -1], [1, 1, 1]]}
        boundary:
          - {face: xmin, fix: all}
          - {group: end, displacement: [null, null, -1.0e-5]}
        cuts:
          - {point: [0.1, 0, 0], normal: [1, 0, 0], within: [[0.05, -1, -1], [0.15, 1, 0.02]]}
        solver: {mode: static, load_steps: 2, tolerance: 1.0e-4, max_iterations: 500,
                 relaxation: adaptive, predictor: true}
        output:
          probes:
            end_z: {group: end, quantity: force, component: z, reduce: sum}
        """,
    "linear_mm": """\
        name: fz-linear
        units: mm-N-s
        domain: {box: [[0, 0, 0], [300, 50, 50]]}
        mesh: {kind: blocks, divisions: [6, 1, 2]}
        materials:
          steel: {density: 7.85e-9, young: 200000, poisson: 0.3, stiffness: kawai}
          alu: {density: 2.7e-9, young: 70000, poisson: 0.33}
        groups:
          tip: {box: [[250, -1, -1], [1000, 1000, 1000]], material: alu}
        boundary: [{face: xmin, fix: all}]
        loads: [{group: tip, force: [0, 0, -1000], moment: [0, 1000, 0]}]
        solver: {mode: linear}
        output:
          fields: [position, orientation, spring_force]
          probes:
            tip_z: {group: tip, quantity: displacement, component: magnitude, reduce: max}
        """,
    "modal_blocks": """\
        name: fz-modal
        domain: {box: [[0, 0, 0], [1.0, 0.1, 0.1]]}
        mesh: {kind: blocks, divisions: [6, 1, 1], spring_points: three}
        materials:
          steel: {density: 8000, young: 200.0e9, poisson: 0.0}
        boundary: [{face: xmin, fix: all}, {face: xmax, fix: [z]}]
        solver: {mode: modal, modes: 3}
        """,
    "dynamic_voronoi_rupture": """\
        name: fz-crack
        domain: {box: [[0, 0, 0], [0.06, 0.003, 0.06]]}
        mesh: {kind: voronoi, size: 0.006, seed: 1}
        materials:
          glass:
            density: 2500
            young: 60.0e9
            poisson: 0.2
            yield: {criterion: mohr_coulomb, cohesion: 1.0e7, friction_angle: 30, tension: 5.0e6}
            rupture: {fracture_energy: 10.0, tensile_strength: 5.0e6}
        groups:
          top: {box: [[-1, -1, 0.045], [1, 1, 1]]}
          bottom: {box: [[-1, -1, -1], [1, 1, 0.015]]}
        boundary:
          - {group: bottom, velocity: [0, null, -0.1], history: [[0, 1], [1.0e-6, 1]]}
        initial: [{group: top, angular_velocity: [0, 1.0, 0]}]
        loads: [{group: top, force: [0, 0, 500.0]}]
        solver: {mode: dynamic, end_time: 2.0e-6, threads: 1}
        output:
          fields: [position, orientation, angular_velocity, spring_force]
          probes:
            top_v: {group: top, quantity: velocity, component: z, reduce: min}
            top_r: {group: top, quantity: rotation, component: y, reduce: mean}
        """,
    "scene_parts": """\
        name: fz-scene
        parts:
          beam: {geometry: {box: [[0, 0, 0], [0.3, 0.05, 0.05]]},
                 mesh: {kind: voronoi, size: 0.025, seed: 2}, material: concrete}
          pad: {geometry: {box: [[0.3, 0, 0], [0.4, 0.05, 0.05]]},
                mesh: {kind: blocks, divisions: [2, 1, 1]}, material: concrete}
          platen: {geometry: {cylinder: {base: [0.15, 0.07, 0], axis: [0, 0, 0.05], radius: 0.02},
                   surfaces: {flat: {normal: [0, -1, 0], angle: 30}}},
                   mesh: {kind: rigid, size: 0.01}, material: steel}
        interfaces:
          - {parts: [beam, pad], law: contact, friction: 0.3}
        materials:
          concrete: {density: 2400, young: 30.0e9, poisson: 0.2}
          steel: {density: 7800, young: 2.0e11, poisson: 0.3}
        boundary:
          - {surface: beam.xmin, fix: all}
          - {group: platen, velocity: [0, -0.1, 0]}
        solver: {mode: dynamic, end_time: 2.0e-6}
        output:
          probes:
            R: {surface: beam.xmin, quantity: reaction, component: y, reduce: sum}
        """,
}
BASES = {k: textwrap.dedent(v) for k, v in BASES.items()}

FUZZ_MAX_CELLS = 150     # rbsm_dyn.case.check.MAX_CELLS during the fuzz
EXAMPLES = 1050          # hypothesis examples (the test asserts >= 1000 were tried)
EXAMPLE_TIME_LIMIT = 30  # seconds: an example that takes longer is a hang

_safe = YAML(typ="safe", pure=True)


def _load(text):
    return _safe.load(text)


_PLAIN_KEY = re.compile(r"[A-Za-z_][A-Za-z0-9_-]*\Z")


def _scalar_text(v):
    """A scalar as YAML 1.2 text (strings double-quoted with JSON escapes,
    which YAML reads the same way)."""
    if v is None:
        return "null"
    if isinstance(v, bool):
        return "true" if v else "false"
    if isinstance(v, int):
        return str(v)
    if isinstance(v, float):
        if math.isnan(v):
            return ".nan"
        if math.isinf(v):
            return ".inf" if v > 0 else "-.inf"
        return repr(v)
    if isinstance(v, str) and _PLAIN_KEY.match(v) and v not in (
            "null", "true", "false", "Null", "NULL", "True", "TRUE", "False", "FALSE"):
        return v
    text = json.dumps(str(v), ensure_ascii=False)
    return "".join(c if c.isprintable() else (f"\\u{ord(c):04x}" if ord(c) < 0x10000
                                              else f"\\U{ord(c):08x}") for c in text)


def _flow(v):
    if isinstance(v, dict):
        return "{" + ", ".join(f"{_scalar_text(k)}: {_flow(x)}" for k, x in v.items()) + "}"
    if isinstance(v, list):
        return "[" + ", ".join(_flow(x) for x in v) + "]"
    return _scalar_text(v)


def _dump(data, indent=0):
    """Plain data -> YAML text: block mappings, flow lists and leaves (like
    the case files; ruamel's dumper took half the time of an example)."""
    out = []
    for k, v in data.items():
        head = " " * indent + _scalar_text(k) + ":"
        if isinstance(v, dict) and v and any(isinstance(x, (dict, list)) for x in v.values()):
            out.append(head + "\n" + _dump(v, indent + 2))
        elif isinstance(v, list) and v and all(isinstance(x, dict) and x for x in v):
            out.append(head + "\n" + "".join(f"{' ' * indent}- {_flow(x)}\n" for x in v))
        else:
            out.append(f"{head} {_flow(v)}\n")
    return "".join(out)


BASE_DATA = {k: _load(v) for k, v in BASES.items()}

# --------------------------------------------------------------- mutations ---

SCHEMA_KEYS = [
    "name", "description", "units", "domain", "mesh", "materials", "groups", "boundary",
    "initial", "loads", "cuts", "solver", "output", "box", "kind", "size", "seed",
    "min_spacing", "divisions", "spring_points", "density", "young", "poisson",
    "stiffness", "yield", "rupture", "friction", "criterion", "stress", "cohesion",
    "friction_angle", "tension", "strain", "fracture_energy", "tensile_strength",
    "material", "face", "fix", "group", "velocity", "displacement", "history",
    "angular_velocity", "force", "moment", "gravity", "point", "normal", "within",
    "mode", "end_time", "dt", "dt_safety", "damping", "alpha", "load_steps", "tolerance",
    "max_iterations", "relaxation", "damping_factor", "predictor", "threads", "modes",
    "file", "interval", "fields", "probes", "quantity", "component", "reduce",
    "cylinder", "sphere", "prism", "union", "difference", "intersection", "base", "axis",
    "radius", "center", "polygon", "holes", "from", "to", "scale", "surfaces", "surface",
    "chord", "pressure", "traction", "follower", "breakable", "law", "values",
    "shear_strength", "shear_fracture_energy", "groups", "points", "direction",
    "cell_stress", "angle", "parts", "interfaces", "geometry", "rigid", "bonded", "contact",
    "yeild", "Young", "end-time", "", "all", "x", "steel", "tip",
]
WORDS = ["", " ", "abc", "all", "tip", "beam", "platen", "beam.xmin", "rigid", "contact", "root", "steel", "glass", "nope", "xmin", "zmax",
         "x", "rz", "magnitude", "mean", "dynamic", "static", "linear", "modal", "voronoi",
         "blocks", "SI", "mm-N-s", "von_mises", "mohr_coulomb", "kawai", "position",
         "1e-5", "0x10", "1_000", ".nan", "null", "~", "yes", "no", "on", "off",
         "2001-12-14", "é", "名前", "a\nb", "a: b", "\t", "-", "*x", "&y", "!t",
         "x.h5", "out/x.h5", ".", "..", "../up.h5", "a b.h5", "ü.h5", "x" * 300]
NUMBERS = [0, -0.0, 1, -1, 2, 3, 0.5, -0.5, 0.49, 0.5, 0.9, 1.0, 89.9, 90, 1e-300, 5e-324,
           -1e-300, 1e-12, 1e-6, 1e-3, 1e3, 1e6, 1e12, 1e30, 1e300, -1e300, 1.7976931348623157e308,
           2 ** 31, 2 ** 63, 2 ** 64, -2 ** 63, 10 ** 30, 10 ** 400,
           math.nan, math.inf, -math.inf]
FACTORS = [-1.0, 0.0, 1e-300, 1e-12, 1e-3, 0.1, 0.5, 0.99, 1.01, 2.0, 10.0, 1e3, 1e12, 1e300]


def _scalar():
    return st.one_of(
        st.sampled_from(NUMBERS),
        st.sampled_from(WORDS),
        st.booleans(),
        st.none(),
        st.floats(allow_nan=True, allow_infinity=True),
        st.integers(min_value=-10 ** 20, max_value=10 ** 20),
        st.text(max_size=6),
    )


def _value():
    scalar = _scalar()
    vec = st.lists(st.one_of(st.sampled_from(NUMBERS), st.none()), min_size=0, max_size=4)
    box = st.lists(st.lists(st.sampled_from(NUMBERS[:20]), min_size=3, max_size=3),
                   min_size=2, max_size=2)
    return st.one_of(
        scalar, vec, box,
        st.just([]), st.just({}), st.just([[]]), st.just([{}]),
        st.dictionaries(st.sampled_from(SCHEMA_KEYS), scalar, max_size=3),
        st.lists(st.dictionaries(st.sampled_from(SCHEMA_KEYS), scalar, max_size=3), max_size=2),
    )


def _paths(node, path=()):
    """Every (path, value) below the root (dict values and list items)."""
    if isinstance(node, dict):
        for k, v in node.items():
            yield path + (k,), v
            yield from _paths(v, path + (k,))
    elif isinstance(node, list):
        for i, v in enumerate(node):
            yield path + (i,), v
            yield from _paths(v, path + (i,))


def _get(data, path):
    for p in path:
        data = data[p]
    return data


def _set(data, path, value):
    _get(data, path[:-1])[path[-1]] = value


def _is_number(v):
    return isinstance(v, (int, float)) and not isinstance(v, bool)


def _group_names(data):
    g = data.get("groups")
    return list(g) if isinstance(g, dict) else []


def _domain_box(data):
    try:
        box = data["domain"]["box"]
        lo, hi = [[float(c) for c in box[0]], [float(c) for c in box[1]]]
        if len(box) == 2 and len(lo) == len(hi) == 3:
            return lo, hi
    except Exception:
        pass
    return [0.0, 0.0, 0.0], [1.0, 1.0, 1.0]


MUTATIONS = ["delete", "replace", "replace", "numeric", "numeric", "unknown_key", "empty",
             "group", "group", "reference", "duplicate_item", "huge", "mode", "swap",
             "material", "valid", "valid", "valid", "valid", "scale", "scale"]

# edits that keep a case valid (mostly): the fuzz must also reach the models
VALID = {
    "kind": ["voronoi", "blocks", "rigid"], "law": ["bonded", "contact"],
    "spring_points": ["moment", "centroid", "three"],
    "stiffness": ["calibrated", "kawai"], "criterion": ["normal", "tresca", "von_mises"],
    "relaxation": ["adaptive", "local"], "predictor": [True, False],
    "quantity": ["displacement", "rotation", "velocity", "force", "reaction"],
    "component": ["x", "y", "z", "magnitude"], "reduce": ["mean", "sum", "max", "min"],
    "face": ["xmin", "xmax", "ymin", "ymax", "zmin", "zmax"],
    "fix": ["all", ["x"], ["z", "y"], ["x", "rz"]], "seed": [0, 1, 7, 2 ** 40],
    "poisson": [0.0, 0.1, 0.25, 0.45], "dt_safety": [0.1, 0.5, 0.85], "units": ["SI", "mm-N-s"],
    "fields": [["position"], ["velocity", "spring_state"], ["spring_force", "angular_velocity"]],
    "min_spacing": [0.0, 0.5, 0.9], "friction": [0.0, 0.6], "modes": [1, 2, 5],
    "load_steps": [1, 3], "tolerance": [1e-3, 1e-8], "max_iterations": [1, 100],
    "damping_factor": [0.0, 0.5], "alpha": [0.0, 1e3], "threads": [1, 2, 64],
    "velocity": [[0, 0, 0], [1, -2, 3], [None, 0, 1], [1e3, 0, 0]],
    "angular_velocity": [[0, 0, 0], [10, 0, 0]], "displacement": [[1e-4, None, None]],
    "force": [[0, 0, 0], [1e4, 0, -1e4]], "moment": [[0, 0, 1]], "gravity": [[0, 0, -9.81]],
    "normal": [[0, 0, 1], [1, 1, 0]], "history": [[[0, 0], [1, 1]], [[0, 1]]],
    "interval": [1e-6], "end_time": [1e-6, 1e-4], "dt": [1e-9, 1e-7],
    "file": ["x.h5", "out.h5", "a b.h5", "ü.h5", "sub/x.h5", ".", "..", "../up.h5",
             "case.yaml"],
    "name": ["n", "a/b", "../up", "..", ".", "é", "x" * 200, "a\\b"],
    "description": ["", "x", None],
}


def mutate(draw, data, log):
    """Apply one structural mutation to ``data`` (in place); log what."""
    kind = draw(st.sampled_from(MUTATIONS))
    paths = [p for p, _ in _paths(data)]
    if not paths:
        data["name"] = draw(_value())
        log.append(("replace", ("name",)))
        return
    if kind == "delete":
        path = draw(st.sampled_from(paths))
        del _get(data, path[:-1])[path[-1]]
    elif kind == "replace":
        path = draw(st.sampled_from(paths))
        _set(data, path, draw(_value()))
    elif kind == "numeric":
        nums = [p for p, v in _paths(data) if _is_number(v)]
        if not nums:
            return mutate(draw, data, log)
        path = draw(st.sampled_from(nums))
        old = _get(data, path)
        how = draw(st.sampled_from(["factor", "number", "int"]))
        if how == "factor":
            f = draw(st.sampled_from(FACTORS))
            try:
                new = old * f
            except OverflowError:
                new = math.inf
            _set(data, path, new)
        elif how == "number":
            _set(data, path, draw(st.sampled_from(NUMBERS)))
        else:
            _set(data, path, draw(st.integers(min_value=-3, max_value=10 ** 12)))
    elif kind == "unknown_key":
        dicts = [()] + [p for p, v in _paths(data) if isinstance(v, dict)]
        path = draw(st.sampled_from(dicts))
        key = draw(st.one_of(st.sampled_from(SCHEMA_KEYS), st.integers(-2, 2), st.none(),
                             st.booleans()))
        _get(data, path)[key] = draw(_value())
        path = path + (key,)
    elif kind == "empty":
        conts = [p for p, v in _paths(data) if isinstance(v, (dict, list))]
        path = draw(st.sampled_from(conts))
        _set(data, path, draw(st.sampled_from([[], {}, None, "", [[], []]])))
    elif kind == "group":
        names = _group_names(data)
        lo, hi = _domain_box(data)
        name = draw(st.sampled_from(names + ["g_new", "all"]))
        if not isinstance(data.get("groups"), dict):
            data["groups"] = {}
        groups = data["groups"]
        what = draw(st.sampled_from(["outside", "whole", "overlap", "inverted", "point",
                                     "flat", "corner", "material", "bad_material", "empty"]))
        if what == "outside":
            box = [[h + 1.0 for h in hi], [h + 2.0 for h in hi]]
        elif what == "whole":
            box = [lo, hi]
        elif what == "overlap" and names:
            other = groups[draw(st.sampled_from(names))]
            box = copy.deepcopy(other.get("box")) if isinstance(other, dict) else None
        elif what == "inverted":
            box = [hi, lo]
        elif what == "point":
            box = [lo, lo]
        elif what == "flat":
            box = [[lo[0], lo[1], lo[2]], [hi[0], hi[1], lo[2]]]
        elif what == "corner":
            box = [[lo[0] - 1, lo[1] - 1, lo[2] - 1], [lo[0], lo[1], lo[2]]]
        else:
            box = None
        g = groups.get(name)
        if not isinstance(g, dict):
            g = groups[name] = {"box": [lo, hi]}
        if what == "material":
            mats = data.get("materials")
            g["material"] = draw(st.sampled_from(list(mats) if isinstance(mats, dict) and mats
                                                 else ["steel"]))
        elif what == "bad_material":
            g["material"] = draw(st.sampled_from(["nope", "", "Steel", "all"]))
        elif what == "empty":
            groups[name] = draw(st.sampled_from([{}, None, [], {"material": "steel"}]))
        else:
            g["box"] = box
        path = ("groups", name)
    elif kind == "valid":
        keyed = [p for p, _ in _paths(data) if isinstance(p[-1], str) and p[-1] in VALID]
        if not keyed:
            return mutate(draw, data, log)
        path = draw(st.sampled_from(keyed))
        _set(data, path, copy.deepcopy(draw(st.sampled_from(VALID[path[-1]]))))
    elif kind == "scale":
        nums = [p for p, v in _paths(data) if _is_number(v) and not isinstance(v, int)]
        if not nums:
            return mutate(draw, data, log)
        path = draw(st.sampled_from(nums))
        _set(data, path, _get(data, path) * draw(st.sampled_from([0.5, 0.9, 1.1, 2.0, -1.0])))
    elif kind == "reference":
        refs = [p for p, v in _paths(data) if p and p[-1] in ("group", "material")]
        if not refs:
            return mutate(draw, data, log)
        path = draw(st.sampled_from(refs))
        _set(data, path, draw(st.sampled_from(_group_names(data) + ["all", "nope", "", "steel"])))
    elif kind == "duplicate_item":
        lists = [p for p, v in _paths(data) if isinstance(v, list) and v]
        if not lists:
            return mutate(draw, data, log)
        path = draw(st.sampled_from(lists))
        lst = _get(data, path)
        lst.append(copy.deepcopy(draw(st.sampled_from(lst))))
    elif kind == "huge":
        what = draw(st.sampled_from(["size", "divisions", "domain", "history", "list",
                                     "offset"]))
        mesh = data.get("mesh")
        if not isinstance(mesh, dict):
            mesh = data["mesh"] = {"kind": "voronoi"}
        if what == "size":
            mesh["size"] = draw(st.sampled_from([1e-9, 1e-6, 1e-4, 1e-3, 1e3, 1e300, 5e-324]))
            path = ("mesh", "size")
        elif what == "divisions":
            mesh["divisions"] = [draw(st.sampled_from([1, 2, 50, 1000, 10 ** 6, 2 ** 63, 10 ** 30]))
                                 for _ in range(3)]
            path = ("mesh", "divisions")
        elif what == "domain":
            f = draw(st.sampled_from([1e3, 1e6, 1e150, 1e200, 1e-150, 1e-200]))
            lo, hi = _domain_box(data)
            data["domain"] = {"box": [[c * f for c in lo], [c * f for c in hi]]}
            path = ("domain", "box")
        elif what == "offset":        # far from the origin: round-off in the mesh
            f = draw(st.sampled_from([1e3, 1e8, 1e12, 1e15, 1e17]))
            lo, hi = _domain_box(data)
            data["domain"] = {"box": [[c + f for c in lo], [c + f for c in hi]]}
            path = ("domain", "box")
        elif what == "history":
            n = draw(st.sampled_from([1, 2, 1000]))
            data.setdefault("loads", [])
            if not isinstance(data["loads"], list):
                data["loads"] = []
            data["loads"].append({"group": "all", "force": [1, 0, 0],
                                  "history": [[i * 1e-7, 1.0] for i in range(n)]})
            path = ("loads",)
        else:
            n = draw(st.sampled_from([50, 500]))
            data["cuts"] = [{"point": [0, 0, 0], "normal": [1, 0, 0],
                             "within": [[-1, -1, -1], [1, 1, 1]]}] * n
            path = ("cuts",)
    elif kind == "mode":
        s = data.get("solver")
        if not isinstance(s, dict):
            s = data["solver"] = {}
        s["mode"] = draw(st.sampled_from(["dynamic", "static", "linear", "modal", "Dynamic", 3]))
        if draw(st.booleans()):
            for k in ("end_time", "load_steps", "tolerance", "max_iterations", "relaxation",
                      "predictor", "modes", "dt_safety", "damping"):
                s.pop(k, None)
            if s["mode"] == "dynamic":
                s["end_time"] = 1e-6
        path = ("solver", "mode")
    elif kind == "swap":
        a, b = draw(st.sampled_from(paths)), draw(st.sampled_from(paths))
        if a[:len(b)] == b or b[:len(a)] == a:
            return mutate(draw, data, log)
        va, vb = copy.deepcopy(_get(data, a)), copy.deepcopy(_get(data, b))
        _set(data, a, vb)
        _set(data, b, va)
        path = a
    else:  # material
        mats = data.get("materials")
        if not isinstance(mats, dict):
            mats = data["materials"] = {}
        what = draw(st.sampled_from(["drop_all", "add", "yield", "rupture", "rename"]))
        if what == "drop_all":
            mats.clear()
        elif what == "add":
            mats[draw(st.sampled_from(["m2", "steel", "all", ""]))] = draw(st.sampled_from([
                {"density": 1, "young": 1, "poisson": 0},
                {"density": 1e4, "young": 1e12, "poisson": 0.45},
                {"density": 1e-300, "young": 1e300, "poisson": 0.0},
                {"density": 1e300, "young": 1e-300, "poisson": 0.0}]))
        elif what in ("yield", "rupture") and mats:
            name = draw(st.sampled_from(list(mats)))
            if isinstance(mats[name], dict):
                mats[name][what] = draw(st.sampled_from([
                    {"criterion": "tresca", "stress": 1.0},
                    {"criterion": "normal", "stress": 1e300},
                    {"criterion": "mohr_coulomb", "cohesion": 0, "friction_angle": 0},
                    {"criterion": "mohr_coulomb", "stress": 1},
                    {"strain": 1e-300}, {"strain": 10.0},
                    {"fracture_energy": 1e-300, "tensile_strength": 1e300},
                    {"fracture_energy": 1.0}, {}]))
        elif what == "rename" and mats:
            old = draw(st.sampled_from(list(mats)))
            mats[old + "_x"] = mats.pop(old)
        path = ("materials",)
    log.append((kind, path))


# Text-level mutations: applied to the YAML text (bytes) after dumping.
BAD_BYTES = [b"\xff", b"\xfe", b"\xe9", b"\x80", b"\xc3\x28", b"\xed\xa0\x80", b"\xf8\x88\x80",
             b"\xc0\xaf", b"\x00", b"\x1b", b"\x7f", b"\xef\xbb\xbf", b"\xe2\x80\xa8"]
SYNTAX = ["[", "]", "{", "}", ":", ",", "- ", "&", "*", "!", "|", ">", "'", '"', "%", "@", "`",
          "#", "? ", "\t", "\n", "  ", ": :", "\\", "---\n", "...\n", "<<: ", "&a ", "*a"]
TAGS = ["!!python/object/apply:os.system ['touch {marker}']",
        "!!python/object:os.system {{}}", "!!python/name:os.system", "!!python/tuple [1, 2]",
        "!!binary aGVsbG8=", "!!set {{a, b}}", "!!omap [a: 1]", "!custom x", "!!float '3'",
        "!!int '3'", "!!str 3", "!!bool 'x'", "!!timestamp 2001-12-14", "!!null ''",
        "!<tag:example.com,2000:x> 1"]
BOMB = ("a0: &a0 [x, x, x, x, x, x, x, x, x, x]\n"
        + "".join(f"a{i}: &a{i} [" + ", ".join([f"*a{i - 1}"] * 10) + "]\n" for i in range(1, 9)))


def text_mutate(draw, raw, marker, log):
    kind = draw(st.sampled_from(["bytes", "syntax", "delete", "truncate", "tag", "bomb",
                                 "dup_line", "tab", "encoding", "crlf", "bom", "empty",
                                 "documents", "anchor", "tag", "bytes", "syntax", "deep",
                                 "long"]))
    pos = draw(st.integers(0, len(raw)))
    if kind == "bytes":
        ins = draw(st.one_of(st.sampled_from(BAD_BYTES), st.binary(min_size=1, max_size=4)))
        raw = raw[:pos] + ins + raw[pos:]
    elif kind == "syntax":
        raw = raw[:pos] + draw(st.sampled_from(SYNTAX)).encode() + raw[pos:]
    elif kind == "delete":
        raw = raw[:pos] + raw[pos + draw(st.integers(1, 20)):]
    elif kind == "truncate":
        raw = raw[:pos]
    elif kind == "tag":
        values = [m.end() for m in re.finditer(rb": ", raw)]
        at = draw(st.sampled_from(values)) if values else 0
        tag = draw(st.sampled_from(TAGS)).format(marker=marker)
        raw = raw[:at] + tag.encode() + b" " + raw[at:] if draw(st.booleans()) else \
            raw[:at] + tag.encode() + b"\n" + raw[raw.find(b"\n", at) + 1 or len(raw):]
    elif kind == "bomb":
        raw = BOMB.encode() + raw if draw(st.booleans()) else \
            raw + b"description: " + BOMB.replace("\n", ", ").encode() + b"\n"
        raw = raw.replace(b"description: a0", b"description: {a0")  # flow mapping
        if b"{a0" in raw:
            raw = raw.rstrip(b", \n") + b"}\n"
    elif kind == "dup_line":
        lines = raw.split(b"\n")
        i = draw(st.integers(0, max(0, len(lines) - 1)))
        lines.insert(i, lines[i])
        raw = b"\n".join(lines)
    elif kind == "tab":
        lines = raw.split(b"\n")
        i = draw(st.integers(0, max(0, len(lines) - 1)))
        lines[i] = b"\t" + lines[i]
        raw = b"\n".join(lines)
    elif kind == "encoding":
        enc = draw(st.sampled_from(["utf-16", "utf-32", "latin-1", "cp1252"]))
        raw = raw.decode("utf-8", "replace").replace("name: ", "name: é", 1).encode(enc, "replace")
    elif kind == "crlf":
        raw = raw.replace(b"\n", b"\r\n")
    elif kind == "bom":
        raw = b"\xef\xbb\xbf" + raw
    elif kind == "empty":
        raw = draw(st.sampled_from([b"", b"\n", b"   \n", b"# c\n", b"---\n", b"~\n", b"[]\n",
                                    b"42\n", b"'x'\n", b"- a\n", b"null\n"]))
    elif kind == "deep":            # nested flow lists at a value
        values = [m.end() for m in re.finditer(rb": ", raw)]
        at = draw(st.sampled_from(values)) if values else 0
        n = draw(st.sampled_from([10, 70, 400, 3000]))
        raw = raw[:at] + b"[" * n + b"1" + b"]" * n + b"\n" + \
            raw[raw.find(b"\n", at) + 1 or len(raw):]
    elif kind == "long":            # a long value (100 kB)
        raw = raw + b"description: " + b"x" * 100_000 + b"\n"
    elif kind == "documents":
        raw = raw + b"---\n" + raw
    else:  # anchor: a legitimate alias, e.g. one material reused
        raw = raw.replace(b"materials:\n", b"materials: &m\n", 1) + b"description: *m\n"
    log.append(("text:" + kind, ()))
    return raw


# ------------------------------------------------------------------ driver ---

MESSAGE = re.compile(r"^rbsm_dyn: (?P<file>.+?):(?P<line>\d+|\?): (?P<path>.+?): (?P<msg>.+)$")
FAILED_RUN = re.compile(r"^rbsm_dyn: run failed: .*(step \d+|load step \d+)")


def _split_path(path):
    """``boundary[0].fix`` -> ['boundary', 0, 'fix'] (keys with dots stay whole
    only when they exist in the data; good enough for the generated names)."""
    out = []
    for m in re.finditer(r"\[(-?\d+)\]|('(?:[^'\\]|\\.)*'|\"(?:[^\"\\]|\\.)*\")|([^.\[\]]+)",
                         path):
        if m.group(1) is not None:
            out.append(int(m.group(1)))
        elif m.group(2) is not None:          # a key shown with repr()
            out.append(ast.literal_eval(m.group(2)))
        else:
            out.append(m.group(3))
    return out


def _resolves(data, parts):
    """True when every part but the last exists in data; the last may be
    missing (a required key) under a mapping that exists."""
    node = data
    for i, p in enumerate(parts):
        last = i == len(parts) - 1
        if isinstance(node, dict):
            for k in (p, str(p)) + ((int(p),) if isinstance(p, str) and p.lstrip("-").isdigit()
                                   else ()):
                if k in node:
                    node = node[k]
                    break
            else:
                if isinstance(p, str) and p in ("true", "false", "null"):
                    k = {"true": True, "false": False, "null": None}[p]
                    if k in node:
                        node = node[k]
                        continue
                return last
        elif isinstance(node, list) and isinstance(p, int) and 0 <= p < len(node):
            node = node[p]
        else:
            return False
    return True


class Hang(Exception):
    pass


@contextlib.contextmanager
def time_limit(seconds):
    def handler(signum, frame):
        raise Hang(f"example still running after {seconds} s (a hang)")
    old = signal.signal(signal.SIGALRM, handler)
    signal.setitimer(signal.ITIMER_REAL, seconds)
    try:
        yield
    finally:
        signal.setitimer(signal.ITIMER_REAL, 0)
        signal.signal(signal.SIGALRM, old)


def cli(argv, cwd=None):
    """(exit code, stdout, stderr) of main(argv) in this process; an
    exception escaping main is a traceback the user would see: re-raised."""
    out, err = io.StringIO(), io.StringIO()
    old = os.getcwd()
    try:
        if cwd is not None:
            os.chdir(cwd)
        with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
            try:
                code = main(argv)
            except SystemExit as exc:   # argparse
                code = exc.code
    finally:
        os.chdir(old)
    return code, out.getvalue(), err.getvalue()


def listing(root):
    return sorted(str(p.relative_to(root)) for p in Path(root).rglob("*"))


def check_bad(code, err, data, text_mutated, what):
    """Exit 2 with one line naming file, line and a key of the file."""
    assert code == 2, what
    assert "Traceback" not in err, what
    lines = err.strip().splitlines()
    assert len(lines) == 1, what
    m = MESSAGE.match(lines[0])
    assert m, what
    assert m.group("file").endswith("case.yaml"), what
    assert m.group("line") != "?", what
    path = m.group("path")
    if path == "<document>":
        # only the document as a whole: YAML syntax, encoding, empty, not a mapping
        assert text_mutated or data is None or not isinstance(data, dict) or not data, what
        return
    if data is not None and not text_mutated:
        assert _resolves(data, _split_path(path)), what


# examples: bodies run; checked: examples that went through fuzz_one to the end
STATS = {"examples": 0, "checked": 0, "exit2": 0, "ok": 0, "runs": 0, "infos": 0,
         "failed_runs": 0, "text": 0}


def fuzz_one(base, data, raw, log, run_kind, root, marker):
    """Run one mutated case through the CLI entry and check the contract."""
    text_mutated = any(k.startswith("text:") for k, _ in log)
    what = f"mutations {log} on base {base!r}:\n{raw!r}"
    work = Path(tempfile.mkdtemp(dir=root))
    case = work / "case.yaml"
    case.write_bytes(raw)
    try:
        with time_limit(EXAMPLE_TIME_LIMIT):
            _fuzz_cli(case, raw, data, run_kind, work, text_mutated, what)
        STATS["checked"] += 1
    finally:
        assert not os.path.exists(marker), "a YAML tag ran a command: " + what
        assert not os.listdir(tempfile.gettempdir()), "left in the temporary directory: " + what
        shutil.rmtree(work, ignore_errors=True)


def _fuzz_cli(case, raw, data, run_kind, work, text_mutated, what):
    code, out, err = cli(["check", str(case)], cwd=work)
    assert listing(work) == ["case.yaml"], what       # check writes nothing
    if code != 0:
        STATS["exit2"] += 1
        check_bad(code, err, data, text_mutated, what + "\n" + err)
        return
    STATS["ok"] += 1
    m = re.search(r"ok \((\d+) bodies", out)
    assert m and 1 <= int(m.group(1)) <= 1.2 * FUZZ_MAX_CELLS + 1, what + out
    if run_kind == "check":
        return
    if run_kind == "info":
        STATS["infos"] += 1
        code, out, err = cli(["info", str(case)], cwd=work)
        assert code == 0 and "bodies" in out, what + err
        assert listing(work) == ["case.yaml"], what
        return
    # a short run: with --out, or to output.file (relative to the working
    # directory) when that stays inside the sandbox
    STATS["runs"] += 1
    loaded = rbsm_dyn.load_case(case)
    target = (work / loaded.output.file).resolve()
    args = [str(case), "--quiet", "--max-steps", "2"]
    if run_kind == "run_out" or work.resolve() not in target.parents:
        target = work.resolve() / "asked.h5"
        args += ["--out", str(target)]
    code, out, err = cli(args, cwd=work)
    assert "Traceback" not in err, what + err
    assert case.read_bytes() == raw, what          # the case file is never touched
    if code == 2:
        check_bad(code, err, data, text_mutated, what + "\n" + err)
        # a check that needs the solver (solver.dt, solver.modes) comes after the
        # history is opened: then the history says so
        written = str(target.relative_to(work.resolve()))
        assert listing(work) in (["case.yaml"], sorted(["case.yaml", written])), what
        if target.exists():
            assert rbsm_dyn.open_history(target).status.startswith("failed"), what
        return
    written = str(target.relative_to(work.resolve()))
    assert listing(work) == sorted(["case.yaml", written]), what + err
    h = rbsm_dyn.open_history(target)
    if code == 1:
        STATS["failed_runs"] += 1
        assert FAILED_RUN.match(err.strip().splitlines()[-1]), what + err
        assert h.status.startswith("failed"), what
    else:
        assert code == 0, what + err
        assert h.status == "completed" and h.frames >= 1, what


def warm_up(root):
    """Compile the kernels each base uses (Numba) before the per-example time
    limit applies: a first compile is not a hang."""
    for name, text in BASES.items():
        work = root / f"warm-{name}"
        work.mkdir()
        (work / "case.yaml").write_text(text, encoding="utf-8")
        for argv in (["info", "case.yaml"], ["case.yaml", "--quiet", "--max-steps", "2"]):
            code, out, err = cli(argv, cwd=work)
            assert code == 0, err
        shutil.rmtree(work)


@st.composite
def mutated_cases(draw):
    base = draw(st.sampled_from(sorted(BASES)))
    data = copy.deepcopy(BASE_DATA[base])
    log = []
    for _ in range(draw(st.sampled_from([1, 1, 1, 2, 3]))):
        try:
            mutate(draw, data, log)
        except (AttributeError, TypeError, KeyError, IndexError):
            log.append(("skipped", ()))     # a mutation that did not fit this data
    n_text = draw(st.sampled_from([0, 0, 0, 0, 0, 1, 1, 2]))
    return base, data, log, n_text


@pytest.fixture
def fuzz_root(tmp_path, monkeypatch):
    """The sandbox of the examples; the temporary directory of the process is
    an empty one of its own (what is left in it is written where not asked)."""
    monkeypatch.setattr(case_check, "MAX_CELLS", FUZZ_MAX_CELLS)
    root = tmp_path / "fuzz"
    root.mkdir()
    temp = tmp_path / "temp"
    temp.mkdir()
    monkeypatch.setattr(tempfile, "tempdir", str(temp))
    return root


def test_fuzzed_case_files_exit_2_naming_the_key_or_run(fuzz_root):
    marker = str(fuzz_root / "pwned")
    for k in STATS:
        STATS[k] = 0

    @settings(max_examples=EXAMPLES, derandomize=True, database=None, deadline=None,
              phases=[Phase.explicit, Phase.generate, Phase.shrink],
              suppress_health_check=list(HealthCheck), print_blob=False)
    @given(st.data())
    def fuzz(d):
        STATS["examples"] += 1
        base, data, log, n_text = d.draw(mutated_cases())
        try:
            raw = _dump(data).encode("utf-8")
        except Exception:           # not representable (never for these values)
            raw = BASES[base].encode()
            data = BASE_DATA[base]
        for _ in range(n_text):
            raw = text_mutate(d.draw, raw, marker, log)
        if n_text:
            STATS["text"] += 1
        run_kind = d.draw(st.sampled_from(["check", "check", "info", "run_out", "run_default"]))
        fuzz_one(base, data, raw, log, run_kind, fuzz_root, marker)

    warm_up(fuzz_root)
    fuzz()
    print("fuzz statistics:", STATS)
    assert STATS["checked"] >= 1000, STATS
    assert STATS["exit2"] >= 300 and STATS["ok"] >= 100 and STATS["runs"] >= 20, STATS


# ------------------------------------------------------------ regressions ---
# Inputs the fuzzer found, each with the key its message must name.  Every
# one goes through the same in-process CLI entry as the fuzz.

def _edit(base, old, new):
    text = BASES[base]
    assert old in text, old
    return text.replace(old, new, 1)


REGRESSIONS = [
    # nested aliases (a "billion laughs" bomb) expanded to 10^9 values: hang
    ("alias bomb", (BOMB + BASES["modal_blocks"]).encode(), "a"),
    ("alias bomb in a value", _edit("modal_blocks", "name: fz-modal\n", "name: fz-modal\n"
                                    "description: {" + BOMB.replace("\n", ", ").rstrip(", ")
                                    + "}\n").encode(), "description"),
    # ... and ruamel printed the 10^8-value duplicate key in its message: hang
    ("duplicate key holding an alias bomb",
     (BASES["modal_blocks"] + "description: {" + BOMB.replace("\n", ", ").rstrip(", ")
      + "}\ndescription: *a8\n").encode(), "description"),
    # a list as a mapping key: TypeError (unhashable) inside ruamel
    ("list as a key", _edit("static_voronoi", "  end: {box:", "  ? - [1, 2]\n  : 1\n  end: {box:")
     .encode(), "groups"),
    # an alias inside the collection it names (a guard: ruamel makes it a None)
    ("recursive alias", (BASES["modal_blocks"] + "description: &r [1, *r]\n").encode(),
     "description"),
    # [[[[...]]]] 5000 deep: 30 s in ruamel's scanner (quadratic), then RecursionError
    ("nested too deeply", (BASES["modal_blocks"] + "description: " + "[" * 5000 + "]" * 5000
                           + "\n").encode(), "<document>"),
    # (one space per level: 1200 levels in 0.7 MB, under the 1 MiB a case file may have)
    ("nested blocks too deeply", (BASES["modal_blocks"] + "description:\n" + "".join(
        " " * i + "-\n" for i in range(1, 1200))).encode(), "<document>"),
    # an explicit tag the value does not fit: KeyError / ValueError inside ruamel
    ("!!bool 'x'", _edit("modal_blocks", "density: 8000", "density: !!bool 'x'").encode(),
     "materials.steel.density"),
    ("!!int 1.5", _edit("modal_blocks", "modes: 3", "modes: !!int 1.5").encode(), "solver.modes"),
    ("!!timestamp", _edit("modal_blocks", "name: fz-modal", "name: !!timestamp 2020-13-45")
     .encode(), "name"),
    # a key with a line separator (U+2028) printed raw: the message broke in two
    ("line separator in a key", b"b\xe2\x80\xa8" + BASES["modal_blocks"].encode(),
     "'b\\u2028name'"),
    # huge or tiny numbers: OverflowError in the cell count (size ** 3) ...
    ("mesh size 1e300", _edit("dynamic_voronoi_rupture", "size: 0.006", "size: 1.0e+300")
     .encode(), "mesh.size"),
    # ... LinAlgError (eigh of 0/0 inertia) for a domain of 1e-300 m ...
    ("domain 1e-300", _edit("modal_blocks", "[1.0, 0.1, 0.1]", "[1.0e-300, 1.0e-301, 1.0e-301]")
     .encode(), "domain.box[1][0]"),
    # ... OverflowError (end_time / dt = inf) in the explicit solver and an
    # ARPACK failure in the modal one for density 1e-300, young 1e300
    ("density 1e-300", _edit("dynamic_voronoi_rupture", "density: 2500", "density: 1.0e-300")
     .encode(), "materials.glass.density"),
    ("young 1e300", _edit("modal_blocks", "young: 200.0e9", "young: 1.0e+300").encode(),
     "materials.steel.young"),
    # a domain far from the origin: the Voronoi mesh failed (RuntimeError "failed to
    # tile the box" at 1e4 m, UFuncTypeError at 1e6 m for cells of 25 mm) ...
    ("voronoi 1e4 m away", _edit("static_voronoi", "[[0, 0, 0], [0.2, 0.05, 0.05]]",
                                 "[[1.0e+4, 0, 0], [10000.2, 0.05, 0.05]]").encode(),
     "domain.box"),
    ("voronoi 1e6 m away", _edit("static_voronoi", "[[0, 0, 0], [0.2, 0.05, 0.05]]",
                                 "[[1.0e+6, 1.0e+6, 0], [1000000.2, 1000000.05, 0.05]]").encode(),
     "domain.box"),
    # ... and blocks 1e15 m away were built from round-off (RuntimeWarnings, then
    # "solver.modes: SVD did not converge" named the wrong key)
    ("blocks 1e15 m away", _edit("modal_blocks", "[[0, 0, 0], [1.0, 0.1, 0.1]]",
                                 "[[1.0e+15, 0, 0], [1000000000000001.0, 0.1, 0.1]]").encode(),
     "domain.box"),
]


@pytest.mark.parametrize("what, raw, key", REGRESSIONS, ids=[r[0] for r in REGRESSIONS])
def test_regression(fuzz_root, what, raw, key):
    work = fuzz_root / "r"
    work.mkdir()
    (work / "case.yaml").write_bytes(raw)
    with time_limit(EXAMPLE_TIME_LIMIT):
        code, out, err = cli(["check", str(work / "case.yaml")], cwd=work)
    assert code == 2, out + err
    m = MESSAGE.match(err.strip())
    assert m and "\n" not in err.strip() and "Traceback" not in err, err
    assert m.group("line") != "?", err
    assert m.group("path").startswith(key), err


# ------------------------------------------------------------ output paths ---

@pytest.mark.parametrize("what, edit, argv, code, key", [
    # name: ../up used to make the default output ../up.h5, outside the directory
    ("name with a path", ("name: fz-modal", "name: ../up"), [], 0, ".._up.h5"),
    ("name with a slash", ("name: fz-modal", "name: /abs"), [], 0, "_abs.h5"),
    # h5py's FileNotFoundError / IsADirectoryError came out as tracebacks
    ("missing directory", ("solver:", "output: {file: sub/x.h5}\nsolver:"), [], 2, "output.file"),
    ("a directory", ("solver:", "output: {file: ..}\nsolver:"), [], 2, "output.file"),
    ("--out missing directory", None, ["--out", "nodir/x.h5"], 2, "--out"),
    ("--out a directory", None, ["--out", "."], 2, "--out"),
    # the run overwrote the case file with HDF5
    ("output.file is the case", ("solver:", "output: {file: case.yaml}\nsolver:"), [], 2,
     "output.file"),
    ("--out is the case", None, ["--out", "case.yaml"], 2, "--out"),
    ("control character", ("solver:", 'output: {file: "a\\x01.h5"}\nsolver:'), [], 2,
     "output.file"),
])
def test_output_is_written_only_where_asked(fuzz_root, what, edit, argv, code, key):
    work = fuzz_root / "w"
    work.mkdir()
    text = _edit("modal_blocks", *edit) if edit else BASES["modal_blocks"]
    (work / "case.yaml").write_text(text, encoding="utf-8")
    got, out, err = cli(["case.yaml", "--quiet", *argv], cwd=work)
    assert got == code, err
    assert "Traceback" not in err
    assert (work / "case.yaml").read_text(encoding="utf-8") == text
    if code == 0:
        assert listing(work) == sorted(["case.yaml", key])
    else:
        assert listing(work) == ["case.yaml"]
        assert len(err.strip().splitlines()) == 1 and key in err, err
        if key != "--out":
            assert MESSAGE.match(err.strip()), err
    assert not os.listdir(tempfile.gettempdir())


# -------------------------------------------------- the real command line ---

def _command(args, cwd, temp):
    """python -m rbsm_dyn ARGS in cwd, with its own empty temporary directory."""
    env = dict(os.environ, TMPDIR=str(temp), NUMBA_NUM_THREADS="1")
    env.pop("RBSM_PROGRESS", None)
    return subprocess.run([sys.executable, "-m", "rbsm_dyn", *args], cwd=cwd, env=env,
                          capture_output=True, text=True, timeout=300)


@pytest.fixture
def sandbox(tmp_path):
    work, temp = tmp_path / "work", tmp_path / "temp"
    work.mkdir()
    temp.mkdir()
    return work, temp


def _one_line_error(proc, key):
    assert proc.returncode == 2, proc.stderr
    assert "Traceback" not in proc.stderr
    lines = proc.stderr.strip().splitlines()
    assert len(lines) == 1, proc.stderr
    m = MESSAGE.match(lines[0])
    assert m and m.group("line") != "?", proc.stderr
    assert m.group("path").startswith(key), proc.stderr
    return m


@pytest.mark.parametrize("what, raw, key", [
    ("non-UTF-8 bytes", BASES["modal_blocks"].replace("fz-modal", "fz-mod\xe9l").encode("latin-1"),
     "<document>"),
    ("YAML syntax error", _edit("modal_blocks", "modes: 3}", "modes: [3}").encode(), "<document>"),
    # ruamel's ReusedAnchorWarning went to stderr before the message
    ("reused anchor", _edit("modal_blocks", "solver: {mode: modal, modes: 3}",
                            "solver: {mode: modal, modes: &n 3}\nx: &n 1").encode(), "x"),
], ids=["non-UTF-8", "syntax", "reused anchor"])
def test_command_line_bad_bytes(sandbox, what, raw, key):
    work, temp = sandbox
    (work / "case.yaml").write_bytes(raw)
    proc = _command(["case.yaml", "--quiet"], work, temp)
    m = _one_line_error(proc, key)
    assert m.group("file") == "case.yaml"
    if what == "non-UTF-8 bytes":
        assert "UTF-8" in proc.stderr and ":1: " in proc.stderr
    assert listing(work) == ["case.yaml"] and not os.listdir(temp)


def test_command_line_python_tags_construct_nothing(sandbox):
    """Tags that would build Python objects (PyYAML's unsafe loader) are
    refused before anything is constructed: no command runs, no file appears."""
    work, temp = sandbox
    marker = work / "pwned"
    tags = [f"!!python/object/apply:os.system ['touch {marker}']",
            f"!!python/object/new:subprocess.Popen {{args: [touch, {marker}]}}",
            "!!python/name:os.system"]
    for i, tag in enumerate(tags):
        text = _edit("modal_blocks", "name: fz-modal", f"name: {tag}")
        (work / "case.yaml").write_text(text, encoding="utf-8")
        proc = _command(["case.yaml", "--quiet"], work, temp)
        _one_line_error(proc, "name")
        assert "not allowed" in proc.stderr
        assert not marker.exists()
    assert listing(work) == ["case.yaml"] and not os.listdir(temp)


def test_command_line_writes_only_the_output_asked_for(sandbox):
    """A run writes its history where --out says (or output.file in the
    working directory) and nothing else: not in the working directory, not
    next to the case, not in the temporary directory."""
    work, temp = sandbox
    cases = work / "cases"
    cases.mkdir()
    (cases / "case.yaml").write_text(BASES["dynamic_blocks"], encoding="utf-8")
    (work / "results").mkdir()
    proc = _command(["cases/case.yaml", "--quiet", "--max-steps", "3",
                     "--out", "results/run.h5"], work, temp)
    assert proc.returncode == 0, proc.stderr
    assert listing(work) == ["cases", "cases/case.yaml", "results", "results/run.h5"]
    assert not os.listdir(temp)
    assert rbsm_dyn.open_history(work / "results" / "run.h5").status == "completed"
    # without --out: output.file (fz-dyn.h5) in the working directory
    proc = _command(["cases/case.yaml", "--quiet", "--max-steps", "3"], work, temp)
    assert proc.returncode == 0, proc.stderr
    assert listing(work) == ["cases", "cases/case.yaml", "fz-dyn.h5", "results",
                             "results/run.h5"]
    # check and info write nothing
    for command in ("check", "info"):
        proc = _command([command, "cases/case.yaml"], work, temp)
        assert proc.returncode == 0, proc.stderr
    assert listing(work) == ["cases", "cases/case.yaml", "fz-dyn.h5", "results",
                             "results/run.h5"]
    assert not os.listdir(temp)


def test_command_line_case_file_name_not_utf8(sandbox):
    """A case file whose name is not UTF-8: printing it crashed with
    UnicodeEncodeError when stdout is strict UTF-8 (PYTHONIOENCODING=utf-8)."""
    work, temp = sandbox
    name = os.fsdecode(b"c\xff.yaml")
    (work / name).write_text(BASES["modal_blocks"], encoding="utf-8")
    env = dict(os.environ, TMPDIR=str(temp), NUMBA_NUM_THREADS="1", PYTHONIOENCODING="utf-8")
    run = subprocess.run([sys.executable, "-m", "rbsm_dyn", "check", name], cwd=work, env=env,
                         capture_output=True, text=True, timeout=300, errors="replace")
    assert run.returncode == 0 and "ok (6 bodies" in run.stdout, run.stderr
    (work / name).write_text(_edit("modal_blocks", "modes: 3", "modes: 0"), encoding="utf-8")
    run = subprocess.run([sys.executable, "-m", "rbsm_dyn", "check", name], cwd=work, env=env,
                         capture_output=True, text=True, timeout=300, errors="replace")
    assert run.returncode == 2 and "Traceback" not in run.stderr, run.stderr
    assert len(run.stderr.strip().splitlines()) == 1 and "solver.modes" in run.stderr
