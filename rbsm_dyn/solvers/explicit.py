"""Explicit dynamics: central differences over chunks of compiled steps.

Step order (one compiled call advances a chunk; Python only at output):

    for each step n (t_n = n·dt):
        springs:  forces at x_n on every spring point (per spring, no atomics)
        bodies:   gather per body (CSR) -> kick v, L by dt (loads at t_n,
                  constraints, damping) -> drift x by dt, rotate q (DLM)
    at an output time t_n (before its step): springs at x_n, half kick for
        synchronized v_n and L_n, energies and probes, append one frame.

A chunk ends at the next output time or after `chunk_steps`; there the run
checks for divergence (non-finite state or a body faster than 10 c0, in
code compiled without fastmath) and, at output steps, for an energy
runaway: the energy the run holds and has dissipated (kinetic + strain +
plastic + fracture + damping) may not exceed what was put in, E0 + |W|,
by more than ENERGY_TOLERANCE (plus a floor), whatever absorbs the excess
(an instability that plasticity soaks up shows as plastic energy).  Either
stops the run with the step and time (RunFailed: exit 1).
"""
import dataclasses
import time as _time

import numpy as np

from ..model import apply_initial, new_state
from ..model.contact import chunk_steps as contact_chunk
from ..model.contact import rebuild, stiffness_check
from ..physics.arrays import Stepping
from ..physics.collide import contact_step
from ..physics.integrate import VELOCITY, run_dynamic, synchronized_momenta
from ..physics.laws import P_CRIT
from ..physics.passes import spring_forces
from ..physics.plane import run_plane
from ..physics.viscous import viscous_pass
from ..case import DT_SAFETY_MAX
from .plane import lift, plane_arrays, plane_contact_arrays, plane_ready, plane_state
from .checkpoint import Checkpointer, Interrupted, SignalGuard
from .passes import (VISCOUS_STATE, Options, aux_stress, body_state, contact_arrays, history,
                     model_arrays, parallel_arg, viscous_springs)



# Energy runaway at an output step: K + U + W_plastic + W_fracture + W_damping
# > ENERGY_TOLERANCE × (E0 + |W_ext|) + ENERGY_FLOOR × Σ m c0².  A sane run
# keeps that total within its balance error of E0 + W (0.1-2 % on the shipped
# cases, at most a few % on coarse meshes), so 1.5× (a 50 % excess) is never
# met by a stable run and is met a few frames after an instability starts
# (it grows exponentially): cases/impulsive_beam.yaml at dt_safety 1.0 ends
# at 12.8× (200 J of plastic work against 15.7 J supplied), at 0.95 at 4.3×.
# The floor (1e-12 of the energy of all the mass moving at the bar wave
# speed c0) keeps round-off from tripping the check when nothing is supplied.
# The work is booked half a step behind the energy (f_n · v_{n+1/2}), which
# right after a load starts from rest is a large share of the little
# supplied (a velocity ramped from 0: 2.1× at step 1, 1.26× at step 2, 1.02×
# by step 5; the velocity step of cases/bar_wave.yaml: 1.27× at step 2): so
# the bound must be exceeded at ENERGY_CONFIRM output frames in a row (an
# instability only grows), or at the last frame after ENERGY_GRACE_STEPS.
ENERGY_TOLERANCE = 1.5
ENERGY_FLOOR = 1.0e-12
ENERGY_CONFIRM = 2
ENERGY_GRACE_STEPS = 20


class RunFailed(RuntimeError):
    """A run that stopped early (divergence, no convergence)."""


