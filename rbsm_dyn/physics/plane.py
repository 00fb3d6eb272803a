"""The plane passes: cells that move in x–y and turn about z (Kawai & Toi
1977, "A new element in discrete analysis of plane strain problems"),
three degrees of freedom per cell, no quaternions and no 3×3 matrices.

A plane model (Model.plane) is its slab's 3D model (prisms of the case's
thickness, spring points on the mid-plane, z, rx, ry held); the explicit
step of a plane model runs these passes on its in-plane projection
(solvers/plane.py) and the 3D passes serve what the plane mode does not
have its own passes for yet.  Same contracts as the 3D passes
(physics/springs.py, integrate.py): per spring its force summed into the
two bodies' accumulators in the schedule of partition.py (no atomics,
the same sums in the same order at any thread count), then per body a
leapfrog step.

Kinematics (DESIGN.md §1 in the plane): p = x + R(θ) r with r the arm at
rest, the gap d = p_b − p_a resolved in the face frame turned by the mid
rotation (θ_a + θ_b)/2, whose direction u = (cos θ_a + cos θ_b, sin θ_a +
sin θ_b) needs no square root: n n^T = N N^T / |u|² with N = R(u) n0 (the
unnormalised rotation by u), as the 3D pass's homogeneous quaternion form.
Exactly the 3D kinematics for rotations about z, so a plane model and its
one-cell slab give the same forces to round-off (tests/test_plane.py).
"""
import numba as nb
import numpy as np

from .inelastic import (add_moment, clear_moment, finish_cell_stress, plastic_offset,
                        spring_law)
from .laws import BROKEN, P_MODEL
from .laws.plastic import CONTINUUM
from .jit import NOALIAS
from .plane_contact import plane_contact_step
from .plane_viscous import plane_viscous_pass
from .integrate import FIXED, FREE, VELOCITY, amplitude, ground_weight, move_ground
from .springs import part_range
from ..partition import PARTS

JIT = dict(cache=True, nogil=True, fastmath={"contract"}, error_model="numpy")
# the inelastic pass as the 3D one (physics/inelastic.py): no fastmath
IJIT = dict(cache=True, nogil=True, fastmath=False, error_model="numpy")


@nb.njit(inline="always", **JIT)
def _clear_part(p, parts, body_wrench, body_support):
    """Zero the accumulators of part p's bodies (springs.clear_part)."""
    i0, i1 = part_range(p, parts, body_wrench.shape[0] - 1)
    for i in range(i0, i1):
        body_wrench[i, 0] = 0.0
        body_wrench[i, 1] = 0.0
        body_wrench[i, 2] = 0.0
        body_support[i, 0] = 0.0
        body_support[i, 1] = 0.0


