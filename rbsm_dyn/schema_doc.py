"""The case-file reference, generated from the schema (rbsm_dyn/case/).

``python -m rbsm_dyn.schema_doc`` writes docs/reference/case_keys.md: one
table per model of the schema (the top level, ``domain``, ``mesh``, each
form of a ``boundary`` item, ...), one row per key with its full key path,
its type or allowed values, its default, its bounds (pydantic ``gt``,
``ge``, ``lt``, ``le``, lengths), its unit dimension (``case.DIMENSIONS``,
with the unit in SI and in ``mm-N-s``) and the comment beside the field in
rbsm_dyn/case/, under the model's docstring.  ``--check`` compares instead and
exits 1 when the committed file is stale; tests/test_docs.py does the same
in the test suite, so the reference cannot drift from the schema.

Nothing here is written by hand but the page's head and the unit names:
a new model, field, bound or dimension in rbsm_dyn/case/ shows up in the file
(an unknown dimension is an error here, not a silent blank).
"""
from __future__ import annotations

import ast
import inspect
import io
import re
import sys
import textwrap
import tokenize
import types
from pathlib import Path
from typing import Annotated, Any, Literal, Union, get_args, get_origin

import annotated_types as at
from pydantic import BaseModel
from pydantic.fields import FieldInfo
from pydantic_core import PydanticUndefined

from . import case as schema

#: where the reference is written, relative to the repository root
OUTPUT = Path("docs") / "reference" / "case_keys.md"
REGENERATE = "python -m rbsm_dyn.schema_doc"

#: unit of each dimension of case.DIMENSIONS: (SI, mm-N-s)
UNITS = {
    "length": ("m", "mm"),
    "time": ("s", "s"),
    "1/time": ("1/s (rad/s)", "1/s (rad/s)"),
    "velocity": ("m/s", "mm/s"),
    "acceleration": ("m/s²", "mm/s²"),
    "force": ("N", "N"),
    "moment": ("N·m", "N·mm"),
    "stress": ("Pa", "MPa"),
    "density": ("kg/m³", "t/mm³"),
    "energy/area": ("J/m² (N/m)", "N/mm"),
    "history": ("[time s, amplitude 1]", "[time s, amplitude 1]"),
    "geometry": ("lengths m (a geometry node)", "lengths mm"),
    "geometry_scale": ("1 (file units to m)", "1 (file units to mm)"),
}

#: Corrections of docstrings in rbsm_dyn/case/ that no longer hold: (class name,
#: stale text, replacement), applied only while the model still says the
#: stale text (so that fixing the docstring there makes this a no-op).
DOC_FIXES = [
    ("Yield", "Yield criterion of the springs (accepted, not yet used by the solver).",
     "Yield criterion of the springs (perfect plasticity of each spring point, "
     "rbsm_dyn/physics/laws/plastic.py)."),
]

#: the order and titles of the sections: (model, title); models found by the
#: walk but not listed here are appended in the order met
TITLES = {
    "Case": "Top level",
}


# ------------------------------------------------------------ type names ---

def _closure(func) -> dict:
    """The closure variables of a validator function (_length, _fix_list)."""
    code = getattr(func, "__code__", None)
    cells = getattr(func, "__closure__", None) or ()
    if code is None:
        return {}
    return {name: cell.cell_contents for name, cell in zip(code.co_freevars, cells)}


def _strip(tp: Any) -> tuple[Any, list, bool]:
    """(inner type, metadata, optional) with Annotated and Optional removed."""
    meta: list = []
    optional = False
    while True:
        origin = get_origin(tp)
        if origin is Annotated:
            args = get_args(tp)
            tp, meta = args[0], meta + list(args[1:])
            continue
        if origin in (Union, types.UnionType):
            args = [a for a in get_args(tp) if a is not type(None)]
            if len(args) < len(get_args(tp)):
                optional = True
            if len(args) == 1:
                tp = args[0]
                continue
        return tp, meta, optional


