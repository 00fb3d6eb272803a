"""The built model kept beside its case, so that a rerun skips the build
(issue 15, item 3).

A run whose build took at least MIN_BUILD_SECONDS writes the model to
``<case dir>/.rbsm_cache/<case file name>.model.npz``; the next run of a
case with the same key loads it instead of building.  The key is a SHA-256
of

* the package version and the text of every module of the package (any
  change of the code that builds a model starts afresh),
* the validated case in SI with its defaults (``Case.resolved``), less what
  a build never reads: ``name``, ``output``, ``initial`` and
  ``solver.threads``,
* the bytes of every file the geometry reads (``file:`` nodes).

So a rerun with another ``end_time`` is a rebuild (the solver section
enters the prescribed motions' histories), a rerun with other output or
initial velocities is not.  One file per case: a new key replaces it.

The file holds only arrays (``np.load`` without pickle) and a JSON tree of
the model's dataclasses, rebuilt from classes of this package only: a
cache file cannot run code.  A missing, stale, unreadable or foreign file
is a rebuild, never an error; a cache folder that cannot be written is
skipped with a note.  ``--no-model-cache`` (or RBSM_MODEL_CACHE=0) turns it
off.
"""
import dataclasses
import hashlib
import importlib
import json
import os
from pathlib import Path

import numpy as np

MIN_BUILD_SECONDS = 2.0      # quicker builds are not worth a file
FOLDER = ".rbsm_cache"
_FORMAT = 1


def enabled():
    """False when RBSM_MODEL_CACHE is 0/no/off."""
    return os.environ.get("RBSM_MODEL_CACHE", "1").strip().lower() not in ("0", "no", "off",
                                                                           "false")


def cache_file(case):
    """Path of the case's cache file, or None for a case not read from a file."""
    src = getattr(case, "_source_file", None)
    if not src or src.startswith("<"):
        return None
    p = Path(src)
    return p.parent / FOLDER / f"{p.name}.model.npz"


def _sources_hash():
    from .._version import __version__
    root = Path(__file__).resolve().parent.parent
    h = hashlib.sha256(__version__.encode())
    for p in sorted(root.rglob("*.py")):
        h.update(str(p.relative_to(root)).encode())
        h.update(p.read_bytes())
    return h.hexdigest()


_SOURCES = None


def cache_key(case):
    """Hex key of what a build of `case` depends on (module docstring)."""
    global _SOURCES
    if _SOURCES is None:
        _SOURCES = _sources_hash()
    data = case.resolved()
    for k in ("name", "output", "initial"):
        data.pop(k, None)
    if isinstance(data.get("solver"), dict):
        data["solver"].pop("threads", None)
    h = hashlib.sha256(_SOURCES.encode())
    h.update(json.dumps(data, sort_keys=True, default=str).encode())
    from ..case import _case_dir
    base = _case_dir(case)
    for name in sorted(set(_files_of(data))):
        p = Path(name) if Path(name).is_absolute() else base / name
        h.update(name.encode())
        try:
            h.update(p.read_bytes())
        except OSError:
            h.update(b"<unreadable>")
    return h.hexdigest()


def _files_of(node):
    """Paths named by `file:` keys anywhere in a resolved case."""
    if isinstance(node, dict):
        for k, v in node.items():
            if k == "file" and isinstance(v, str):
                yield v
            else:
                yield from _files_of(v)
    elif isinstance(node, list):
        for v in node:
            yield from _files_of(v)


# ---- a model as arrays + a JSON tree ---------------------------------------

