"""Body kernels: read each body's spring wrench (summed by the spring pass,
physics/springs.py), apply loads and constraints, and advance bodies.

Translations: leapfrog central difference (v at half steps, x at whole
steps; e.g. Belytschko, Liu & Moran, Nonlinear FE, §6.2).  Rotations: world
angular momentum L at half steps, kick L += dt·T, then the free-rotor DLM
splitting with exact sub-rotations for the full principal inertia
(physics/rotation.py), so a torque-free body keeps world L exactly.

Per-body degree-of-freedom kinds (`dof_kind (N, 6) int8`, components x, y,
z, rx, ry, rz in world axes): 0 free, 1 fixed, 2 prescribed velocity
(translations), 3 prescribed displacement (translations).  `dof_value` holds
the velocity [m/s] or displacement [m]; `dof_hist` an amplitude table index
(−1: constant 1).  Amplitude tables are piecewise linear (hist_ptr, hist_t,
hist_a).

Loads: `body_fext`, `body_mext` (N, 3) world force and moment about the
centroid, fixed in space (dead); `body_ffol`, `body_mfol` (N, 3), or (0, 3)
when there are none: follower loads, constant in the body's principal
frame (world value R·f at the body's present rotation R: a load on a face of
the rigid cell turns with it).  Both are scaled by the body's amplitude
`body_load_hist`.  Work of a dead load: F_n · v_{n+1/2} dt, which sums to
F · (x − x0) for a constant force; of a follower load: F_n · v̄_n dt with
v̄_n = (v_{n−1/2} + v_{n+1/2})/2 (and M_n · ω̄_n dt), the kinetic energy the
load gives a free body over the step: F_n · v_{n+1/2} dt would book
|F|² dt²/2m too much each step when F turns (a first-order drift).
"""

import numba as nb
import numpy as np

from .jit import NOALIAS
from .rotation import dlm_free_rotor, quat_mul, quat_to_matrix
from .arrays import flag
from .collide import contact_step
from .passes import spring_forces
from .springs import part_range
from .viscous import viscous_pass
from ..partition import PARTS

JIT = dict(cache=True, nogil=True, fastmath={"contract"}, error_model="numpy")

FREE, FIXED, VELOCITY, DISPLACEMENT = 0, 1, 2, 3


@nb.njit(**JIT)
def amplitude(h, t, hist_ptr, hist_t, hist_a):
    """Piecewise-linear amplitude of table h at time t (constant 1 if h < 0,
    held constant outside the table).  The segment by bisection: a ground
    motion's table has four points a record step (tens of thousands), and a
    scan from its start cost each prescribed component up to that many
    comparisons a step."""
    if h < 0:
        return 1.0
    i0 = hist_ptr[h]
    i1 = hist_ptr[h + 1]
    if t <= hist_t[i0]:
        return hist_a[i0]
    if t > hist_t[i1 - 1]:
        return hist_a[i1 - 1]
    lo = i0          # hist_t[lo] < t <= hist_t[hi]: the first i with t <= hist_t[i] is hi
    hi = i1 - 1
    while hi - lo > 1:
        mid = (lo + hi) // 2
        if t <= hist_t[mid]:
            hi = mid
        else:
            lo = mid
    w = (t - hist_t[hi - 1]) / (hist_t[hi] - hist_t[hi - 1])
    return hist_a[hi - 1] + w * (hist_a[hi] - hist_a[hi - 1])


@nb.njit(inline="always", **JIT)
def ground_weight(t, dt, ground_hist, ground_dir, hist_ptr, hist_t, hist_a, body_vel, n, k):
    """The weight w = ½ (v_old + v_new) dt [m] of the support forces' work
    along component k over the step (the trapezoid of ∫ f · dx_g over the
    step's two half steps, as a constraint's r v̄ dt), v_new = v_g(t +
    dt/2) = ground_dir[k] × its table; 0 while the ground is at rest
    (ground_hist −1).  The ground is row n of the body arrays: the support
    springs and the contact ground take its position (physics/springs.py,
    collide.py); move_ground drifts it after the kick."""
    if ground_hist[0] < 0:
        return 0.0
    v_new = ground_dir[k] * amplitude(ground_hist[0], t + 0.5 * dt, hist_ptr, hist_t, hist_a)
    return 0.5 * (body_vel[n, k] + v_new) * dt


