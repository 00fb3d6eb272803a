"""What a run records: static model data, per-frame fields, energies and
probes, written through io/history.py in the H5MD layout (docs/history.md).

Energies (output steps only, never per step):
  kinetic   ½ Σ m v·v + ½ Σ Lb·I⁻¹Lb at synchronized velocities [J]
  strain    ½ Σ k δ² over spring points [J], plus the auxiliary-stress
            energy Σ_c ½ λ_c V_c χ_c θ_c² of the Poisson correction
            (physics/poisson.py) when the model has it
  external  work of loads, gravity and constraints since t = 0 [J]
  damping   energy dissipated by mass-proportional damping [J]
  plastic   dissipated by yield and by friction on closed cracks [J]
  fracture  dissipated by rupture and softening [J]
  contact_friction  dissipated by Coulomb friction between cells in contact
            (case ``contact``, physics/collide.py; the series exists only
            in a run with contact, whose strain term then holds the
            contacts' elastic energy too) [J]
Balance: kinetic + strain + damping + plastic + fracture (+ contact_friction)
         = kinetic(0) + strain(0) + external.
Cracks: n_broken (springs broken, open or in contact) and crack_area [m²]
(their area); spring states per frame in springs/state when asked.
Damage (field spring_damage, springs/damage (S,) float32): per spring point
0 intact to 1 broken (spring_damage_of).
Cell stress (field cell_stress, particles/bodies/stress (N, 3, 3) [Pa]):
the symmetrised Love–Weber average of each cell's spring forces
(physics/cell_stress.py), computed only in the frames of a run that asks.
Probes: a reduction over a group's bodies, or (relative_displacement) the
displacement of group or point b minus that of a (probe_plan).
"""
import json

import numpy as np

from .._version import __version__
from ..io.history import HistoryWriter
from ..physics.rotation import quat_matrix_np, quat_mul_np
from ..physics.collide import O_E, O_W
from ..physics.inelastic import strain_energy
from ..physics.laws import BROKEN
from ..physics.poisson import poisson_energy
from ..physics.cell_stress import cell_stress
from .passes import Options, body_state, history, model_arrays

FIELD_SERIES = {
    "position": ("particles/bodies/position", (3,), "f8", "m"),
    "orientation": ("particles/bodies/orientation", (4,), "f8", "1"),
    "velocity": ("particles/bodies/velocity", (3,), "f8", "m s-1"),
    "angular_velocity": ("particles/bodies/angular_velocity", (3,), "f8", "s-1"),
    "spring_state": ("springs/state", None, "i1", "1"),
    "spring_force": ("springs/force", None, "f8", "N"),
    # symmetric; stored whole (not as 6 Voigt numbers) so that no component
    # order has to be guessed: eigvalsh and einsum read it as it is
    "cell_stress": ("particles/bodies/stress", (3, 3), "f8", "Pa"),
    # damage of each spring point, 0 intact .. 1 broken (spring_damage_of):
    # softening shows here before the spring breaks
    "spring_damage": ("springs/damage", None, "f4", "1"),
}


def spring_damage_of(model, state):
    """The damage (S,) float32 written by the field spring_damage: the
    softening damage D of an intact spring (physics/inelastic.py, State.
    spring_dmg: its stiffness in tension is (1 − D) k), 1 where the spring
    is broken (state >= BROKEN: also a spring cut before the run or broken
    by the strain or strength law, whose D stays 0), 0 in an elastic model.
    Never decreases over a run: D grows only, a broken spring stays broken."""
    if not model.inelastic:
        return np.zeros(model.n_springs, dtype=np.float32)
    d = np.clip(state.spring_dmg, 0.0, 1.0).astype(np.float32)
    d[state.spring_state >= BROKEN] = 1.0
    return d


def frame_buffer(case):
    """Frames are written in batches (io/history_writer.py set_buffering): at most
    256 frames, 64 MiB or output.flush_interval seconds of wall time late
    (a killed run loses at most that; a failed or stopped one nothing);
    flush_interval 0 writes every frame at once."""
    sec = float(getattr(case.output, "flush_interval", 1.0))
    return dict(frames=256 if sec > 0 else 1, seconds=sec, nbytes=64 << 20)