def _flatten(obj, arrays):
    if isinstance(obj, np.ndarray):
        if obj.dtype.hasobject:
            raise TypeError("object array")
        key = f"a{len(arrays)}"
        arrays[key] = obj
        return {"nd": key}
    if dataclasses.is_dataclass(obj) and not isinstance(obj, type):
        return {"dc": _class_name(obj),
                "f": {f.name: _flatten(getattr(obj, f.name), arrays)
                      for f in dataclasses.fields(obj)}}
    if isinstance(obj, tuple) and hasattr(obj, "_fields"):
        return {"nt": _class_name(obj), "f": [_flatten(v, arrays) for v in obj]}
    if isinstance(obj, tuple):
        return {"tu": [_flatten(v, arrays) for v in obj]}
    if isinstance(obj, list):
        return {"li": [_flatten(v, arrays) for v in obj]}
    if isinstance(obj, dict):
        if not all(isinstance(k, str) for k in obj):
            raise TypeError("dict with keys that are not strings")
        return {"di": {k: _flatten(v, arrays) for k, v in obj.items()}}
    if isinstance(obj, np.generic):
        obj = obj.item()
    if obj is None or isinstance(obj, (bool, int, float, str)):
        return {"v": obj}
    raise TypeError(f"cannot keep a {type(obj).__name__}")


def _class_name(obj):
    cls = type(obj)
    if not cls.__module__.startswith("rbsm_dyn."):
        raise TypeError(f"class {cls.__module__}.{cls.__qualname__}")
    return f"{cls.__module__}:{cls.__qualname__}"


def _class(name):
    mod, _, qual = name.partition(":")
    if not mod.startswith("rbsm_dyn."):
        raise ValueError(f"foreign class {name}")
    obj = importlib.import_module(mod)
    for part in qual.split("."):
        obj = getattr(obj, part)
    return obj


def _unflatten(node, arrays):
    tag = next(k for k in node if k != "f")      # one tag, and "f" for fields
    val = node[tag]
    if tag == "nd":
        return arrays[val]
    if tag == "dc":
        cls = _class(val)
        if not dataclasses.is_dataclass(cls):
            raise ValueError(f"{val} is not a dataclass")
        return cls(**{k: _unflatten(v, arrays) for k, v in node["f"].items()})
    if tag == "nt":
        return _class(val)(*[_unflatten(v, arrays) for v in node["f"]])
    if tag == "tu":
        return tuple(_unflatten(v, arrays) for v in val)
    if tag == "li":
        return [_unflatten(v, arrays) for v in val]
    if tag == "di":
        return {k: _unflatten(v, arrays) for k, v in val.items()}
    if tag == "v":
        return val
    raise ValueError(f"unknown node {tag}")


def save(case, model, note=None):
    """Write the model to the case's cache file (atomically); returns the
    path, or None when it could not be written (then `note(text)` says why)."""
    path = cache_file(case)
    if path is None:
        return None
    arrays = {}
    try:
        tree = _flatten(model, arrays)
    except TypeError as exc:           # a model this format cannot hold
        if note:
            note(f"model not cached ({exc})")
        return None
    head = json.dumps({"format": _FORMAT, "key": cache_key(case), "tree": tree})
    tmp = path.with_name(f"{path.name}.{os.getpid()}.tmp")
    try:
        path.parent.mkdir(exist_ok=True)
        with open(tmp, "wb") as f:
            np.savez(f, __head__=np.frombuffer(head.encode(), dtype=np.uint8), **arrays)
        os.replace(tmp, path)
    except OSError as exc:
        if note:
            note(f"model not cached: cannot write {path} ({exc.strerror or exc})")
        try:
            tmp.unlink()
        except OSError:
            pass
        return None
    return path


def load(case):
    """The cached model of `case`, or None (no file, another key, unreadable)."""
    path = cache_file(case)
    if path is None or not path.is_file():
        return None
    try:
        with np.load(path, allow_pickle=False) as z:
            head = json.loads(bytes(z["__head__"]).decode())
            if head.get("format") != _FORMAT or head.get("key") != cache_key(case):
                return None
            arrays = {k: z[k] for k in z.files if k != "__head__"}
        return _unflatten(head["tree"], arrays)
    except Exception:        # a damaged or foreign file is a rebuild, never an error
        return None
