"""One explicit run over P processes: ``mpirun -n P python -m rbsm_dyn CASE``.

Rank 0 leads: it reads the case, builds the model, writes the history and
checkpoints and runs the explicit driver (solvers/explicit.py) as one
process does; only its stepping goes through `Leader.advance`.  The bodies
are split over the ranks (domains.py: recursive coordinate bisection or
METIS, weighted by spring points); each rank holds its own bodies, one
layer of ghosts and the springs that touch its own bodies (a spring
between two ranks on both), in the one-process order, and steps them with
the one-process kernels (physics/integrate.py run_dynamic), one step at a
time, trading the ghosts' positions after each step (one nonblocking
exchange with each neighbour: position, rotation matrix and the rotation
increment, what the force passes read).  Every own body's wrench is the
one-process sum in the one-process order (domains.schedule), so the run's
history is the one-process history bit for bit, for any P and any thread
count.

A chunk of steps (explicit._loop's) is one command from rank 0: the
ranks step it and send their own bodies' and springs' rows back, so that
between chunks rank 0 holds the whole state, bit for bit the one a single
process has there: output, energy checks, the stable-step adapter and
checkpoints run on it unchanged (and a checkpoint restarts on any P).
After rank 0 has changed the state between chunks (the start, a restart,
a change of the step) the next chunk first sends each rank its rows.

Contact between cells: rank 0 runs the broad phase between chunks as one
process does; after each, the ranks get their share anew: the candidate
pairs touching an own body (in the one-process order, so each body's
contact forces are gathered in that order) and, as ghosts, the cells
they meet; the ghosts' momenta are traded too (a pair's slip).

Continuum yield: the ghosts' plastic strain increments are traded with
their positions (the next pass's gaps).  The Poisson correction: an own
cell's force needs its linked neighbours' pressures, so those neighbours
get their own links' springs and cells as well (domains.local_domains: a
second layer of ghosts; local_poisson).

A plane model steps on the plane passes (physics/plane.py,
plane_contact.py) the same way: each rank its rows of the plane state
(solvers/plane.py plane_state, which rank 0 keeps on the State and lifts
to the slab's arrays after each chunk), the ghosts' positions and
(cos θ, sin θ) traded after each step (with contact their velocities and
spins too), viscous springs included (physics/plane_viscous.py); a plane
model with the Poisson correction steps on its slab's 3D passes,
distributed as any 3D model.

Not distributed yet (refused with P > 1, naming the reason): the static,
linear and modal solvers.  Rank 0 builds and holds the whole model (the
distributed build of DESIGN.md §10 is to come).
"""
import os
import time

import numpy as np

from ..domains import ragged
from ..physics.arrays import (Bodies, BodyState, PlaneBodies, PlaneContact, PlaneState,
                              SpringHistory, Stepping, ViscousSprings)
from ..physics.integrate import run_dynamic
from .passes import VISCOUS_STATE, Options, model_arrays, parallel_arg, viscous_springs

#: the rows a ghost needs from its owner each step: what the spring passes
#: read of a body (physics/springs.py material_points, mid_increment); with
#: contact its half-step momenta (physics/collide.py _pair_force: the
#: slip's increment); with continuum yield its plastic strain increment
#: (physics/inelastic.py plastic_offset: the next pass's gaps)
GHOST_FIELDS = ("body_pos", "body_rot", "body_dq")
CONTACT_GHOST_FIELDS = ("body_vel", "body_angmom")
CELL_GHOST_FIELDS = ("cell_dep",)
#: doubles a ghost of a run without contact or continuum yield takes
GHOST_WIDTH = 3 + 9 + 4
#: per body (N+1 rows, the ground's last) and per body (N rows) state arrays
BODY_FIELDS = ("body_pos", "body_quat", "body_vel", "body_angmom", "body_rot", "body_dq",
               "body_wrench", "body_support")
BODY_FIELDS_N = ("body_work", "body_damp", "body_reaction")
#: a plane model's (physics/plane.py): what its passes read of a ghost
#: (the springs: position and cos, sin θ; contact: velocity and spin), its
#: per body state arrays (N+1 rows, then N rows)
PLANE_GHOST_FIELDS = ("body_pos", "body_cs")
PLANE_CONTACT_GHOST_FIELDS = ("body_vel", "body_omega")
PLANE_BODY_FIELDS = ("body_pos", "body_theta", "body_cs", "body_vel", "body_omega",
                     "body_wrench", "body_support")