@nb.njit(inline="always", **JIT)
def _elastic_group(g, group_ptr, spring_bodies, spring_arm_a, spring_arm_b, spring_slot,
                   face_n0, face_k, spring_area, body_pos, body_cs, body_wrench, body_support,
                   store, spring_force):
    """The springs of group g in order: f = k_s d + (k_n − k_s) n (n·d) on
    body a at the midpoint m of the two material points, −f on body b
    (Kawai 1978, eq. 13 form, in the plane)."""
    s0 = group_ptr[g]
    s1 = group_ptr[g + 1]
    if s1 == s0:
        return
    ground = body_support.shape[0] - 1
    cur = np.uint64(spring_bodies[s0, 0])
    w0 = w1 = w2 = 0.0
    for s in range(np.uint64(s0), np.uint64(s1)):
        a = np.uint64(spring_bodies[s, 0])
        b = np.uint64(spring_bodies[s, 1])
        ca, sa = body_cs[a, 0], body_cs[a, 1]
        cb, sb = body_cs[b, 0], body_cs[b, 1]
        ax, ay = spring_arm_a[s, 0], spring_arm_a[s, 1]
        bx, by = spring_arm_b[s, 0], spring_arm_b[s, 1]
        ua0 = ca * ax - sa * ay
        ua1 = sa * ax + ca * ay
        ub0 = cb * bx - sb * by
        ub1 = sb * bx + cb * by
        d0 = (body_pos[b, 0] - body_pos[a, 0]) + (ub0 - ua0)
        d1 = (body_pos[b, 1] - body_pos[a, 1]) + (ub1 - ua1)
        # the face normal turned by the mid rotation, unnormalised: N = R(u) n0
        f = np.int64(spring_slot[s])
        u0 = ca + cb
        u1 = sa + sb
        n0x, n0y = face_n0[f, 0], face_n0[f, 1]
        N0 = u0 * n0x - u1 * n0y
        N1 = u1 * n0x + u0 * n0y
        area = spring_area[s]
        kn = face_k[f, 0] * area
        ks = face_k[f, 1] * area
        cn = (kn - ks) * (N0 * d0 + N1 * d1) / (u0 * u0 + u1 * u1)
        f0 = ks * d0 + cn * N0
        f1 = ks * d1 + cn * N1
        if a != cur:
            body_wrench[cur, 0] += w0
            body_wrench[cur, 1] += w1
            body_wrench[cur, 2] += w2
            cur = a
            w0 = w1 = w2 = 0.0
        # lever arms to the midpoint: l_a = R r_a + d/2, l_b = R r_b − d/2
        w0 += f0
        w1 += f1
        w2 += (ua0 + 0.5 * d0) * f1 - (ua1 + 0.5 * d1) * f0
        if b == ground:
            body_support[a, 0] += f0
            body_support[a, 1] += f1
        else:
            body_wrench[b, 0] -= f0
            body_wrench[b, 1] -= f1
            body_wrench[b, 2] -= (ub0 - 0.5 * d0) * f1 - (ub1 - 0.5 * d1) * f0
        if store:
            spring_force[s, 0] = f0
            spring_force[s, 1] = f1
    body_wrench[cur, 0] += w0
    body_wrench[cur, 1] += w1
    body_wrench[cur, 2] += w2


@nb.njit(**JIT, **NOALIAS)
def _elastic_range(lo, hi, parts, psprings, ps, store):
    """Groups lo..hi in order, the group inlined: the one compiled loop of
    the pass, on one thread (small models) or for each group of a phase
    (physics/jit.py)."""
    group_ptr = psprings.group_ptr
    spring_bodies = psprings.spring_bodies
    spring_arm_a = psprings.spring_arm_a
    spring_arm_b = psprings.spring_arm_b
    spring_slot = psprings.spring_slot
    face_n0 = psprings.face_n0
    face_k = psprings.face_k
    spring_area = psprings.spring_area
    body_pos = ps.body_pos
    body_cs = ps.body_cs
    body_wrench = ps.body_wrench
    body_support = ps.body_support
    spring_force = ps.spring_force
    for g in range(lo, hi):
        if g < parts:
            _clear_part(g, parts, body_wrench, body_support)
        _elastic_group(g, group_ptr, spring_bodies, spring_arm_a, spring_arm_b, spring_slot,
                       face_n0, face_k, spring_area, body_pos, body_cs, body_wrench,
                       body_support, store, spring_force)


@nb.njit(parallel=True, **JIT)
def _elastic_phase(lo, hi, parts, psprings, ps, store):
    """Groups lo..hi of one phase in parallel (they share no body)."""
    for g in nb.prange(lo, hi):
        _elastic_range(np.int64(g), np.int64(g) + 1, parts, psprings, ps, store)


@nb.njit(**JIT)
def _elastic_serial(psprings, ps, store):
    """Every group in order, one thread (small models)."""
    phase_ptr = psprings.phase_ptr
    _elastic_range(np.int64(0), np.int64(phase_ptr[phase_ptr.shape[0] - 1]), phase_ptr[1],
                   psprings, ps, store)


