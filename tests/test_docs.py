"""The documentation tells the truth about the schema, and it builds.

* the case-file reference (docs/reference/case_keys.md) is what
  ``python -m rbsm_dyn.schema_doc`` makes of rbsm_dyn/case/ today, and it
  and docs/case_file.md name every key (and every allowed value) the schema
  accepts;
* every YAML example in docs/*.md that is a case, or a fragment of one
  (a mapping of top-level case keys), validates: a whole case as it is, a
  fragment merged into a small valid case;
* ``mkdocs build --strict`` passes (warnings, broken links and anchors
  between pages among them, are errors: mkdocs.yml "validation").
"""
from __future__ import annotations

import copy
import re
import subprocess
import sys
from pathlib import Path
from typing import Literal, get_args, get_origin

import pytest
from ruamel.yaml import YAML
from ruamel.yaml.error import YAMLError

from rbsm_dyn import case as schema
from rbsm_dyn import schema_doc
from rbsm_dyn.case import CaseError, load_case_text

ROOT = Path(__file__).resolve().parent.parent
DOCS = ROOT / "docs"
REFERENCE = ROOT / schema_doc.OUTPUT
CASE_FILE_MD = DOCS / "case_file.md"
TOP_KEYS = {f.alias or n for n, f in schema.Case.model_fields.items()}


# ------------------------------------------------ the generated reference ---

def test_reference_is_up_to_date():
    committed = REFERENCE.read_text(encoding="utf-8") if REFERENCE.exists() else ""
    assert committed == schema_doc.generate(), (
        f"{schema_doc.OUTPUT} does not match rbsm_dyn/case/: regenerate with "
        f"{schema_doc.REGENERATE} and commit it")


def _schema_models() -> list[type]:
    """Every model class of rbsm_dyn/case/, found apart from schema_doc's
    walk (every subclass of the schema's base model, recursively)."""
    out, todo = [], [schema._Node]
    while todo:
        for sub in todo.pop().__subclasses__():
            if sub.__module__.startswith(schema.__name__ + ".") and sub not in out:
                out.append(sub)
                todo.append(sub)
    return out


def test_reference_has_every_model_and_key():
    text = REFERENCE.read_text(encoding="utf-8")
    rows = re.findall(r"^\| `([^`]+)` \|", text, flags=re.M)
    for model in _schema_models():
        assert f"Model `{model.__name__}`" in text, (
            f"the schema's model {model.__name__} has no section in {schema_doc.OUTPUT} "
            f"(is it reachable from Case? regenerate with {schema_doc.REGENERATE})")
        for name, f in model.model_fields.items():
            key = f.alias or name
            assert any(r == key or r.endswith("." + key) for r in rows), (
                f"{model.__name__}.{name} (YAML key {key!r}) has no row in "
                f"{schema_doc.OUTPUT}")
    for path, model, key in schema_doc.keys():
        paths = dict(schema_doc.walk())[model]
        first = f"{paths[0]}.{key}" if paths[0] else key
        assert first in rows, f"key {first} has no row in {schema_doc.OUTPUT}"
        where = path.rsplit(".", 1)[0] if "." in path else ""
        assert not where or f"`{where}`" in text, (
            f"key path {path}: its mapping `{where}` is not named in {schema_doc.OUTPUT}")


def test_every_key_is_in_case_file_md():
    """Each YAML key of the schema is named in docs/case_file.md: as a code
    span `key`, or as `key:` inside code (a span or an example block)."""
    text = CASE_FILE_MD.read_text(encoding="utf-8")
    code = " ".join(re.findall(r"`([^`]*)`", text)) + "\n" + "\n".join(
        line for line in text.splitlines() if line.startswith("    "))
    missing = []
    for path, model, key in schema_doc.keys():
        if f"`{key}`" in text or re.search(rf"(?<![\w.-]){re.escape(key)}:", code):
            continue
        missing.append(path)
    assert not missing, f"keys the schema accepts but docs/case_file.md never names: {missing}"


