"""Pictures of a history: the deformed cells with their cracks, and the
probes and energies over time.

    python -m rbsm_dyn render RUN.h5 [--frame K] [--out PNG] [--scale F] [--color C]
    python -m rbsm_dyn plot RUN.h5 [--out PNG]

``render`` draws frame K (default the last) off-screen with pyvista: the
cells coloured by the magnitude of their displacement (``--color
displacement``, the default) or by their stress, when the history has the
``cell_stress`` field: a component (``sxx``, ``syy``, ``szz``, ``sxy``,
``syz``, ``sxz``; blue compression, red tension, a range symmetric about
0), ``von_mises``, ``principal_max`` or ``principal_min`` (io/export.py
stress_measures); displacements
magnified by F (default: chosen so that the largest displacement shows as
about 4 % of the domain size, rounded to 1, 2 or 5 × 10^n, never below 1);
the factor is printed and written in the picture.  Faces on which a spring
broke are drawn red (their edges too, so that a crack shows through the
cells), yielded faces orange.  The view looks along the thinnest side of the
domain (y on a tie), z up.

``plot`` draws the energies (kinetic, strain, dissipated, external work and
the balance error, solvers/output.py) and each probe over time with
matplotlib (the optional extra ``rbsm_dyn[plot]``).

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

from .export import STRESS_MEASURES, cells_mesh, faces_mesh
from .history import input_problem, open_history, require_rbsm_history

__all__ = ["render", "plot", "auto_scale", "RendererUnavailable", "check_renderer", "COLORS"]

STATE_COLORS = {1: "orange", 2: "red", 3: "red"}

#: render --size bounds [pixels] (below: nothing to see, VTK divides by 0;
#: above: the off-screen buffer no longer fits in memory)
SIZE_MIN, SIZE_MAX = 16, 8192

#: what the cells can be coloured by (--color): the displacement magnitude
#: or a measure of the cell stress (io/export.py STRESS_MEASURES)
COLORS = ("displacement",) + STRESS_MEASURES
# (ASCII: VTK's fonts may lack Greek letters)
_COLOR_LABELS = {"sxx": "stress xx", "syy": "stress yy", "szz": "stress zz",
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


def _fmt_scale(s: float) -> str:
    return f"{s:g}"


def _view(box_min, box_max):
    """Camera direction (from the focal point to the camera) and up vector:
    along the thinnest side (y first on a tie), z up."""
    ext = np.asarray(box_max) - np.asarray(box_min)
    order = [1, 0, 2]                       # prefer y, then x, then z
    axis = min(order, key=lambda a: (ext[a], order.index(a)))
    direction = np.zeros(3)
    direction[axis] = -1.0 if axis == 1 else 1.0    # look from -y (x right, z up)
    up = np.array([0.0, 0.0, 1.0]) if axis != 2 else np.array([0.0, 1.0, 0.0])
    return direction, up


def render(path, *, frame: int = -1, out=None, scale: float | None = None,
           window_size=(1600, 800), show_edges: bool = True,
           color: str = "displacement") -> dict:
    """Draw frame ``frame`` of history ``path`` to a PNG (module docstring),
    the cells coloured by ``color`` (one of COLORS).
    Returns ``{"out", "frame", "time", "scale", "max_displacement",
    "n_broken_faces", "n_yielded_faces", "renderer", "color", "color_range"}``
    (color_range: the (min, max) of the colour bar)."""
    if color not in COLORS:
        raise ValueError(f"--color must be one of {', '.join(COLORS)} (got {color!r})")
    if len(window_size) != 2 or not all(SIZE_MIN <= int(v) <= SIZE_MAX for v in window_size):
        raise ValueError(f"--size W H must be between {SIZE_MIN} and {SIZE_MAX} pixels each "
                         f"(got {' '.join(str(v) for v in window_size)})")
    renderer = check_renderer()
    import pyvista as pv
    pv.OFF_SCREEN = True
    path = Path(path)
    require_rbsm_history(path)
    h = open_history(path, frames=frame)
    if h.position is None:
        raise KeyError(f"{path}: no body positions in the history (output.fields)")
    fi = int(h.frame_index[0])
    out = Path(out) if out is not None else path.with_name(f"{path.stem}_frame{fi}.png")
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
    if color == "displacement":
        scalars, label, cmap = "displacement [m]", "displacement [m]", "viridis"
        clim = (float(umag.min(initial=0.0)), max_u)
    else:
        if h.cell_stress is None:
            raise KeyError(f"{path}: no cell stress in the history (add cell_stress to "
                           "output.fields) for --color " + color)
        label = f"{_COLOR_LABELS[color]} [Pa]"
        scalars = label
        val = np.asarray(cells.cell_data[color])
        cells.cell_data[label] = val
        top = float(np.abs(val).max(initial=0.0))
        if color in ("von_mises",):
            cmap, clim = "viridis", (0.0, top)
        else:
            # signed: blue compression, red tension, zero in the middle
            cmap, clim = "coolwarm", (-top, top)
        if clim[1] <= clim[0]:
            clim = (clim[0] - 1.0, clim[1] + 1.0)
    faces = faces_mesh(h, 0, geom, scale=scale, min_state=1)
    state = np.asarray(faces.cell_data["state"]) if faces.n_cells else np.zeros(0)

    case = h.case()
    name = case.get("name") or path.stem
    pl = pv.Plotter(off_screen=True, window_size=list(window_size))
    pl.set_background("white")
    pl.add_mesh(cells, scalars=scalars, cmap=cmap, clim=clim, show_edges=show_edges,
                preference="point" if color == "displacement" else "cell",
                edge_color="#303030", line_width=0.5, lighting=True,
                scalar_bar_args={"title": label, "color": "black", "vertical": True,
                                 "position_x": 0.89, "position_y": 0.1,
                                 "height": 0.7, "width": 0.05, "fmt": "%.2e"})
    n_broken = int(np.count_nonzero(state >= 2))
    n_yield = int(np.count_nonzero(state == 1))
    for st_sel, face_color in (((state == 1), "orange"), ((state >= 2), "red")):
        ids = np.nonzero(st_sel)[0]
        if len(ids) == 0:
            continue
        sub = faces.extract_cells(ids)
        pl.add_mesh(sub, color=face_color, opacity=1.0, lighting=False)
        pl.add_mesh(sub.extract_all_edges(), color=face_color, line_width=3,
                    render_lines_as_tubes=False)
    t = float(h.time[0])
    mode = case.get("solver", {}).get("mode", "dynamic")
    tlabel = {"static": f"load factor {t:.4g}", "modal": f"mode {int(h.step[0])}",
              "linear": "linear solution"}.get(mode, f"t = {t:.4g} s")
    text = (f"{name}: frame {fi}, {tlabel}\n"
            f"displacement magnified x {_fmt_scale(scale)} (largest: {max_u:.3g} m)"
            + (f"; colour: {label}" if color != "displacement" else "") + "\n"
            f"red: broken faces ({n_broken}), orange: yielded faces ({n_yield})")
    pl.add_text(text, position="upper_left", font_size=11, color="black")
    direction, up = _view(box_min, box_max)
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
    pl.camera.focal_point = 0.5 * (lo + hi)
    pl.camera.position = 0.5 * (lo + hi) + direction * size * 3
    pl.camera.parallel_scale = 0.5 * max(hgt / 0.72, w / (0.72 * aspect))
    out.parent.mkdir(parents=True, exist_ok=True)
    pl.screenshot(str(out))
    pl.close()
    return {"out": str(out), "frame": fi, "time": t, "scale": float(scale),
            "max_displacement": max_u, "n_broken_faces": n_broken,
            "n_yielded_faces": n_yield, "renderer": renderer, "color": color,
            "color_range": (float(clim[0]), float(clim[1]))}


# ------------------------------------------------------------------ plot
ENERGIES = (("kinetic", "kinetic"), ("strain", "strain"), ("plastic", "plastic"),
            ("fracture", "fracture"), ("damping", "damping"),
            ("contact_friction", "contact friction"),
            ("external_work", "external work"))
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
                     + get("fracture") + get("contact_friction") - supplied)
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
    ``{"out", "probes", "balance_error"}`` (balance_error: largest |error| /
    largest supplied energy)."""
    try:
        import matplotlib
    except ImportError as exc:
        raise ImportError("plot needs matplotlib: pip install 'rbsm_dyn[plot]'") from exc
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    path = Path(path)
    out = Path(out) if out is not None else path.with_name(f"{path.stem}_plot.png")
    require_rbsm_history(path)
    names = _observable_names(path)
    probes = [n for n in names if n not in NOT_PROBES][:max_probes]
    case, obs, (te, error), big_err, sup, units = read_observables(
        path, probes + ["n_broken", "residual"])
    probes = [n for n in probes if n in obs]
    mode = case.get("solver", {}).get("mode", "dynamic")
    xlabel = {"static": "load factor λ", "modal": "mode", "linear": "frame"}.get(mode, "time [s]")
    extra = [n for n in ("n_broken", "residual") if n in obs and np.any(obs[n][1])]
    n_panels = 1 + len(probes) + len(extra)
    fig, axes = plt.subplots(n_panels, 1, sharex=True, figsize=(8, 2.4 + 2.0 * n_panels),
                             squeeze=False)
    axes = axes[:, 0]
    ax = axes[0]
    for key, label in ENERGIES:
        if key in obs and np.any(obs[key][1] != 0):
            ax.plot(*obs[key], label=label)
    ax.plot(te, error, "k--", lw=1, label="balance error")
    rel = big_err / sup if sup > 0 else 0.0
    ax.set_ylabel("energy [J]")
    ax.set_title(f"{case.get('name') or path.stem}: energies (balance error ≤ {rel:.2%} "
                 "of the supplied energy)", fontsize=10)
    ax.legend(fontsize=8, ncol=3)
    ax.grid(alpha=0.3)
    for ax, name in zip(axes[1:], probes + extra):
        unit = units.get(name, "1")
        ax.plot(*obs[name], color="C0")
        ax.set_ylabel(f"{name} [{unit}]" if unit != "1" else name)
        ax.grid(alpha=0.3)
    axes[-1].set_xlabel(xlabel)
    fig.tight_layout()
    out.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(out, dpi=100)
    plt.close(fig)
    return {"out": str(out), "probes": probes, "balance_error": rel}


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
    p.add_argument("history", help="history file (RUN.h5)")
    p.add_argument("--frame", type=int, default=-1, metavar="K",
                   help="frame to draw (negative counts from the end; default the last)")
    p.add_argument("--out", metavar="PNG", help="picture file (default RUN_frameK.png)")
    p.add_argument("--scale", type=float, default=None, metavar="F",
                   help="displacement magnification (default: automatic, printed)")
    p.add_argument("--size", type=int, nargs=2, default=(1600, 800), metavar=("W", "H"),
                   help=f"picture size in pixels, {SIZE_MIN} to {SIZE_MAX} each "
                        "(default 1600 800)")
    p.add_argument("--color", "--colour", choices=COLORS, default="displacement",
                   help="colour the cells by the displacement magnitude (default) or by "
                        "their stress (needs the cell_stress field): a component sxx ... sxz, "
                        "von_mises, principal_max, principal_mid, principal_min")
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
                     window_size=tuple(args.size), color=getattr(args, "color", "displacement"))
    except RendererUnavailable as exc:
        print(f"rbsm_dyn: render: {exc}", file=sys.stderr)
        return 1
    except (KeyError, IndexError, ValueError, OSError) as exc:
        print(f"rbsm_dyn: render: {exc}", file=sys.stderr)
        return 2
    if not args.quiet:
        print(f"rbsm_dyn: frame {res['frame']} (t = {res['time']:.4g}): displacement "
              f"magnified x {_fmt_scale(res['scale'])} (largest {res['max_displacement']:.3g} m), "
              f"{res['n_broken_faces']} broken and {res['n_yielded_faces']} yielded faces "
              f"-> {res['out']}")
    return 0


def add_plot_arguments(p) -> None:
    p.add_argument("history", help="history file (RUN.h5)")
    p.add_argument("--out", metavar="PNG", help="picture file (default RUN_plot.png)")
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
        print(f"rbsm_dyn: energies and {len(res['probes'])} probes "
              f"(energy balance error ≤ {res['balance_error']:.2%}) -> {res['out']}")
    return 0