PLANE_BODY_FIELDS_N = ("body_work", "body_damp", "body_reaction")
#: the spring history's per-spring-point arrays (length 0 when unused)
SPRING_FIELDS = ("spring_state", "spring_dp", "spring_kappa", "spring_dmg", "spring_wp",
                 "spring_wf", "spring_rate") + VISCOUS_STATE
#: the cells' history (length 0 when unused): continuum yield's (N+1 rows)
#: and the Poisson correction's (N rows)
CELL_FIELDS = ("cell_moment", "cell_sigma", "cell_dep")
POISSON_CELL_FIELDS = ("cell_chi", "cell_wf")
#: spring-point steps in a chunk between gathers (explicit.run's
#: chunk_steps; one process takes 2e7): rank 0 gathers every rank's rows
#: after each chunk (about 60 B a spring point of an inelastic model), so
#: a chunk ten times longer keeps that below a few per cent of the steps;
#: output frames still end a chunk
CHUNK_SPRING_STEPS = 2.0e8
_TAG = 17
_CMD = 18
#: a waiting rank polls for rank 0's next command at most this often [s]
#: (MPI's blocking calls spin a core: a rank waiting through rank 0's
#: output frames would keep a user's core busy)
POLL = 1.0e-3


def refusal(case, model):
    """Why this run cannot go over several processes (a message naming
    the key), or None."""
    mode = case.solver.mode
    if mode != "dynamic":
        return (f"solver.mode {mode} runs on one process: the distributed run is explicit "
                "dynamics only; start it without mpirun (or with -n 1)")
    return None


def _plane(model):
    """Whether the model steps on the plane passes (solvers/plane.py)."""
    from .plane import plane_ready
    return plane_ready(model, Options.of(model))


def _rows(x, idx):
    """x[idx] (a fresh contiguous array), or x itself when it is empty
    (a feature the model does not use)."""
    return np.ascontiguousarray(x[idx]) if len(x) else x


def local_arrays(model, dom):
    """The kernels' Bodies, Springs, Loads of one rank's Domain."""
    bodies, springs, loads = model_arrays(model)
    rows = dom.bodies
    rows_g = np.append(rows, model.n_bodies)        # and the ground's row
    sp, fc = dom.springs, dom.faces
    b = Bodies(_rows(bodies.body_mass, rows), _rows(bodies.body_inertia, rows),
               _rows(bodies.body_pos0, rows_g), _rows(bodies.body_quat0, rows_g))
    s = springs._replace(
        spring_bodies=dom.spring_bodies, spring_arm_a=_rows(springs.spring_arm_a, sp),
        spring_arm_b=_rows(springs.spring_arm_b, sp), spring_slot=dom.spring_slot,
        spring_area=_rows(springs.spring_area, sp), face_frame0=_rows(springs.face_frame0, fc),
        face_k=_rows(springs.face_k, fc), face_h=_rows(springs.face_h, fc),
        face_law=_rows(springs.face_law, fc), group_ptr=dom.group_ptr,
        phase_ptr=dom.phase_ptr, cell_ivol=_rows(springs.cell_ivol, rows_g),
        cell_plane=_rows(springs.cell_plane, rows_g), cell_lever=_rows(springs.cell_lever, rows_g),
        cell_k=_rows(springs.cell_k, rows_g), cell_2g=_rows(springs.cell_2g, rows_g))
    lo = loads._replace(**{f: _rows(getattr(loads, f), rows) for f in
                           ("body_fext", "body_mext", "body_ffol", "body_mfol",
                            "body_load_hist", "dof_kind", "dof_value", "dof_hist")})
    return b, s, lo


