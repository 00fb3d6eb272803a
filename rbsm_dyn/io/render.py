"""Pictures of a history: one frame of the cells and cracks (render), the
energies, frequencies and probes (plot).

    python -m rbsm_dyn render RUN.h5 [--frame K] [--out PNG] [--scale F] [--size W H] [--color C]
                                     [--view V]
    python -m rbsm_dyn plot RUN.h5 [--out PNG]

``render`` draws frame K (default the last) off-screen with pyvista: the
cells coloured by the magnitude of their displacement (``--color
displacement``, the default), by a component of it (``ux``, ``uy``,
``uz``; blue negative, red positive, a range symmetric about 0), by their
stress, when the history has the ``cell_stress`` field: a component
(``sxx``, ``syy``, ``szz``, ``sxy``, ``syz``, ``sxz``; blue compression,
red tension), ``von_mises``, ``principal_max``, ``principal_mid`` or
``principal_min`` (io/export.py stress_measures), or (``--color damage``,
with the ``spring_damage`` field) grey cells and their faces coloured by
the damage of their springs, 0..1, so that softening faces show before
they break.  Displacements are magnified by F (default: chosen so that the
largest displacement shows as about 4 % of the domain size, rounded to 1,
2 or 5 × 10^n, never below 1); the factor is printed and written in the
picture.  Faces on which a spring broke during the run are drawn red
(their edges too, so that a crack shows through the cells), faces broken
from the start (a ``cuts`` notch, contact interfaces between parts: spring
state >= 2 in frame 0) black, yielded faces orange.  Every picture has an
axes triad (lower left) and a length scale bar under the cells (of the
undeformed lengths; a round 1, 2 or 5 × 10^n m).  ``--view`` says where
the camera looks from: ``iso`` (from +x, −y, +z), an axis side (``+z``
above, ``-z`` below ...), or ``auto`` (the default): a plane model in its
plane (from +z), isometric for a
solid scene, and for one at most 1.5 cells thick along its thinnest side
(a plane model) along that side (y on a tie: the side along which the
cells moved least, so that a mode bending sideways is seen across), z up.  A modal history's picture names
the mode and its frequency, a static one's the load factor.

``plot`` draws the energies (kinetic, strain, dissipated, external work and
the balance error, solvers/output.py) and each probe over time (load
factor in static mode, where external work is booked along the load path,
so that the balance holds at each converged step) with matplotlib (the
optional extra ``rbsm_dyn[plot]``).  For a modal history it draws the
natural frequencies against the mode number instead (no energies: the
strain energy of a mode shape drawn at an arbitrary amplitude balances
nothing), and each probe's value in each mode shape.

Off-screen rendering needs an OpenGL implementation, not a screen.  The VTK
wheels from PyPI (>= 9.4) choose one at run time: an X display if DISPLAY is
set, else EGL (libEGL and Mesa: Debian ``libegl1 libegl-mesa0
libgl1-mesa-dri``), else OSMesa (``libosmesa6``).  Without DISPLAY we ask
VTK for EGL directly (VTK_DEFAULT_OPENGL_WINDOW=vtkEGLRenderWindow, which
also silences its "bad X server connection" warning) when libEGL is found,
OSMesa when only that is; with none of them :class:`RendererUnavailable`
says what to install (or run under ``xvfb-run``).
"""
from __future__ import annotations

import ctypes.util
import math
import os
import sys
from pathlib import Path

import numpy as np

from .export import STRESS_MEASURES, cells_mesh, faces_mesh, run_folder, spring_damage
from .geometry import frame_state
from .history import MissingData, input_problem, open_history, require_rbsm_history

__all__ = ["render", "build_plotter", "plot", "auto_scale", "nice_length", "RendererUnavailable",
           "check_renderer", "COLORS", "RENDER_DESCRIPTION", "PLOT_DESCRIPTION"]

#: what ``python -m rbsm_dyn render --help`` and ``plot --help`` say first
RENDER_DESCRIPTION = (
    "Draw one frame of a history (default the last) to a PNG, off-screen: the deformed "
    "cells coloured by their displacement (magnitude or a component), their stress or the "
    "damage of their faces; cracks formed in the run red, faces broken from the start (a "
    "notch cut before the run) black, yielded faces orange; an axes triad and a length "
    "scale bar.")
PLOT_DESCRIPTION = (
    "Draw the energies with their balance and each probe over time (over the load factor "
    "in a static run) to a PNG with matplotlib; for a modal run the natural frequencies "
    "and the probes against the mode number.")

#: face colours: cracks formed during the run, faces broken from the start
#: (a cuts notch, contact interfaces between parts: state >= 2 in frame 0),
#: yielded faces (and, in the damage picture, yielded faces
#: with no damage, since the damage colours run through orange)
CRACK_COLOR, NOTCH_COLOR, YIELD_COLOR, YIELD_COLOR_DAMAGE = "red", "black", "orange", "deepskyblue"
STATE_COLORS = {1: YIELD_COLOR, 2: CRACK_COLOR, 3: CRACK_COLOR}
DAMAGE_CMAP = "YlOrRd"

#: render --size bounds [pixels] (below: nothing to see, VTK divides by 0;
#: above: the off-screen buffer no longer fits in memory)
SIZE_MIN, SIZE_MAX = 16, 8192