def _constraint_text(meta: list) -> list[str]:
    out = []
    for m in meta:
        if isinstance(m, FieldInfo):
            out += _constraint_text(m.metadata)
        elif isinstance(m, at.Gt):
            out.append(f"> {m.gt:g}")
        elif isinstance(m, at.Ge):
            out.append(f"≥ {m.ge:g}")
        elif isinstance(m, at.Lt):
            out.append(f"< {m.lt:g}")
        elif isinstance(m, at.Le):
            out.append(f"≤ {m.le:g}")
        elif isinstance(m, at.MinLen):
            out.append(f"at least {m.min_length} item" + ("s" if m.min_length > 1 else ""))
        elif isinstance(m, at.MaxLen):
            out.append(f"at most {m.max_length} items")
    return out


def _validators(meta: list) -> dict:
    """What the before-validators of a type say: length/form, fix list."""
    out = {}
    for m in meta:
        func = getattr(m, "func", None)
        if func is None:
            continue
        env = _closure(func)
        if "n" in env and "form" in env:
            out["length"] = (env["n"], env["form"])
        if "components" in env:
            out["all"] = env["components"]
    return out


def type_text(tp: Any, extra: list = ()) -> tuple[str, list[str]]:
    """(the type or allowed values as a reader writes them, bounds);
    ``extra``: the field's own metadata (pydantic moves a field's top-level
    Annotated metadata there)."""
    tp, meta, _ = _strip(tp)
    meta = list(extra) + meta
    cons = _constraint_text(meta)
    val = _validators(meta)
    origin = get_origin(tp)
    if tp is str:
        cons = ["not empty" if c.startswith("at least 1 item") else c for c in cons]
    if origin is Literal:
        text = ", ".join(f"`{v}`" for v in get_args(tp))
        text = ("one of " if len(get_args(tp)) > 1 else "") + text
    elif tp is bool:
        text = "`true` or `false`"
    elif tp is int:
        text = "integer"
    elif tp is float:
        text = "number"
    elif tp is str:
        text = "string"
    elif tp is dict:
        text = "mapping (a geometry node's keys)"
    elif isinstance(tp, type) and issubclass(tp, BaseModel):
        text = f"mapping ([{tp.__name__}](#{_anchor(tp)}))"
    elif origin is list or tp is list:
        args = get_args(tp)
        item = args[0] if args else Any
        if args and _models(item):
            names = ", ".join(f"[{m.__name__}](#{_anchor(m)})" for m in _models(item))
            text = f"list of mappings ({names})"
        elif args:
            inner, inner_cons = type_text(item)
            text = f"list of {_plural(inner)}"
            cons += [f"each {c}" for c in inner_cons]
        else:
            text = "list of geometry nodes"
        if "length" in val:
            n, form = val["length"]
            head, _, note = form.partition(" (")
            inner = _strip(item)[0]
            what = {int: "integers", str: "names", float: "numbers"}.get(inner, "")
            text = f"`{head}`" + (f" ({n} {what})" if what and n > 2 or what == "names" else "") \
                + (f" ({note}" if note else "")
        if "all" in val:
            text = f"`all` or a {text} (`all` = {', '.join(val['all'])})"
    elif origin is dict:
        names = ", ".join(f"[{m.__name__}](#{_anchor(m)})" for m in _models(get_args(tp)[1]))
        text = f"mapping name → {names}" if names else "mapping"
    elif origin in (Union, types.UnionType):
        text = " or ".join(type_text(a)[0] for a in get_args(tp))
    else:
        text = getattr(tp, "__name__", str(tp))
    return text, cons


def _plural(text: str) -> str:
    words = {"number": "numbers", "integer": "integers", "string": "strings"}
    if text in words:
        return words[text]
    if text.startswith("one of "):
        return "items, each " + text
    return text


def _models(tp: Any) -> list[type]:
    """The BaseModel classes a type holds (through lists, dicts, unions)."""
    tp, _, _ = _strip(tp)
    if isinstance(tp, type) and issubclass(tp, BaseModel):
        return [tp]
    out: list = []
    for a in get_args(tp):
        for m in _models(a):
            if m not in out:
                out.append(m)
    return out


def _container(tp: Any) -> str:
    """How a field's models are reached: '' (a mapping), '[]' (a list of
    them), '.<name>' (a mapping of named ones)."""
    tp, _, _ = _strip(tp)
    origin = get_origin(tp)
    if origin is list:
        return "[]"
    if origin is dict:
        return ".<name>"
    return ""


