"""The kernel interface (DESIGN.md §11, physics/arrays.py): compiled
functions take a few containers, and parallel loops never touch one.

Read from the source (ast), so the rules hold for every kernel, including
those no test runs: no compiled function takes more than 12 parameters
(inlined leaf helpers: 30); inside a prange loop no container's field is
read (Numba loses writes to a NamedTuple's field inside a prange: numba
issues 5872, 7135, 10338), and a container goes only whole into a
compiled call, in a function with no other loop (it hid a container's
writes from the loop fuser);
a container unpacked into locals names its fields in their order."""
import ast
from pathlib import Path

import pytest

from rbsm_dyn.physics import arrays

PKG = Path(__file__).resolve().parent.parent / "rbsm_dyn"
MAX_PARAMS = 12
MAX_INLINE_PARAMS = 30
#: the parameter names the kernels give their containers
CONTAINERS = {"bodies": arrays.Bodies, "springs": arrays.Springs, "loads": arrays.Loads,
              "bs": arrays.BodyState, "hist": arrays.SpringHistory,
              "aux": arrays.PoissonSlots, "contact": arrays.ContactArrays,
              "stepping": arrays.Stepping, "relax": arrays.Relaxation,
              "pbodies": arrays.PlaneBodies, "psprings": arrays.PlaneSprings,
              "ploads": arrays.PlaneLoads, "ps": arrays.PlaneState}


def _jit_decorator(fn):
    """The njit decorator of a function definition (None if not compiled)."""
    for d in fn.decorator_list:
        call = d if isinstance(d, ast.Call) else None
        f = call.func if call else d
        name = f.attr if isinstance(f, ast.Attribute) else getattr(f, "id", "")
        if name in ("njit", "jit"):
            return call or d
    return None


def _inline(dec):
    return isinstance(dec, ast.Call) and any(
        k.arg == "inline" and isinstance(k.value, ast.Constant) and k.value.value == "always"
        for k in dec.keywords)


def kernels():
    """(file, function node, decorator) of every compiled function in the package."""
    out = []
    for p in sorted(PKG.rglob("*.py")):
        tree = ast.parse(p.read_text(encoding="utf-8"))
        for node in ast.walk(tree):
            if isinstance(node, ast.FunctionDef):
                dec = _jit_decorator(node)
                if dec is not None:
                    out.append((p.relative_to(PKG.parent), node, dec))
    return out


KERNELS = kernels()


def _is_prange(loop):
    it = loop.iter
    if not isinstance(it, ast.Call):
        return False
    f = it.func
    return (isinstance(f, ast.Attribute) and f.attr == "prange") or (
        isinstance(f, ast.Name) and f.id == "prange")


def test_there_are_kernels_and_prange_loops():
    assert len(KERNELS) > 50
    assert sum(1 for _, fn, _ in KERNELS for n in ast.walk(fn)
               if isinstance(n, ast.For) and _is_prange(n)) >= 8


def test_no_compiled_function_takes_more_than_12_parameters():
    too_long = []
    for path, fn, dec in KERNELS:
        n = len(fn.args.args) + len(fn.args.kwonlyargs)
        limit = MAX_INLINE_PARAMS if _inline(dec) else MAX_PARAMS
        if n > limit:
            too_long.append(f"{path}:{fn.lineno} {fn.name} ({n} > {limit})")
    assert not too_long, "\n".join(too_long)


def test_no_container_inside_a_prange_loop():
    """Inside a prange body: no attribute of anything but a module or an
    array's shape, and a container only as a whole argument of a compiled
    call (numba issue 7135: a call inside the loop keeps the writes made
    through a NamedTuple), in a function with no other loop (a container
    passed to a call hid its writes from the loop fuser, which fused two
    loops into a race)."""
    bad = []
    allowed_attr = {"shape", "size", "ndim"}
    for path, fn, _ in KERNELS:
        loops = [n for n in ast.walk(fn) if isinstance(n, (ast.For, ast.While))]
        for loop in (n for n in loops if isinstance(n, ast.For) and _is_prange(n)):
            call_args = {id(a) for stmt in loop.body for n in ast.walk(stmt)
                         if isinstance(n, ast.Call) and isinstance(n.func, ast.Name)
                         for a in n.args}
            for node in (n for stmt in loop.body for n in ast.walk(stmt)):
                if isinstance(node, ast.Name) and node.id in CONTAINERS:
                    if id(node) not in call_args:
                        bad.append(f"{path}:{node.lineno} {fn.name}: container {node.id!r}")
                    elif len(loops) > 1:
                        bad.append(f"{path}:{node.lineno} {fn.name}: container {node.id!r} "
                                   "passed to a call in a function with another loop")
                elif (isinstance(node, ast.Attribute) and node.attr not in allowed_attr
                      and not (isinstance(node.value, ast.Name)
                               and node.value.id in ("np", "nb", "math", "numba"))):
                    bad.append(f"{path}:{node.lineno} {fn.name}: attribute .{node.attr}")
    assert not bad, "\n".join(bad)


def test_a_container_is_unpacked_by_its_field_names_in_order():
    wrong = []
    n_unpacked = 0
    for path, fn, _ in KERNELS:
        for node in ast.walk(fn):
            if (isinstance(node, ast.Assign) and isinstance(node.value, ast.Name)
                    and node.value.id in CONTAINERS and isinstance(node.targets[0], ast.Tuple)):
                names = [t.id for t in node.targets[0].elts]
                fields = list(CONTAINERS[node.value.id]._fields)
                n_unpacked += 1
                # the relaxation reads the bodies' masses as the real ones
                names = ["body_mass" if x == "body_mass_real" else x for x in names]
                if names != fields:
                    wrong.append(f"{path}:{node.lineno} {fn.name}: {names} != {fields}")
    assert n_unpacked >= 5
    assert not wrong, "\n".join(wrong)


@pytest.mark.parametrize("name", sorted(CONTAINERS))
def test_container_fields_are_prefixed_by_their_entity_or_documented(name):
    """Every field of a container is named in the module docstring of
    physics/arrays.py (shapes and units are given there)."""
    doc = arrays.__doc__ + "".join(c.__doc__ or "" for c in CONTAINERS.values())
    missing = [f for f in CONTAINERS[name]._fields if f not in doc]
    assert not missing, f"{name}: {missing} not documented in physics/arrays.py"