PROBE_UNITS = {"displacement": "m", "rotation": "rad", "velocity": "m s-1",
               "force": "N", "reaction": "N", "relative_displacement": "m"}


def versions():
    import h5py
    import numba
    import scipy
    return {"rbsm_dyn": __version__, "numpy": np.__version__, "numba": numba.__version__,
            "scipy": scipy.__version__, "h5py": h5py.__version__}


def rotation_vectors(model, body_quat):
    """World rotation vectors (axis × angle) of Δq = q q0⁻¹ (N, 3) [rad]."""
    q0 = model.body_quat0[:-1].copy()
    q0[:, 1:] *= -1
    dq = quat_mul_np(body_quat[:-1], q0)
    dq[dq[:, 0] < 0] *= -1
    s = np.linalg.norm(dq[:, 1:], axis=1)
    ang = 2 * np.arctan2(s, dq[:, 0])
    with np.errstate(invalid="ignore", divide="ignore"):
        fac = np.where(s > 1e-300, ang / s, 2.0)
    return dq[:, 1:] * fac[:, None]


def point_body(mesh, point):
    """The body whose cell holds a point [m], or None when no cell does.

    A cell holds p when its winding number about p is positive: the sum of
    the solid angles of its (fan-triangulated, outward) polygons seen from
    p over 4π, 1 inside, 1/2 on a face, a corner's share on an edge or a
    vertex, 0 outside (solid angle of a triangle: Van Oosterom & Strackee,
    IEEE Trans. Biomed. Eng. 30 (1983) 125–126); exact for non-convex
    cells too.  Only the cells whose bounding box holds p are looked at.  On
    a face, edge or corner shared by cells, the one whose centroid is
    nearest."""
    p = np.asarray(point, dtype=float)
    V = mesh.vertices
    cvp = np.asarray(mesh.cell_vertex_ptr, dtype=np.int64)
    lo = np.minimum.reduceat(V, cvp[:-1], axis=0)
    hi = np.maximum.reduceat(V, cvp[:-1], axis=0)
    size = float(np.max(V.max(axis=0) - V.min(axis=0)))
    tol = 1e-9 * size
    cand = np.nonzero(np.all((lo - tol <= p) & (p <= hi + tol), axis=1))[0]
    if len(cand) == 0:
        return None
    # the polygons of the candidate cells, in cell order
    cp = np.asarray(mesh.cell_poly_ptr, dtype=np.int64)
    npoly = cp[cand + 1] - cp[cand]
    first = np.cumsum(npoly) - npoly
    polys = np.arange(npoly.sum()) - np.repeat(first, npoly) + np.repeat(cp[cand], npoly)
    # their fan triangles (v0, v_k, v_k+1), k = 1 .. n-2
    pp = np.asarray(mesh.poly_ptr, dtype=np.int64)
    ntri = pp[polys + 1] - pp[polys] - 2
    tfirst = np.cumsum(ntri) - ntri
    k = np.arange(ntri.sum()) - np.repeat(tfirst, ntri) + 1
    start = np.repeat(pp[polys], ntri)
    a = V[mesh.poly_vertex[start]] - p
    b = V[mesh.poly_vertex[start + k]] - p
    c = V[mesh.poly_vertex[start + k + 1]] - p
    la, lb, lc = (np.linalg.norm(x, axis=1) for x in (a, b, c))
    num = np.einsum("ki,ki->k", a, np.cross(b, c))
    den = (la * lb * lc + np.einsum("ki,ki->k", a, b) * lc
           + np.einsum("ki,ki->k", a, c) * lb + np.einsum("ki,ki->k", b, c) * la)
    # tan(Ω/2) = num/den; p in the triangle's plane: Ω = 2π inside it (den
    # < 0; the limit from the cell's side), 0 outside, 0 on its edges
    flat = np.abs(num) <= 1e-12 * la * lb * lc
    omega = np.where(flat, np.where(den < 0, 2 * np.pi, 0.0), 2 * np.arctan2(num, den))
    cell_of_tri = np.repeat(np.repeat(np.arange(len(cand)), npoly), ntri)
    winding = np.bincount(cell_of_tri, omega, minlength=len(cand)) / (4 * np.pi)
    pool = cand[winding > 1e-6]
    if len(pool) == 0:
        return None
    return int(pool[np.argmin(np.linalg.norm(mesh.cell_centroid[pool] - p, axis=1))])