def spring_pass(model, state, step=0.0, static=False):
    """Spring wrenches on the bodies (with the auxiliary stress of the
    Poisson correction, physics/poisson.py) and the force on body a of every spring
    (state.spring_force) at the current positions, for output and
    synchronisation: an inelastic pass works on copies of the spring history,
    so repeating it at an output step changes nothing; those copies, the
    spring history at the current positions, are returned (None for an
    elastic model).  `step` [s]: the
    forces of an explicit time step of that size (a strain-law spring
    breaking inside the step keeps a share of its force, and a rate law's
    smoothed rate moves on, physics/inelastic.py; 0: a static pass).  `static`:
    a static solution's frame: the viscous springs' committed forces (no
    step in time; solvers/creep.py)."""
    m = model
    opt = Options.of(m)
    bodies, springs, loads = model_arrays(m)
    bs = body_state(state)
    hist = history(state, opt, copy=True)
    spring_forces(springs, bs, hist, aux_stress(m, state, opt), True, float(step),
                  parallel_arg(opt))
    trial = None if hist is None else hist._asdict()
    if m.contact is not None:
        # on a copy of the slip memory: repeating it at an output step
        # changes nothing (the step from here commits); the copy, with the
        # pairs' forces and energies at these positions, is returned
        cs = state.contact.trial()
        contact_step(contact_arrays(m, cs), bodies, bs, state.dt, False)
        trial = {} if trial is None else trial
        trial["contact"] = cs
    if opt.viscous:
        # on copies, as the spring history: the viscous forces and work at
        # these positions (the step from here commits its own)
        visc = viscous_springs(m, state, opt, copy=True, dt=0.0 if static else None,
                               static=static)
        viscous_pass(springs, bs, visc, True, parallel_arg(opt))
        trial = {} if trial is None else trial
        trial.update({f: getattr(visc, f) for f in VISCOUS_STATE})
    return trial


def check_model(case, model):
    """Refuse a model that cannot be run (CaseError, exit 2): no springs
    (nothing ties the bodies: no stable step to take dt from, no stiffness;
    only a dynamic run with a fixed solver.dt -- free rigid bodies -- makes
    sense) or a body without a positive, finite mass or inertia."""
    if model.n_springs == 0 and not (case.solver.mode == "dynamic"
                                     and (getattr(case.solver, "dt", None)
                                          or model.contact is not None)):
        why = ("no stable step to take dt from: give solver.dt for free rigid bodies, "
               if case.solver.mode == "dynamic" else f"nothing for mode {case.solver.mode} "
               "to solve: ")
        raise case.error(("mesh",), f"the model has no springs ({model.n_bodies} "
                         f"bod{'y' if model.n_bodies == 1 else 'ies'}, no shared faces and no "
                         f"supports): {why}mesh it into more than one cell or support it")
    bad = ~(np.isfinite(model.body_mass) & (model.body_mass > 0))
    bad |= ~np.all(np.isfinite(model.body_inertia) & (model.body_inertia > 0), axis=1)
    if np.any(bad):
        i = int(np.argmax(bad))
        raise case.error(("materials",), f"body {i} has mass {model.body_mass[i]:.4g} kg and "
                         f"inertia {np.asarray(model.body_inertia[i]).tolist()} kg m2: every "
                         "body needs a positive mass and inertia (density, cell volume)")


def choose_dt(case, model):
    """(dt, stable estimate) [s]; CaseError for a fixed solver.dt above
    DT_SAFETY_MAX × the estimate (the largest dt_safety, case/solver.py) or a model
    without a finite stable step (check_model)."""
    check_model(case, model)
    est = model.stable_dt()
    if model.contact is not None and model.n_springs == 0:
        # rigid cells on contact alone: the contact's own bound
        from ..model.contact import contact_stable_dt
        est = min(est, contact_stable_dt(model))
    fixed = getattr(case.solver, "dt", None)
    if not (est > 0) or (not np.isfinite(est) and not fixed):
        raise case.error(("solver", "dt"), f"the model has no finite stable step (estimate "
                         f"{est} s): give solver.dt")
    dt = case.solver.dt_safety * est
    if fixed:
        if case.solver.dt > DT_SAFETY_MAX * est:
            raise case.error(("solver", "dt"), f"exceeds {DT_SAFETY_MAX:g} × the stable step "
                             f"estimate {est:.4g} s = {DT_SAFETY_MAX * est:.4g} s (got "
                             f"{case.solver.dt:.4g})")
        dt = case.solver.dt
    return dt, est


