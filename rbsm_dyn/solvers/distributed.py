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

Not distributed yet (refused with P > 1, naming the reason): contact
between cells, the Poisson correction, continuum yield, plane models, and the static, linear and modal solvers.  Rank 0 builds and
holds the whole model (the distributed build of DESIGN.md §10 is to come).
"""
import time

import numpy as np

from ..physics.arrays import (Bodies, BodyState, Loads, SpringHistory, Springs, Stepping,
                              ViscousSprings)
from ..physics.integrate import run_dynamic
from .passes import VISCOUS_STATE, Options, model_arrays, parallel_arg, viscous_springs

#: the rows a ghost needs from its owner each step: what the spring passes
#: read of a body (physics/springs.py material_points, mid_increment)
GHOST_FIELDS = ("body_pos", "body_rot", "body_dq")
GHOST_WIDTH = 3 + 9 + 4
#: per body (N+1 rows, the ground's last) and per body (N rows) state arrays
BODY_FIELDS = ("body_pos", "body_quat", "body_vel", "body_angmom", "body_rot", "body_dq",
               "body_wrench", "body_support")
BODY_FIELDS_N = ("body_work", "body_damp", "body_reaction")
#: the spring history's per-spring-point arrays (length 0 when unused)
SPRING_FIELDS = ("spring_state", "spring_dp", "spring_kappa", "spring_dmg", "spring_wp",
                 "spring_wf", "spring_rate") + VISCOUS_STATE
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
    why = [(model.contact is not None, "contact (contact between cells)"),
           (bool(model.poisson_on), "the Poisson correction (materials' poisson)"),
           (model.cell_ivol.size > 0, "continuum yield (yield.model: continuum)"),
           (bool(model.plane), "a plane model (plane)")]
    got = [w for on, w in why if on]
    if got:
        return (f"{', '.join(got)} not distributed yet: run this case on one process "
                "(without mpirun, or -n 1)")
    return None


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


def state_rows(state, dom, n_bodies):
    """One rank's rows of the whole state (dict of fresh arrays)."""
    rows = dom.bodies
    rows_g = np.append(rows, n_bodies)
    out = {f: _rows(getattr(state, f), rows_g) for f in BODY_FIELDS}
    out.update({f: _rows(getattr(state, f), rows) for f in BODY_FIELDS_N})
    out.update({f: _rows(getattr(state, f), dom.springs) for f in SPRING_FIELDS})
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
        st = {f: np.zeros_like(x) for f, x in pkg["state"].items()}
        st["spring_force"] = np.zeros((len(self.dom.springs), 3))
        self.st = st
        self.bs = BodyState(*(st[f] for f in BodyState._fields))
        if self.options.inelastic:
            empty = {f: np.zeros((0,) + x.shape[1:], x.dtype)
                     for f, x in pkg["cells"].items()}
            self.hist = SpringHistory(*(st[f] if f in st else empty[f]
                                        for f in SpringHistory._fields))
        else:
            self.hist = None
        self.load(pkg["state"])
        self.send = {q: (ids, np.empty((len(ids), GHOST_WIDTH))) for q, ids in self.dom.send.items()}
        self.recv = {q: (ids, np.empty((len(ids), GHOST_WIDTH))) for q, ids in self.dom.recv.items()}
        self.n_local = n
        #: [s] spent stepping and in the ghost exchange (waits included)
        self.seconds = [0.0, 0.0]

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
            run_dynamic(1, step0 + k, stepping, self.bodies, self.springs, self.loads, self.bs,
                        self.hist, None, None, visc, par)
            t1 = clock()
            self.exchange()
            self.seconds[0] += t1 - t0
            self.seconds[1] += clock() - t1
        return step0 + n

    def exchange(self):
        """The ghosts' rows from their owners (nonblocking, one message per
        neighbour each way)."""
        from mpi4py import MPI
        st = self.st
        pos, rot, dq = st["body_pos"], st["body_rot"], st["body_dq"]
        reqs = [self.comm.Irecv(buf, source=q, tag=_TAG) for q, (_, buf) in self.recv.items()]
        for q, (ids, buf) in self.send.items():
            buf[:, 0:3] = pos[ids]
            buf[:, 3:12] = rot[ids].reshape(-1, 9)
            buf[:, 12:16] = dq[ids]
            reqs.append(self.comm.Isend(buf, dest=q, tag=_TAG))
        MPI.Request.Waitall(reqs)
        for q, (ids, buf) in self.recv.items():
            pos[ids] = buf[:, 0:3]
            rot[ids] = buf[:, 3:12].reshape(-1, 3, 3)
            dq[ids] = buf[:, 12:16]

    def own_rows(self):
        """This rank's own bodies' and springs' rows (and the ground's,
        the same on every rank)."""
        k = self.dom.n_own
        out = {f: self.st[f][:k].copy() for f in BODY_FIELDS + BODY_FIELDS_N}
        out["ground"] = {f: self.st[f][-1].copy() for f in BODY_FIELDS}
        own = self.dom.own_springs
        out.update({f: _rows(self.st[f], own) for f in SPRING_FIELDS})
        return out