@nb.njit(**JIT)
def plane_spring_pass(psprings, ps, store, parallel):
    """Linear-elastic plane springs summed into the bodies' wrenches
    (ps: arrays.PlaneState); `parallel` None: one thread in group order
    (the same sums, so the same result), else phase by phase."""
    if parallel is None:
        _elastic_serial(psprings, ps, store)
        return
    phase_ptr = psprings.phase_ptr
    parts = phase_ptr[1]
    for ph in range(phase_ptr.shape[0] - 1):
        _elastic_phase(phase_ptr[ph], phase_ptr[ph + 1], parts, psprings, ps, store)


@nb.njit(inline="always", **IJIT)
def _inelastic_group(g, group_ptr, spring_bodies, spring_arm_a, spring_arm_b, spring_slot,
                     face_n0, face_k, spring_area, face_h, face_law, law_params, body_pos,
                     body_cs, body_wrench, body_support, spring_state, spring_dp, spring_kappa,
                     spring_dmg, spring_wp, spring_wf, spring_rate, store, spring_force, step,
                     cell_dep, cell_moment):
    """The springs of group g with the inelastic law (physics/inelastic.py
    spring_law, shared with the 3D pass): the local gap in the frame
    (n, e_z × n, e_z) turned by the mid rotation (model/springs.py
    plane_frames: the same components as the slab's), δt = 0.  Continuum
    yield as the 3D pass: the spring takes its cells' plastic flow
    (plastic_offset, along n and τ), the cells' Σ sym(l ⊗ f) (xx, yy, xy)
    are gathered into cell_moment."""
    gather = cell_moment.shape[0] > 0
    s0 = group_ptr[g]
    s1 = group_ptr[g + 1]
    if s1 == s0:
        return
    ground = body_support.shape[0] - 1
    cur = np.uint64(spring_bodies[s0, 0])
    w0 = w1 = w2 = 0.0
    for s in range(np.uint64(s0), np.uint64(s1)):
        a = np.uint64(spring_bodies[s, 0])
        b = np.uint64(spring_bodies[s, 1])
        ca, sa = body_cs[a, 0], body_cs[a, 1]
        cb, sb = body_cs[b, 0], body_cs[b, 1]
        ax, ay = spring_arm_a[s, 0], spring_arm_a[s, 1]
        bx, by = spring_arm_b[s, 0], spring_arm_b[s, 1]
        ua0 = ca * ax - sa * ay
        ua1 = sa * ax + ca * ay
        ub0 = cb * bx - sb * by
        ub1 = sb * bx + cb * by
        d0 = (body_pos[b, 0] - body_pos[a, 0]) + (ub0 - ua0)
        d1 = (body_pos[b, 1] - body_pos[a, 1]) + (ub1 - ua1)
        f = np.int64(spring_slot[s])
        u0 = ca + cb
        u1 = sa + sb
        r = 1.0 / np.sqrt(u0 * u0 + u1 * u1)
        n0x, n0y = face_n0[f, 0], face_n0[f, 1]
        nx = (u0 * n0x - u1 * n0y) * r
        ny = (u1 * n0x + u0 * n0y) * r
        dn = nx * d0 + ny * d1
        ds = nx * d1 - ny * d0                  # along τ = e_z × n = (−n_y, n_x)
        area = spring_area[s]
        kn = face_k[f, 0] * area
        ks = face_k[f, 1] * area
        pn = ps = 0.0
        cont = (gather and law_params[face_law[f], P_MODEL] == CONTINUUM
                and spring_state[s] < BROKEN)
        if cont:
            o0, o1, _ = plastic_offset(a, b, cell_dep, ua0 + 0.5 * d0, ua1 + 0.5 * d1, 0.0,
                                       ub0 - 0.5 * d0, ub1 - 0.5 * d1, 0.0)
            pn = nx * o0 + ny * o1
            ps = nx * o1 - ny * o0
            spring_dp[s, 0] += pn
            spring_dp[s, 1] += ps
        # turned by more than a right angle against each other: cos(θa − θb) < 0
        fn, fs, ft = spring_law(s, f, dn, ds, 0.0, ca * cb + sa * sb < 0.0, area, kn, ks, ks,
                                face_h, face_law, law_params, spring_state, spring_dp,
                                spring_kappa, spring_dmg, spring_wp, spring_wf, spring_rate,
                                step)
        if cont:
            spring_wp[s] += fn * pn + fs * ps
        f0 = fn * nx - fs * ny
        f1 = fn * ny + fs * nx
        if a != cur:
            body_wrench[cur, 0] += w0
            body_wrench[cur, 1] += w1
            body_wrench[cur, 2] += w2
            cur = a
            w0 = w1 = w2 = 0.0
        w0 += f0
        w1 += f1
        w2 += (ua0 + 0.5 * d0) * f1 - (ua1 + 0.5 * d1) * f0
        if b == ground:
            body_support[a, 0] += f0
            body_support[a, 1] += f1
        else:
            body_wrench[b, 0] -= f0
            body_wrench[b, 1] -= f1
            body_wrench[b, 2] -= (ub0 - 0.5 * d0) * f1 - (ub1 - 0.5 * d1) * f0
        if store:
            spring_force[s, 0] = f0
            spring_force[s, 1] = f1
        if gather:
            add_moment(a, 1.0, ua0 + 0.5 * d0, ua1 + 0.5 * d1, 0.0, f0, f1, 0.0, cell_moment)
            if b != ground:
                add_moment(b, -1.0, ub0 - 0.5 * d0, ub1 - 0.5 * d1, 0.0, f0, f1, 0.0,
                           cell_moment)
    body_wrench[cur, 0] += w0
    body_wrench[cur, 1] += w1
    body_wrench[cur, 2] += w2