#: what the cells can be coloured by (--color): the displacement magnitude
#: or a component, the damage of the faces, a measure of the cell stress
#: (io/export.py STRESS_MEASURES)
DISPLACEMENT_COLORS = ("displacement", "ux", "uy", "uz")
COLORS = DISPLACEMENT_COLORS + ("damage",) + STRESS_MEASURES
# (ASCII: VTK's fonts may lack Greek letters)
_COLOR_LABELS = {"displacement": "displacement", "ux": "displacement x",
                 "uy": "displacement y", "uz": "displacement z", "damage": "damage",
                 "sxx": "stress xx", "syy": "stress yy", "szz": "stress zz",
                 "sxy": "stress xy", "syz": "stress yz", "sxz": "stress xz",
                 "von_mises": "von Mises stress",
                 "principal_max": "largest principal stress",
                 "principal_mid": "middle principal stress",
                 "principal_min": "smallest principal stress"}


class RendererUnavailable(RuntimeError):
    """No OpenGL implementation for off-screen rendering."""


def check_renderer(find_library=None, environ=None) -> str:
    """Choose VTK's OpenGL window for off-screen use and return its name
    ("x", "egl" or "osmesa"; the user's VTK_DEFAULT_OPENGL_WINDOW if set);
    raise :class:`RendererUnavailable` with what to install when there is
    none.  Sets VTK_DEFAULT_OPENGL_WINDOW unless the user did."""
    find_library = find_library or ctypes.util.find_library
    environ = os.environ if environ is None else environ
    if environ.get("VTK_DEFAULT_OPENGL_WINDOW"):
        return environ["VTK_DEFAULT_OPENGL_WINDOW"]
    if environ.get("DISPLAY") or environ.get("WAYLAND_DISPLAY"):
        return "x"
    if find_library("EGL"):
        environ["VTK_DEFAULT_OPENGL_WINDOW"] = "vtkEGLRenderWindow"
        return "egl"
    if find_library("OSMesa"):
        environ["VTK_DEFAULT_OPENGL_WINDOW"] = "vtkOSOpenGLRenderWindow"
        return "osmesa"
    raise RendererUnavailable(
        "no OpenGL renderer for off-screen pictures: no DISPLAY, and neither libEGL nor "
        "libOSMesa is installed. Install Mesa's EGL (Debian/Ubuntu: apt-get install libegl1 "
        "libegl-mesa0 libgl1-mesa-dri) or OSMesa (apt-get install libosmesa6), or run under "
        "a virtual screen (apt-get install xvfb; xvfb-run python -m rbsm_dyn render ...)")


def auto_scale(max_disp: float, size: float, target: float = 0.04) -> float:
    """Magnification that shows the largest displacement as about
    ``target`` × size, rounded down to 1, 2 or 5 × 10^n; 1 if the
    displacements are already that large, or round-off (below 1e-9 × size)."""
    if not (max_disp > 1e-9 * size) or not (size > 0):
        return 1.0
    raw = target * size / max_disp
    if raw <= 1.0:
        return 1.0
    e = math.floor(math.log10(raw))
    for m in (5, 2, 1):
        if m * 10.0 ** e <= raw * (1 + 1e-12):
            return float(m * 10.0 ** e)
    return 1.0


def nice_length(x: float) -> float:
    """The largest 1, 2 or 5 × 10^n not above x > 0 (the scale bar)."""
    if not (x > 0) or not math.isfinite(x):
        return 1.0
    e = math.floor(math.log10(x))
    for m in (5, 2, 1):
        if m * 10.0 ** e <= x * (1 + 1e-12):
            return float(m * 10.0 ** e)
    return 10.0 ** (e - 1) * 5


def format_length(L: float) -> str:
    """A length [m] in the unit that makes it a small number: 0.05 -> "50
    mm" (ASCII "um" for micrometres: VTK's fonts may lack Greek)."""
    for unit, f in (("km", 1e3), ("m", 1.0), ("mm", 1e-3), ("um", 1e-6), ("nm", 1e-9)):
        if L >= f * (1 - 1e-9):
            return f"{round(L / f, 9):g} {unit}"
    return f"{L:.3g} m"


def _fmt_scale(s: float) -> str:
    return f"{s:g}"


#: --view: auto (below), iso (from +x, -y, +z: x to the right, z up), or the
#: side the camera looks from (+z: from above; -z: from below, where a slab's
#: tension face is)
VIEWS = ("auto", "iso", "+x", "-x", "+y", "-y", "+z", "-z")
#: auto: a scene at most this many cells thick along its thinnest side (a
#: plane model, a one-cell slab) is seen along that side, others isometric
PLANE_CELLS = 1.5


def _view(box_min, box_max, displacement=None, view="auto", cell_size=None):
    """Camera direction (from the focal point to the camera) and up vector
    of ``view`` (VIEWS).  auto: isometric, unless the scene is at most
    PLANE_CELLS cells of ``cell_size`` thick along its thinnest side (or
    ``cell_size`` is None): then along the thinnest side, z up.  On a tie,
    the side along which the displacements (N, 3), when given, are
    smallest (so that a cantilever's mode bending sideways is seen from
    above, not end-on), else y first."""
    ext = np.asarray(box_max) - np.asarray(box_min)
    if view not in VIEWS:
        raise ValueError(f"--view must be one of {', '.join(VIEWS)} (got {view!r})")
    if view == "auto" and cell_size is not None and ext.min() > PLANE_CELLS * cell_size:
        view = "iso"
    if view == "iso":
        return np.array([1.0, -1.0, 1.0]) / np.sqrt(3.0), np.array([0.0, 0.0, 1.0])
    if view != "auto":
        axis = "xyz".index(view[1])
        direction = np.zeros(3)
        direction[axis] = 1.0 if view[0] == "+" else -1.0
        up = np.array([0.0, 0.0, 1.0]) if axis != 2 else np.array([0.0, 1.0, 0.0])
        return direction, up
    order = [1, 0, 2]                       # prefer y, then x, then z
    thin = float(ext.min())
    tied = [a for a in order if ext[a] <= thin * (1 + 1e-9)]
    if displacement is not None and len(tied) > 1 and len(displacement):
        along = np.sqrt(np.mean(np.asarray(displacement, float) ** 2, axis=0))
        if along[tied].max() > 0:
            tied = sorted(tied, key=lambda a: (along[a] > 1e-3 * along.max(), along[a]))
    axis = tied[0] if tied else min(order, key=lambda a: (ext[a], order.index(a)))
    direction = np.zeros(3)
    direction[axis] = -1.0 if axis == 1 else 1.0    # look from -y (x right, z up)
    up = np.array([0.0, 0.0, 1.0]) if axis != 2 else np.array([0.0, 1.0, 0.0])
    return direction, up