def advance(model, state, n_steps, damping_alpha=0.0, damping_local=0.0, options=None):
    """Advance the state by n_steps explicit steps (compiled loop,
    physics/integrate.py run_dynamic; its passes chosen once by `options`,
    default Options.of(model)).  Damping: mass-proportional α [1/s],
    Cundall's local β (physics/integrate.py dynamic_body_pass)."""
    m = model
    opt = Options.of(m) if options is None else options
    bodies, springs, loads = model_arrays(m)
    if plane_ready(m, opt):
        # a plane model on the plane passes; the slab's arrays lifted after
        pb, psp, pl = plane_arrays(m)
        state.step = run_plane(
            n_steps, state.step, Stepping(float(state.dt), float(damping_alpha),
                                          float(damping_local), float(state.t0)),
            pb, psp, pl, plane_state(m, state), history(state, opt),
            plane_contact_arrays(m, state.contact) if opt.contact else None,
            viscous_springs(m, state, opt), parallel_arg(opt))
        lift(m, state)
        return
    contact = contact_arrays(m, state.contact) if opt.contact else None
    state.step = run_dynamic(
        n_steps, state.step, Stepping(float(state.dt), float(damping_alpha),
                                      float(damping_local), float(state.t0)),
        bodies, springs, loads, body_state(state), history(state, opt),
        aux_stress(m, state, opt), contact, viscous_springs(m, state, opt), parallel_arg(opt))


def synchronize(model, state, trial=None):
    """(v_n, L_n) at the current whole step, reactions at t_n.  `trial`: a
    dict that gets the spring history at the current positions
    (spring_pass), which the step from here will commit."""
    m = model
    hist = spring_pass(m, state, step=state.dt)
    if trial is not None and hist is not None:
        trial.update(hist)
    n = m.n_bodies
    vel = np.empty((n, 3))
    ang = np.empty((n, 3))
    bodies, springs, loads = model_arrays(m)
    synchronized_momenta(state.time, state.dt, bodies, loads, body_state(state),
                         (vel, ang, state.body_reaction), parallel_arg(Options.of(m)))
    return vel, ang


def start_half_step(model, state):
    """Turn the initial velocities v0, L0 (at t = 0) into the leapfrog's
    v(−dt/2) = v0 − (dt/2) a0 and L(−dt/2) = L0 − (dt/2) T0, so that the first
    kick lands on v(dt/2) = v0 + (dt/2) a0 (second order from the start;
    Belytschko, Liu & Moran, Nonlinear FE, box 6.1)."""
    dt = state.dt
    state.dt = -dt
    vel, ang = synchronize(model, state)
    state.dt = dt
    state.body_vel[:-1] = vel
    state.body_angmom[:-1] = ang
    if len(model.body_ffol):
        # the follower work booked from here on starts with the half step
        # before t = 0 (external_work): take it off
        state.body_work -= follower_half_step_work(model, state)


def load_amplitude(model, t):
    """Amplitude of each body's load at time t: evaluated once per distinct
    history (a few), then spread over the bodies (no loop over bodies)."""
    from ..physics.integrate import amplitude
    if not len(model.body_load_hist):
        return np.zeros(0)
    hist, body = np.unique(model.body_load_hist, return_inverse=True)
    amp = np.array([amplitude(h, t, model.hist_ptr, model.hist_t, model.hist_a) for h in hist])
    return amp[body.reshape(-1)]


def external_work(model, state, w_steps, vel=None):
    """Work of loads, gravity and constraints since t = 0 [J], accumulated
    per step as f_n · v_{n+1/2} dt (for a constant force such as gravity this
    is exactly f · (x − x0), since x_{n+1} − x_n = v_{n+1/2} dt).

    Follower loads are booked f_n · v̄_n dt, v̄_n the mean of the half-step
    velocities (physics/integrate.py): with the last half step ½ f_N ·
    v_{N−1/2} dt added here (and the one before t = 0 taken off by
    start_half_step), their work is the trapezoidal rule of ∫ f · dx
    (second order, and the same as a dead load's while f does not turn)."""
    w = float(np.sum(w_steps))
    if len(model.body_ffol):
        w += float(np.sum(follower_half_step_work(model, state)))
    if vel is not None:
        w += constraint_half_step_work(model, state, vel)
    w += ground_half_step_work(model, state)
    return w


def ground_half_step_work(model, state):
    """Work [J] of a moving ground through the supports and contacts that
    tie bodies to it, over the half step from the last kick to the present
    frame, ½ dt f_N · v_g,N−1/2 (f_N the support forces, body_support): the
    body pass books f_n · ½ (v_g,n−1/2 + v_g,n+1/2) dt per step
    (physics/integrate.py), the trapezoid of ∫ f · dx_g."""
    if model.ground_hist[0] < 0:
        return 0.0
    n = model.n_bodies
    return float(0.5 * state.dt * np.sum(state.body_support[:n] @ state.body_vel[n]))