def _package(model, dom, options, state):
    """What a rank needs to step its share (pickled to it once)."""
    cells = {f: getattr(state, f) for f in SpringHistory._fields if f.startswith("cell_")}
    opt = Options(inelastic=options.inelastic, poisson=False, contact=False,
                  parallel=options.parallel and len(dom.springs) > 0, viscous=options.viscous)
    import numba
    return {"domain": dom, "arrays": local_arrays(model, dom), "options": opt,
            "threads": numba.get_num_threads(),
            "state": state_rows(state, dom, model.n_bodies),
            "cells": {f: x[:0] for f, x in cells.items()}}


class Leader:
    """Rank 0's side: `advance`, the explicit driver's stepper
    (explicit.run's `stepper`); at its first call the decomposition and each
    rank's package."""

    def __init__(self, comm, method="rcb"):
        self.comm = comm
        self.method = method
        self.doms = None
        self.figures = {}

    def _setup(self, model, state):
        from ..domains import decompose, local_domains, summary
        comm = self.comm
        owner = decompose(model, comm.size, self.method)
        doms = local_domains(owner, model.spring_bodies, model.spring_slot, model.group_ptr,
                             model.phase_ptr)
        self.doms = doms
        self.figures = summary(doms, model.n_springs)
        self.figures["method"] = self.method
        opt = Options.of(model)
        for q in range(1, comm.size):
            comm.send(("setup", None), dest=q, tag=_CMD)
            comm.send(_package(model, doms[q], opt, state), dest=q, tag=_TAG)
        self.local = LocalRun(comm, _package(model, doms[0], opt, state))
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

    def advance(self, model, state, n_steps, damping_alpha=0.0, damping_local=0.0,
                options=None):
        """explicit.advance over the ranks: n_steps steps of the state."""
        if self.doms is None:
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
        if send:
            rows = [state_rows(state, d, model.n_bodies) for d in self.doms]
            self.local.load(self.comm.scatter(rows, root=0))
        step = self.local.steps(int(n_steps), int(state.step), stepping, laws)
        parts = self.comm.gather(self.local.own_rows(), root=0)
        n = model.n_bodies
        for d, part in zip(self.doms, parts):
            own = d.bodies[:d.n_own]
            for f in BODY_FIELDS + BODY_FIELDS_N:
                getattr(state, f)[own] = part[f]
            sp = d.springs[d.own_springs]
            for f in SPRING_FIELDS:
                if len(getattr(state, f)):
                    getattr(state, f)[sp] = part[f]
        for f in BODY_FIELDS:
            getattr(state, f)[n] = parts[0]["ground"][f]
        state.step = step
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