def _literals(tp) -> set:
    if get_origin(tp) is Literal:
        return set(get_args(tp))
    out: set = set()
    for a in get_args(tp):
        out |= _literals(a)
    return out


def test_every_allowed_value_is_in_case_file_md():
    """Each value a Literal of the schema allows (a mode, a law, a field,
    a probe quantity) is named in docs/case_file.md."""
    text = CASE_FILE_MD.read_text(encoding="utf-8")
    missing = []
    for model in _schema_models():
        for name, f in model.model_fields.items():
            for value in sorted(_literals(f.annotation)):
                if not re.search(rf"(?<![\w.-]){re.escape(value)}(?![\w-])", text):
                    missing.append(f"{model.__name__}.{name}: {value}")
    assert not missing, f"allowed values docs/case_file.md never names: {missing}"


# ------------------------------------------------------- the YAML examples ---

def code_blocks(text: str) -> list[tuple[int, str, str]]:
    """(line, kind, code) of every fenced block (kind: its language or
    'fenced') and every indented block (kind 'indented') of a Markdown text."""
    lines = text.splitlines()
    out = []
    i = 0
    while i < len(lines):
        m = re.match(r"^\s*```\s*(\w*)", lines[i])
        if m:
            j, buf = i + 1, []
            while j < len(lines) and not lines[j].strip().startswith("```"):
                buf.append(lines[j])
                j += 1
            out.append((i + 1, m.group(1) or "fenced", "\n".join(buf)))
            i = j + 1
            continue
        if lines[i].startswith("    ") and (i == 0 or not lines[i - 1].strip()):
            j, buf = i, []
            while j < len(lines) and (lines[j].startswith("    ") or not lines[j].strip()):
                buf.append(lines[j][4:])
                j += 1
            out.append((i + 1, "indented", "\n".join(buf).rstrip()))
            i = j
            continue
        i += 1
    return out


def _parse(code: str):
    try:
        return YAML(typ="safe", pure=True).load(code)
    except YAMLError:
        return None


def _chunks(code: str) -> list[tuple[int, str]]:
    """A block of several examples (``mesh: {...}`` on two lines, blank
    lines between): each top-level item with its continuation lines."""
    out: list[list] = []
    for k, line in enumerate(code.splitlines()):
        if line and not line[0].isspace() and not line.startswith("#"):
            out.append([k, [line]])
        elif out:
            out[-1][1].append(line)
    return [(k, "\n".join(body)) for k, body in out]


def yaml_examples() -> list[tuple[str, str]]:
    """(where, code) of every example in docs/*.md that is a case or a
    mapping of top-level case keys.  A ```yaml block must be one; an
    indented or unlabelled block counts when it parses as one (a block of
    several one-line examples is split into them)."""
    found = []
    for md in sorted(DOCS.glob("*.md")):
        for line, kind, code in code_blocks(md.read_text(encoding="utf-8")):
            where = f"docs/{md.name}:{line}"
            data = _parse(code)
            if kind == "yaml":
                found.append((where, code))
                continue
            if kind not in ("indented", "fenced"):
                continue
            if isinstance(data, dict) and data and set(data) <= TOP_KEYS:
                found.append((where, code))
            elif data is None and code.strip():
                for k, chunk in _chunks(code):
                    d = _parse(chunk)
                    if isinstance(d, dict) and d and set(d) <= TOP_KEYS:
                        found.append((f"docs/{md.name}:{line + k}", chunk))
    return found