@nb.njit(parallel=True, **IJIT)
def _inelastic_phase(lo, hi, parts, psprings, ps, hist, store, step):
    """Groups lo..hi of one phase in parallel (they share no body)."""
    group_ptr = psprings.group_ptr
    spring_bodies = psprings.spring_bodies
    spring_arm_a = psprings.spring_arm_a
    spring_arm_b = psprings.spring_arm_b
    spring_slot = psprings.spring_slot
    face_n0 = psprings.face_n0
    face_k = psprings.face_k
    spring_area = psprings.spring_area
    face_h = psprings.face_h
    face_law = psprings.face_law
    law_params = psprings.law_params
    body_pos = ps.body_pos
    body_cs = ps.body_cs
    body_wrench = ps.body_wrench
    body_support = ps.body_support
    spring_force = ps.spring_force
    spring_state = hist.spring_state
    spring_dp = hist.spring_dp
    spring_kappa = hist.spring_kappa
    spring_dmg = hist.spring_dmg
    spring_wp = hist.spring_wp
    spring_wf = hist.spring_wf
    spring_rate = hist.spring_rate
    cell_dep = hist.cell_dep
    cell_moment = hist.cell_moment
    gather = cell_moment.shape[0] > 0
    for g in nb.prange(lo, hi):
        if g < parts:
            _clear_part(g, parts, body_wrench, body_support)
            if gather:
                clear_moment(g, parts, cell_moment)
        _inelastic_group(g, group_ptr, spring_bodies, spring_arm_a, spring_arm_b, spring_slot,
                         face_n0, face_k, spring_area, face_h, face_law, law_params, body_pos,
                         body_cs, body_wrench, body_support, spring_state, spring_dp,
                         spring_kappa, spring_dmg, spring_wp, spring_wf, spring_rate, store,
                         spring_force, step, cell_dep, cell_moment)