def _anchor(model: type) -> str:
    return "model-" + model.__name__.lower()


# --------------------------------------------------------- comments, docs ---

def field_comments(model: type) -> dict[str, str]:
    """The ``# comment`` beside each field in the class body (rbsm_dyn/case/)."""
    try:
        source = textwrap.dedent(inspect.getsource(model))
    except (OSError, TypeError):
        return {}
    tree = ast.parse(source)
    body = tree.body[0].body if tree.body and isinstance(tree.body[0], ast.ClassDef) else []
    comments = {}
    for tok in tokenize.generate_tokens(io.StringIO(source).readline):
        if tok.type == tokenize.COMMENT:
            comments[tok.start[0]] = tok.string.lstrip("#").strip()
    out = {}
    for node in body:
        if isinstance(node, ast.AnnAssign) and isinstance(node.target, ast.Name):
            text = comments.get(node.end_lineno)
            if text:
                out[node.target.id] = text
    return out


#: references to design notes that are not in the repository, dropped
#: from the docstrings: "(DESIGN.md §6)", "DESIGN.md §8, "
MISSING_REFS = re.compile(r"\s*\((?:DESIGN|VERIFICATION)\.md[^),]*\)|(?:DESIGN|VERIFICATION)\.md[^),]*, ")


def docstring(model: type) -> str:
    """The model's own docstring (not its base's), on one line, with the
    corrections of DOC_FIXES and without MISSING_REFS."""
    doc = inspect.cleandoc(model.__dict__.get("__doc__") or "")
    for name, stale, new in DOC_FIXES:
        if model.__name__ == name and stale in doc:
            doc = doc.replace(stale, new)
    doc = MISSING_REFS.sub("", doc)
    return " ".join(doc.split())


def _default_text(f: FieldInfo) -> str:
    if f.default is PydanticUndefined and f.default_factory is None:
        return "**required**"
    value = f.default if f.default_factory is None else f.default_factory()
    if value is None:
        return "—"
    if isinstance(value, BaseModel):
        given = value.model_dump(exclude_unset=True)
        return "`{}`" if not given else f"`{given}`"
    if isinstance(value, bool):
        return "`true`" if value else "`false`"
    return f"`{_yaml(value)}`"


def _yaml(value: Any) -> str:
    """A default as it would be written in the case file (flow style)."""
    if isinstance(value, list):
        return "[" + ", ".join(_yaml(v) for v in value) + "]"
    if isinstance(value, dict):
        return "{" + ", ".join(f"{k}: {_yaml(v)}" for k, v in value.items()) + "}"
    return schema._show(value).strip("'")


def _unit_text(model: type, name: str) -> str:
    dim = schema.DIMENSIONS.get((model, name))
    if dim is None:
        return ""
    if dim not in UNITS:
        raise KeyError(f"dimension {dim!r} of {model.__name__}.{name} has no unit name in "
                       "rbsm_dyn/schema_doc.py UNITS")
    si, mm = UNITS[dim]
    return f"{dim}: {si}" + (f" / {mm}" if mm != si else "")


# ------------------------------------------------------------------ walk ---

def walk(root: type = None) -> list[tuple[type, list[str]]]:
    """Every model reachable from ``root`` (default schema.Case), in the
    order met (depth first), with the key paths at which it occurs."""
    root = root or schema.Case
    order: list[type] = []
    paths: dict[type, list[str]] = {}

    def visit(model: type, path: str) -> None:
        if model in paths:
            if path not in paths[model]:
                paths[model].append(path)
            return
        order.append(model)
        paths[model] = [path]
        for name, f in model.model_fields.items():
            key = f.alias or name
            sub = f"{path}.{key}" if path else key
            for m in _models(f.annotation):
                visit(m, sub + _container(f.annotation))

    visit(root, "")
    return [(m, paths[m]) for m in order]


def keys(root: type = None) -> list[tuple[str, type, str]]:
    """(full key path, model, YAML key) of every key the schema accepts."""
    out = []
    for model, paths in walk(root):
        for path in paths:
            for name, f in model.model_fields.items():
                key = f.alias or name
                out.append((f"{path}.{key}" if path else key, model, key))
    return out


