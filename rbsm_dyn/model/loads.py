"""Groups, surfaces, surface loads, constraints, loads and their amplitude
tables: what a build reads from a case's groups, boundary and loads."""
import numpy as np

from ..physics.integrate import DISPLACEMENT, FIXED, VELOCITY
from .core import IDX

FACES = ("xmin", "xmax", "ymin", "ymax", "zmin", "zmax")
COMPONENTS = ("x", "y", "z", "rx", "ry", "rz")


def _select(case, name, centroids):
    """(int32) the bodies of a group: all, or those with their centroid in its box."""
    if name == "all":
        return np.arange(len(centroids), dtype=IDX)
    box = np.asarray(case.groups[name].box, dtype=float)
    tol = 1e-9 * np.max(np.abs(centroids)) if len(centroids) else 0.0
    inside = np.all((centroids >= box[0] - tol) & (centroids <= box[1] + tol), axis=1)
    return np.nonzero(inside)[0].astype(IDX)


def body_groups(case, mesh, parts, body_part):
    """The groups of bodies: all, each part's bodies (a scene of parts), the case's groups."""
    n = mesh.n_cells
    groups = {"all": np.arange(n, dtype=IDX)}
    for k, part in enumerate(parts if case.parts else []):
        groups[part.name] = np.nonzero(body_part == k)[0].astype(IDX)
    for name in (case.groups or {}):
        ids = _select(case, name, mesh.cell_centroid)
        if len(ids) == 0:
            raise case.error(("groups", name, "box"), "selects no body (no cell centroid inside)")
        groups[name] = ids
    return groups


def surface_ids(case, mesh, name):
    """Indices into mesh.surface_names of a named surface (case/parts.py
    surface_indices: a box's xmin ... zmax, a geometry's naming rules, or
    <part>.<surface> in a scene of parts)."""
    from ..case import surface_indices
    try:
        return surface_indices(case, name)
    except ValueError as exc:
        raise case.error(("boundary",), str(exc)) from None


def surface_load(case, mesh, item, path):
    """Dead load of a surface-load item on its boundary faces: (cells (B,),
    forces (B, 3) [N], moments about the cell centroids (B, 3) [N m]), one
    row per face.  Pressure p: F = −p n A (n the outward normal, p > 0
    pushes into the solid); traction t: F = t A; A the face's true area,
    applied at its area centroid x_f: M = (x_f − x_c) × F (DESIGN.md §6)."""
    faces = np.nonzero(np.isin(mesh.bface_side, surface_ids(case, mesh, item.surface)))[0]
    if len(faces) == 0:
        raise case.error(path + ("surface",), f"surface {item.surface!r} has no boundary "
                         "face in the mesh")
    if case.plane is not None and np.max(np.abs(mesh.bface_normal[faces, 2])) > 1e-9:
        raise case.error(path + ("surface",), f"surface {item.surface} is a face of the plane "
                         "(the slab's top or bottom): a plane case loads its edges only")
    cells = mesh.bface_cell[faces]
    area = mesh.bface_area[faces][:, None]
    if item.pressure is not None:
        f = -item.pressure * mesh.bface_normal[faces] * area
    else:
        f = np.asarray(item.traction, float)[None, :] * area
    arm = mesh.bface_centroid[faces] - mesh.cell_centroid[cells]
    return cells.astype(IDX), f, np.cross(arm, f)


class Amplitudes:
    """The amplitude tables (t, a) of the prescribed motions and loads, one
    after the other (Model.hist_ptr, hist_t, hist_a)."""

    def __init__(self):
        self.t, self.a, self.ptr = [], [], [0]

    def add(self, table):
        """Append a table [[t, a], ...]; its index."""
        table = np.asarray(table, float)
        self.t.extend(table[:, 0])
        self.a.extend(table[:, 1])
        self.ptr.append(len(self.t))
        return len(self.ptr) - 2


def interface_notes(case, mesh):
    """Notes (messages for the user) on the interfaces whose parts do not touch."""
    notes = []
    for i, it in enumerate(case.interfaces):
        if mesh.face_interface is None or not np.any(mesh.face_interface == i):
            notes.append(f"interfaces[{i}]: parts {it.parts[0]} and {it.parts[1]} do not touch "
                         "(no shared faces): nothing joins them")
    return notes