@nb.njit(**JIT)
def move_ground(t, dt, ground_hist, ground_dir, hist_ptr, hist_t, hist_a, body_pos, body_vel):
    """Drift of the ground's row (the last) with its velocity at t + dt/2,
    after the bodies' kick (which booked the work with the velocity before
    it).  Called after the body loop's function, not at its end: Numba
    dropped these writes when they followed the prange loop (measured,
    numba 0.68)."""
    if ground_hist[0] < 0:
        return
    n = body_pos.shape[0] - 1
    a = amplitude(ground_hist[0], t + 0.5 * dt, hist_ptr, hist_t, hist_a)
    for k in range(ground_dir.shape[0]):
        v = ground_dir[k] * a
        body_vel[n, k] = v
        body_pos[n, k] += v * dt


@nb.njit(inline="always", **JIT)
def _inv_inertia_world(R, inertia, r, c):
    """Entry (r, c) of A = R I⁻¹ Rᵀ, the world inverse inertia."""
    return (R[r, 0] * R[c, 0] / inertia[0] + R[r, 1] * R[c, 1] / inertia[1]
            + R[r, 2] * R[c, 2] / inertia[2])


@nb.njit(**JIT)
def constrain_rotation(i, dof_kind, R, inertia, L):
    """Make the world angular velocity ω = R I⁻¹ Rᵀ L zero in the fixed world
    components by a reaction moment along those axes: solve A_cc λ = −(A L)_c,
    L += Σ λ_c e_c (A = R I⁻¹ Rᵀ).  One or two fixed components are solved in
    closed form (A_cc is 1×1 or 2×2, symmetric positive definite): nothing is
    allocated inside the parallel body loop."""
    nfix = 0
    c0 = c1 = 0
    for c in range(3):
        if dof_kind[i, 3 + c] == FIXED:
            if nfix == 0:
                c0 = c
            else:
                c1 = c
            nfix += 1
    if nfix == 0:
        return
    if nfix == 3:
        L[0] = 0.0
        L[1] = 0.0
        L[2] = 0.0
        return
    r0 = -(_inv_inertia_world(R, inertia, c0, 0) * L[0]
           + _inv_inertia_world(R, inertia, c0, 1) * L[1]
           + _inv_inertia_world(R, inertia, c0, 2) * L[2])
    a00 = _inv_inertia_world(R, inertia, c0, c0)
    if nfix == 1:
        L[c0] += r0 / a00
        return
    r1 = -(_inv_inertia_world(R, inertia, c1, 0) * L[0]
           + _inv_inertia_world(R, inertia, c1, 1) * L[1]
           + _inv_inertia_world(R, inertia, c1, 2) * L[2])
    a01 = _inv_inertia_world(R, inertia, c0, c1)
    a11 = _inv_inertia_world(R, inertia, c1, c1)
    # Cramer's rule for the 2×2 SPD system
    det = a00 * a11 - a01 * a01
    L[c0] += (r0 * a11 - a01 * r1) / det
    L[c1] += (a00 * r1 - a01 * r0) / det


@nb.njit(**JIT)
def refresh_rotation(i, body_quat, body_quat0, body_rot, body_dq):
    """Rotation matrix and increment Δq = q q0⁻¹ of body i from its quaternion."""
    quat_to_matrix(body_quat[i], body_rot[i])
    q = body_quat[i]
    p = body_quat0[i]
    w, x, y, z = quat_mul(q[0], q[1], q[2], q[3], p[0], -p[1], -p[2], -p[3])
    body_dq[i, 0] = w
    body_dq[i, 1] = x
    body_dq[i, 2] = y
    body_dq[i, 3] = z


@nb.njit(**JIT)
def refresh_all_rotations(n, body_quat, body_quat0, body_rot, body_dq):
    """refresh_rotation of bodies 0..n−1 (a new state, an increment of a
    static solver: not every step; one thread, no parallel variant to
    compile)."""
    for i in range(n):
        refresh_rotation(i, body_quat, body_quat0, body_rot, body_dq)


