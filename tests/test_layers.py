"""Data flows one way (DESIGN.md §3, docs/modules.md "Layers"): every
import inside the package, at module level or inside a function, goes to
a lower layer or stays in its own unit, and no two modules import each
other, directly or round a circle.  Read from the source (ast)."""
import ast
from pathlib import Path

PKG = Path(__file__).resolve().parent.parent / "rbsm_dyn"

#: the layers, lowest first: a unit may import its own modules and those of
#: lower layers only (docs/modules.md draws the same table)
LAYERS = [
    {"_version", "partition", "calibration", "fracture_calibration", "compression_calibration",
     "records", "threads", "_kernel_cache", "compile_once", "mpi_env", "domains"},
    {"physics"},              # kernels only
    {"mesh"},
    {"geometry"},
    {"case"},
    {"model"},
    {"stiffness", "io"},      # io: history, model cache, export, render
    {"solvers"},
    {"cli", "bench", "schema_doc", "__init__", "__main__"},
]
RANK = {u: r for r, layer in enumerate(LAYERS) for u in layer}


def modules():
    out = {}
    for p in PKG.rglob("*.py"):
        parts = p.relative_to(PKG.parent).with_suffix("").parts
        name = ".".join(parts[:-1] if parts[-1] == "__init__" else parts)
        out[name] = p
    return out


MODULES = modules()


def imports(name, path):
    """The package modules `name` imports (module and function level)."""
    pkg = name if path.name == "__init__.py" else name.rsplit(".", 1)[0]
    found = set()
    for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
        if isinstance(node, ast.ImportFrom):
            if node.level:
                base = pkg.split(".")[:len(pkg.split(".")) - node.level + 1]
                mod = ".".join(base + ([node.module] if node.module else []))
            else:
                mod = node.module or ""
            if not mod.startswith("rbsm_dyn"):
                continue
            for a in node.names:       # `from . import x` may name a module
                sub = f"{mod}.{a.name}"
                found.add(sub if sub in MODULES else mod)
        elif isinstance(node, ast.Import):
            found |= {a.name for a in node.names if a.name.startswith("rbsm_dyn")}
    return {m for m in found if m in MODULES and m != name}


GRAPH = {m: imports(m, p) for m, p in MODULES.items()}


def unit(name):
    parts = name.split(".")
    return parts[1] if len(parts) > 1 else "__init__"


def test_every_unit_has_a_layer():
    assert {unit(m) for m in MODULES} <= set(RANK), {unit(m) for m in MODULES} - set(RANK)


def test_imports_go_down_the_layers():
    up = [f"{a} imports {b}" for a, bs in GRAPH.items() for b in bs
          if unit(a) != unit(b) and RANK[unit(b)] > RANK[unit(a)]]
    assert not up, "\n".join(sorted(up))


def test_no_import_circles():
    """Tarjan's strongly connected components of the module graph: none
    with more than one module."""
    index, low, stack, on, comps, count = {}, {}, [], set(), [], [0]

    def visit(v):
        index[v] = low[v] = count[0]
        count[0] += 1
        stack.append(v)
        on.add(v)
        for w in GRAPH[v]:
            if w not in index:
                visit(w)
                low[v] = min(low[v], low[w])
            elif w in on:
                low[v] = min(low[v], index[w])
        if low[v] == index[v]:
            comp = []
            while True:
                w = stack.pop()
                on.discard(w)
                comp.append(w)
                if w == v:
                    break
            if len(comp) > 1:
                comps.append(sorted(comp))

    for v in GRAPH:
        if v not in index:
            visit(v)
    assert len(GRAPH) > 80
    assert not comps, comps