def constraints(case, mesh, groups, hist, notes):
    """Constraints and prescribed motion: dof_kind, dof_value, dof_hist (N,
    6), and the ground's motion, ground_hist (1,) int32 (its velocity's
    table, −1: at rest) and ground_dir (3,) (_ground_motion)."""
    n = mesh.n_cells
    dof_kind = np.zeros((n, 6), dtype=np.int8)
    dof_value = np.zeros((n, 6))
    dof_hist = np.full((n, 6), -1, dtype=IDX)
    static = case.solver.mode != "dynamic"
    end_time = getattr(case.solver, "end_time", None) or 1.0
    dof_item = np.full((n, 6), -1)          # the boundary item that set each component

    def claim(ids, c, j, what):
        """Warn when an earlier item prescribed component c of these bodies
        differently (the later item wins)."""
        prev = dof_item[ids, c]
        clash = prev >= 0
        if clash.any():
            k = int(prev[clash][0])
            notes.append(f"boundary[{j}] ({what}) and boundary[{k}] both prescribe "
                         f"{COMPONENTS[c]} of {int(clash.sum())} bodies; boundary[{j}] wins")
        dof_item[ids, c] = j

    for j, item in enumerate(case.boundary or []):
        if hasattr(item, "face"):             # a support on a face or surface
            continue
        if getattr(item, "surface", None) is not None:
            # the cells with a boundary face on the surface
            on = np.isin(mesh.bface_side, surface_ids(case, mesh, item.surface))
            ids = np.unique(mesh.bface_cell[on]).astype(IDX)
        else:
            ids = groups[item.group]
        if getattr(item, "fix", None) is not None:
            fix = COMPONENTS if item.fix == "all" else tuple(item.fix)
            for c in fix:
                claim(ids, COMPONENTS.index(c), j, "fix")
                dof_kind[ids, COMPONENTS.index(c)] = FIXED
            continue
        if getattr(item, "velocity", None) is not None:
            if static:
                raise case.error(("boundary", j, "velocity"),
                                 "prescribed velocity needs solver.mode: dynamic "
                                 "(use displacement in static mode)")
            kind, vec = VELOCITY, item.velocity
            h = hist.add(item.history) if getattr(item, "history", None) else -1
        else:
            kind, vec = DISPLACEMENT, item.displacement
            table = getattr(item, "history", None) or [[0.0, 0.0], [end_time, 1.0]]
            h = hist.add(table)
        for c in range(3):
            if vec[c] is not None:
                claim(ids, c, j, "velocity" if kind == VELOCITY else "displacement")
                dof_kind[ids, c] = kind
                dof_value[ids, c] = vec[c]
                dof_hist[ids, c] = h
    ground_hist, ground_dir = np.full(1, -1, dtype=IDX), np.zeros(3)
    if case.ground_motion is not None:
        ground_hist[0], ground_dir[:] = _ground_motion(case, mesh, hist, dof_kind, dof_value,
                                                       dof_hist, dof_item)
    _shared_bodies(dof_item, notes, list(case.boundary or []))
    return dof_kind, dof_value, dof_hist, ground_hist, ground_dir


def _ground_motion(case, mesh, hist, dof_kind, dof_value, dof_hist, dof_item):
    """`ground_motion`: the ground moves along its direction with the
    velocity v_g(t) (records.integrate: exact for the record linear between
    its samples, at four points a step, linear between them); returns its
    velocity's table and the unit direction.  The components along it that
    the `{group, fix}` supports hold become prescribed velocities v_g times
    the direction's component (the rest stays fixed), and the ground's own
    row of the body arrays moves with it (physics/integrate.py), carrying
    the supports by springs ({face | surface, fix}) and the contact ground.
    A velocity, not the displacement: a table of displacements would make
    the velocity jump at each of its points and the constraint's work of
    those jumps (½ m Δv² each) would not be the kinetic energy it gives
    (2 % of the work on a one-degree-of-freedom oscillator); the
    displacement is the velocity's midpoint-rule integral, within (dt²/24)
    max|ȧ_g| of d_g."""
    from ..case.boundary import FaceSupport, GroupFix
    gm = case.ground_motion
    at = ("ground_motion",)
    if case.solver.mode != "dynamic":
        raise case.error(at, "a ground motion needs solver.mode: dynamic")
    items = list(case.boundary or [])
    direction = np.asarray(gm.direction, dtype=float)
    norm = float(np.linalg.norm(direction))
    if norm == 0.0:
        raise case.error(at + ("direction",), "a nonzero vector: the ground's direction")
    if case.plane is not None and direction[2] != 0.0:
        raise case.error(at + ("direction",), "in a plane case the ground moves in the "
                         "plane: [x, y]")
    direction = direction / norm
    tf, vf, _ = ground_table(case)
    h = hist.add(np.column_stack([tf, vf]))
    fixes = [j for j, item in enumerate(items) if isinstance(item, GroupFix)]
    moved = 0
    for c in range(3):
        if direction[c] == 0.0:
            continue
        rows = np.isin(dof_item[:, c], fixes) & (dof_kind[:, c] == FIXED)
        dof_kind[rows, c] = VELOCITY
        dof_value[rows, c] = direction[c]
        dof_hist[rows, c] = h
        moved += int(rows.sum())
    springs = any(isinstance(item, FaceSupport) for item in items)
    ground = case.contact is not None and getattr(case.contact, "ground", None) is not None
    if moved == 0 and not springs and not ground:
        raise case.error(at, "nothing moves with the ground: no {group, fix} support holds "
                         "a component along its direction, and there is no support by "
                         "springs ({face | surface, fix}) and no contact ground")
    return h, direction