@nb.njit(**JIT)
def rotate_body(i, dt, inertia, body_quat, body_angmom, body_rot):
    """Free-rotor update of body i's quaternion over dt with its (half-step)
    world angular momentum (DLM, physics/rotation.py)."""
    L = body_angmom[i]
    if L[0] == 0.0 and L[1] == 0.0 and L[2] == 0.0:
        return
    R = body_rot[i]
    dlm_free_rotor(body_quat[i],
                   R[0, 0] * L[0] + R[1, 0] * L[1] + R[2, 0] * L[2],
                   R[0, 1] * L[0] + R[1, 1] * L[1] + R[2, 1] * L[2],
                   R[0, 2] * L[0] + R[1, 2] * L[1] + R[2, 2] * L[2],
                   inertia, dt)


@nb.njit(inline="always", **JIT)
def _translate(i, t, dt, keep, dt_c, damping_alpha, damping_local, follow, local, amp, R,
               body_wrench, body_support, body_mass, body_pos, body_pos0, body_vel,
               body_fext, body_ffol, gravity, dof_kind, dof_value, dof_hist, hist_ptr, hist_t,
               hist_a, body_reaction):
    """Kick and drift of body i's translations (dynamic_body_pass).
    Returns the work of loads and constraints and the damping dissipation
    of the step [J]."""
    g = body_wrench[i]
    m = body_mass[i]
    dt_cm = dt_c / m
    work = 0.0
    damp = 0.0
    for k in range(3):
        fext = amp * body_fext[i, k] + m * gravity[k]
        ffol = 0.0
        if follow:
            ffol = amp * (R[k, 0] * body_ffol[i, 0] + R[k, 1] * body_ffol[i, 1]
                          + R[k, 2] * body_ffol[i, 2])
        f = g[k] + fext + ffol
        v_old = body_vel[i, k]
        kind = dof_kind[i, k]
        fd = 0.0
        if kind == FREE:
            if local:
                # local damping: −β|f| sign(v) (v at t − dt/2)
                fd = -damping_local * abs(f) * ((v_old > 0.0) - (v_old < 0.0))
            # mass-proportional damping, central difference (c = α dt / 2):
            # v' = ((1 − c) v + dt f/m) / (1 + c)
            v_new = keep * v_old + dt_cm * (f + fd)
            reaction = body_support[i, k]
        else:
            if kind == FIXED:
                v_new = 0.0
            elif kind == VELOCITY:
                v_new = dof_value[i, k] * amplitude(dof_hist[i, k], t + 0.5 * dt,
                                                    hist_ptr, hist_t, hist_a)
            else:
                target = body_pos0[i, k] + dof_value[i, k] * amplitude(
                    dof_hist[i, k], t + dt, hist_ptr, hist_t, hist_a)
                v_new = (target - body_pos[i, k]) / dt
            # force the constraint adds so that m a = f + r
            r = m * (v_new - v_old) / dt - f
            reaction = body_support[i, k] + r
            # its work r v̄ dt, v̄ the mean of the half-step velocities (the
            # kinetic energy m Δv v̄ of the kick less f v̄ dt, the forces'
            # share, second order as a trapezoid of ∫ f dx; the half step
            # to an output frame: explicit.constraint_half_step_work); r v_new
            # dt booked ½ m Δv² too much at each jump of the velocity
            work += r * (0.5 * (v_old + v_new)) * dt
        va = 0.5 * (v_old + v_new)
        work += fext * v_new * dt + ffol * va * dt
        damp += damping_alpha * m * va * va * dt - fd * va * dt
        body_vel[i, k] = v_new
        body_pos[i, k] += v_new * dt
        body_reaction[i, k] = reaction
    return work, damp