@nb.njit(**IJIT)
def _inelastic_serial(psprings, ps, hist, store, step):
    """Every group in order, one thread (small models)."""
    group_ptr = psprings.group_ptr
    spring_bodies = psprings.spring_bodies
    spring_arm_a = psprings.spring_arm_a
    spring_arm_b = psprings.spring_arm_b
    spring_slot = psprings.spring_slot
    face_n0 = psprings.face_n0
    face_k = psprings.face_k
    spring_area = psprings.spring_area
    face_h = psprings.face_h
    face_law = psprings.face_law
    law_params = psprings.law_params
    body_pos = ps.body_pos
    body_cs = ps.body_cs
    body_wrench = ps.body_wrench
    body_support = ps.body_support
    spring_force = ps.spring_force
    spring_state = hist.spring_state
    spring_dp = hist.spring_dp
    spring_kappa = hist.spring_kappa
    spring_dmg = hist.spring_dmg
    spring_wp = hist.spring_wp
    spring_wf = hist.spring_wf
    spring_rate = hist.spring_rate
    cell_dep = hist.cell_dep
    cell_moment = hist.cell_moment
    gather = cell_moment.shape[0] > 0
    phase_ptr = psprings.phase_ptr
    parts = phase_ptr[1]
    for g in range(0, phase_ptr[phase_ptr.shape[0] - 1]):
        if g < parts:
            _clear_part(g, parts, body_wrench, body_support)
            if gather:
                clear_moment(g, parts, cell_moment)
        _inelastic_group(g, group_ptr, spring_bodies, spring_arm_a, spring_arm_b, spring_slot,
                         face_n0, face_k, spring_area, face_h, face_law, law_params, body_pos,
                         body_cs, body_wrench, body_support, spring_state, spring_dp,
                         spring_kappa, spring_dmg, spring_wp, spring_wf, spring_rate, store,
                         spring_force, step, cell_dep, cell_moment)


@nb.njit(**IJIT)
def plane_inelastic_pass(psprings, ps, hist, store, step, parallel):
    """Plane springs with yield, rupture and contact (hist: arrays.SpringHistory,
    updated), summed into the bodies' wrenches; `step`: the forces of an
    explicit step (physics/inelastic.py).  `parallel` None: one thread."""
    if parallel is None:
        _inelastic_serial(psprings, ps, hist, store, step)
    else:
        phase_ptr = psprings.phase_ptr
        parts = phase_ptr[1]
        for ph in range(phase_ptr.shape[0] - 1):
            _inelastic_phase(phase_ptr[ph], phase_ptr[ph + 1], parts, psprings, ps, hist,
                             store, step)
    if hist.cell_moment.shape[0] > 0:
        # continuum yield: the cells' stress for the next pass (the 3D
        # finish: ps.body_wrench's columns 0, 1 are the forces, and a plane
        # model holds no cell along z by a lever)
        finish_cell_stress(psprings, ps, hist)