def probe_plan(model, probes, case=None):
    """How each probe is evaluated: name -> tuple (Recorder.probe_values).

    relative_displacement of groups: the mean centroid displacement of
    group b minus group a; of points: the displacement of the material
    point p_b of its body minus that of p_a (point_body; the body's rotation
    moves the point: u = x + R_Δ (p − x0) − p)."""
    plan = {}
    R0 = quat_matrix_np(model.body_quat0[:-1])
    for name, p in probes.items():
        if p.quantity != "relative_displacement":
            if getattr(p, "surface", None) is not None:
                # the cells with a boundary face on the surface
                from ..case import surface_indices
                mesh = model.mesh
                on = np.isin(mesh.bface_side, surface_indices(case, p.surface))
                plan[name] = ("group", np.unique(mesh.bface_cell[on]).astype(np.int32))
            else:
                plan[name] = ("group", model.groups[p.group])
            continue
        if p.direction is not None:
            d = np.asarray(p.direction, dtype=float)
            proj = d / np.linalg.norm(d)
        else:
            proj = p.component
        if p.groups is not None:
            plan[name] = ("groups", model.groups[p.groups[0]], model.groups[p.groups[1]], proj)
            continue
        ends = []
        for k, pt in enumerate(p.points):
            found = point_body(model.mesh, pt)
            if found is None:
                # (raised when the first frame is recorded, inside the run,
                # where the command line reports a CaseError with exit 2)
                where = ("output", "probes", name, "points", k)
                msg = (f"lies in no cell of the model (got {list(pt)}: inside the "
                       "domain's bounds, outside its solid)")
                plan[name] = ("error", case.error(where, msg) if case is not None
                              else ValueError(msg))
                break
            i = found
            pt = np.asarray(pt, dtype=float)
            # the arm from the centroid in the body's principal frame (R(q) moves it)
            ends.append((i, R0[i].T @ (pt - model.body_pos0[i]), pt))
        else:
            plan[name] = ("points", ends[0], ends[1], proj)
    return plan


def probe_warnings(case, model):
    """Warnings about relative-displacement probes by points that cannot
    measure what they seem to: two points either side of a cut's plane
    whose cells both lie on one side of it (a Voronoi cell straddles the
    plane: `cuts` splits the springs by the side of the cells' centroids),
    so the probe reads the deformation of one side, not the opening."""
    notes = []
    for name, plan in probe_plan(model, dict(case.output.probes or {}), case).items():
        if plan[0] != "points":
            continue
        (ia, _, pa), (ib, _, pb) = plan[1], plan[2]
        for k, cut in enumerate(case.cuts):
            x0 = np.asarray(cut.point, dtype=float)
            n = np.asarray(cut.normal, dtype=float)
            lo, hi = (np.asarray(b, dtype=float) for b in cut.within)
            mid = 0.5 * (pa + pb)
            if np.sign((pa - x0) @ n) == np.sign((pb - x0) @ n) or \
                    np.any(mid < lo) or np.any(mid > hi):
                continue
            ca = np.sign((model.body_pos0[ia] - x0) @ n)
            cb = np.sign((model.body_pos0[ib] - x0) @ n)
            if ca == cb:
                notes.append(f"output.probes.{name}: its points lie either side of cuts[{k}], "
                             f"but in cells {ia} and {ib} whose centroids are both on one side "
                             "(a cell straddles the cut's plane): it reads the deformation of "
                             "one side, not the opening; move the points a cell or more from "
                             "the plane, or use groups: [a, b] of cells either side")
    return notes