#: The small valid case a fragment is merged into: a box, two materials,
#: the groups, a probe and a surface the examples of docs/case_file.md name.
BASE = """\
name: doc-example
domain: {box: [[0, 0, 0], [1.0, 0.1, 0.1]]}
mesh: {kind: blocks, divisions: [10, 1, 1]}
materials:
  steel: {density: 7850, young: 2.0e11, poisson: 0.3}
  concrete: {density: 2400, young: 3.0e10, poisson: 0.2}
groups:
  tip: {box: [[0.9, -1, -1], [1.1, 1, 1]]}
  low: {box: [[-1, -1, -1], [0.1, 1, 1]]}
  high: {box: [[0.9, -1, -1], [1.1, 1, 1]]}
solver: {mode: dynamic, end_time: 1.0e-3}
"""

#: keys whose mappings a fragment adds to (the others it replaces)
MERGED = ("materials", "groups", "output")


def merged(fragment: dict) -> dict:
    case = YAML(typ="safe", pure=True).load(BASE)
    for key, value in fragment.items():
        if key in MERGED and isinstance(value, dict):
            case[key] = {**case.get(key, {}), **value}
        else:
            case[key] = copy.deepcopy(value)
    if "parts" in fragment:                      # a scene replaces the shorthand
        case.pop("domain", None)
        case.pop("mesh", None)
    probes = case.get("output", {}).get("probes", {})
    control = (case["solver"].get("control") or {}).get("probe")
    if control and control not in probes:        # a control names its probe
        case.setdefault("output", {})["probes"] = {**probes, control: {
            "quantity": "relative_displacement", "groups": ["low", "high"],
            "component": "x"}}
    return case


def _dump(data: dict) -> str:
    import io
    out = io.StringIO()
    YAML(typ="safe", pure=True).dump(data, out)
    return out.getvalue()


@pytest.fixture(scope="module")
def example_dir(tmp_path_factory):
    """A directory for the examples' case files, with the geometry files
    they name (docs/case_file.md: roller.stl, a cylinder along z)."""
    import trimesh
    d = tmp_path_factory.mktemp("doc_examples")
    trimesh.creation.cylinder(radius=0.05, height=0.1, sections=32).export(d / "roller.stl")
    return d


EXAMPLES = yaml_examples()


def test_examples_are_found():
    """The extraction finds the examples of docs/case_file.md (a parser
    that found none would make the next test pass vacuously)."""
    where = [w for w, _ in EXAMPLES if w.startswith("docs/case_file.md")]
    assert len(where) >= 12, f"only {len(where)} case examples found in docs/case_file.md: {where}"


@pytest.mark.parametrize("where,code", EXAMPLES, ids=[w for w, _ in EXAMPLES])
def test_yaml_example_validates(where, code, example_dir):
    data = _parse(code)
    assert isinstance(data, dict), f"{where}: a ```yaml example that is not a YAML mapping"
    bad = set(data) - TOP_KEYS
    assert not bad, f"{where}: a ```yaml example with keys that are not case keys: {sorted(bad)}"
    whole = "name" in data and "solver" in data
    text = code if whole else _dump(merged(data))
    try:
        load_case_text(text, str(example_dir / "example.yaml"))
    except CaseError as exc:
        what = "the case" if whole else "the fragment, merged into a small valid case,"
        pytest.fail(f"{where}: {what} does not validate: {exc}\n--- YAML ---\n{text}")


# ------------------------------------------------------------- the build ---

def test_mkdocs_build_strict(tmp_path):
    """The site builds with warnings as errors (CI runs this test)."""
    proc = subprocess.run(
        [sys.executable, "-m", "mkdocs", "build", "--strict", "--quiet",
         "-f", str(ROOT / "mkdocs.yml"), "-d", str(tmp_path / "site")],
        cwd=ROOT, capture_output=True, text=True, timeout=120)
    assert proc.returncode == 0, (
        f"mkdocs build --strict failed (exit {proc.returncode}):\n{proc.stdout}\n{proc.stderr}")
    for page in ("index.html", "case_file/index.html", "reference/case_keys/index.html",
                 "theory/index.html", "benchmarks/index.html"):
        assert (tmp_path / "site" / page).is_file(), f"the built site has no {page}"
