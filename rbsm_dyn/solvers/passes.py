"""Options: which passes a run compiles and calls, chosen once per run.

The explicit step is a list of passes (physics/integrate.py run_dynamic):

    springs (elastic | inelastic) -> aux stress (Poisson) -> contact
        -> viscous springs -> bodies

and dynamic relaxation the same force passes with its own body pass
(physics/relax.py run_relax).  A pass that is off gets None for its
container (physics/arrays.py): Numba prunes it before typing, so it is
neither compiled nor paid for per spring point.  This module turns a
Model and State (model.py) into the kernels' containers and Options.
"""
from dataclasses import dataclass

import numpy as np

from ..physics.arrays import (BodyState, Bodies, ContactArrays, Loads, Springs, SpringHistory,
                              ViscousSprings, of)
from ..physics.poisson import poisson_slots
# spring points below which every pass runs on one thread (the same sums in
# the same order, so the same result), and the threaded variants, a cold
# start's largest compile, are not compiled
from ..physics.springs import SERIAL_SPRINGS


@dataclass(frozen=True)
class Options:
    """The switches of a run (hashable).  inelastic: the spring history
    pass (yield, rupture, cuts, contact springs); poisson: the auxiliary
    stress; contact: contact between any cells; viscous: the dashpots and
    Maxwell branches of the springs (physics/viscous.py); parallel: the
    threaded variants of the passes."""
    inelastic: bool
    poisson: bool
    contact: bool
    parallel: bool
    viscous: bool = False

    @classmethod
    def of(cls, model, threads=None):
        """The options of a model.  The threaded variants run at any thread
        count from SERIAL_SPRINGS spring points up, one thread included:
        there the parallel pass on one thread steps faster than the
        one-thread variant (elastic, 106 838 spring points: 29.9 against
        42.1 ns per spring-point-step; Numba's outlined prange body reads
        its arrays as arguments, the serial loop through the containers),
        so the one-thread variants serve small models only, where the
        threaded ones' compilation (a cold start's largest cost) does not
        pay.  `threads` is kept for callers that know the run's count."""
        return cls(inelastic=bool(model.inelastic), poisson=bool(model.poisson_on),
                   contact=model.contact is not None,
                   parallel=model.n_springs >= SERIAL_SPRINGS, viscous=model.viscous)

    def passes(self, body="dynamic"):
        """The step's passes in order, by name (for `info` and the docs);
        body "plane": a plane model's step (physics/plane.py,
        plane_contact.py), on the 3D passes of its slab when it has the
        Poisson correction or viscous springs."""
        if body == "plane":
            if not (self.poisson or self.viscous):
                return (["springs:plane-" + ("inelastic" if self.inelastic else "elastic")]
                        + (["contact:plane"] if self.contact else []) + ["bodies:plane"])
            body = "dynamic"
        out = ["springs:" + ("inelastic" if self.inelastic else "elastic")]
        if self.poisson:
            out.append("aux_stress")
        if self.contact and body == "dynamic":
            out.append("contact")
        if self.viscous and body == "dynamic":
            out.append("viscous")
        out.append("bodies:" + body)
        return out


def model_arrays(model):
    """(Bodies, Springs, Loads) of a model (built once, kept on it)."""
    got = model.__dict__.get("_kernel_arrays")
    if got is None:
        got = (of(Bodies, model), of(Springs, model), of(Loads, model))
        model.__dict__["_kernel_arrays"] = got
    return got


def body_state(state):
    """The BodyState of a State (the same arrays, no copies)."""
    return of(BodyState, state)


def history(state, options, copy=False):
    """The SpringHistory of a state (copies with `copy`), None when the
    run has no inelastic springs."""
    if not options.inelastic:
        return None
    if copy:
        return SpringHistory(*(getattr(state, f).copy() for f in SpringHistory._fields))
    return of(SpringHistory, state)


#: the viscous springs' state arrays (model.State, arrays.ViscousSprings)
VISCOUS_STATE = ("spring_gap", "spring_q", "spring_fv", "spring_wv")


def viscous_springs(model, state, options, copy=False, dt=None, static=False):
    """The ViscousSprings of a run, None without viscous springs: its step
    factors for dt [s] (default |state.dt|), its state arrays copied with
    `copy` (an output step's pass commits nothing).  `static`: a static
    run in time (solvers/creep.py): the Kelvin springs integrated exactly
    (kelvin_a, kelvin_b); dt = 0 there gives back the committed forces (a
    frame's pass)."""
    if not options.viscous:
        return None
    dt = abs(float(state.dt)) if dt is None else float(dt)
    a, b = step_factors(model.law_branch_tau, dt, static)
    ka = kb = np.zeros(0)
    if static:
        td = model.law_dashpot
        ka, kb = step_factors(np.where(td > 0.0, td, 1.0), dt, static)
    arrays = [getattr(state, f) for f in VISCOUS_STATE]
    if copy:
        arrays = [x.copy() for x in arrays]
    return ViscousSprings(model.law_dashpot, model.law_branch_g, a, b, ka, kb,
                          state.spring_state, *arrays, 1.0 / dt if dt > 0 else 0.0)


def step_factors(tau, dt, static):
    """a = e^(−dt/τ) and b = τ (1 − a)/dt of relaxation times τ [s]
    (physics/viscous.py); dt = 0: (1, 0) in a static run (the forces
    kept), (1, 1) in a dynamic one (the limit: a rate-free step)."""
    if dt == 0.0:
        return np.ones_like(tau), (np.zeros_like(tau) if static else np.ones_like(tau))
    # b → 1 as dt/τ → 0: expm1 keeps its digits
    return np.exp(-dt / tau), -tau * np.expm1(-dt / tau) / dt


def aux_stress(model, state, options):
    """The PoissonSlots of the run, None without the correction."""
    if not options.poisson:
        return None
    return poisson_slots(model.poisson, state.aux_g, state.aux_p)


def contact_arrays(model, cs):
    """The ContactArrays of a contact state cs (model/contact.py ContactState);
    the contact pass is threaded at any size (launch_threads)."""
    launch_threads()
    cm = model.contact
    return ContactArrays(cs.pairs, cs.slip, cs.sep, cs.out, cs.ptr, cs.entry, cs.body_friction,
                         cs.body_dwrench, cm.cell_face_ptr, cm.loop_ptr, cm.loop_xyz,
                         cm.face_plane, cm.cell_loop_ptr, cm.vert_ptr, cm.vert_xyz, cm.radius,
                         cm.body_size, cm.body_e, cm.body_g, cm.body_rigid, cm.ground,
                         float(cm.mu), float(cm.kfac), float(cm.zeta), cs.scratch,
                         model.n_springs == 0)


def launch_threads():
    """Start Numba's threading layer (once; a no-op after).  A parallel
    kernel starts it when it is compiled or loaded, but a kernel compiled
    without parallel=True that calls threaded passes (run_dynamic,
    spring_forces, contact_step ...) and is loaded from the cache does
    not: its threaded loops then call an unset launcher, and the process
    dies with SIGSEGV (measured, numba 0.68.1, empty cache: a process
    calls elastic_spring_pass, a second compiles spring_forces over it, the
    third loads spring_forces and crashes; with this call first it runs).
    The code before issue 26 hid it: every run called the threaded
    refresh_all_rotations first."""
    from numba.np.ufunc.parallel import _launch_threads
    _launch_threads()


def parallel_arg(options):
    """The kernels' `parallel` argument: None prunes the threaded variants;
    True starts the threading layer first (launch_threads)."""
    if not options.parallel:
        return None
    launch_threads()
    return True