def local_plane_arrays(model, dom):
    """The plane kernels' PlaneBodies, PlaneSprings, PlaneLoads of one rank's
    Domain (solvers/plane.py plane_arrays, its rows)."""
    from .plane import plane_arrays
    pb, ps, pl = plane_arrays(model)
    rows = dom.bodies
    rows_g = np.append(rows, model.n_bodies)
    sp, fc = dom.springs, dom.faces
    b = PlaneBodies(_rows(pb.body_mass, rows), _rows(pb.body_jz, rows),
                    _rows(pb.body_pos0, rows_g))
    s = ps._replace(
        spring_bodies=dom.spring_bodies, spring_arm_a=_rows(ps.spring_arm_a, sp),
        spring_arm_b=_rows(ps.spring_arm_b, sp), spring_slot=dom.spring_slot,
        spring_area=_rows(ps.spring_area, sp), face_n0=_rows(ps.face_n0, fc),
        face_k=_rows(ps.face_k, fc), face_h=_rows(ps.face_h, fc),
        face_law=_rows(ps.face_law, fc), group_ptr=dom.group_ptr, phase_ptr=dom.phase_ptr,
        cell_ivol=_rows(ps.cell_ivol, rows_g), cell_plane=_rows(ps.cell_plane, rows_g),
        cell_lever=_rows(ps.cell_lever, rows_g), cell_k=_rows(ps.cell_k, rows_g),
        cell_2g=_rows(ps.cell_2g, rows_g))
    lo = pl._replace(**{f: _rows(getattr(pl, f), rows) for f in
                        ("body_fext", "body_ffol", "body_load_hist", "dof_kind", "dof_value",
                         "dof_hist")})
    return b, s, lo


def local_plane_contact(model, dom):
    """A plane model's contact geometry of one rank's bodies
    (solvers/plane.py plane_contact_geometry, arrays.PlaneContact): the
    polygons of its cells, their edges' faces and the faces' edges
    renumbered to the rank's faces (those of local_contact, `face_of`)."""
    from .plane import plane_contact_geometry
    cm = model.contact
    ptr, xy, edge_face, face_edge, radius, thickness = plane_contact_geometry(model)
    rows = dom.bodies
    poly_ptr, verts = ragged(ptr, rows)
    _, faces = ragged(cm.cell_face_ptr, rows)
    f_local = np.full(len(cm.face_plane), -1, dtype=np.int64)
    f_local[faces] = np.arange(len(faces))
    v_local = np.full(len(xy), -1, dtype=np.int64)
    v_local[verts] = np.arange(len(verts))
    ef = edge_face[verts].astype(np.int64)
    ef = np.where(ef >= 0, f_local[np.maximum(ef, 0)], -1)
    fe = face_edge[faces].astype(np.int64)
    fe = np.where(fe >= 0, v_local[np.maximum(fe, 0)], -1)
    return {"poly_ptr": poly_ptr.astype(np.int64), "poly_xy": np.ascontiguousarray(xy[verts]),
            "edge_face": ef.astype(np.int32), "face_edge": fe.astype(np.int32),
            "radius": radius[rows], "thickness": float(thickness),
            **{f: _rows(getattr(cm, f), rows) for f in
               ("body_size", "body_e", "body_g", "body_rigid")},
            "face_of": faces}


def local_contact(model, dom):
    """The contact geometry of one rank's bodies (model/contact.py
    ContactModel, physics/arrays.py ContactArrays): the faces, loops and
    vertices of its cells renumbered, and `face_of` (f,) each local face's
    one-process row (the separating-face memory holds face rows)."""
    cm = model.contact
    rows = dom.bodies
    cell_face_ptr, faces = ragged(cm.cell_face_ptr, rows)
    loop_ptr, loops = ragged(cm.loop_ptr, faces)
    vert_ptr, verts = ragged(cm.vert_ptr, rows)
    return {"cell_face_ptr": cell_face_ptr.astype(cm.cell_face_ptr.dtype),
            "loop_ptr": loop_ptr.astype(cm.loop_ptr.dtype),
            "loop_xyz": np.ascontiguousarray(cm.loop_xyz[loops]),
            "face_plane": np.ascontiguousarray(cm.face_plane[faces]),
            "cell_loop_ptr": loop_ptr[cell_face_ptr].astype(cm.cell_loop_ptr.dtype),
            "vert_ptr": vert_ptr.astype(cm.vert_ptr.dtype),
            "vert_xyz": np.ascontiguousarray(cm.vert_xyz[verts]),
            **{f: _rows(getattr(cm, f), rows) for f in
               ("radius", "body_size", "body_e", "body_g", "body_rigid")},
            "face_of": faces}