@nb.njit(inline="always", **JIT)
def _translate(i, t, dt, keep, dt_c, damping_alpha, damping_local, follow, local, amp, c, s,
               body_wrench, body_support, body_mass, body_pos, body_pos0, body_vel, body_fext,
               body_ffol, gravity, dof_kind, dof_value, dof_hist, hist_ptr, hist_t, hist_a,
               body_reaction):
    """Kick and drift of body i's x, y (integrate._translate in the plane;
    (c, s) the body's cos, sin θ).  Returns the step's work and damping
    dissipation [J]."""
    m = body_mass[i]
    dt_cm = dt_c / m
    work = 0.0
    damp = 0.0
    for k in range(2):
        fext = amp * body_fext[i, k] + m * gravity[k]
        ffol = 0.0
        if follow:
            if k == 0:
                ffol = amp * (c * body_ffol[i, 0] - s * body_ffol[i, 1])
            else:
                ffol = amp * (s * body_ffol[i, 0] + c * body_ffol[i, 1])
        f = body_wrench[i, k] + fext + ffol
        v_old = body_vel[i, k]
        kind = dof_kind[i, k]
        fd = 0.0
        if kind == FREE:
            if local:
                fd = -damping_local * abs(f) * ((v_old > 0.0) - (v_old < 0.0))
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
def _turn(i, dt, keep, dt_c, damping_alpha, damping_local, follow, local, amp, work, damp,
          body_wrench, body_jz, body_fext, body_ffol, dof_kind, body_theta, body_cs,
          body_omega, body_work, body_damp):
    """Kick and turn of body i about z: J ω' = J ω + dt T, θ' = θ + ω' dt
    (the exact rotation of a free body in the plane; integrate._rotate's
    free rotor about one principal axis), dead and follower moments alike
    about z (the follower's work on the mean ω, as in 3D); adds the step's
    work and damping dissipation to body_work, body_damp."""
    jz = body_jz[i]
    mdead = amp * body_fext[i, 2]
    mfol = amp * body_ffol[i, 2] if follow else 0.0
    torque = body_wrench[i, 2] + mdead + mfol
    w_old = body_omega[i]
    td = 0.0
    if local:
        td = -damping_local * abs(torque) * ((w_old > 0.0) - (w_old < 0.0))
    if dof_kind[i, 2] == FIXED:
        w_new = 0.0
    else:
        w_new = keep * w_old + dt_c * (torque + td) / jz
        damp -= 0.5 * dt * td * (w_old + w_new)
        damp += damping_alpha * jz * w_new * w_new * dt
        work += mdead * w_new * dt + mfol * 0.5 * (w_old + w_new) * dt
    body_omega[i] = w_new
    if w_new != 0.0:
        th = body_theta[i] + w_new * dt
        body_theta[i] = th
        body_cs[i, 0] = np.cos(th)
        body_cs[i, 1] = np.sin(th)
    body_work[i] += work
    body_damp[i] += damp


@nb.njit(parallel=True, **JIT)
def _bodies_parallel(t, stepping, pbodies, ploads, ps):
    dt, damping_alpha, damping_local, t0 = stepping
    body_mass, body_jz, body_pos0 = pbodies
    (body_fext, body_ffol, body_load_hist, gravity, dof_kind, dof_value, dof_hist, hist_ptr,
     hist_t, hist_a, ground_hist, ground_dir) = ploads
    (body_pos, body_theta, body_cs, body_vel, body_omega, body_wrench, body_support,
     body_work, body_damp, body_reaction, spring_force) = ps
    n = body_mass.shape[0]
    c = 0.5 * damping_alpha * dt
    keep = (1.0 - c) / (1.0 + c)
    dt_c = dt / (1.0 + c)
    follow = body_ffol.shape[0] > 0
    local = damping_local > 0.0
    moving = ground_hist[0] >= 0
    gw0 = ground_weight(t, dt, ground_hist, ground_dir, hist_ptr, hist_t, hist_a, body_vel, n, 0)
    gw1 = ground_weight(t, dt, ground_hist, ground_dir, hist_ptr, hist_t, hist_a, body_vel, n, 1)
    for p in nb.prange(PARTS):
        i0, i1 = part_range(p, PARTS, n)
        for i in range(i0, i1):
            amp = amplitude(body_load_hist[i], t, hist_ptr, hist_t, hist_a)
            work, damp = _translate(i, t, dt, keep, dt_c, damping_alpha, damping_local, follow,
                                    local, amp, body_cs[i, 0], body_cs[i, 1], body_wrench,
                                    body_support, body_mass, body_pos, body_pos0, body_vel,
                                    body_fext, body_ffol, gravity, dof_kind, dof_value,
                                    dof_hist, hist_ptr, hist_t, hist_a, body_reaction)
            if moving:
                # the ground's work through the body's supports (integrate.py)
                work += body_support[i, 0] * gw0 + body_support[i, 1] * gw1
            _turn(i, dt, keep, dt_c, damping_alpha, damping_local, follow, local, amp, work,
                  damp, body_wrench, body_jz, body_fext, body_ffol, dof_kind, body_theta,
                  body_cs, body_omega, body_work, body_damp)