def _face_kinds(h, faces, geom, state0):
    """Per face of ``faces`` (faces_mesh of frame 0 of ``h``): new crack
    (a spring on it broke after frame 0), notch (broken faces whose broken
    springs were all broken in frame 0: a cut), yielded (largest state 1).
    ``state0``: the spring states of the history's frame 0 (None: every
    broken face counts as a new crack)."""
    if faces.n_cells == 0:
        z = np.zeros(0, bool)
        return z, z, z
    state = np.asarray(faces.cell_data["state"])
    broken = state >= 2
    st = h.spring_state[0] if h.spring_state is not None else None
    if st is None or state0 is None:
        newly = broken
    else:
        new_springs = (np.asarray(st) >= 2) & (np.asarray(state0) < 2)
        fnew, _, bnew, _ = frame_state(np.where(new_springs, 2, 0).astype(np.int8),
                                       h.static["springs/face"], geom.n_faces, geom.n_bfaces)
        fid = np.asarray(faces.cell_data["face_id"])
        inner = fid >= 0
        flag = np.zeros(len(fid), bool)
        flag[inner] = fnew[fid[inner]] >= 2
        flag[~inner] = bnew[-1 - fid[~inner]] >= 2
        newly = broken & flag
    return newly, broken & ~newly, state == 1


def _cell_scalars(color, cells, true_cells, umag, path, h):
    """(scalars name, bar label, colormap, clim, preference) of the cells
    for ``color``; adds the array to ``cells``."""
    if color == "displacement":
        return ("displacement [m]", "displacement [m]", "viridis",
                (float(umag.min(initial=0.0)), float(umag.max(initial=0.0))), "point")
    if color in DISPLACEMENT_COLORS:
        label = f"{_COLOR_LABELS[color]} [m]"
        val = np.asarray(true_cells.point_data["displacement"])[:, "xyz".index(color[1])]
        cells.point_data[label] = val
        top = float(np.abs(val).max(initial=0.0))
        clim = (-top, top) if top > 0 else (-1.0, 1.0)
        return label, label, "coolwarm", clim, "point"
    if h.cell_stress is None:
        raise MissingData(f"{path}: no cell stress in the history (add cell_stress to "
                       "output.fields) for --color " + color)
    label = f"{_COLOR_LABELS[color]} [Pa]"
    val = np.asarray(cells.cell_data[color])
    cells.cell_data[label] = val
    top = float(np.abs(val).max(initial=0.0))
    if color == "von_mises":
        cmap, clim = "viridis", (0.0, top)
    else:
        # signed: blue compression, red tension, zero in the middle
        cmap, clim = "coolwarm", (-top, top)
    if clim[1] <= clim[0]:
        clim = (clim[0] - 1.0, clim[1] + 1.0)
    return label, label, cmap, clim, "cell"


def _frame_label(h, case, mode):
    """What the frame is: time, load factor, or mode and its frequency."""
    t = float(h.time[0])
    if mode == "modal":
        k = int(h.step[0])
        if k == 0:
            return "undeformed (mode shapes in frames 1..M)"
        f = None
        if "frequency" in h.observables and len(h.observables["frequency"]):
            f = float(h.observables["frequency"][0])
        elif "modes/frequency" in h.static and k - 1 < len(h.static["modes/frequency"]):
            f = float(np.asarray(h.static["modes/frequency"])[k - 1])
        return f"mode {k}" + (f", f = {f:.4g} Hz" if f is not None else "")
    return {"static": f"load factor {t:.4g}",
            "linear": "linear solution"}.get(mode, f"t = {t:.4g} s")