def local_poisson(model, dom):
    """The Poisson correction's slots of one rank (physics/poisson.py,
    arrays.PoissonSlots): the full links of its own cells and of the cells
    linked to them (dom.linked), none for the other ghosts (their pressure
    0); neighbours, reverse slots and spring ranges renumbered (a reverse
    slot into a cell without links points to itself: only ghosts' wrenches,
    which are not kept, read it)."""
    pa = model.poisson
    n = model.n_bodies
    rows = dom.bodies
    full = np.zeros(n, dtype=bool)
    full[rows[:dom.n_own]] = True
    full[dom.linked] = True
    sptr = np.asarray(pa.cell_slot_ptr, dtype=np.int64)
    mine = full[rows]
    cnt = np.where(mine, sptr[rows + 1] - sptr[rows], 0)
    ptr = np.zeros(len(rows) + 1, dtype=np.int64)
    np.cumsum(cnt, out=ptr[1:])
    _, slots = ragged(sptr, rows[mine])
    g2l = np.full(n + 1, -1, dtype=np.int64)
    g2l[rows] = np.arange(len(rows))
    rev_g = np.asarray(pa.slot_rev, dtype=np.int64)[slots]
    rev = np.arange(len(slots))
    if len(slots):
        order = np.argsort(slots, kind="stable")
        at = np.minimum(np.searchsorted(slots[order], rev_g), len(slots) - 1)
        found = slots[order][at] == rev_g
        rev[found] = order[at][found]
    s0 = np.searchsorted(dom.springs, np.asarray(pa.slot_s0, dtype=np.int64)[slots])
    s1 = s0 + (np.asarray(pa.slot_s1, dtype=np.int64) - pa.slot_s0)[slots]
    it = np.asarray(pa.slot_cell).dtype
    return {"cell_slot_ptr": ptr.astype(np.asarray(pa.cell_slot_ptr).dtype),
            "slot_cell": g2l[np.asarray(pa.slot_cell)[slots]].astype(it),
            "slot_rev": rev.astype(np.asarray(pa.slot_rev).dtype),
            "slot_g": np.ascontiguousarray(pa.slot_g[slots]),
            "cell_c0": np.where(mine, pa.cell_c0[rows], 0.0),
            "slot_s0": s0.astype(np.asarray(pa.slot_s0).dtype),
            "slot_s1": s1.astype(np.asarray(pa.slot_s1).dtype),
            "cell_lv": np.where(mine, pa.cell_lv[rows], 0.0)}


def _face_rows(sep, face_of, to_local):
    """The separating-face memory (−1: none) renumbered: one-process rows to
    local ones (to_local) or back."""
    out = sep.copy()
    hit = sep >= 0
    if to_local:
        order = np.argsort(face_of, kind="stable")
        out[hit] = order[np.searchsorted(face_of, sep[hit], sorter=order)]
    else:
        out[hit] = face_of[sep[hit]]
    return out


def state_rows(state, dom, n_bodies, face_of=None, plane=None):
    """One rank's rows of the whole state (dict of fresh arrays); with
    contact (face_of: local_contact's) its pairs' and bodies' contact state;
    `plane`: a plane model's PlaneState (its rows in place of the slab's)."""
    rows = dom.bodies
    rows_g = np.append(rows, n_bodies)
    if plane is None:
        out = {f: _rows(getattr(state, f), rows_g) for f in BODY_FIELDS}
        out.update({f: _rows(getattr(state, f), rows) for f in BODY_FIELDS_N})
    else:
        out = {f: _rows(getattr(plane, f), rows_g) for f in PLANE_BODY_FIELDS}
        out.update({f: _rows(getattr(plane, f), rows) for f in PLANE_BODY_FIELDS_N})
    out.update({f: _rows(getattr(state, f), dom.springs) for f in SPRING_FIELDS})
    out.update({f: _rows(getattr(state, f), rows_g) for f in CELL_FIELDS})
    out.update({f: _rows(getattr(state, f), rows) for f in POISSON_CELL_FIELDS})
    if dom.pairs is not None:
        cs = state.contact
        out["c_slip"] = cs.slip[dom.pairs]
        out["c_sep"] = _face_rows(cs.sep[dom.pairs], face_of, True)
        out["c_out"] = cs.out[dom.pairs]
        out["c_friction"] = cs.body_friction[rows]
        out["c_dwrench"] = cs.body_dwrench[rows]
    return out