def constraint_half_step_work(model, state, vel):
    """Work [J] of the prescribed velocities over the half step from the
    last kick to the present frame (v_{N−1/2} → v_N, vel the synchronised
    (N, 3)): the half kick's kinetic energy ½ m (v_N² − v_{N−1/2}²) less
    the forces' share ½ dt f_N v̄ (f_N = the reaction less the support
    springs' part and the constraint's, synchronized_momenta), so that the
    per-step r v̄ dt of the body pass (physics/integrate.py) meets the
    frame's kinetic energy."""
    m = model
    n = m.n_bodies
    held = m.dof_kind[:, :3] == VELOCITY
    if not np.any(held):
        return 0.0
    v_half = state.body_vel[:n]
    mass = np.broadcast_to(m.body_mass[:, None], (n, 3))
    # r_N over the half kick: m (v_N − v_half)/(dt/2) − f_N, and −f_N is the
    # constraint part of the reaction (body_reaction − body_support)
    r = (2.0 * mass * (vel - v_half) / state.dt
         + (state.body_reaction[:n] - state.body_support[:n]))
    return float(np.sum((r * 0.25 * state.dt * (vel + v_half))[held]))


def follower_half_step_work(model, state):
    """½ dt (f · v + m_b · ω_b) per body (N,) [J] of the follower loads at
    the present time, with the half-step velocities v, ω before it."""
    m = model
    n = m.n_bodies
    amp = load_amplitude(m, state.time)
    R = state.body_rot[:n]
    f = np.einsum("nij,nj->ni", R, m.body_ffol)
    w_b = np.einsum("nji,nj->ni", R, state.body_angmom[:n]) / m.body_inertia  # Rᵀ L / I
    return 0.5 * state.dt * amp * (np.sum(f * state.body_vel[:n], axis=1)
                                   + np.sum(m.body_mfol * w_b, axis=1))