def build_plotter(path, *, frame: int = -1, scale: float | None = None,
                  window_size=(1600, 800), show_edges: bool = True,
                  color: str = "displacement", view: str = "auto"):
    """The picture of frame ``frame`` of history ``path``, ready to be
    drawn: ``(plotter, info)`` (off-screen pyvista Plotter; call
    ``plotter.screenshot(png)`` and ``plotter.close()``).  ``info`` holds
    what :func:`render` returns but ``out``, and ``scale_bar`` (length [m],
    label)."""
    if color not in COLORS:
        raise ValueError(f"--color must be one of {', '.join(COLORS)} (got {color!r})")
    if view not in VIEWS:
        raise ValueError(f"--view must be one of {', '.join(VIEWS)} (got {view!r})")
    if len(window_size) != 2 or not all(SIZE_MIN <= int(v) <= SIZE_MAX for v in window_size):
        raise ValueError(f"--size W H must be between {SIZE_MIN} and {SIZE_MAX} pixels each "
                         f"(got {' '.join(str(v) for v in window_size)})")
    window_size = (int(window_size[0]), int(window_size[1]))
    renderer = check_renderer()
    import pyvista as pv
    pv.OFF_SCREEN = True
    path = Path(path)
    require_rbsm_history(path)
    h = open_history(path, frames=frame)
    if h.position is None:
        raise MissingData(f"{path}: no body positions in the history (output.fields)")
    fi = int(h.frame_index[0])
    dmg = spring_damage(h, 0)
    if color == "damage" and dmg is None:
        raise MissingData(f"{path}: no spring damage in the history (add spring_damage to "
                       "output.fields) for --color damage")
    geom = h.geometry()
    true_cells = cells_mesh(h, 0, geom, scale=1.0)
    umag = np.linalg.norm(true_cells.point_data["displacement"], axis=1)
    box_min, box_max = geom.vertices.min(axis=0), geom.vertices.max(axis=0)
    size = float(np.linalg.norm(box_max - box_min))
    max_u = float(umag.max(initial=0.0))
    if scale is None:
        scale = auto_scale(max_u, size)
    cells = cells_mesh(h, 0, geom, scale=scale) if scale != 1.0 else true_cells
    cells.point_data["displacement [m]"] = umag
    faces = faces_mesh(h, 0, geom, scale=scale, min_state=1)
    state = np.asarray(faces.cell_data["state"]) if faces.n_cells else np.zeros(0)
    state0 = None
    if h.spring_state is not None:
        state0 = (h.spring_state[0] if fi == 0
                  else open_history(path, frames=0).spring_state[0])
    newly, notch, yielded = _face_kinds(h, faces, geom, state0)

    case = h.case()
    name = case.get("name") or path.stem
    mode = case.get("solver", {}).get("mode", "dynamic")
    pl = pv.Plotter(off_screen=True, window_size=list(window_size))
    pl.set_background("white")
    bar_args = {"color": "black", "vertical": True, "position_x": 0.89, "position_y": 0.1,
                "height": 0.7, "width": 0.05, "fmt": "%.2e"}
    if color == "damage":
        label, clim = "damage", (0.0, 1.0)
        pl.add_mesh(cells, color="#d0d0d0", show_edges=show_edges, edge_color="#606060",
                    line_width=0.5, lighting=True)
    else:
        scalars, label, cmap, clim, pref = _cell_scalars(color, cells, true_cells, umag, path, h)
        pl.add_mesh(cells, scalars=scalars, cmap=cmap, clim=clim, show_edges=show_edges,
                    preference=pref, edge_color="#303030", line_width=0.5, lighting=True,
                    scalar_bar_args={"title": label, **bar_args})
    n_broken = int(np.count_nonzero(state >= 2))
    n_yield = int(np.count_nonzero(yielded))
    n_notch = int(np.count_nonzero(notch))
    n_damaged = 0
    fdmg = (np.asarray(faces.cell_data["damage"]) if dmg is not None and faces.n_cells
            else np.zeros(faces.n_cells))

    def draw(ids, **style):
        if len(ids) == 0:
            return
        sub = faces.extract_cells(ids)
        pl.add_mesh(sub, opacity=1.0, lighting=False, **style)
        pl.add_mesh(sub.extract_all_edges(), line_width=3, render_lines_as_tubes=False,
                    **style)

    if color == "damage":
        # the damaged faces by their damage (broken ones at 1), the notch
        # black, yielded faces without damage blue
        shown = np.nonzero((fdmg > 0) & ~notch)[0]
        n_damaged = int(np.count_nonzero((fdmg > 0) & (fdmg < 1) & (state < 2)))
        if len(shown):
            sub = faces.extract_cells(shown)
            # per point (each face has its own points), so that the edges
            # carry the face's damage too
            sub.point_data["damage"] = _face_values_at_points(
                sub, np.asarray(sub.cell_data["damage"]))
            style = dict(scalars="damage", cmap=DAMAGE_CMAP, clim=(0.0, 1.0),
                         preference="point", lighting=False)
            pl.add_mesh(sub, opacity=1.0, scalar_bar_args={"title": "damage", **bar_args,
                                                           "fmt": "%.2f"}, **style)
            pl.add_mesh(sub.extract_all_edges(), line_width=3, render_lines_as_tubes=False,
                        show_scalar_bar=False, **style)
        draw(np.nonzero(yielded & ~(fdmg > 0))[0], color=YIELD_COLOR_DAMAGE)
        draw(np.nonzero(notch)[0], color=NOTCH_COLOR)
    else:
        for sel, face_color in ((yielded, YIELD_COLOR), (notch, NOTCH_COLOR),
                                (newly, CRACK_COLOR)):
            draw(np.nonzero(sel)[0], color=face_color)
    t = float(h.time[0])
    tlabel = _frame_label(h, case, mode)
    if color == "damage":
        legend = (f"faces coloured by damage ({n_damaged} softening, {n_broken - n_notch} "
                  f"broken at 1); black: broken from the start ({n_notch})"
                  + (f"; blue: yielded faces ({n_yield})" if n_yield else ""))
    else:
        kinds = [f"red: cracks formed in the run ({n_broken - n_notch})" if n_broken > n_notch
                 else "", f"black: broken from the start ({n_notch})" if n_notch else "",
                 f"orange: yielded faces ({n_yield})" if n_yield else ""]
        legend = ", ".join(k for k in kinds if k) or "no broken or yielded faces"
    text = (f"{name}: frame {fi}, {tlabel}\n"
            f"displacement magnified x {_fmt_scale(scale)} (largest: {max_u:.3g} m)"
            + (f"; colour: {label}" if color != "displacement" else "") + "\n" + legend)
    pl.add_text(text, position="upper_left", font_size=11, color="black")
    cell_size = (float(np.prod(np.maximum(box_max - box_min, 0.0))) / max(h.n_bodies, 1)) ** (1 / 3)
    if view == "auto" and getattr(h, "dimension", 3) == 2:
        view = "+z"                  # a plane model: seen in its plane
    direction, up = _view(box_min, box_max, true_cells.point_data["displacement"], view,
                          cell_size)
    centre = 0.5 * (box_min + box_max)
    pl.camera.focal_point = centre
    pl.camera.position = centre + direction * size * 3
    pl.camera.up = up
    pl.camera.parallel_projection = True
    pl.reset_camera()
    # fit the deformed picture (parallel scale = half the visible height),
    # leaving room for the text above and the colour bar on the right
    lo, hi = np.asarray(cells.bounds[0::2]), np.asarray(cells.bounds[1::2])
    right = np.cross(-direction, up)
    corners = np.array([[a, b, c] for a in (lo[0], hi[0]) for b in (lo[1], hi[1])
                        for c in (lo[2], hi[2])])
    w = np.ptp(corners @ right)
    hgt = np.ptp(corners @ up)
    aspect = window_size[0] / window_size[1]
    focal = 0.5 * (lo + hi)
    pl.camera.focal_point = focal
    pl.camera.position = focal + direction * size * 3
    ps = 0.5 * max(hgt / 0.72, w / (0.72 * aspect))
    if not ps > 0:
        ps = 0.5 * size if size > 0 else 1.0
    pl.camera.parallel_scale = ps
    bar = _add_scale_bar(pl, corners, focal, right, up, direction, ps, window_size, w, hgt)
    _add_axes(pl, window_size)
    pl.reset_camera_clipping_range()
    info = {"frame": fi, "time": t, "scale": float(scale), "max_displacement": max_u,
            "n_broken_faces": n_broken, "n_yielded_faces": n_yield,
            "n_notch_faces": n_notch, "n_new_crack_faces": n_broken - n_notch,
            "n_damaged_faces": n_damaged, "renderer": renderer, "color": color,
            "color_range": (float(clim[0]), float(clim[1])), "scale_bar": bar,
            "title": tlabel, "mode": mode}
    return pl, info