def surface_load_levers(case, model):
    """(cells (K,), lever ⊗ force (K, 9) [N m]) of the surface loads at
    amplitude 1, one row per loaded boundary face: the face's force F_f
    acts at its area centroid x_f, lever x_f − x_c from its cell's centroid
    (reference), as model/loads.py surface_load books it.  For the cell stress
    (physics/cell_stress.py): None without surface loads."""
    from ..model import surface_ids, surface_load
    mesh = model.mesh
    cells, terms = [], []
    for j, item in enumerate(case.loads):
        if getattr(item, "surface", None) is None:
            continue
        c, f, _ = surface_load(case, mesh, item, ("loads", j))
        # the faces surface_load loads, in its order
        faces = np.nonzero(np.isin(mesh.bface_side, surface_ids(case, mesh, item.surface)))[0]
        arm = mesh.bface_centroid[faces] - mesh.cell_centroid[c]
        cells.append(np.asarray(c, dtype=np.int64))
        terms.append(np.einsum("ki,kj->kij", arm, f).reshape(-1, 9))
    if not cells:
        return None
    return np.concatenate(cells), np.concatenate(terms)


def viscous_energies(m, state):
    """(stored, dissipated) [J] of the viscous springs (physics/viscous.py):
    the Maxwell branches hold Σ q²/(2 g k) − ½ g k δ² beyond the spring
    pass's ½ k δ² (intact springs); the rest of the viscous forces' work
    spring_wv is dissipated."""
    work = float(np.sum(state.spring_wv))
    if m.n_branches == 0 or len(state.spring_q) == 0:
        return 0.0, work
    kg = m.law_branch_g[m.spring_law][:, :, None] * m.spring_k[:, None, :]     # (S, M, 3)
    d = state.spring_gap[:, None, :]
    with np.errstate(divide="ignore", invalid="ignore"):
        e = np.where(kg > 0.0, 0.5 * state.spring_q ** 2 / kg - 0.5 * kg * d * d, 0.0)
    e = e.sum(axis=(1, 2))
    if len(state.spring_state):
        e = np.where(state.spring_state < BROKEN, e, 0.0)
    stored = float(np.sum(e))
    return stored, work - stored


def strain_energy_of(m, state):
    """Energy held by the springs of model m in `state` [J]
    (physics/inelastic.strain_energy; the Poisson pass's apart)."""
    opt = Options.of(m)
    return strain_energy(model_arrays(m)[1], body_state(state), history(state, opt))


def observable_units(case, model, extra=()):
    """The observables a history holds, with their units: the energies
    (docs/history.md), contact friction and viscous work where the model
    has them, the ground's displacement and velocity along its direction
    [m, m/s] in a case with a ground_motion (History.ground_displacement),
    and `extra` ((name, unit) pairs of a solver)."""
    units = {"kinetic": "J", "strain": "J", "external_work": "J", "damping": "J",
             "plastic": "J", "fracture": "J", "n_broken": "1", "crack_area": "m2"}
    if model.contact is not None:
        units["contact_friction"] = "J"
    if model.viscous:
        units["viscous"] = "J"
    if getattr(case, "ground_motion", None) is not None:
        units["ground_displacement"] = "m"
        units["ground_velocity"] = "m/s"
    units.update(dict(extra))
    return units