class LocalRun:
    """One rank's share of the run: its kernel containers and state, its
    steps and its ghost exchange."""

    def __init__(self, comm, pkg):
        self.comm = comm
        self.dom = pkg["domain"]
        self.bodies, self.springs, self.loads = pkg["arrays"]
        self.options = pkg["options"]
        import numba
        # rank 0's thread count (its --threads, solver.threads or default)
        numba.set_num_threads(max(1, min(pkg["threads"], numba.config.NUMBA_NUM_THREADS)))
        n = self.dom.n_local
        self.plane = pkg.get("plane", False)
        st = {f: np.zeros_like(x) for f, x in pkg["state"].items()}
        st["spring_force"] = np.zeros((len(self.dom.springs), 2 if self.plane else 3))
        self.st = st
        self.bs = (PlaneState if self.plane else BodyState)(
            *(st[f] for f in (PlaneState if self.plane else BodyState)._fields))
        self.hist = None
        if self.options.inelastic:
            self.hist = SpringHistory(*(st[f] for f in SpringHistory._fields))
        # the ghosts' rows traded each step, as (n + 1, width) views
        if self.plane:
            names = PLANE_GHOST_FIELDS + (PLANE_CONTACT_GHOST_FIELDS if self.options.contact
                                          else ())
        else:
            names = GHOST_FIELDS + (CONTACT_GHOST_FIELDS if self.options.contact else ())
        names += CELL_GHOST_FIELDS if len(st["cell_dep"]) else ()
        self.ghost = [st[f].reshape(len(st[f]), -1) for f in names]
        self.aux = None
        if self.options.poisson:
            from ..physics.arrays import PoissonSlots
            q = pkg["poisson"]
            self.aux = PoissonSlots(**q, aux_g=np.zeros((len(q["slot_cell"]), 3)),
                                    aux_p=np.zeros((7, n)))
        self.contact = self.face_of = None
        if self.options.contact:
            self.face_of = pkg["contact"]["face_of"]
            self.contact = self._contact(pkg)
        self.load(pkg["state"])
        w = sum(x.shape[1] for x in self.ghost)
        self.send = {q: (ids, np.empty((len(ids), w))) for q, ids in self.dom.send.items()}
        self.recv = {q: (ids, np.empty((len(ids), w))) for q, ids in self.dom.recv.items()}
        self.n_local = n
        #: [s] spent stepping and in the ghost exchange (waits included)
        self.seconds = [0.0, 0.0]

    def _contact(self, pkg):
        """The ContactArrays of this rank (its pairs, their state arrays in
        self.st, its cells' geometry)."""
        import numba

        from ..physics.arrays import ContactArrays
        from ..physics.collide import body_pairs
        from .passes import launch_threads
        launch_threads()
        g, c = pkg["contact"], pkg["contact_const"]
        pairs = self.dom.pair_bodies
        ptr, entry = body_pairs(pairs, self.dom.n_local)
        st = self.st
        scratch = np.zeros((max(1, numba.get_num_threads()),) + tuple(c["scratch_shape"]))
        if self.plane:
            return PlaneContact(pairs, st["c_slip"], st["c_sep"], st["c_out"], ptr, entry,
                                st["c_friction"], st["c_dwrench"], g["poly_ptr"], g["poly_xy"],
                                g["edge_face"], g["face_edge"], g["radius"], g["body_size"],
                                g["body_e"], g["body_g"], g["body_rigid"], c["ground"], c["mu"],
                                c["kfac"], c["zeta"], g["thickness"], scratch, c["overwrite"])
        return ContactArrays(pairs, st["c_slip"], st["c_sep"], st["c_out"], ptr, entry,
                             st["c_friction"], st["c_dwrench"], g["cell_face_ptr"],
                             g["loop_ptr"], g["loop_xyz"], g["face_plane"], g["cell_loop_ptr"],
                             g["vert_ptr"], g["vert_xyz"], g["radius"], g["body_size"],
                             g["body_e"], g["body_g"], g["body_rigid"], c["ground"], c["mu"],
                             c["kfac"], c["zeta"], scratch, c["overwrite"])

    def load(self, rows):
        """Take these rows (state_rows) as the local state."""
        for f, x in rows.items():
            np.copyto(self.st[f], x)

    def steps(self, n, step0, stepping, laws=None):
        """n explicit steps from step0, the ghosts traded after each;
        `laws`: the viscous springs' per-law arrays of the step (the
        ViscousSprings fields but the state's), None without them."""
        par = parallel_arg(self.options)
        visc = None
        if laws is not None:
            st = self.st
            state = st["spring_state"] if self.hist is not None else np.zeros(0, np.int8)
            visc = ViscousSprings(*laws[:6], state, *(st[f] for f in VISCOUS_STATE), laws[6])
        clock = time.perf_counter
        for k in range(n):
            t0 = clock()
            if self.plane:
                from ..physics.plane import run_plane
                run_plane(1, step0 + k, stepping, self.bodies, self.springs, self.loads,
                          self.bs, self.hist, self.contact, visc, par)
            else:
                run_dynamic(1, step0 + k, stepping, self.bodies, self.springs, self.loads,
                            self.bs, self.hist, self.aux, self.contact, visc, par)
            t1 = clock()
            self.exchange()
            self.seconds[0] += t1 - t0
            self.seconds[1] += clock() - t1
        return step0 + n

    def exchange(self):
        """The ghosts' rows from their owners (nonblocking, one message per
        neighbour each way)."""
        from mpi4py import MPI
        reqs = [self.comm.Irecv(buf, source=q, tag=_TAG) for q, (_, buf) in self.recv.items()]
        for q, (ids, buf) in self.send.items():
            o = 0
            for x in self.ghost:
                w = x.shape[1]
                buf[:, o:o + w] = x[ids]
                o += w
            reqs.append(self.comm.Isend(buf, dest=q, tag=_TAG))
        # wait giving the core away between tests: a busy-waiting rank
        # (MPI's Waitall spins) on a machine with more runnable threads than
        # cores takes the time its neighbour needs to finish the step
        while not MPI.Request.Testall(reqs):
            os.sched_yield()
        for q, (ids, buf) in self.recv.items():
            o = 0
            for x in self.ghost:
                w = x.shape[1]
                x[ids] = buf[:, o:o + w]
                o += w

    def own_rows(self):
        """This rank's own bodies' and springs' rows (and the ground's,
        the same on every rank)."""
        k = self.dom.n_own
        body = (PLANE_BODY_FIELDS + PLANE_BODY_FIELDS_N) if self.plane \
            else (BODY_FIELDS + BODY_FIELDS_N)
        out = {f: self.st[f][:k].copy() for f in body}
        out["ground"] = {f: self.st[f][-1].copy() for f in
                         (PLANE_BODY_FIELDS if self.plane else BODY_FIELDS) + CELL_FIELDS
                         if len(self.st[f])}
        own = self.dom.own_springs
        out.update({f: _rows(self.st[f], own) for f in SPRING_FIELDS})
        out.update({f: self.st[f][:k].copy() for f in CELL_FIELDS + POISSON_CELL_FIELDS})
        if self.contact is not None:
            mine = self.dom.own_pairs
            out["c_slip"] = self.st["c_slip"][mine]
            out["c_sep"] = _face_rows(self.st["c_sep"][mine], self.face_of, False)
            out["c_out"] = self.st["c_out"][mine]
            out["c_friction"] = self.st["c_friction"][:k].copy()
            out["c_dwrench"] = self.st["c_dwrench"][:k].copy()
        return out