@nb.njit(**JIT)
def _bodies_serial(t, stepping, pbodies, ploads, ps):
    dt, damping_alpha, damping_local, t0 = stepping
    body_mass, body_jz, body_pos0 = pbodies
    (body_fext, body_ffol, body_load_hist, gravity, dof_kind, dof_value, dof_hist, hist_ptr,
     hist_t, hist_a, ground_hist, ground_dir) = ploads
    (body_pos, body_theta, body_cs, body_vel, body_omega, body_wrench, body_support,
     body_work, body_damp, body_reaction, spring_force) = ps
    n = body_mass.shape[0]
    c = 0.5 * damping_alpha * dt
    keep = (1.0 - c) / (1.0 + c)
    dt_c = dt / (1.0 + c)
    follow = body_ffol.shape[0] > 0
    local = damping_local > 0.0
    moving = ground_hist[0] >= 0
    gw0 = ground_weight(t, dt, ground_hist, ground_dir, hist_ptr, hist_t, hist_a, body_vel, n, 0)
    gw1 = ground_weight(t, dt, ground_hist, ground_dir, hist_ptr, hist_t, hist_a, body_vel, n, 1)
    for i in range(n):
        amp = amplitude(body_load_hist[i], t, hist_ptr, hist_t, hist_a)
        work, damp = _translate(i, t, dt, keep, dt_c, damping_alpha, damping_local, follow,
                                local, amp, body_cs[i, 0], body_cs[i, 1], body_wrench,
                                body_support, body_mass, body_pos, body_pos0, body_vel,
                                body_fext, body_ffol, gravity, dof_kind, dof_value,
                                dof_hist, hist_ptr, hist_t, hist_a, body_reaction)
        if moving:
            work += body_support[i, 0] * gw0 + body_support[i, 1] * gw1
        _turn(i, dt, keep, dt_c, damping_alpha, damping_local, follow, local, amp, work,
              damp, body_wrench, body_jz, body_fext, body_ffol, dof_kind, body_theta,
              body_cs, body_omega, body_work, body_damp)


@nb.njit(**JIT)
def plane_body_pass(t, stepping, pbodies, ploads, ps, parallel):
    """One leapfrog step of every plane body from the forces at t
    (integrate.dynamic_body_pass in the plane; the same work, damping and
    reaction bookkeeping).  `parallel` None: one thread."""
    if parallel is None:
        _bodies_serial(t, stepping, pbodies, ploads, ps)
    else:
        _bodies_parallel(t, stepping, pbodies, ploads, ps)
    move_ground(t, stepping.dt, ploads.ground_hist, ploads.ground_dir, ploads.hist_ptr,
                ploads.hist_t, ploads.hist_a, ps.body_pos, ps.body_vel)


@nb.njit(**JIT)
def run_plane(n_steps, step0, stepping, pbodies, psprings, ploads, ps, hist, contact, visc,
              parallel):
    """Advance a plane model n_steps explicit steps in compiled code:

        springs   forces at x_n of every spring point: elastic (hist None,
                  plane_spring_pass) or inelastic with the spring history
                  hist (plane_inelastic_pass)
        contact   contact between any cells (contact: PlaneContact, or
                  None; physics/plane_contact.py)
        viscous   the viscous springs (visc: ViscousSprings, or None;
                  physics/plane_viscous.py)
        bodies    kick v, ω with the forces at t_n, drift x, turn θ

    Returns the step count after them."""
    for k in range(n_steps):
        t = stepping.t0 + (step0 + k) * stepping.dt
        if hist is None:
            plane_spring_pass(psprings, ps, False, parallel)
        else:
            plane_inelastic_pass(psprings, ps, hist, False, stepping.dt, parallel)
        if contact is not None:
            plane_contact_step(contact, pbodies, ps, stepping.dt)
        if visc is not None:
            plane_viscous_pass(psprings, ps, visc, False, parallel)
        plane_body_pass(t, stepping, pbodies, ploads, ps, parallel)
    return step0 + n_steps
