"""Triangle selectors: a plane, a box, a normal cone (and any of them
combined).  Used by ``surfaces:`` in a geometry node and by
``Solid.surface({...})``.

A selector is a mapping with one or more of

* ``plane: {point: [x, y, z], normal: [nx, ny, nz], tol: t}`` — the
  triangles whose three vertices lie within ``tol`` [m] of the plane
  (default tol: 1e-6 of the diagonal of the body's bounding box);
* ``box: [[x0, y0, z0], [x1, y1, z1]]`` — the triangles whose centroid lies
  in the box (bounds included; the rule groups use for bodies);
* ``normal: [nx, ny, nz]`` with ``angle: deg`` (default 1) — the triangles
  whose outward normal is within ``angle`` degrees of the direction;

and selects the triangles that satisfy all of them.
"""
from __future__ import annotations

import math
from collections.abc import Mapping

import numpy as np

from .errors import GeometryError

__all__ = ["select_triangles", "SELECTOR_KEYS", "number", "vector"]

SELECTOR_KEYS = ("plane", "box", "normal", "angle")


def number(x, path, *, positive=False, nonnegative=False):
    """A finite real number from the spec (not a bool, not a string)."""
    if isinstance(x, bool) or not isinstance(x, (int, float, np.integer, np.floating)):
        raise GeometryError(path, f"must be a number (got {x!r})")
    x = float(x)
    if not math.isfinite(x):
        raise GeometryError(path, f"must be finite (got {x})")
    if positive and not x > 0:
        raise GeometryError(path, f"must be > 0 (got {x:g})")
    if nonnegative and not x >= 0:
        raise GeometryError(path, f"must be >= 0 (got {x:g})")
    return x


def vector(x, n, path):
    """A list of n numbers from the spec, as a float64 array."""
    if isinstance(x, (str, bytes, Mapping)) or not hasattr(x, "__len__") or len(x) != n:
        raise GeometryError(path, f"must be a list of {n} numbers (got {x!r})")
    return np.array([number(v, path + (i,)) for i, v in enumerate(x)], dtype=np.float64)


def _unit(x, path):
    v = vector(x, 3, path)
    norm = float(np.linalg.norm(v))
    if norm == 0.0:
        raise GeometryError(path, "must not be the zero vector")
    return v / norm


def _mapping(x, path, allowed, required=()):
    if not isinstance(x, Mapping):
        raise GeometryError(path, f"must be a mapping (got {x!r})")
    for k in x:
        if k not in allowed:
            raise GeometryError(path + (k,), f"unknown key (allowed: {', '.join(allowed)})")
    for k in required:
        if k not in x:
            raise GeometryError(path, f"missing key '{k}'")
    return x


def select_triangles(vertices, triangles, selector, path=()):
    """Boolean mask (T,) of the triangles a selector picks (module docstring)."""
    sel = _mapping(selector, tuple(path), SELECTOR_KEYS)
    path = tuple(path)
    if not any(k in sel for k in ("plane", "box", "normal")):
        raise GeometryError(path, "a selector needs plane, box or normal")
    if "angle" in sel and "normal" not in sel:
        raise GeometryError(path + ("angle",), "angle goes with normal")
    v = np.asarray(vertices, dtype=np.float64)
    t = np.asarray(triangles, dtype=np.int64)
    p = v[t]                                            # (T, 3, 3)
    mask = np.ones(len(t), dtype=bool)
    if "plane" in sel:
        q = path + ("plane",)
        pl = _mapping(sel["plane"], q, ("point", "normal", "tol"), ("point", "normal"))
        point = vector(pl["point"], 3, q + ("point",))
        normal = _unit(pl["normal"], q + ("normal",))
        if "tol" in pl:
            tol = number(pl["tol"], q + ("tol",), nonnegative=True)
        else:
            tol = 1e-6 * float(np.linalg.norm(np.ptp(v, axis=0))) if len(v) else 0.0
        dist = np.abs((p - point) @ normal)             # (T, 3)
        mask &= np.all(dist <= tol, axis=1)
    if "box" in sel:
        q = path + ("box",)
        b = sel["box"]
        if isinstance(b, (str, bytes, Mapping)) or not hasattr(b, "__len__") or len(b) != 2:
            raise GeometryError(q, f"must be [[x0, y0, z0], [x1, y1, z1]] (got {b!r})")
        lo, hi = vector(b[0], 3, q + (0,)), vector(b[1], 3, q + (1,))
        if np.any(hi < lo):
            raise GeometryError(q, "upper corner below the lower corner")
        c = p.mean(axis=1)
        mask &= np.all((c >= lo) & (c <= hi), axis=1)
    if "normal" in sel:
        d = _unit(sel["normal"], path + ("normal",))
        angle = number(sel.get("angle", 1.0), path + ("angle",), nonnegative=True)
        n = np.cross(p[:, 1] - p[:, 0], p[:, 2] - p[:, 0])
        norm = np.linalg.norm(n, axis=1)
        ok = norm > 0
        cosang = np.full(len(t), -2.0)
        cosang[ok] = (n[ok] @ d) / norm[ok]
        mask &= cosang >= math.cos(math.radians(angle))
    return mask