def _package(model, dom, options, state, plane=None):
    """What a rank needs to step its share (pickled to it; again after
    each broad phase of a run with contact: its ghosts change); `plane`: a
    plane model's PlaneState (it steps on the plane passes)."""
    import numba
    opt = Options(inelastic=options.inelastic, poisson=options.poisson, contact=options.contact,
                  parallel=options.parallel and len(dom.springs) > 0, viscous=options.viscous)
    arrays = local_arrays(model, dom) if plane is None else local_plane_arrays(model, dom)
    pkg = {"domain": dom, "arrays": arrays, "options": opt, "plane": plane is not None,
           "threads": numba.get_num_threads()}
    if options.poisson:
        pkg["poisson"] = local_poisson(model, dom)
    face_of = None
    if options.contact:
        cm = model.contact
        pkg["contact"] = local_contact(model, dom)
        face_of = pkg["contact"]["face_of"]
        if plane is not None:
            pkg["contact"] = local_plane_contact(model, dom)
            from ..physics.plane_contact import SCRATCH_ROWS_2D
            from .plane import plane_contact_geometry
            ptr = plane_contact_geometry(model)[0]
            scratch_shape = (SCRATCH_ROWS_2D(int(np.max(np.diff(ptr), initial=3))), 3)
        pkg["contact_const"] = {"ground": cm.ground, "mu": float(cm.mu), "kfac": float(cm.kfac),
                                "zeta": float(cm.zeta), "overwrite": model.n_springs == 0,
                                "scratch_shape": state.contact.scratch.shape[1:]
                                if plane is None else scratch_shape}
    pkg["state"] = state_rows(state, dom, model.n_bodies, face_of, plane)
    return pkg