@nb.njit(inline="always", **JIT)
def _rotate(i, dt, keep, dt_c, damping_alpha, damping_local, follow, local, amp, R, work, damp,
            body_wrench, body_inertia, body_angmom, body_mext, body_mfol, dof_kind, body_quat,
            body_quat0, body_rot, body_dq, body_work, body_damp):
    """Kick of body i's world angular momentum, constraints, free rotor
    (dynamic_body_pass); adds the step's work and damping dissipation (the
    running sums `work`, `damp` of _translate) to body_work, body_damp."""
    g = body_wrench[i]
    L = body_angmom[i]
    inertia = body_inertia[i]
    l0, l1, l2 = L[0], L[1], L[2]          # L at t − dt/2
    w0 = 0.0
    w1 = 0.0
    w2 = 0.0
    td0 = 0.0
    td1 = 0.0
    td2 = 0.0
    if local:
        # world ω = R I⁻¹ Rᵀ L at t − dt/2, for the sign of local damping
        b0 = (R[0, 0] * l0 + R[1, 0] * l1 + R[2, 0] * l2) / inertia[0]
        b1 = (R[0, 1] * l0 + R[1, 1] * l1 + R[2, 1] * l2) / inertia[1]
        b2 = (R[0, 2] * l0 + R[1, 2] * l1 + R[2, 2] * l2) / inertia[2]
        w0 = R[0, 0] * b0 + R[0, 1] * b1 + R[0, 2] * b2
        w1 = R[1, 0] * b0 + R[1, 1] * b1 + R[1, 2] * b2
        w2 = R[2, 0] * b0 + R[2, 1] * b1 + R[2, 2] * b2
    for k in range(3):
        mext = amp * body_mext[i, k]
        if follow:
            mext += amp * (R[k, 0] * body_mfol[i, 0] + R[k, 1] * body_mfol[i, 1]
                           + R[k, 2] * body_mfol[i, 2])
        torque = g[3 + k] + mext
        if local:
            wk = w0 if k == 0 else (w1 if k == 1 else w2)
            td = -damping_local * abs(torque) * ((wk > 0.0) - (wk < 0.0))
            torque += td
            if k == 0:
                td0 = td
            elif k == 1:
                td1 = td
            else:
                td2 = td
        l_old = L[k]
        L[k] = keep * l_old + dt_c * torque       # ((1 − c) L + dt T)/(1 + c)
    constrain_rotation(i, dof_kind, R, inertia, L)
    if local:
        # dissipated: −T_d·ω over the kick, ω averaged over it (exact for
        # the kinetic energy ½ Lᵀ R I⁻¹ Rᵀ L at fixed R)
        b0 = (R[0, 0] * L[0] + R[1, 0] * L[1] + R[2, 0] * L[2]) / inertia[0]
        b1 = (R[0, 1] * L[0] + R[1, 1] * L[1] + R[2, 1] * L[2]) / inertia[1]
        b2 = (R[0, 2] * L[0] + R[1, 2] * L[1] + R[2, 2] * L[2]) / inertia[2]
        v0 = R[0, 0] * b0 + R[0, 1] * b1 + R[0, 2] * b2
        v1 = R[1, 0] * b0 + R[1, 1] * b1 + R[1, 2] * b2
        v2 = R[2, 0] * b0 + R[2, 1] * b1 + R[2, 2] * b2
        damp -= 0.5 * dt * (td0 * (w0 + v0) + td1 * (w1 + v1) + td2 * (w2 + v2))
    if damping_alpha > 0.0 or amp != 0.0:
        # ω at the half step, for damping dissipation and moment work
        # (world M·ω = M·R ω_b; a follower moment: m_b·ω_b)
        for k in range(3):
            lb = R[0, k] * L[0] + R[1, k] * L[1] + R[2, k] * L[2]
            wb = lb / inertia[k]
            damp += damping_alpha * lb * wb * dt
            for r in range(3):
                work += amp * body_mext[i, r] * R[r, k] * wb * dt
            if follow:
                wb_old = (R[0, k] * l0 + R[1, k] * l1 + R[2, k] * l2) / inertia[k]
                work += amp * body_mfol[i, k] * 0.5 * (wb_old + wb) * dt
    rotate_body(i, dt, inertia, body_quat, body_angmom, body_rot)
    refresh_rotation(i, body_quat, body_quat0, body_rot, body_dq)
    body_work[i] += work
    body_damp[i] += damp