def run(case, model, recorder, *, max_steps=None, progress=None, chunk_steps=None,
        restart=None, governor=None, stepper=None):
    """Run a dynamic case, writing frames through `recorder`.

    governor: a threads.Governor that re-picks the default thread count
    between chunks of steps (None: the count stays).
    stepper: what advances the state by a chunk of steps, advance's
    signature (default advance; solvers/distributed.py Leader.advance: over
    MPI ranks).

    restart: (State, checkpoint data) from checkpoint.load_for_restart: go on
    from that state (its frames are in the recorder's file already).
    Checkpoints (solvers/checkpoint.py) at output.checkpoint_interval, at the
    end, and on SIGINT/SIGTERM (then checkpoint.Interrupted is raised).
    Returns a dict of figures (steps, dt, wall time).  Raises RunFailed."""
    dt, est = choose_dt(case, model)
    if restart is None:
        state = new_state(model)
        state.dt = dt
        apply_initial(case, model, state)
        if model.contact is not None:
            rebuild(model, state, force=True)
        start_half_step(model, state)
    else:
        # the leapfrog's half-step state as saved: no start_half_step again
        state = restart[0]
        dt = state.dt
    damping = getattr(case.solver, "damping", None)
    # α of the keys or of rayleigh (β is the springs' dashpot: the model's)
    alpha = float(damping.coefficients()[0]) if damping is not None else 0.0
    local = float(getattr(damping, "local", 0.0) or 0.0)
    end_time = case.solver.end_time
    interval = case.output.interval

    def schedule():
        return _schedule(state, end_time, interval, max_steps)
    n_total, out_every = schedule()
    if chunk_steps is None:
        chunk_steps = max(1, int(2e7 // max(model.n_springs, 1)))
    # divergence guard: no body in a sane run moves at ten times the fastest
    # bar wave speed of its materials (checked outside fastmath code)
    c0 = max(np.sqrt(mat["young"] / mat["density"]) for mat in model.materials)
    v_limit = 10.0 * c0

    def record():
        # the frame shows the springs at its own positions: the history the
        # next step commits (breaks and damage at x_n booked with the forces
        # that give v_n), not the one committed at x_n-1
        trial = {}
        vel, ang = synchronize(model, state, trial)
        now = dataclasses.replace(state, **trial)
        ek = recorder.kinetic(vel, ang, now)
        obs = {"kinetic": ek, "strain": recorder.strain_energy(now),
               "external_work": external_work(model, state, state.body_work, vel),
               "damping": float(np.sum(state.body_damp))}
        if local:
            obs["kinetic_ratio"] = ek / obs["strain"] if obs["strain"] > 0 else 0.0
            quasi.see(state.time, obs["kinetic_ratio"], obs["strain"])
        return recorder.append(now, state.step, state.time, vel, ang, obs,
                               load_amplitude(model, state.time))

    e_floor = ENERGY_FLOOR * float(np.sum(model.body_mass)) * c0 ** 2
    most = [0.0]              # the most supplied so far

    def energy_runaway(obs, e0):
        """None, or why the run has diverged: the energy held and dissipated
        (kinetic + strain + plastic + fracture + damping + viscous) equals E0 + W in a
        sane run; more than ENERGY_TOLERANCE × the largest E0 + |W| so far
        (+ floor) is an instability, whatever absorbs it (module constants).
        The largest so far: W can return to 0 (a block bouncing under
        gravity at the top of its flight) while the balance keeps its small
        error; an instability grows past any earlier bound."""
        most[0] = max(most[0], e0 + abs(obs["external_work"]))
        supplied = most[0]
        parts = {k: float(obs.get(k, 0.0)) for k in
                 ("kinetic", "strain", "plastic", "fracture", "damping",
                  "contact_friction", "viscous")}
        total = sum(parts.values())
        if total <= ENERGY_TOLERANCE * supplied + e_floor:
            return None
        return (f"kinetic + strain + plastic + fracture + damping (+ contact friction, "
                f"viscous) "
                f"energy {total:.4g} J "
                f"({', '.join(f'{k} {v:.4g}' for k, v in parts.items())}) exceeds "
                f"{ENERGY_TOLERANCE:g}× the initial energy plus |external work| "
                f"({supplied:.4g} J)")

    quasi = QuasiStaticCheck(end_time)
    t_wall = _time.perf_counter()
    ckpt = Checkpointer(recorder, case)
    with SignalGuard() as guard:
        if restart is None:
            obs = record()
            e0 = obs["kinetic"] + obs["strain"]
        else:
            obs = {}
            e0 = float(restart[1]["e0"])
        ckpt.mark(state)
        adapt = StepAdapter(model) if adapts(model) and np.isfinite(est) else None
        start_step = state.step
        _loop(model, state, recorder, progress, record, energy_runaway, ckpt, guard, e0,
              schedule, chunk_steps, (alpha, local), v_limit, est, adapt, governor,
              stepper or advance, obs0=obs)
        if restart is None or state.step != start_step:
            # (a restart that has no step left to make -- killed after its
            # end-of-run checkpoint, before "completed" -- does not write that
            # checkpoint again: it would go into the other slot, which holds
            # the previous checkpoint in an uninterrupted run's file, and flip
            # `current`: benchmarks/restart_cases.py found the file differing)
            ckpt.write(state, e0)
    wall = _time.perf_counter() - t_wall
    warn = [quasi.warning()] if local and quasi.warning() else []
    if model.contact is not None and state.contact.stiff_warning:
        warn.append(state.contact.stiff_warning)
    return dict(steps=state.step, dt=dt, dt_estimate=est, wall_time=wall, state=state,
                warnings=warn, dt_final=state.dt,
                dt_changes=0 if adapt is None else adapt.changes)


def _schedule(state, end_time, interval, max_steps):
    """(last step, steps between frames) of a run from its time base:
    frames every round(interval/dt) steps from the step at which dt last
    changed (State.step_base), the last step the first at or past end_time
    (capped at max_steps)."""
    dt = state.dt
    t_base = state.t0 + state.step_base * dt
    n_total = state.step_base + int(np.ceil((end_time - t_base) / dt - 1e-9))
    if max_steps is not None:
        n_total = min(n_total, int(max_steps))
    return n_total, max(1, int(round(interval / dt)))


def adapts(model):
    """Whether a run re-bounds its stable step as it goes: a model with
    yield, whose plastic gaps lengthen the springs' levers
    (model/stable_step.py _face_row_sums).  Not a model that only
    breaks: a crack's gap is open or slides in contact, and every shipped
    fracture case ran at dt_safety 1.0 with a fixed step
    (benchmarks/results/stability.md (e)), so it pays nothing for it; not
    with viscous springs, whose rate is the last step's gap difference
    over dt (physics/viscous.py)."""
    if not model.inelastic or model.viscous or model.n_springs == 0:
        return False
    return bool(np.any(model.law_params[np.unique(model.face_law), P_CRIT] > 0))


#: the bound is made again at the first frame after this many steps
#: since the frame that last made it (frames counted from the last change
#: of the step, so a restart makes it at the same frames): it costs about
#: 20 steps of one thread (3 passes over the springs; cases/branching_glass
#: 297 465 springs: 0.44 s against 20 ms a step), so about 5 %
CHECK_STEPS = 400
#: a step above the bound is reduced to this share of it, so that the
#: bound, which falls slowly as the gaps grow, is not met again at once
STEP_MARGIN = 0.9


class StepAdapter:
    """The explicit step of a deforming model, kept below the stable-step
    bound of its present state (Model.stable_dt(state), itself below the
    exact step).  The bound falls as plastic gaps grow: a spring's force
    acts at the midpoint of its two material points, so its levers
    lengthen by half its gap and the rotational modes stiffen
    (cases/impulsive_beam.yaml at 25 mm of deflection: the exact step falls
    to 0.64 of the undeformed one; benchmarks/results/stability.md (f)).
    A step above the bound goes on at STEP_MARGIN of it.  The step chosen
    at the start (dt_safety × the undeformed bound) is kept as long as it
    is below; the step only falls."""

    def __init__(self, model):
        self.model = model
        self.changes = 0

    def check(self, state, out_every):
        """The new step [s] if the present one exceeds the bound of this
        state, else None; the bound is made at every
        ceil(CHECK_STEPS / out_every)-th frame since the last change."""
        every = max(1, -(-CHECK_STEPS // out_every))
        if ((state.step - state.step_base) // out_every) % every:
            return None
        bound = self.model.stable_dt(state)
        if not (np.isfinite(bound) and bound > 0.0) or state.dt <= bound:
            return None
        return STEP_MARGIN * bound


def change_step(model, state, dt_new):
    """Go on from the present whole step t_N with the step dt_new: the
    synchronised v_N, L_N restart the leapfrog at v_N − (dt_new/2) a_N
    (start_half_step, second order as at t = 0), the time base moves to
    t_N, and the external work keeps its value at t_N (the half-step
    corrections of external_work are those of the new half step)."""
    vel, ang = synchronize(model, state)
    w_before = external_work(model, state, state.body_work, vel)
    t_now = state.time
    state.body_vel[:-1] = vel
    state.body_angmom[:-1] = ang
    state.dt = dt_new
    state.t0 = t_now - state.step * dt_new
    state.step_base = state.step
    start_half_step(model, state)
    if state.plane is not None:
        # a plane model's state made again from the slab's arrays at the
        # next chunk (solvers/plane.py plane_state): θ as it is, ω of the new L
        n = model.n_bodies
        state.body_omega[:n] = state.body_angmom[:n, 2] / plane_arrays(model)[0].body_jz
        state.plane = None
    vel, _ = synchronize(model, state)
    if len(state.body_work):
        state.body_work[0] += w_before - external_work(model, state, state.body_work, vel)


#: a quasi-static explicit run whose kinetic energy exceeds this fraction of
#: its strain energy is not quasi-static (Abaqus/Explicit's guideline: the
#: kinetic energy a small fraction, 5-10 %, of the internal energy
#: through most of the process; Abaqus Analysis User's Guide, "Quasi-static
#: analysis")
QUASI_STATIC_RATIO = 0.05
#: ... in more than this fraction of the frames checked (a crack that snaps
#: in one frame is dynamic there, not the whole run)
QUASI_STATIC_FRAMES = 0.1


class QuasiStaticCheck:
    """Watches the kinetic-to-strain energy ratio of a run with local
    damping over the frames after the first 10 % of the run (before, the
    strain energy is nearly zero and the ratio meaningless): a warning when
    it exceeds QUASI_STATIC_RATIO in more than QUASI_STATIC_FRAMES of them."""

    def __init__(self, end_time):
        self.t_from = 0.1 * end_time
        self.worst = (0.0, 0.0)
        self.frames_over = 0
        self.frames = 0

    def see(self, t, ratio, strain):
        if t < self.t_from or strain <= 0:
            return
        self.frames += 1
        if ratio > QUASI_STATIC_RATIO:
            self.frames_over += 1
        if ratio > self.worst[0]:
            self.worst = (ratio, t)

    def warning(self):
        ratio, t = self.worst
        if self.frames_over <= QUASI_STATIC_FRAMES * self.frames:
            return None
        return (f"not quasi-static: the kinetic energy reached {100 * ratio:.3g} % of the "
                f"strain energy at t = {t:.4g} s ({self.frames_over} of {self.frames} frames "
                f"over {100 * QUASI_STATIC_RATIO:g} %); load more slowly (a longer "
                f"solver.end_time and load history) or raise solver.damping.local")


def _contact_hint(model, state):
    """The contacts' stable-step message for a divergence, or ""."""
    if model.contact is None or not state.contact.stiff_warning:
        return ""
    return f" ({state.contact.stiff_warning})"


def _loop(model, state, recorder, progress, record, energy_runaway, ckpt, guard, e0,
          schedule, chunk_steps, damping, v_limit, est, adapt=None, governor=None,
          stepper=advance, obs0=None):
    # the last frame's observables (the progress line's Ek: the start's
    # until the first frame of the loop)
    obs = dict(obs0 or {})
    over = 0                  # output frames in a row over the energy bound
    # the passes, once per run: for the most threads the run may take
    opt = Options.of(model, threads=None if governor is None else governor.available)
    n_total, out_every = schedule()
    dt = state.dt
    if progress:
        progress.start(n_total, dt)
    while state.step < n_total:
        base = state.step_base
        next_out = base + ((state.step - base) // out_every + 1) * out_every
        n = min(next_out, n_total, state.step + chunk_steps) - state.step
        if model.contact is not None:
            # the broad phase again when a cell has moved half the skin; a
            # chunk short enough that none moves a quarter skin in it
            rebuild(model, state)
            n = min(n, contact_chunk(model, state, dt, model.gravity))
        stepper(model, state, n, *damping, options=opt)
        if model.contact is not None and not state.contact.stiff_warning:
            # the stable step with the contacts the chunk ended with
            state.contact.stiff_warning = stiffness_check(model, state, dt, est)
        if governor is not None:
            governor.check()
        pos = state.body_pos
        if not np.all(np.isfinite(pos)) or not np.all(np.isfinite(state.body_angmom)) or \
                np.abs(state.body_vel).max() > v_limit:
            msg = (f"diverged at step {state.step}, t = {state.time:.6g} s "
                   f"(dt = {dt:.4g} s, stable estimate {est:.4g} s): non-finite state or "
                   f"a body faster than 10 c0 = {v_limit:.4g} m/s; reduce solver.dt_safety "
                   "or check the case" + _contact_hint(model, state))
            recorder.fail(msg)
            raise RunFailed(msg)
        if (state.step - state.step_base) % out_every == 0 or state.step == n_total:
            obs = record()
            why = energy_runaway(obs, e0)
            over = over + 1 if why else 0
            if over >= ENERGY_CONFIRM or (why and state.step == n_total
                                          and state.step >= ENERGY_GRACE_STEPS):
                msg = (f"diverged at step {state.step}, t = {state.time:.6g} s "
                       f"(dt = {dt:.4g} s, stable estimate {est:.4g} s): {why}; reduce "
                       "solver.dt_safety or check the case" + _contact_hint(model, state))
                recorder.fail(msg)
                raise RunFailed(msg)
            new_dt = adapt.check(state, out_every) if adapt is not None else None
            if new_dt is not None:
                change_step(model, state, new_dt)
                adapt.changes += 1
                dt = new_dt
                est = model.stable_dt(state)
                n_total, out_every = schedule()
                if progress:
                    progress.retotal(n_total)
            if ckpt.due(state) and state.step < n_total:
                ckpt.write(state, e0)
        if guard.signum is not None and state.step < n_total:
            ckpt.write(state, e0)
            raise Interrupted(guard.signum, state.step, state.time)
        if progress:
            progress.update(state.step, state.time, obs.get("kinetic", 0.0))