class Leader:
    """Rank 0's side: `advance`, the explicit driver's stepper
    (explicit.run's `stepper`); at its first call the decomposition and each
    rank's package."""

    def __init__(self, comm, method="rcb"):
        self.comm = comm
        self.method = method
        self.doms = None
        self.owner = None
        self.builds = -1
        self.setups = 0
        self.figures = {}

    def _setup(self, model, state):
        """The decomposition (once) and the ranks' packages (again after
        each broad phase of a run with contact)."""
        from ..domains import decompose, local_domains, summary
        comm = self.comm
        if self.owner is None:
            self.owner = decompose(model, comm.size, self.method)
        owner = self.owner
        pairs = None
        if model.contact is not None:
            pairs = state.contact.pairs
            self.builds = state.contact.builds
        links = None
        if model.poisson_on:
            pa = model.poisson
            links = (pa.cell_slot_ptr, pa.slot_cell, pa.slot_s0, pa.slot_s1)
        doms = local_domains(owner, model.spring_bodies, model.spring_slot, model.group_ptr,
                             model.phase_ptr, pairs, links)
        self.doms = doms
        self.face_of = [None] * len(doms)
        if model.contact is not None:
            self.face_of = [local_contact(model, d)["face_of"] for d in doms]
        self.figures = summary(doms, model.n_springs)
        self.figures["method"] = self.method
        opt = Options.of(model)
        ps = self._plane_state(model, state)
        for q in range(1, comm.size):
            comm.send(("setup", None), dest=q, tag=_CMD)
            comm.send(_package(model, doms[q], opt, state, ps), dest=q, tag=_TAG)
        self.local = LocalRun(comm, _package(model, doms[0], opt, state, ps))
        self.setups += 1
        self._mark(state)

    def seconds(self, reset=False):
        """[(stepping, exchange) s] of every rank since its start or the
        last reset (then zeroed)."""
        for q in range(1, self.comm.size):
            self.comm.send(("seconds", reset), dest=q, tag=_CMD)
        got = self.comm.gather(tuple(self.local.seconds), root=0)
        if reset:
            self.local.seconds[:] = [0.0, 0.0]
        return [tuple(round(x, 3) for x in g) for g in got]

    def exchange_seconds(self, k=100):
        """[s] of one ghost exchange alone, the mean of k on every rank
        (benchmarks/mpi_scaling.py)."""
        for q in range(1, self.comm.size):
            self.comm.send(("exchange", k), dest=q, tag=_CMD)
        t0 = time.perf_counter()
        for _ in range(k):
            self.local.exchange()
        return (time.perf_counter() - t0) / k

    def _mark(self, state):
        self.synced = (state.step, state.dt, state.t0)

    @staticmethod
    def _plane_state(model, state):
        """A plane model's PlaneState (solvers/plane.py plane_state: kept on
        the State between chunks, as one process keeps it), or None."""
        if not _plane(model):
            return None
        from .plane import plane_state
        return plane_state(model, state)

    def advance(self, model, state, n_steps, damping_alpha=0.0, damping_local=0.0,
                options=None):
        """explicit.advance over the ranks: n_steps steps of the state."""
        if self.doms is None or (model.contact is not None
                                 and state.contact.builds != self.builds):
            self._setup(model, state)
        send = self.synced != (state.step, state.dt, state.t0)
        stepping = Stepping(float(state.dt), float(damping_alpha), float(damping_local),
                            float(state.t0))
        laws = None
        if self.local.options.viscous:
            v = viscous_springs(model, state, self.local.options)
            laws = (v.law_dashpot, v.law_g, v.law_a, v.law_b, v.kelvin_a, v.kelvin_b, v.inv_dt)
        cmd = ("advance", (int(n_steps), int(state.step), stepping, send, laws))
        for q in range(1, self.comm.size):
            self.comm.send(cmd, dest=q, tag=_CMD)
        ps = self._plane_state(model, state)
        if send:
            rows = [state_rows(state, d, model.n_bodies, f, ps)
                    for d, f in zip(self.doms, self.face_of)]
            self.local.load(self.comm.scatter(rows, root=0))
        step = self.local.steps(int(n_steps), int(state.step), stepping, laws)
        parts = self.comm.gather(self.local.own_rows(), root=0)
        n = model.n_bodies
        body = state if ps is None else ps
        fields = BODY_FIELDS + BODY_FIELDS_N if ps is None \
            else PLANE_BODY_FIELDS + PLANE_BODY_FIELDS_N
        for d, part in zip(self.doms, parts):
            own = d.bodies[:d.n_own]
            for f in fields:
                getattr(body, f)[own] = part[f]
            sp = d.springs[d.own_springs]
            for f in SPRING_FIELDS:
                if len(getattr(state, f)):
                    getattr(state, f)[sp] = part[f]
            for f in CELL_FIELDS + POISSON_CELL_FIELDS:
                if len(getattr(state, f)):
                    getattr(state, f)[own] = part[f]
            if model.contact is not None:
                cs, pr = state.contact, d.pairs[d.own_pairs]
                cs.slip[pr] = part["c_slip"]
                cs.sep[pr] = part["c_sep"]
                cs.out[pr] = part["c_out"]
                cs.body_friction[own] = part["c_friction"]
                cs.body_dwrench[own] = part["c_dwrench"]
        for f, x in parts[0]["ground"].items():
            getattr(body if f in PLANE_BODY_FIELDS + BODY_FIELDS else state, f)[n] = x
        state.step = step
        if ps is not None:
            from .plane import lift
            lift(model, state)
        self._mark(state)