def _face_values_at_points(poly, per_face):
    """A per-face array repeated on each face's points (faces_mesh gives
    each polygon its own points; extract_cells keeps that)."""
    vals = np.zeros(poly.n_points)
    offs = np.asarray(poly.cell_offsets if hasattr(poly, "cell_offsets") else poly.offset)
    vals[np.asarray(poly.cell_connectivity)] = np.repeat(per_face, np.diff(offs))
    return vals


def _add_axes(pl, window_size):
    """An axes triad in the lower left corner, about 150 pixels square."""
    W, H = window_size
    side = min(150.0, 0.25 * W, 0.25 * H)
    pl.add_axes(line_width=2, color="black", viewport=(0, 0, side / W, side / H))


def _add_scale_bar(pl, corners, focal, right, up, direction, ps, window_size, w, hgt):
    """A black bar of a round length (nice_length of a quarter of the
    picture's width, or height) under the cells' right end, with end ticks
    and its length written to its left.  Returns (length [m], label)."""
    import pyvista as pv
    W, H = window_size
    L = nice_length(0.25 * (w if w > 0 else hgt))
    label = format_length(L)
    cr, cu = corners @ right, corners @ up
    depth = float(np.max(corners @ direction))          # in front of the cells
    x1 = float(cr.max())
    x0 = x1 - L
    y = float(cu.min()) - 0.05 * 2 * ps
    tick = 0.012 * 2 * ps

    def at(xr, yu):
        return xr * right + yu * up + depth * direction

    pts = np.array([at(x0, y), at(x1, y), at(x0, y - tick), at(x0, y + tick),
                    at(x1, y - tick), at(x1, y + tick)])
    lines = np.array([2, 0, 1, 2, 2, 3, 2, 4, 5])
    pl.add_mesh(pv.PolyData(pts, lines=lines), color="black", line_width=3,
                lighting=False, reset_camera=False, name="scale_bar")
    # its label, in pixels (parallel projection: H / (2 ps) pixels per metre)
    px = W / 2 + (x0 - float(focal @ right)) * H / (2 * ps) - 8
    py = H / 2 + (y - float(focal @ up)) * H / (2 * ps)
    txt = pl.add_text(label, position=(max(px, 0.0), max(py, 0.0)), font_size=10,
                      color="black", name="scale_bar_label")
    try:
        txt.prop.justification_horizontal = "right"
        txt.prop.justification_vertical = "center"
    except AttributeError:                    # (older pyvista: left, bottom)
        pass
    return L, label


def render(path, *, frame: int = -1, out=None, scale: float | None = None,
           window_size=(1600, 800), show_edges: bool = True,
           color: str = "displacement", view: str = "auto") -> dict:
    """Draw frame ``frame`` of history ``path`` to a PNG (module docstring),
    the cells coloured by ``color`` (one of COLORS).
    Returns ``{"out", "frame", "time", "scale", "max_displacement",
    "n_broken_faces", "n_yielded_faces", "n_notch_faces",
    "n_new_crack_faces", "n_damaged_faces", "renderer", "color",
    "color_range", "scale_bar", "title", "mode"}`` (color_range: the (min,
    max) of the colour bar; n_broken_faces counts the notch too;
    n_damaged_faces: softening, not broken, with --color damage)."""
    pl, info = build_plotter(path, frame=frame, scale=scale, window_size=window_size,
                             show_edges=show_edges, color=color, view=view)
    try:
        path = Path(path)
        out = (Path(out) if out is not None
               else run_folder(path) / f"frame{info['frame']}.png")
        out.parent.mkdir(parents=True, exist_ok=True)
        pl.screenshot(str(out))
    finally:
        pl.close()
    return {"out": str(out), **info}