def _text(text: str) -> str:
    """Prose for Markdown: ``<`` and ``>`` outside code spans escaped (so
    that ``<name>`` is not taken for an HTML tag)."""
    parts = re.split(r"(`+[^`]*?`+)", text)
    return "".join(p if p.startswith("`") else p.replace("<", "&lt;").replace(">", "&gt;")
                   for p in parts)


def _cell(text: str) -> str:
    return text.replace("|", "\\|").replace("\n", " ")


HEAD = """\
# Case-file reference

<!-- generated by `{cmd}` from rbsm_dyn/case/: do not edit by hand;
     tests/test_docs.py fails when this file is stale -->

Every key a case file accepts, generated from the schema in
`rbsm_dyn/case/` (the pydantic models; `{cmd}` writes this page, and
the test suite fails when it no longer matches the schema).  The
[case file](../case_file.md) page explains what the keys do and how they
work together; this page is the complete list.

How to read the tables:

* **key**: the full key path; `<name>` is a name you choose (a material,
  a group, a part, a probe), `[]` an item of a list.
* **type / allowed values**: `number` is an integer or a decimal (never a
  string, a boolean, NaN or infinity), `integer` a whole number; `or
  null` means the key may be given as `null` (the same as leaving it out).
* **default**: **required** keys must be given; `—` means the key is
  optional with no default (leaving it out means "not used", or a default
  computed from other keys: see the description).  Some keys are required
  only in some modes or forms (`solver.end_time` in mode `dynamic`); the
  [case file](../case_file.md) page and `python -m rbsm_dyn check` say
  which.
* **bounds**: the value's limits, checked when the case is read (a value
  outside is an error naming the file, the line and the key path).
* **unit**: the key's dimension, then its unit in SI / in `units: mm-N-s`
  (a single unit when both are the same).  Keys without a dimension are
  dimensionless or not numbers; angles are in degrees.
* **note**: the comment beside the field in `rbsm_dyn/case/`.

Every model refuses keys it does not list.  The geometry nodes under
`domain` and `parts.<name>.geometry` (`cylinder`, `sphere`, `prism`,
`union`, `difference`, `intersection`, `file` and their keys) are checked
by `rbsm_dyn.geometry`, not by this schema: see
[geometry](../case_file.md#geometry).
"""


def generate() -> str:
    """The text of docs/reference/case_keys.md."""
    lines = [HEAD.format(cmd=REGENERATE)]
    for model, paths in walk():
        title = TITLES.get(model.__name__) or (
            ", ".join(f"`{p}`" for p in paths) + f" ({model.__name__})")
        lines.append(f'## {title} {{#{_anchor(model)}}}\n')
        lines.append(f"Model `{model.__name__}`" + (
            f", at {', '.join(f'`{p}`' for p in paths)}" if model is not schema.Case else "")
            + ".\n")
        doc = docstring(model)
        if doc:
            lines.append(_text(doc) + "\n")
        comments = field_comments(model)
        lines.append("| key | type / allowed values | default | bounds | unit | note |")
        lines.append("|---|---|---|---|---|---|")
        for name, f in model.model_fields.items():
            key = f.alias or name
            path = f"{paths[0]}.{key}" if paths[0] else key
            kind, cons = type_text(f.annotation, f.metadata)
            row = [f"`{path}`", kind, _default_text(f), ", ".join(cons),
                   _unit_text(model, name), _text(comments.get(name, ""))]
            lines.append("| " + " | ".join(_cell(c) for c in row) + " |")
        lines.append("")
    return "\n".join(lines).rstrip() + "\n"


def main(argv: list[str] | None = None) -> int:
    argv = sys.argv[1:] if argv is None else argv
    root = Path(__file__).resolve().parent.parent
    target = root / OUTPUT
    text = generate()
    if "--check" in argv:
        if not target.exists() or target.read_text(encoding="utf-8") != text:
            print(f"{OUTPUT} is stale: regenerate with {REGENERATE}", file=sys.stderr)
            return 1
        print(f"{OUTPUT} is up to date")
        return 0
    target.parent.mkdir(parents=True, exist_ok=True)
    target.write_text(text, encoding="utf-8")
    print(f"wrote {OUTPUT} ({len(keys())} keys)")
    return 0


if __name__ == "__main__":
    sys.exit(main())