def ground_table(case):
    """(t [s], v [m/s], d [m]) of a case's ground motion: the record,
    linear between its samples, integrated exactly to the ground's
    velocity and displacement along its direction (records.py), baseline
    corrected; CaseError naming ground_motion.file when it cannot be read."""
    from pathlib import Path
    from ..case import _case_dir
    from ..records import integrate, read_record
    gm = case.ground_motion
    path = Path(gm.file)
    if not path.is_absolute():
        path = _case_dir(case) / path
    try:
        t, a = read_record(path, dt=gm.dt, units=gm.units, scale=gm.scale,
                           columns=tuple(gm.columns), skip=gm.skip)
        if len(t) < 2 or np.any(np.diff(t) <= 0.0):
            raise ValueError("the times must increase")
        (tf, _, vf, df), _ = integrate(t, a, baseline=gm.baseline)
    except (OSError, ValueError, IndexError) as exc:
        raise case.error(("ground_motion", "file"), f"{path}: {exc}") from None
    return tf, vf, df


def _shared_bodies(dof_item, notes, boundary=()):
    """A note for two boundary items that prescribe different components of
    the same bodies (a corner cell in `top` with z and in `right` with x):
    each body takes the components of both, which is what a corner needs,
    but said, so that an overlap of groups that was not meant is seen.  Two
    items of one group (`{group: g, fix: [x, y]}` and `{group: g,
    velocity: ...}`) are meant: no note."""
    hi = dof_item.max(axis=1)
    lo = np.where(dof_item >= 0, dof_item, hi[:, None]).min(axis=1)
    rows, counts = np.unique(dof_item[lo != hi], axis=0, return_counts=True)
    seen = {}
    for row, count in zip(rows, counts):
        items = sorted({int(k) for k in row if k >= 0})
        for a in range(len(items)):
            for b in range(a + 1, len(items)):
                seen[(items[a], items[b])] = seen.get((items[a], items[b]), 0) + int(count)
    for (j, k), count in sorted(seen.items()):
        gj, gk = (getattr(boundary[i], "group", None) if i < len(boundary) else None
                  for i in (j, k))
        if gj is not None and gj == gk:
            continue
        cj = ", ".join(COMPONENTS[c] for c in range(6) if np.any(dof_item[:, c] == j))
        ck = ", ".join(COMPONENTS[c] for c in range(6) if np.any(dof_item[:, c] == k))
        notes.append(f"boundary[{j}] ({cj}) and boundary[{k}] ({ck}) share {count} "
                     f"bod{'y' if count == 1 else 'ies'}: each takes the components of both")


def _turns(item, case):
    """Whether a load item is a follower in this case's run (a surface
    load's `turns`: a pressure follows in mode dynamic by default)."""
    return bool(getattr(item, "turns", None) and item.turns(case.solver.mode))


def body_loads(case, mesh, groups, rot0, hist):
    """Loads on the bodies: fext, mext, ffol, mfol (N, 3), load_hist (N,), gravity (3,)."""
    # loads: a group's total force/moment shared over its bodies by volume;
    # a surface load's force on each boundary face of the surface, at the
    # face's area centroid (surface_load); a follower's in the principal
    # frames.  One amplitude history per body: items on one body must share
    # it (equal tables are one history).
    n = mesh.n_cells
    fext = np.zeros((n, 3))
    mext = np.zeros((n, 3))
    ffol = np.zeros((n, 3))
    mfol = np.zeros((n, 3))
    load_hist = np.full(n, -1, dtype=IDX)
    load_item = np.full(n, -1)              # an item that loads the body
    load_tables = {}
    gravity = np.zeros(3)
    for j, item in enumerate(case.loads or []):
        if getattr(item, "gravity", None) is not None:
            gravity += np.asarray(item.gravity, float)
            continue
        if getattr(item, "surface", None) is not None:
            ids, f, mom = surface_load(case, mesh, item, ("loads", j))
        else:
            ids = groups[item.group]
            w = mesh.cell_volume[ids] / mesh.cell_volume[ids].sum()
            f = w[:, None] * np.asarray(item.force, float)
            mom = w[:, None] * np.asarray(item.moment, float)
        h = -1
        if getattr(item, "history", None):
            key = tuple(map(tuple, item.history))
            if key not in load_tables:
                load_tables[key] = hist.add(item.history)
            h = load_tables[key]
        bodies = np.unique(ids)
        clash = bodies[(load_item[bodies] >= 0) & (load_hist[bodies] != h)]
        if len(clash):
            k = int(load_item[clash[0]])
            raise case.error(("loads", j, "history"),
                             f"{len(clash)} bodies are also loaded by loads[{k}] with another "
                             "history (a body follows one load history: give both items the "
                             "same history, or load disjoint bodies)")
        load_hist[bodies] = h
        load_item[bodies] = j
        if _turns(item, case):
            # f_b = R0ᵀ f: constant in the rigid cell's frame
            np.add.at(ffol, ids, np.einsum("nki,nk->ni", rot0[ids], f))
            np.add.at(mfol, ids, np.einsum("nki,nk->ni", rot0[ids], mom))
        else:
            np.add.at(fext, ids, f)
            np.add.at(mext, ids, mom)
    if not any(_turns(item, case) for item in case.loads or []):
        ffol = mfol = np.zeros((0, 3))
    return fext, mext, ffol, mfol, load_hist, gravity