@nb.njit(**JIT, **NOALIAS)
def _dynamic_bodies_range(i0, i1, t, stepping, bodies, loads, bs, gw0, gw1, gw2):
    """Bodies i0..i1 in order: the one compiled loop of the pass, on one
    thread (small models) or per part (physics/jit.py).  gw0..2: the
    ground's weights of the work of the forces that tie bodies to it
    (support springs, contact), when it moves (it moves after the pass:
    dynamic_body_pass, move_ground)."""
    # the fields into locals before the loop (physics/arrays.py)
    dt, damping_alpha, damping_local, t0 = stepping
    body_mass, body_inertia, body_pos0, body_quat0 = bodies
    (body_fext, body_mext, body_ffol, body_mfol, body_load_hist, gravity, dof_kind, dof_value,
     dof_hist, hist_ptr, hist_t, hist_a, ground_hist, ground_dir) = loads
    (body_pos, body_quat, body_vel, body_angmom, body_rot, body_dq, body_wrench, body_support,
     body_work, body_damp, body_reaction, spring_force) = bs
    c = 0.5 * damping_alpha * dt
    # (1 − c)/(1 + c) and dt/(1 + c): divisions out of the loop
    keep = (1.0 - c) / (1.0 + c)
    dt_c = dt / (1.0 + c)
    follow = body_ffol.shape[0] > 0
    local = damping_local > 0.0
    moving = ground_hist[0] >= 0
    for i in range(i0, i1):
        amp = amplitude(body_load_hist[i], t, hist_ptr, hist_t, hist_a)
        R = body_rot[i]                      # at t, as the spring forces
        work, damp = _translate(i, t, dt, keep, dt_c, damping_alpha, damping_local, follow,
                                local, amp, R, body_wrench, body_support, body_mass,
                                body_pos, body_pos0, body_vel, body_fext, body_ffol,
                                gravity, dof_kind, dof_value, dof_hist, hist_ptr, hist_t,
                                hist_a, body_reaction)
        if moving:
            # the ground's work through the body's supports: f · v̄_g dt
            work += body_support[i, 0] * gw0 + body_support[i, 1] * gw1 \
                + body_support[i, 2] * gw2
        _rotate(i, dt, keep, dt_c, damping_alpha, damping_local, follow, local, amp, R,
                work, damp, body_wrench, body_inertia, body_angmom, body_mext, body_mfol,
                dof_kind, body_quat, body_quat0, body_rot, body_dq, body_work, body_damp)


@nb.njit(**JIT)
def _ground_weights(t, dt, loads, bs, n):
    """The moving ground's weights of _dynamic_bodies_range (zeros when it
    does not move)."""
    gh, gd, hp, ht, ha, vel = (loads.ground_hist, loads.ground_dir, loads.hist_ptr,
                               loads.hist_t, loads.hist_a, bs.body_vel)
    return (ground_weight(t, dt, gh, gd, hp, ht, ha, vel, n, 0),
            ground_weight(t, dt, gh, gd, hp, ht, ha, vel, n, 1),
            ground_weight(t, dt, gh, gd, hp, ht, ha, vel, n, 2))


@nb.njit(parallel=True, **JIT)
def _dynamic_bodies_parallel(t, stepping, bodies, loads, bs):
    n = bodies.body_mass.shape[0]
    gw0, gw1, gw2 = _ground_weights(t, stepping.dt, loads, bs, n)
    # by the parts of partition.py (bodies i·PARTS // n = p): the same chunks
    # as the spring pass's phase 0, so that a thread can keep its bodies
    for p in nb.prange(PARTS):
        i0, i1 = part_range(p, PARTS, n)
        _dynamic_bodies_range(np.int64(i0), np.int64(i1), t, stepping, bodies, loads, bs,
                              gw0, gw1, gw2)


@nb.njit(**JIT)
def _dynamic_bodies_serial(t, stepping, bodies, loads, bs):
    n = bodies.body_mass.shape[0]
    gw0, gw1, gw2 = _ground_weights(t, stepping.dt, loads, bs, n)
    _dynamic_bodies_range(np.int64(0), np.int64(n), t, stepping, bodies, loads, bs,
                          gw0, gw1, gw2)