def stop_workers(comm, code):
    """Rank 0's last word to the other ranks (whether or not a run started)."""
    for q in range(1, comm.size):
        comm.send(("stop", int(code)), dest=q, tag=_CMD)


def _command(comm):
    """Rank 0's next command, waited for without spinning: polled with a
    sleep that doubles from 20 µs to POLL."""
    import time
    req = comm.irecv(source=0, tag=_CMD)
    nap = 2.0e-5
    while True:
        done, msg = req.test()
        if done:
            return msg
        time.sleep(nap)
        nap = min(2.0 * nap, POLL)


def worker(comm):
    """Ranks 1.. : step what rank 0 sends until it says stop; returns the
    exit status rank 0 gives."""
    local = None
    while True:
        cmd, arg = _command(comm)
        if cmd == "stop":
            return arg
        if cmd == "exchange":
            for _ in range(arg):
                local.exchange()
        elif cmd == "seconds":
            comm.gather(tuple(local.seconds), root=0)
            if arg:
                local.seconds[:] = [0.0, 0.0]
        elif cmd == "setup":
            local = LocalRun(comm, comm.recv(source=0, tag=_TAG))
        elif cmd == "advance":
            n, step0, stepping, send, laws = arg
            if send:
                local.load(comm.scatter(None, root=0))
            local.steps(n, step0, stepping, laws)
            comm.gather(local.own_rows(), root=0)