# ------------------------------------------------------------------ plot
ENERGIES = (("kinetic", "kinetic"), ("strain", "strain"), ("plastic", "plastic"),
            ("fracture", "fracture"), ("damping", "damping"),
            ("contact_friction", "contact friction"), ("viscous", "viscous"),
            ("external_work", "external work"))
#: the y label of an observable's own panel where its name alone misleads:
#: n_broken counts spring points (a face has several; `render` counts faces)
PANEL_LABELS = {"n_broken": "broken spring points"}


def _plastic_label(case):
    """The legend of the `plastic` observable: the work of yield and of
    friction on closed cracks (solvers/output.py), named for what the case
    can dissipate there -- no material with a yield key (interfaces take
    theirs from a material): friction on cracks alone."""
    mats = (case.get("materials") or {}).values()
    yields = any(isinstance(m, dict) and m.get("yield") for m in mats)
    return "plastic (yield + friction on cracks)" if yields else "friction on closed cracks"


NOT_PROBES = {name for name, _ in ENERGIES} | {"n_broken", "crack_area", "residual",
                                               "frequency"}


#: frames read at a time by ``plot`` (each series it draws, one slice)
PLOT_CHUNK = 1 << 16
#: buckets of frames drawn per series at most: a longer series is cut into
#: this many, each drawn by its minimum and maximum (the envelope; the
#: picture is 800 pixels wide, so every column still shows its extremes)
PLOT_POINTS = 2000


def _envelope(t, y, b):
    """Min and max of y in buckets of b frames (b = 1: y itself), each pair
    in frame order: (t, y) of at most 2 len(y)/b points."""
    if b <= 1 or len(y) == 0:
        return t, y
    n = len(y)
    full = n // b * b
    base = np.arange(0, full, b)
    blocks = y[:full].reshape(-1, b)
    parts = [base + blocks.argmin(axis=1), base + blocks.argmax(axis=1)]
    if full < n:                         # a last, shorter bucket
        parts += [[full + int(np.argmin(y[full:]))], [full + int(np.argmax(y[full:]))]]
    idx = np.unique(np.concatenate(parts))
    return t[idx], y[idx]