@nb.njit(**JIT)
def dynamic_body_pass(t, stepping, bodies, loads, bs, parallel):
    """One leapfrog step of every body, from forces at time t to t + dt
    (stepping: arrays.Stepping; bodies, loads: the Model's; bs: the
    BodyState).  `parallel` None: one thread (the same numbers).

    Accumulates per body the work of external loads and constraints
    (`body_work` [J]) and the energy dissipated by damping (`body_damp`
    [J]): mass-proportional (`damping_alpha` [1/s]) and Cundall's local
    non-viscous damping (`damping_local` = β: each free force and moment
    component f gets −β|f| sign(v), v its velocity at t − dt/2; Cundall
    1987, Itasca PFC "local damping"; it vanishes where the body does not
    accelerate, so steady loading is not dragged and supports are not
    loaded); `body_reaction` gets the force of supports and constraints on
    the body at time t [N]."""
    if parallel is None:
        _dynamic_bodies_serial(t, stepping, bodies, loads, bs)
    else:
        _dynamic_bodies_parallel(t, stepping, bodies, loads, bs)
    move_ground(t, stepping.dt, loads.ground_hist, loads.ground_dir, loads.hist_ptr,
                loads.hist_t, loads.hist_a, bs.body_pos, bs.body_vel)


@nb.njit(**JIT)
def run_dynamic(n_steps, step0, stepping, bodies, springs, loads, bs, hist, aux, contact,
                visc, parallel):
    """Advance n_steps explicit steps inside compiled code; returns the
    step count after them.  The step is this list of passes, each chosen
    once per run (solvers/passes.py Options; a container that is None
    prunes its pass before typing, so a scene pays, and compiles, only for
    what it uses):

        springs      forces at x_n of every spring point, summed into the
                     body wrenches: elastic (hist None) or inelastic with
                     the spring history hist (yield, rupture, contact)
        aux stress   the Poisson correction (aux: PoissonSlots, or None)
        contact      contact between any cells (contact: ContactArrays, or
                     None; contact.overwrite: no springs clear the wrenches)
        viscous      dashpots and Maxwell branches of the springs (visc:
                     ViscousSprings, or None; physics/viscous.py)
        bodies       kick v, L with the forces at t_n, drift x, rotate q

    `parallel` None: every pass on one thread (small models)."""
    yes = flag(True)
    for k in range(n_steps):
        t = stepping.t0 + (step0 + k) * stepping.dt
        # store as a constant: the loop gets a spring pass compiled for it,
        # `if store:` folded out of the per-spring loop (a run-time flag
        # there made the step 8-22 % slower); output frames compile their
        # own variant (two per run, as before issue 26).  The step [s]: a
        # strain-law break's share and the rate laws' smoothing
        spring_forces(springs, bs, hist, aux, False, stepping.dt, parallel)
        if contact is not None:
            contact_step(contact, bodies, bs, stepping.dt, yes)
        if visc is not None:
            viscous_pass(springs, bs, visc, False, parallel)
        dynamic_body_pass(t, stepping, bodies, loads, bs, parallel)
    return step0 + n_steps