class Recorder:
    """Opens the history, writes the static part, appends frames."""

    def __init__(self, case, model, path, *, threads, extra_observables=(), lock=True,
                 stage=False):
        """lock, stage: as in io/history.HistoryWriter (the command line
        holds the lock itself and stages the file: a run that fails its
        checks before the first frame leaves an existing ``path`` as it
        was)."""
        self.case = case
        self.model = model
        out = case.output
        self.fields = list(out.fields)
        self.probes = dict(out.probes or {})
        self.plan = probe_plan(model, self.probes, case)
        self.levers = (surface_load_levers(case, model) if "cell_stress" in self.fields
                       else None)
        self.writer = w = HistoryWriter(
            path, creator="rbsm_dyn", creator_version=__version__,
            parameters={"case_yaml": case.source_text,
                        "case": json.dumps(case.resolved()),
                        "versions": json.dumps(versions()),
                        "threads": str(threads),
                        "materials": json.dumps(model.materials)},
            lock=lock, stage=stage)
        try:
            self._setup(case, model, w, extra_observables)
        except BaseException:
            w.discard()          # (Ctrl-C while the static part is written, ...)
            raise

    def _setup(self, case, model, w, extra_observables):
        w.set_buffering(**frame_buffer(case))
        m, mesh = model, model.mesh
        # 2: a plane model (its cells move in x-y; positions keep z = 0);
        # the H5MD box stays 3D (docs/history.md)
        w.set_root_attr("dimension", np.int32(2 if m.plane else 3))
        w.set_root_attr("plane", str(m.plane))
        w.write_static("particles/bodies/mass", m.body_mass, "kg")
        w.write_static("particles/bodies/inertia", m.body_inertia, "kg m2")
        w.write_static("particles/bodies/volume", m.body_volume, "m3")
        w.write_static("particles/bodies/material", m.body_material, "1")
        w.write_static("particles/bodies/reference_position", m.body_pos0[:-1], "m")
        w.write_static("particles/bodies/reference_orientation", m.body_quat0[:-1], "1")
        w.write_static("particles/bodies/geometry/vertices", mesh.vertices, "m")
        w.write_static("particles/bodies/geometry/cell_vertex_ptr", mesh.cell_vertex_ptr, "1")
        w.write_static("particles/bodies/geometry/poly_ptr", mesh.poly_ptr, "1")
        w.write_static("particles/bodies/geometry/poly_vertex", mesh.poly_vertex, "1")
        w.write_static("particles/bodies/geometry/cell_poly_ptr", mesh.cell_poly_ptr, "1")
        w.write_static("connectivity/springs", m.spring_bodies, "1")
        w.write_static("springs/position", m.spring_point, "m")
        w.write_static("springs/normal", m.spring_normal, "1")
        w.write_static("springs/area", m.spring_area, "m2")
        w.write_static("springs/face", m.spring_face, "1")
        w.write_static("springs/support", m.is_support.astype(np.int8), "1")
        # internal face polygons, so that crack faces (springs/state >= 2 of
        # spring s -> face springs/face[s]) can be drawn
        w.write_static("springs/faces/vertex_ptr", mesh.face_vertex_ptr, "1")
        w.write_static("springs/faces/vertex_xyz", mesh.face_vertex_xyz, "m")
        w.write_static("springs/faces/cells", mesh.face_cells, "1")
        # boundary face polygons: support spring s (springs/face[s] < 0) lies
        # on boundary face -1 - springs/face[s] (drawn by export and render)
        w.write_static("springs/boundary_faces/vertex_ptr", mesh.bface_vertex_ptr, "1")
        w.write_static("springs/boundary_faces/vertex_xyz", mesh.bface_vertex_xyz, "m")
        w.write_static("springs/boundary_faces/cell", mesh.bface_cell, "1")
        for name in self.fields:
            path_, tail, dt, unit = FIELD_SERIES[name]
            if tail is None:
                tail = ((m.n_springs,) if name in ("spring_state", "spring_damage")
                        else (m.n_springs, 3))
            else:
                tail = (m.n_bodies,) + tail
            w.add_series(path_, tail, dt, unit)
        self.observables = observable_units(case, m, extra_observables)
        for name, unit in self.observables.items():
            w.add_series(f"observables/{name}", (), "f8", unit)
        for name, p in self.probes.items():
            w.add_series(f"observables/{name}", (), "f8", PROBE_UNITS[p.quantity])
        if case.solver.mode == "dynamic":
            # checkpoint slots (solvers/checkpoint.py): no dataset can be made after start()
            from ..model import new_state
            from .checkpoint import create_slots
            create_slots(w.h5file, new_state(m))
        w.start()

    @classmethod
    def resume(cls, case, model, path, frames, *, extra_observables=(), lock=True):
        """A Recorder appending to an existing history (restart,
        solvers/checkpoint.py): the file is cut back to ``frames`` frames."""
        self = cls.__new__(cls)
        self.case = case
        self.model = model
        self.fields = list(case.output.fields)
        self.probes = dict(case.output.probes or {})
        self.plan = probe_plan(model, self.probes, case)
        self.levers = (surface_load_levers(case, model) if "cell_stress" in self.fields
                       else None)
        self.observables = observable_units(case, model, extra_observables)
        self.writer = HistoryWriter.reopen(path, frames=frames, lock=lock)
        self.writer.set_buffering(**frame_buffer(case))
        expected = {FIELD_SERIES[n][0] for n in self.fields} | \
            {f"observables/{n}" for n in list(self.observables) + list(self.probes)}
        if set(self.writer.series_paths) != expected:
            self.writer.discard()
            raise ValueError(f"{path}: its series {sorted(self.writer.series_paths)} are not "
                             f"those of the case {sorted(expected)}")
        return self

    def without_mesh_arrays(self):
        """Go on with the model less its mesh arrays (Model.without_mesh_arrays)
        and return it: the geometry is in the history by now and the probe
        plan and surface-load levers were taken when the Recorder was made;
        what append, the energies and the checkpoints read is the model's
        own arrays.  (cli/run.py, for the explicit and relaxation runs.)"""
        self.model = self.model.without_mesh_arrays()
        return self.model

    def strain_energy(self, state):
        m = self.model
        u = strain_energy_of(m, state)
        if m.poisson_on:
            u += poisson_energy(m.poisson, state.body_pos, state.body_rot,
                                state.spring_state, state.spring_dmg)
        if m.contact is not None and state.contact is not None:
            # the contacts' elastic energy at these positions (the pass that
            # synchronised this frame, explicit.spring_pass)
            u += float(np.sum(state.contact.out[:, O_E]))
        if m.viscous:
            u += viscous_energies(m, state)[0]
        return u

    def spring_observables(self, state):
        """Dissipated energies and crack measures of the springs now (and
        the friction of contacts between cells, in a run with contact)."""
        m = self.model
        extra = {}
        cs = state.contact if m.contact is not None else None
        if cs is not None:
            # at a frame (a trial contact state) with the step's own: its
            # slip springs stand at the frame already (their strain), having
            # lost what the Coulomb return and a changed area took, which
            # the next step books (physics/collide.py O_W)
            w = float(np.sum(cs.body_friction))
            if cs.is_trial:
                w += float(np.sum(cs.out[:, O_W]))
            extra["contact_friction"] = w
        if m.viscous:
            extra["viscous"] = viscous_energies(m, state)[1]
        if not m.inelastic:
            return {"plastic": 0.0, "fracture": 0.0, "n_broken": 0.0, "crack_area": 0.0,
                    **extra}
        broken = state.spring_state >= BROKEN
        return {"plastic": float(np.sum(state.spring_wp)),
                # with the auxiliary stress's share released by damage (physics/poisson.py)
                "fracture": float(np.sum(state.spring_wf)) + float(np.sum(state.cell_wf)),
                "n_broken": float(np.count_nonzero(broken)),
                "crack_area": float(np.sum(m.spring_area[broken])), **extra}

    def probe_values(self, state, vel, omega, t, amp_load):
        m = self.model
        out = {}
        for name, p in self.probes.items():
            plan = self.plan[name]
            if plan[0] == "error":
                raise plan[1]
            if plan[0] != "group":
                out[name] = self.relative_displacement(state, plan)
                continue
            ids = plan[1]
            if p.quantity == "displacement":
                v = state.body_pos[ids] - m.body_pos0[ids]
            elif p.quantity == "rotation":
                v = rotation_vectors(m, state.body_quat)[ids]
            elif p.quantity == "velocity":
                v = vel[ids]
            elif p.quantity == "force":
                v = amp_load[ids, None] * m.body_fext[ids] + m.body_mass[ids, None] * m.gravity
                if len(m.body_ffol):      # follower loads: R·f at the present rotation
                    v = v + amp_load[ids, None] * np.einsum("nij,nj->ni", state.body_rot[ids],
                                                             m.body_ffol[ids])
            else:
                v = state.body_reaction[ids]
            if getattr(p, "relative_to", None) == "ground":
                v = v - self.ground_motion(t, p.quantity)
            comp = v[:, "xyz".index(p.component)] if p.component in "xyz" else np.linalg.norm(v, axis=1)
            out[name] = float(getattr(np, p.reduce)(comp))
        return out

    def ground_motion(self, t, quantity):
        """The ground's displacement or velocity (3,) at time t (model/loads.py
        ground_table, linear between its points; at rest before and after)."""
        table = getattr(self, "_ground", None)
        if table is None:
            from ..model.loads import ground_table
            gm = self.case.ground_motion
            tg, vg, dg = ground_table(self.case)
            e = np.asarray(gm.direction, float)
            table = self._ground = (tg, vg, dg, e / np.linalg.norm(e))
        tg, vg, dg, e = table
        y = vg if quantity == "velocity" else dg
        return np.interp(t, tg, y, left=0.0, right=float(y[-1])) * e

    def relative_displacement(self, state, plan):
        """Displacement of end b minus end a (probe_plan), projected."""
        m = self.model
        kind, a, b, proj = plan
        if kind == "groups":
            du = (np.mean(state.body_pos[b] - m.body_pos0[b], axis=0)
                  - np.mean(state.body_pos[a] - m.body_pos0[a], axis=0))
        else:
            def u(end):
                i, arm, p = end
                return state.body_pos[i] + state.body_rot[i] @ arm - p
            du = u(b) - u(a)
        if isinstance(proj, str):
            return float(np.linalg.norm(du) if proj == "magnitude" else du["xyz".index(proj)])
        return float(du @ proj)

    def append(self, state, step, time, vel, angmom, observables, amp_load):
        """vel, angmom: synchronized (N, 3) arrays at this time."""
        m = self.model
        R = state.body_rot[:-1]
        lb = np.einsum("nki,nk->ni", R, angmom)
        omega = np.einsum("nik,nk->ni", R, lb / m.body_inertia)
        values = {}
        for name in self.fields:
            path_ = FIELD_SERIES[name][0]
            if name == "position":
                values[path_] = state.body_pos[:-1]
            elif name == "orientation":
                values[path_] = state.body_quat[:-1]
            elif name == "velocity":
                values[path_] = vel
            elif name == "angular_velocity":
                values[path_] = omega
            elif name == "spring_state":
                values[path_] = (state.spring_state if m.inelastic
                                 else np.zeros(m.n_springs, dtype=np.int8))
            elif name == "spring_force":
                values[path_] = state.spring_force
            elif name == "spring_damage":
                values[path_] = spring_damage_of(m, state)
            elif name == "cell_stress":
                extra = None
                if self.levers is not None:
                    cells, terms = self.levers
                    extra = (cells, amp_load[cells, None] * terms)
                values[path_] = cell_stress(m, state, extra=extra)
        obs = self.spring_observables(state)
        obs.update(observables)
        if "ground_displacement" in self.observables:
            e = self.ground_motion(time, "displacement")
            obs["ground_displacement"] = float(e @ self._ground[3])
            obs["ground_velocity"] = float(self.ground_motion(time, "velocity") @ self._ground[3])
        obs.update(self.probe_values(state, vel, omega, time, amp_load))
        for name, val in obs.items():
            values[f"observables/{name}"] = val
        self.writer.append_frame(step, time, values)
        return obs

    def kinetic(self, vel, angmom, state):
        m = self.model
        lb = np.einsum("nki,nk->ni", state.body_rot[:-1], angmom)
        return 0.5 * float(np.sum(m.body_mass[:, None] * vel * vel)) + \
            0.5 * float(np.sum(lb * lb / m.body_inertia))

    def rewind(self, frames, path_work):
        """Keep the first ``frames`` frames and go on from there, the path
        work's running sum (statics.path_work) put back to ``path_work``
        (what it was after the last frame kept)."""
        self.writer.truncate(frames)
        self._path_work = path_work

    def fail(self, message):
        self.writer.mark_failed(message)

    def close(self):
        self.writer.close()