def read_observables(path, names, *, chunk=PLOT_CHUNK, points=PLOT_POINTS):
    """What ``plot`` draws, read in bounded memory: only the observables
    ``names`` (those with a value in every frame), PLOT_CHUNK frames at a
    time, each reduced to its envelope of at most 2 × PLOT_POINTS points,
    and the energy balance (History.energy_balance) with its largest error
    and supplied energy over every frame.  Returns (case dict, {name: (t,
    y)}, (t, error), largest |error|, largest |supplied|, units)."""
    import json

    import h5py
    from .history import _open_h5, _read_dataset
    f = _open_h5(str(path))
    with f:
        case = {}
        if "parameters" in f and "case" in f["parameters"]:
            case = json.loads(_read_dataset(f["parameters"]["case"]))
        g = f["observables"] if "observables" in f else {}
        lengths = {n: g[n]["value"].shape[0] for n in g
                   if isinstance(g[n], h5py.Group) and "value" in g[n]
                   and g[n]["value"].ndim == 1}
        T = int(f.attrs["frames"]) if "frames" in f.attrs else min(lengths.values(), default=0)
        have = [n for n in lengths if lengths[n] >= T]
        want = [n for n in dict.fromkeys(list(names) + [k for k, _ in ENERGIES]) if n in have]
        units = {n: g[n]["value"].attrs.get("unit", "1") for n in want}
        units = {n: u.decode() if isinstance(u, bytes) else str(u) for n, u in units.items()}
        b = max(1, math.ceil(T / points))
        step = b * max(1, chunk // b)               # whole buckets per slice
        t_name = want[0] if want else None
        env = {n: ([], []) for n in want + ["error"]}
        big_err = big_sup = 0.0
        e0 = None
        for a in range(0, T, step):
            z = min(T, a + step)
            t = np.asarray(g[t_name]["time"][a:z], np.float64) if t_name else np.zeros(0)
            vals = {n: np.asarray(g[n]["value"][a:z], np.float64) for n in want}

            def get(n):
                return vals.get(n, np.zeros(z - a))
            if e0 is None:
                e0 = float(get("kinetic")[0] + get("strain")[0]) if z > a else 0.0
            supplied = e0 + get("external_work")
            error = (get("kinetic") + get("strain") + get("damping") + get("plastic")
                     + get("fracture") + get("contact_friction") + get("viscous") - supplied)
            big_err = max(big_err, float(np.max(np.abs(error), initial=0.0)))
            big_sup = max(big_sup, float(np.max(np.abs(supplied), initial=0.0)))
            vals["error"] = error
            for n, v in vals.items():
                tt, yy = _envelope(t, v, b)
                env[n][0].append(tt)
                env[n][1].append(yy)
            del vals, error, supplied
    series = {n: (np.concatenate(ts) if ts else np.zeros(0),
                  np.concatenate(ys) if ys else np.zeros(0)) for n, (ts, ys) in env.items()}
    err = series.pop("error")
    return case, series, err, big_err, big_sup, units


def plot(path, *, out=None, max_probes: int = 6) -> dict:
    """Energies and probes of history ``path`` over time, one PNG
    (matplotlib, Agg).  Reads only the observables it draws, in slices
    (read_observables: bounded memory whatever the file's size).  Returns
    ``{"out", "probes", "balance_error", "mode", "frequencies"}``
    (balance_error: largest |error| / largest supplied energy; None for a
    modal history, whose picture is its frequencies (frequencies [Hz],
    else None) and probes by mode, no energies)."""
    try:
        import matplotlib
    except ImportError as exc:
        raise ImportError("plot needs matplotlib: pip install 'rbsm_dyn[plot]'") from exc
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    path = Path(path)
    out = Path(out) if out is not None else run_folder(path) / "plot.png"
    require_rbsm_history(path)
    names = _observable_names(path)
    probes = [n for n in names if n not in NOT_PROBES][:max_probes]
    case, obs, (te, error), big_err, sup, units = read_observables(
        path, probes + ["n_broken", "residual", "frequency"])
    probes = [n for n in probes if n in obs]
    mode = case.get("solver", {}).get("mode", "dynamic")
    if mode == "modal":
        return _plot_modal(path, out, case, obs, probes, units, plt)
    xlabel = {"static": "load factor λ", "linear": "frame"}.get(mode, "time [s]")
    extra = [n for n in ("n_broken", "residual") if n in obs and np.any(obs[n][1])]
    n_panels = 1 + len(probes) + len(extra)
    fig, axes = plt.subplots(n_panels, 1, sharex=True, figsize=(8, 2.4 + 2.0 * n_panels),
                             squeeze=False)
    axes = axes[:, 0]
    ax = axes[0]
    for key, label in ENERGIES:
        if key in obs and np.any(obs[key][1] != 0):
            ax.plot(*obs[key], label=_plastic_label(case) if key == "plastic" else label)
    # static and linear runs book the work of the loads along the load path
    # (docs/history.md): at each converged step it equals strain +
    # dissipation, so the balance means what it does in a dynamic run
    ax.plot(te, error, "k--", lw=1, label="balance error"
            + (" (at equilibrium)" if mode in ("static", "linear") else ""))
    rel = big_err / sup if sup > 0 else 0.0
    ax.set_ylabel("energy [J]")
    ax.set_title(f"{case.get('name') or path.stem}: energies (balance error ≤ {rel:.2%} "
                 "of the supplied energy)", fontsize=10)
    ax.legend(fontsize=8, ncol=3)
    ax.grid(alpha=0.3)
    for ax, name in zip(axes[1:], probes + extra):
        unit = units.get(name, "1")
        ax.plot(*obs[name], color="C0")
        ax.set_ylabel(PANEL_LABELS.get(name) or (f"{name} [{unit}]" if unit != "1" else name))
        ax.grid(alpha=0.3)
    axes[-1].set_xlabel(xlabel)
    fig.tight_layout()
    out.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(out, dpi=100)
    plt.close(fig)
    return {"out": str(out), "probes": probes, "balance_error": rel, "mode": mode,
            "frequencies": None}


def _modal_frequencies(path, obs):
    """(mode numbers, frequencies [Hz]) of a modal history: /modes/frequency
    when written (at the end of the run), else the frequency observable of
    frames 1..M."""
    from .history import _open_h5
    f = _open_h5(str(path))
    with f:
        if "modes" in f and "frequency" in f["modes"]:
            fr = np.asarray(f["modes"]["frequency"][()], np.float64).reshape(-1)
            return np.arange(1, len(fr) + 1), fr
    if "frequency" in obs:
        k, fr = obs["frequency"]
        keep = np.asarray(k) >= 1
        return np.rint(np.asarray(k)[keep]).astype(int), np.asarray(fr, np.float64)[keep]
    return np.zeros(0, int), np.zeros(0)


def _plot_modal(path, out, case, obs, probes, units, plt):
    """A modal history: its natural frequencies against the mode number
    (each written on its bar) and each probe's value in each mode shape
    (drawn at the display amplitude).  No energies: the strain energy of a
    shape drawn at an arbitrary amplitude balances nothing."""
    modes, freq = _modal_frequencies(path, obs)
    n_panels = 1 + len(probes)
    fig, axes = plt.subplots(n_panels, 1, sharex=True, figsize=(8, 2.6 + 2.0 * n_panels),
                             squeeze=False)
    axes = axes[:, 0]
    ax = axes[0]
    if len(freq):
        bars = ax.bar(modes, freq, color="C0", width=0.6)
        ax.bar_label(bars, labels=[f"{v:.4g}" for v in freq], fontsize=8, padding=2)
        ax.set_ylim(0, 1.15 * float(np.max(freq)) if np.max(freq) > 0 else 1.0)
    ax.set_ylabel("natural frequency [Hz]")
    ax.set_title(f"{case.get('name') or path.stem}: {len(freq)} natural frequencies"
                 + (f" (f1 = {freq[0]:.4g} Hz)" if len(freq) else ""), fontsize=10)
    ax.grid(alpha=0.3, axis="y")
    for ax, name in zip(axes[1:], probes):
        k, v = obs[name]
        keep = np.asarray(k) >= 1
        unit = units.get(name, "1")
        ax.plot(np.asarray(k)[keep], np.asarray(v)[keep], "o", color="C0")
        ax.axhline(0.0, color="0.5", lw=0.8)
        ax.set_ylabel(f"{name} [{unit}]" if unit != "1" else name)
        ax.grid(alpha=0.3)
    axes[-1].set_xlabel("mode")
    if len(modes):
        axes[-1].set_xticks(modes)
    fig.tight_layout()
    out.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(out, dpi=100)
    plt.close(fig)
    return {"out": str(out), "probes": probes, "balance_error": None, "mode": "modal",
            "frequencies": [float(v) for v in freq]}


def _observable_names(path):
    """Names of the observables of a history with a value in every frame,
    in file order (metadata only)."""
    import h5py
    from .history import _open_h5
    f = _open_h5(str(path))
    with f:
        g = f["observables"] if "observables" in f else {}
        lengths = {n: g[n]["value"].shape[0] for n in g
                   if isinstance(g[n], h5py.Group) and "value" in g[n]
                   and g[n]["value"].ndim == 1}
        T = int(f.attrs["frames"]) if "frames" in f.attrs else min(lengths.values(), default=0)
        return [n for n in lengths if lengths[n] >= T]


# ------------------------------------------------------------------- CLI
def add_arguments(p) -> None:
    p.description = RENDER_DESCRIPTION
    p.add_argument("history", help="history file (RUN.h5)")
    p.add_argument("--frame", type=int, default=-1, metavar="K",
                   help="frame to draw (negative counts from the end; default the last)")
    p.add_argument("--out", metavar="PNG", help="picture file (default RUN/frameK.png beside RUN.h5)")
    p.add_argument("--scale", type=float, default=None, metavar="F",
                   help="displacement magnification (default: automatic, printed)")
    p.add_argument("--size", type=int, nargs=2, default=(1600, 800), metavar=("W", "H"),
                   help=f"picture size in pixels, {SIZE_MIN} to {SIZE_MAX} each "
                        "(default 1600 800)")
    p.add_argument("--color", "--colour", choices=COLORS, default="displacement",
                   metavar="C",
                   help="colour the cells by the displacement magnitude (displacement, the "
                        "default) or a component (ux, uy, uz); by their stress (needs the "
                        "cell_stress field): a component sxx, syy, szz, sxy, syz, sxz, or "
                        "von_mises, principal_max, principal_mid, principal_min; or draw them "
                        "grey with their faces coloured by damage (damage: needs the "
                        "spring_damage field)")
    p.add_argument("--view", choices=VIEWS, default="auto", metavar="V",
                   help="where the camera looks from: iso (isometric, from +x -y +z, z up), "
                        "+x, -x, +y, -y, +z (above), -z (below: a slab's tension face); "
                        "auto (the default): iso, or along the thinnest side for a scene "
                        "one cell thick there (a plane model)")
    p.add_argument("--quiet", action="store_true", help="print nothing on success")


def main(args) -> int:
    """``python -m rbsm_dyn render`` on a parsed namespace."""
    problem = input_problem(args.history)
    if problem:
        print(f"rbsm_dyn: render: {problem}", file=sys.stderr)
        return 2
    w, h = args.size
    if not (SIZE_MIN <= w <= SIZE_MAX and SIZE_MIN <= h <= SIZE_MAX):
        print(f"rbsm_dyn: render: --size W H must be between {SIZE_MIN} and {SIZE_MAX} "
              f"pixels each (got {w} {h})", file=sys.stderr)
        return 2
    if args.scale is not None and not (args.scale > 0 and math.isfinite(args.scale)):
        print(f"rbsm_dyn: render: --scale must be a positive number (got {args.scale})",
              file=sys.stderr)
        return 2
    try:
        res = render(args.history, frame=args.frame, out=args.out, scale=args.scale,
                     window_size=tuple(args.size), color=getattr(args, "color", "displacement"),
                     view=getattr(args, "view", "auto"))
    except RendererUnavailable as exc:
        print(f"rbsm_dyn: render: {exc}", file=sys.stderr)
        return 1
    except (KeyError, IndexError, ValueError, OSError) as exc:
        print(f"rbsm_dyn: render: {exc}", file=sys.stderr)
        return 2
    if not args.quiet:
        what = (res["title"] if res["mode"] in ("modal", "static", "linear")
                else f"t = {res['time']:.4g}")
        print(f"rbsm_dyn: frame {res['frame']} ({what}): displacement "
              f"magnified x {_fmt_scale(res['scale'])} (largest {res['max_displacement']:.3g} m), "
              f"{res['n_broken_faces']} broken"
              + (f" ({res['n_notch_faces']} of them from the start)" if res['n_notch_faces']
                 else "")
              + f" and {res['n_yielded_faces']} yielded faces; scale bar {res['scale_bar'][1]} "
              f"-> {res['out']}")
    return 0


def add_plot_arguments(p) -> None:
    p.description = PLOT_DESCRIPTION
    p.add_argument("history", help="history file (RUN.h5)")
    p.add_argument("--out", metavar="PNG", help="picture file (default RUN/plot.png beside RUN.h5)")
    p.add_argument("--quiet", action="store_true", help="print nothing on success")


def main_plot(args) -> int:
    """``python -m rbsm_dyn plot`` on a parsed namespace."""
    problem = input_problem(args.history)
    if problem:
        print(f"rbsm_dyn: plot: {problem}", file=sys.stderr)
        return 2
    try:
        res = plot(args.history, out=args.out)
    except ImportError as exc:
        print(f"rbsm_dyn: plot: {exc}", file=sys.stderr)
        return 1
    except (KeyError, ValueError, OSError) as exc:
        print(f"rbsm_dyn: plot: {exc}", file=sys.stderr)
        return 2
    if not args.quiet:
        if res["mode"] == "modal":
            fr = res["frequencies"] or []
            print(f"rbsm_dyn: {len(fr)} natural frequencies"
                  + (f" ({fr[0]:.4g} to {fr[-1]:.4g} Hz)" if fr else "")
                  + f" and {len(res['probes'])} probes by mode -> {res['out']}")
        else:
            print(f"rbsm_dyn: energies and {len(res['probes'])} probes "
                  f"(energy balance error ≤ {res['balance_error']:.2%}) -> {res['out']}")
    return 0