@nb.njit(parallel=True, **JIT)
def _synchronized_parallel(t, dt, bodies, loads, bs, out):
    # the fields into locals before the loop (physics/arrays.py)
    body_mass, body_inertia, body_pos0, body_quat0 = bodies
    (body_fext, body_mext, body_ffol, body_mfol, body_load_hist, gravity, dof_kind, dof_value,
     dof_hist, hist_ptr, hist_t, hist_a, ground_hist, ground_dir) = loads
    (body_pos, body_quat, body_vel, body_angmom, body_rot, body_dq, body_wrench, body_support,
     body_work, body_damp, body_reaction, spring_force) = bs
    out_vel, out_angmom, out_reaction = out
    follow = body_ffol.shape[0] > 0
    for i in nb.prange(body_mass.shape[0]):
        g = body_wrench[i]
        sup = body_support[i]
        m = body_mass[i]
        R = body_rot[i]
        amp = amplitude(body_load_hist[i], t, hist_ptr, hist_t, hist_a)
        for k in range(3):
            f = g[k] + amp * body_fext[i, k] + m * gravity[k]
            mext = amp * body_mext[i, k]
            if follow:
                f += amp * (R[k, 0] * body_ffol[i, 0] + R[k, 1] * body_ffol[i, 1]
                            + R[k, 2] * body_ffol[i, 2])
                mext += amp * (R[k, 0] * body_mfol[i, 0] + R[k, 1] * body_mfol[i, 1]
                               + R[k, 2] * body_mfol[i, 2])
            kind = dof_kind[i, k]
            if kind == FREE:
                out_vel[i, k] = body_vel[i, k] + 0.5 * dt * f / m
                out_reaction[i, k] = sup[k]
            else:
                if kind == FIXED:
                    v = 0.0
                elif kind == VELOCITY:
                    v = dof_value[i, k] * amplitude(dof_hist[i, k], t, hist_ptr, hist_t, hist_a)
                else:
                    v = body_vel[i, k]
                out_vel[i, k] = v
                out_reaction[i, k] = sup[k] - f
            fixed_rot = dof_kind[i, 3 + k] == FIXED
            out_angmom[i, k] = 0.0 if fixed_rot else (
                body_angmom[i, k] + 0.5 * dt * (g[3 + k] + mext))


@nb.njit(**JIT)
def _synchronized_serial(t, dt, bodies, loads, bs, out):
    # the fields into locals before the loop (physics/arrays.py)
    body_mass, body_inertia, body_pos0, body_quat0 = bodies
    (body_fext, body_mext, body_ffol, body_mfol, body_load_hist, gravity, dof_kind, dof_value,
     dof_hist, hist_ptr, hist_t, hist_a, ground_hist, ground_dir) = loads
    (body_pos, body_quat, body_vel, body_angmom, body_rot, body_dq, body_wrench, body_support,
     body_work, body_damp, body_reaction, spring_force) = bs
    out_vel, out_angmom, out_reaction = out
    follow = body_ffol.shape[0] > 0
    for i in range(body_mass.shape[0]):
        g = body_wrench[i]
        sup = body_support[i]
        m = body_mass[i]
        R = body_rot[i]
        amp = amplitude(body_load_hist[i], t, hist_ptr, hist_t, hist_a)
        for k in range(3):
            f = g[k] + amp * body_fext[i, k] + m * gravity[k]
            mext = amp * body_mext[i, k]
            if follow:
                f += amp * (R[k, 0] * body_ffol[i, 0] + R[k, 1] * body_ffol[i, 1]
                            + R[k, 2] * body_ffol[i, 2])
                mext += amp * (R[k, 0] * body_mfol[i, 0] + R[k, 1] * body_mfol[i, 1]
                               + R[k, 2] * body_mfol[i, 2])
            kind = dof_kind[i, k]
            if kind == FREE:
                out_vel[i, k] = body_vel[i, k] + 0.5 * dt * f / m
                out_reaction[i, k] = sup[k]
            else:
                if kind == FIXED:
                    v = 0.0
                elif kind == VELOCITY:
                    v = dof_value[i, k] * amplitude(dof_hist[i, k], t, hist_ptr, hist_t, hist_a)
                else:
                    v = body_vel[i, k]
                out_vel[i, k] = v
                out_reaction[i, k] = sup[k] - f
            fixed_rot = dof_kind[i, 3 + k] == FIXED
            out_angmom[i, k] = 0.0 if fixed_rot else (
                body_angmom[i, k] + 0.5 * dt * (g[3 + k] + mext))


@nb.njit(**JIT)
def synchronized_momenta(t, dt, bodies, loads, bs, out, parallel):
    """Velocity and world angular momentum at the whole step t (half kick
    from t − dt/2 with the forces at t; output steps only), and the force
    of supports and constraints on each body at t, into out = (out_vel,
    out_angmom, out_reaction) (N, 3) each.  `parallel` None: one thread."""
    if parallel is None:
        _synchronized_serial(t, dt, bodies, loads, bs, out)
    else:
        _synchronized_parallel(t, dt, bodies, loads, bs, out)
