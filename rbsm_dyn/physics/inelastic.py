"""Spring-point kernel for scenes with yield, rupture or contact.

Chosen once per run instead of springs.elastic_spring_pass when the model
asks for any inelastic physics (Model.inelastic), so that a purely elastic
scene pays nothing for them (DESIGN.md §5).  Same contract as the elastic
pass: per spring s it adds its wrench to its two bodies' accumulators in
the thread-safe schedule (springs.deposit, partition.py).

Per-spring history (State): spring_state (S,) int8 (laws/__init__.py),
spring_dp (S, 3) [m] plastic gap (intact) or slip (broken, components 1–2)
in the spring frame, spring_kappa (S,) [m] largest opening (law tension) or
the last step's equivalent opening (law mixed_mode) or equivalent strain
(law strain; once broken, the share λ of _crossing_share still to book,
with the gap it acted on in spring_dp, for one step), spring_dmg (S,)
damage, spring_wp, spring_wf (S,) [J] plastic (incl. friction) and
fracture dissipation so far, spring_rate (S,) [1/s] the smoothed rate of
equivalent strain of a `rate` law ((0,) when no law has one).

Order for an intact spring (laws in physics/laws/):
  1. softening damage from the largest elastic opening (rupture.py),
  2. trial force k (δ − δp), damage on tension and shear,
  3. return mapping onto the yield surface (plastic.py), δp and W_p grow,
  4. rupture by strain or full damage: the spring turns into contact and
     the elastic energy it loses is W_f (strain law in an explicit step,
     `step` > 0: the energy at the crossing of ε_cr, _crossing_share).
A broken spring is a contact (contact.py) until its gap |δ| exceeds the
spring length h (opened, slid or turned by a whole cell): then the two
cells have parted and the pair is never in contact again (spring_kappa =
inf marks it), so fragments that fly and tumble do not push through a face
they no longer share.  From there, contact between the two cells (and
with any new partner: sliding by more than h along a crack, fragments) is
the case key ``contact`` (physics/collide.py), which leaves alone every
pair whose springs still act.
"""
import math

import numba as nb
import numpy as np
from numba.core import types
from numba.extending import overload

from .laws import (BROKEN, CONTACT, ELASTIC, P_CAP, P_CAPH, P_CAPK, P_COH, P_CRIT, P_EPSCR, P_FT,
                   P_GF, P_GS, P_MODEL, P_MU, P_RATE, P_RS, P_RUPT, P_SLOW, P_SY, P_TANPHI,
                   P_TENSION, YIELDED)
from .laws.contact import CONTACT_OFF, contact_traction
from .laws.plastic import CONTINUUM, plastic_return
from .laws.rupture import (MIXED, SOFTENING, STRAIN, cap_stress, equivalent_strain,
                           fib2010_compression_dif, fib2010_tension_dif, mixed_mode_damage,
                           smoothed_rate, softening_damage)
from .springs import (add_wrench, clear_part, flush_a, gap_and_scaled_frame, material_points,
                      mid_increment, part_range, scaled_frame)

JIT = dict(cache=True, nogil=True, fastmath=False, error_model="numpy")

# n2 = |Δq_a ± Δq_b|² = 2 + 2 cos(θ/2) for a relative rotation θ of the pair;
# below this a broken pair has turned by more than 90° and is parted
N2_PARTED = 2.0 + 2.0 * math.cos(math.pi / 4.0)


@nb.njit(inline="always", **JIT)
def _contact_energy(kn, dn):
    return 0.5 * kn * dn * dn if dn < 0.0 else 0.0


@nb.njit(inline="always", **JIT)
def _crossing_share(r, rho):
    """Share λ of its intact force that a spring of the strain law keeps at
    the step where it breaks, when its equivalent strain went from r ε to ε
    over the step and the threshold is ε_cr = ρ ε (0 ≤ r ≤ ρ ≤ 1).

    The leapfrog's kinetic energy changes by the trapezoidal work
    ½ (f_n + f_n+1)·Δx of each force over each step (Belytschko, Liu &
    Moran, Nonlinear Finite Elements, 2000, §6.2.4, energy balance), so a
    force f_n+1 = λ k e_n+1 at the breaking step, then nothing, takes
    U_n + ½ (f_n + f_n+1)·Δe_n + ½ f_n+1·Δe_n+1 out of the motion.  On a
    straight path e_n = r e_n+1 the first two terms are (r + λ (1 − r)) U,
    U = ½ k e_n+1² (booked at the breaking step), the last is booked at the
    next step from the stored λ and e_n+1; with Δe_n+1 ≈ Δe_n the sum is
    (r + 2λ (1 − r)) U, the energy at the crossing, ρ² U, for
    λ = (ρ² − r)/(2 (1 − r)): ½ when the threshold is met at the end of
    the step, −r/2 (the push that takes back the pull applied past the
    crossing) when it was met at its start.  Breaking with nothing (λ = 0)
    and booking U instead released the energy of the overshoot, which grows
    with dt² in fast fracture (8-16× the fracture energy at 4× the step)
    and had not been taken from the motion."""
    if r > rho:
        r = rho
    if r < 0.0:
        r = 0.0
    if 1.0 - r <= 1.0e-12:
        return 0.5
    return (rho * rho - r) / (2.0 * (1.0 - r))


@nb.njit(inline="always", **JIT)
def spring_law(s, f, dn, ds, dt, turned, area, kn, ks, kt, face_h, face_law, law_params,
               spring_state, spring_dp, spring_kappa, spring_dmg, spring_wp, spring_wf,
               spring_rate, step):
    """The inelastic law of spring point s (of face f) at its local gap
    (dn, ds, dt) [m] in the turned spring frame: its traction's forces
    (fn, fs, ft) [N], the history updated (module docstring, steps 1-4,
    and the contact of a broken spring).  kn, ks, kt [N/m] the point's
    stiffness (area [m²] × the face's per area); `turned`: the pair has
    turned by more than a right angle against each other (a broken pair
    then parts).  Shared by the 3D pass (_inelastic_group) and the plane
    pass (physics/plane.py), which differ only in their kinematics.  A law
    of continuum yield (P_MODEL = CONTINUUM) has no return here: its cells
    flow (finish_cell_stress) and the caller moves spring_dp with them
    (plastic_offset)."""
    li = face_law[f]           # the law's row (scalars read in place: a row view
                               # costs a reference count per spring)
    state = spring_state[s]
    fn = fs = ft = 0.0
    gn = gs = gt = lam = 0.0
    crossed = False            # strain law broken inside this explicit step
    if state < BROKEN:
        en = dn - spring_dp[s, 0]
        es = ds - spring_dp[s, 1]
        et = dt - spring_dp[s, 2]
        dmg = spring_dmg[s]
        rupt = law_params[li, P_RUPT]
        if rupt == SOFTENING:
            kappa = spring_kappa[s]
            if en > kappa:
                k_old = kappa
                kappa = en
                spring_kappa[s] = kappa
                dnew = softening_damage(kappa, kn / area, law_params[li, P_FT],
                                        law_params[li, P_GF])
                if dnew > dmg:
                    # energy release rate Y = ½ k e² (undamaged springs; en > 0)
                    # at the product of the last and this opening, ½ k κ₁κ₂:
                    # on the linear envelope the energy dissipated from κ₁ to
                    # κ₂ is ½ (σ₁κ₂ − σ₂κ₁) = ½ k κ₁κ₂ (D₂ − D₁) exactly, for
                    # any increment (κ₁ at least the elastic limit f_t/k, κ₂
                    # at most the opening 2 G_f/f_t where it is lost), as the
                    # mixed-mode branch books it; ½ k κ₂² overstated a Newton
                    # increment's (+16 % on 6 increments of softening)
                    y = 0.5 * (kn * en * en + ks * es * es + kt * et * et)
                    ft, gf = law_params[li, P_FT], law_params[li, P_GF]
                    y *= max(k_old, ft * area / kn) * min(en, 2.0 * gf / ft) / (en * en)
                    spring_wf[s] += y * (dnew - dmg)
                    dmg = dnew
                    spring_dmg[s] = dmg
        elif rupt == MIXED:
            strength = law_params[li, P_FT]
            # the envelope raised by the rate of the steps before this one;
            # the rate is held from the step the spring starts to soften
            # (smoothed_rate): the factor is that of the loading it failed at
            # (spring_rate has no rows unless a law has a rate: a run without
            # one tests a loop-invariant length, not the law's row)
            rated = spring_rate.shape[0] > 0 and law_params[li, P_RATE] > 0.0
            loading = rated and dmg == 0.0
            cfac = 1.0
            if rated:
                # fib Model Code 2010 §5.1.11.1: the tensile factor on the
                # envelope, the compressive one in compression (rupture.py)
                tdif = fib2010_tension_dif(spring_rate[s])
                strength *= tdif
                cfac = fib2010_compression_dif(spring_rate[s]) / tdif
            dnew, w = mixed_mode_damage(en, es, et, kn / area, ks / area, kt / area,
                                        strength, law_params[li, P_GF],
                                        law_params[li, P_RS], law_params[li, P_GS], cfac)
            if dnew > dmg:
                # Y = −∂U/∂D, U = ½ (1 − D)(kn ⟨en⟩² + ks es² + kt et²) + ½ kn ⟨−en⟩²,
                # taken at the product of this step's and the last step's
                # equivalent openings (Y w_prev/w): with the leapfrog's
                # kinetic energy change ½ (f_n + f_n+1)·Δx, the damage
                # released between two steps is then booked exactly, where
                # Y(e_n+1) overstates it by ½ k e Δe ΔD (energy created
                # in fast fracture: +2–5 % of the work measured before)
                pn = en if en > 0.0 else 0.0
                y = 0.5 * (kn * pn * pn + ks * es * es + kt * et * et)
                if w > 0.0:
                    y *= spring_kappa[s] / w
                spring_wf[s] += y * (dnew - dmg)
                dmg = dnew
                spring_dmg[s] = dmg
            if loading and step > 0.0:
                spring_rate[s] = smoothed_rate(spring_rate[s], spring_kappa[s], w, step,
                                               face_h[f], law_params[li, P_SLOW])
            spring_kappa[s] = w      # equivalent opening of this step
        fn = kn * en
        if fn > 0.0:
            fn *= 1.0 - dmg          # a crack transmits no tension ...
        fs = (1.0 - dmg) * ks * es   # ... and less shear
        ft = (1.0 - dmg) * kt * et
        cap = law_params[li, P_CAP]
        if cap > 0.0 and fn < 0.0:
            # the compressive cap (rupture.cap_stress): the normal traction
            # held on the boundary of the total normal gap, the excess a
            # plastic closing of the gap (its work booked as plastic)
            g = -area * cap_stress(dn, kn / area, cap, law_params[li, P_CAPH],
                                   law_params[li, P_CAPK])[0]
            if fn < g:
                pn = (fn - g) / kn
                spring_dp[s, 0] += pn
                spring_wp[s] += g * pn
                fn = g
                en -= pn
                state = YIELDED
        crit = law_params[li, P_CRIT]
        if crit > 0 and law_params[li, P_MODEL] != CONTINUUM:
            gn, gs, gt, yielded = plastic_return(int(crit), law_params[li, P_SY] * area,
                                                 law_params[li, P_COH] * area,
                                                 law_params[li, P_TANPHI],
                                                 law_params[li, P_TENSION] * area,
                                                 kn, ks, fn, fs, ft)
            if yielded:
                # (a support may hold only some components: k = 0 there)
                pn = (fn - gn) / kn if kn > 0.0 else 0.0
                ps = (fs - gs) / ks if ks > 0.0 else 0.0
                pt = (ft - gt) / kt if kt > 0.0 else 0.0
                spring_dp[s, 0] += pn
                spring_dp[s, 1] += ps
                spring_dp[s, 2] += pt
                spring_wp[s] += gn * pn + gs * ps + gt * pt
                fn, fs, ft = gn, gs, gt
                en -= pn
                es -= ps
                et -= pt
                state = YIELDED
        broken = dmg >= 1.0
        if rupt == STRAIN:
            eps = equivalent_strain(dn, ds, dt, face_h[f])
            eps0 = spring_kappa[s]       # the last step's equivalent strain
            spring_kappa[s] = eps
            if eps >= law_params[li, P_EPSCR]:
                broken = True
                if step > 0.0 and state == ELASTIC:
                    crossed = True
                    lam = _crossing_share(eps0 / eps, law_params[li, P_EPSCR] / eps)
        if broken:
            # stored energy before (with damage) minus what contact keeps
            e_in = 0.5 * (fn * en + fs * es + ft * et)
            # a capped spring's plastic closing stays: its contact starts
            # from the compacted gap (no other broken spring has dp_n < 0)
            off = spring_dp[s, 0] if cap > 0.0 and spring_dp[s, 0] < 0.0 else 0.0
            released = e_in - _contact_energy(kn, dn - off)
            if crossed:
                # threshold crossed inside the step: the work of the
                # released force over this step, (r + λ (1 − r)) of the
                # energy now (_crossing_share); the rest of the share's
                # work is booked at the next step
                r = eps0 / eps
                released *= r + lam * (1.0 - r)
            spring_wf[s] += released
            state = BROKEN
            spring_dp[s, 0] = off
            spring_dp[s, 1] = ds
            spring_dp[s, 2] = dt
            if rupt == STRAIN:
                spring_kappa[s] = 0.0        # broken: no share pending ...
            if crossed:
                # intact force at this step, minus what contact takes over below
                gn, gs, gt = fn, fs, ft
                # ... unless kept: λ and the released gap (the slip
                # memory holds δs, δt until the next step)
                spring_kappa[s] = lam
                spring_dp[s, 0] = dn if dn > 0.0 else 0.0
        spring_state[s] = state
    if state >= BROKEN:
        lam0 = spring_kappa[s]
        if law_params[li, P_RUPT] == STRAIN and not crossed and lam0 != 0.0 and lam0 != np.inf:
            # the share λ k e_n kept at the breaking step n does work
            # over this step too (trapezoidal rule, _crossing_share):
            # ½ λ k e_n·(δ − e_n), fracture energy
            e0 = spring_dp[s, 0]
            e1 = spring_dp[s, 1]
            e2 = spring_dp[s, 2]
            spring_wf[s] += 0.5 * lam0 * (kn * e0 * (dn - e0) + ks * e1 * (ds - e1)
                                          + kt * e2 * (dt - e2))
            spring_kappa[s] = 0.0
            spring_dp[s, 0] = 0.0
        if (dn * dn + ds * ds + dt * dt > face_h[f] * face_h[f]
                or turned):
            # moved apart by a whole spring length (opened, slid or turned
            # away), or turned by more than a right angle against each
            # other (the mid frame is no longer the face's): the two cells
            # have parted and no longer meet at this face (RBSM contact is
            # between the original neighbours only)
            spring_kappa[s] = np.inf
        ss0 = spring_dp[s, 1]
        st0 = spring_dp[s, 2]
        mu = law_params[li, P_MU] if spring_kappa[s] != np.inf else CONTACT_OFF
        # (a capped spring's compaction, spring_dp[s, 0] < 0; else 0 or,
        # for a step, the released gap of the strain law, > 0)
        off = spring_dp[s, 0] if spring_dp[s, 0] < 0.0 else 0.0
        fn, fs, ft, ss1, st1, closed = contact_traction(mu, kn, ks, kt, dn - off, ds, dt,
                                                        ss0, st0)
        if closed:
            # friction work on the slip increment
            spring_wp[s] += fs * (ss1 - ss0) + ft * (st1 - st0)
        spring_dp[s, 1] = ss1
        spring_dp[s, 2] = st1
        spring_state[s] = CONTACT if closed else BROKEN
        if crossed:
            fn += lam * (gn - fn)
            fs += lam * (gs - fs)
            ft += lam * (gt - ft)
    return fn, fs, ft


@nb.njit(inline="always", **JIT)
def _quad(x, u0, u1, u2, v0, v1, v2):
    """u·σ·v of the symmetric σ = x (6,) in the order xx yy zz yz xz xy."""
    return (u0 * v0 * x[0] + u1 * v1 * x[1] + u2 * v2 * x[2]
            + (u1 * v2 + u2 * v1) * x[3] + (u0 * v2 + u2 * v0) * x[4]
            + (u0 * v1 + u1 * v0) * x[5])


@nb.njit(inline="always", **JIT)
def _times(x, l0, l1, l2):
    """σ·l of the symmetric σ = x (6,) in the order xx yy zz yz xz xy."""
    return (x[0] * l0 + x[5] * l1 + x[4] * l2,
            x[5] * l0 + x[1] * l1 + x[3] * l2,
            x[4] * l0 + x[3] * l1 + x[2] * l2)


@nb.njit(inline="always", **JIT)
def plastic_offset(a, b, cell_dep, la0, la1, la2, lb0, lb1, lb2):
    """The plastic gap [m] (world) a spring point takes from the plastic
    strain increments of its two cells (continuum yield, laws/plastic.py):
    ε̄ (x_b − x_a) = ε̄ (l_a − l_b), ε̄ the mean of the two cells' increments,
    l the levers from the centroids to the point (springs.add_wrench): the
    gap a uniform strain ε̄ gives two rigid cells, the same at every point
    of the face; at a support (b the ground, whose levers are world
    positions and whose row is zero) the cell's mirror image across the
    point, 2 l_a.  (Each cell straining about its own centroid instead,
    ε_a l_a − ε_b l_b, varies along the face where the two differ: on
    Prandtl's punch it locked more, 1.23 against 1.17 (2 + π)k at 64 × 32
    blocks.)"""
    if b == cell_dep.shape[0] - 1:
        c0, c1, c2 = 2.0 * la0, 2.0 * la1, 2.0 * la2
    else:
        c0, c1, c2 = la0 - lb0, la1 - lb1, la2 - lb2
    xa0, xa1, xa2 = _times(cell_dep[a], c0, c1, c2)
    xb0, xb1, xb2 = _times(cell_dep[b], c0, c1, c2)
    return 0.5 * (xa0 + xb0), 0.5 * (xa1 + xb1), 0.5 * (xa2 + xb2)


@nb.njit(inline="always", **JIT)
def add_moment(c, sign, l0, l1, l2, f0, f1, f2, cell_moment):
    """Add sign · sym(l ⊗ f) [N m] to cell c's row (xx yy zz yz xz xy)."""
    cell_moment[c, 0] += sign * l0 * f0
    cell_moment[c, 1] += sign * l1 * f1
    cell_moment[c, 2] += sign * l2 * f2
    cell_moment[c, 3] += sign * 0.5 * (l1 * f2 + l2 * f1)
    cell_moment[c, 4] += sign * 0.5 * (l0 * f2 + l2 * f0)
    cell_moment[c, 5] += sign * 0.5 * (l0 * f1 + l1 * f0)


@nb.njit(inline="always", **JIT)
def clear_moment(p, parts, cell_moment):
    """Zero the moment rows of the bodies of part p (as springs.clear_part)."""
    i0, i1 = part_range(p, parts, cell_moment.shape[0] - 1)
    for i in range(i0, i1):
        for k in range(6):
            cell_moment[i, k] = 0.0


@nb.njit(inline="always", **JIT)
def _inelastic_group(g, group_ptr, spring_bodies, spring_arm_a, spring_arm_b,
                     spring_slot, face_frame0, face_k, spring_area, face_h, face_law, law_params,
                     body_pos, body_rot, body_dq, body_wrench, body_support,
                     spring_state, spring_dp, spring_kappa, spring_dmg, spring_wp, spring_wf,
                     spring_rate, store, spring_force, step, cell_dep, cell_moment):
    """The springs of group g, in order (partition.py).  The spring points
    of one face follow each other (same a, b and reference frame): their
    turned frame F is computed once per face (springs._elastic_group).
    With continuum yield (cell_moment has rows) an intact spring of such a
    law first takes the plastic gap of its cells' last flow (cell_dep,
    plastic_offset) into spring_dp, booking its work at the new force, and
    the springs' Σ sym(l ⊗ f) are gathered into their cells' rows of
    cell_moment (the same schedule as the wrenches: no atomics)."""
    gather = cell_moment.shape[0] > 0
    s0 = group_ptr[g]
    s1 = group_ptr[g + 1]
    if s1 == s0:
        return
    cur = np.uint64(spring_bodies[s0, 0])
    w0 = w1 = w2 = w3 = w4 = w5 = 0.0
    fa = fb = np.uint64(0)
    r0 = r1 = r2 = r3 = np.nan      # the held face's reference frame (none yet)
    n2 = F00 = F01 = F02 = F10 = F11 = F12 = F20 = F21 = F22 = 0.0
    for s in range(np.uint64(s0), np.uint64(s1)):
        a = np.uint64(spring_bodies[s, 0])
        b = np.uint64(spring_bodies[s, 1])
        d0, d1, d2, la0, la1, la2, lb0, lb1, lb2 = material_points(
            s, a, b, spring_arm_a, spring_arm_b, body_pos, body_rot)
        f = spring_slot[s]
        if (a != fa or b != fb or face_frame0[f, 0] != r0 or face_frame0[f, 1] != r1
                or face_frame0[f, 2] != r2 or face_frame0[f, 3] != r3):
            fa = a
            fb = b
            r0, r1, r2, r3 = (face_frame0[f, 0], face_frame0[f, 1], face_frame0[f, 2],
                              face_frame0[f, 3])
            q0, q1, q2, q3, n2 = mid_increment(a, b, body_dq)
            G00, G01, G02, G10, G11, G12, G20, G21, G22 = scaled_frame(
                q0, q1, q2, q3, n2, r0, r1, r2, r3)
            c = 1.0 / n2
            F00, F01, F02 = c * G00, c * G01, c * G02
            F10, F11, F12 = c * G10, c * G11, c * G12
            F20, F21, F22 = c * G20, c * G21, c * G22
        dn = F00 * d0 + F10 * d1 + F20 * d2
        ds = F01 * d0 + F11 * d1 + F21 * d2
        dt = F02 * d0 + F12 * d1 + F22 * d2
        area = spring_area[s]
        kn = face_k[f, 0] * area
        ks = face_k[f, 1] * area
        kt = face_k[f, 2] * area
        pn = ps = pt = 0.0
        cont = (gather and law_params[face_law[f], P_MODEL] == CONTINUUM
                and spring_state[s] < BROKEN)
        if cont:
            o0, o1, o2 = plastic_offset(a, b, cell_dep, la0, la1, la2, lb0, lb1, lb2)
            pn = F00 * o0 + F10 * o1 + F20 * o2
            ps = F01 * o0 + F11 * o1 + F21 * o2
            pt = F02 * o0 + F12 * o1 + F22 * o2
            spring_dp[s, 0] += pn
            spring_dp[s, 1] += ps
            spring_dp[s, 2] += pt
        fn, fs, ft = spring_law(s, f, dn, ds, dt, n2 < N2_PARTED, area, kn, ks, kt, face_h,
                                face_law, law_params, spring_state, spring_dp, spring_kappa,
                                spring_dmg, spring_wp, spring_wf, spring_rate, step)
        if cont:
            spring_wp[s] += fn * pn + fs * ps + ft * pt
        f0 = F00 * fn + F01 * fs + F02 * ft
        f1 = F10 * fn + F11 * fs + F12 * ft
        f2 = F20 * fn + F21 * fs + F22 * ft
        cur, w0, w1, w2, w3, w4, w5 = add_wrench(
            s, a, cur, w0, w1, w2, w3, w4, w5, f0, f1, f2,
            la0, la1, la2, lb0, lb1, lb2, spring_bodies, body_wrench, body_support)
        if store:
            spring_force[s, 0] = f0
            spring_force[s, 1] = f1
            spring_force[s, 2] = f2
        if gather:
            # lever arms to the force's point (springs.add_wrench)
            add_moment(a, 1.0, la0, la1, la2, f0, f1, f2, cell_moment)
            if b != cell_moment.shape[0] - 1:
                add_moment(b, -1.0, lb0, lb1, lb2, f0, f1, f2, cell_moment)
    flush_a(cur, w0, w1, w2, w3, w4, w5, body_wrench)

@nb.njit(parallel=True, **JIT)
def _inelastic_phase(lo, hi, parts, springs, bs, hist, store, step):
    """Groups lo..hi of one phase in parallel (they share no body)."""
    # the fields into locals before the prange (physics/arrays.py)
    group_ptr = springs.group_ptr
    spring_bodies = springs.spring_bodies
    spring_arm_a = springs.spring_arm_a
    spring_arm_b = springs.spring_arm_b
    spring_slot = springs.spring_slot
    face_frame0 = springs.face_frame0
    face_k = springs.face_k
    spring_area = springs.spring_area
    face_h = springs.face_h
    face_law = springs.face_law
    law_params = springs.law_params
    body_pos = bs.body_pos
    body_rot = bs.body_rot
    body_dq = bs.body_dq
    body_wrench = bs.body_wrench
    body_support = bs.body_support
    spring_force = bs.spring_force
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
            clear_part(g, parts, body_wrench, body_support)
            if gather:
                clear_moment(g, parts, cell_moment)
        _inelastic_group(g, group_ptr, spring_bodies, spring_arm_a, spring_arm_b, spring_slot,
                         face_frame0, face_k, spring_area, face_h, face_law, law_params,
                         body_pos, body_rot, body_dq, body_wrench, body_support, spring_state,
                         spring_dp, spring_kappa, spring_dmg, spring_wp, spring_wf, spring_rate,
                         store, spring_force, step, cell_dep, cell_moment)


@nb.njit(**JIT)
def _inelastic_serial(springs, bs, hist, store, step):
    """Every group in order, one thread (small models)."""
    group_ptr = springs.group_ptr
    spring_bodies = springs.spring_bodies
    spring_arm_a = springs.spring_arm_a
    spring_arm_b = springs.spring_arm_b
    spring_slot = springs.spring_slot
    face_frame0 = springs.face_frame0
    face_k = springs.face_k
    spring_area = springs.spring_area
    face_h = springs.face_h
    face_law = springs.face_law
    law_params = springs.law_params
    body_pos = bs.body_pos
    body_rot = bs.body_rot
    body_dq = bs.body_dq
    body_wrench = bs.body_wrench
    body_support = bs.body_support
    spring_force = bs.spring_force
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
    phase_ptr = springs.phase_ptr
    parts = phase_ptr[1]
    for g in range(0, phase_ptr[phase_ptr.shape[0] - 1]):
        if g < parts:
            clear_part(g, parts, body_wrench, body_support)
            if gather:
                clear_moment(g, parts, cell_moment)
        _inelastic_group(g, group_ptr, spring_bodies, spring_arm_a, spring_arm_b, spring_slot,
                         face_frame0, face_k, spring_area, face_h, face_law, law_params,
                         body_pos, body_rot, body_dq, body_wrench, body_support, spring_state,
                         spring_dp, spring_kappa, spring_dmg, spring_wp, spring_wf, spring_rate,
                         store, spring_force, step, cell_dep, cell_moment)


@nb.njit(**JIT)
def _inelastic_phases(springs, bs, hist, store, step):
    """Phase by phase, each in parallel."""
    phase_ptr = springs.phase_ptr
    parts = phase_ptr[1]
    for ph in range(phase_ptr.shape[0] - 1):
        _inelastic_phase(phase_ptr[ph], phase_ptr[ph + 1], parts, springs, bs, hist, store,
                         step)


def _inelastic_threads(springs, bs, hist, store, step, parallel):
    """The serial or the threaded pass, by `parallel`'s type (compiled
    callers only)."""
    raise NotImplementedError("a compiled function only")


@overload(_inelastic_threads, jit_options=dict(nogil=True, error_model="numpy"))
def _inelastic_threads_of(springs, bs, hist, store, step, parallel):
    # chosen by type: `if parallel is None` is pruned before typing only
    # when parallel is None, so a threaded run compiled the serial variant
    # as well (48 s of a cold brazilian_disc, unused)
    if isinstance(parallel, types.NoneType):
        def serial(springs, bs, hist, store, step, parallel):
            _inelastic_serial(springs, bs, hist, store, step)
        return serial

    def threaded(springs, bs, hist, store, step, parallel):
        _inelastic_phases(springs, bs, hist, store, step)
    return threaded


@nb.njit(**JIT)
def inelastic_spring_pass(springs, bs, hist, store, step, parallel):
    """Forces of elastic–plastic, rupturing and contact springs (see module),
    summed into the bodies' wrenches in the schedule of partition.py, with
    the spring history `hist` (arrays.SpringHistory) updated;
    `store`: also write each spring's force (output steps); `step` [s]: the
    explicit time step (0: a static pass): a strain-law spring breaking
    inside the step keeps its share of the force, and the loading rate of
    the `rate` laws is smoothed over it (spring_rate, laws/rupture.py).
    Phase 0's groups first zero their parts' accumulators
    (springs.clear_part).  `parallel` None: one thread in group order.

    The group stays inlined into the prange body (_inelastic_phase): as a
    range function of its own, as the elastic pass has, it compiled 3 times
    faster but stepped 30-38 % slower on a notched tension specimen
    (benchmarks/results/compile.md)."""
    _inelastic_threads(springs, bs, hist, store, step, parallel)


#: share of the radial return taken per pass (finish_cell_stress): a cell's
#: springs relieve it by up to 1.75 × 2G Δε_p (blocks at ν = 0.3, whose
#: normal springs carry E' = E(1 − ν)/((1 + ν)(1 − 2ν))), so a full return
#: overshoots; half a return per step does not, the rest comes in the next
#: steps (a lag of a few steps, as the explicit step's own)
RETURN_SHARE = 0.5


@nb.njit(**JIT)
def finish_cell_stress(springs, bs, hist):
    """Continuum yield (laws/plastic.py), after a spring pass: each cell's
    stress σ_c = Σ sym(l ⊗ f)/V_c [Pa] (Love–Weber, physics/cell_stress.py)
    from the moments the pass gathered, then its plastic flow: where
    √J2(σ_c) > k_c the radial return of J2 plasticity (Simo & Hughes,
    Computational Inelasticity, §3.3.1), Δε_p = β (1 − k/√J2) s/(2G), s
    the deviator, β = RETURN_SHARE, into cell_dep for the next pass
    (plastic_offset); else 0.

    A cell held along axis k (fixed or prescribed: a platen's, a grip's
    cells) takes a reaction R_k = −(its springs' force)_k that acts where it
    meets what holds it, at the lever cell_lever[c, k] (model/build.py):
    sym(l ⊗ e_k) R_k/V_c is added (without it such a cell's stress is about
    half the stress it passes on).  A cell with no springs along an axis it
    is held on (cell_plane ≥ 0: a one-cell-thick slab held in plane strain,
    a plane-strain model's cell along z) takes for that normal stress the
    mean of the other two, its value in plastic flow (Hill 1950, ch. VI), so
    that it flows in plane strain."""
    cell_moment = hist.cell_moment
    cell_sigma = hist.cell_sigma
    cell_dep = hist.cell_dep
    cell_ivol = springs.cell_ivol
    cell_plane = springs.cell_plane
    cell_lever = springs.cell_lever
    cell_k = springs.cell_k
    cell_2g = springs.cell_2g
    body_wrench = bs.body_wrench
    for c in range(cell_ivol.shape[0] - 1):
        iv = cell_ivol[c]
        for k in range(6):
            cell_sigma[c, k] = cell_moment[c, k] * iv
        for k in range(3):
            l0, l1, l2 = cell_lever[c, k, 0], cell_lever[c, k, 1], cell_lever[c, k, 2]
            if l0 != 0.0 or l1 != 0.0 or l2 != 0.0:
                r = -body_wrench[c, k] * iv
                # sym(l ⊗ e_k) r in the order xx yy zz yz xz xy
                cell_sigma[c, k] += l0 * r if k == 0 else (l1 * r if k == 1 else l2 * r)
                if k == 0:
                    cell_sigma[c, 5] += 0.5 * l1 * r
                    cell_sigma[c, 4] += 0.5 * l2 * r
                elif k == 1:
                    cell_sigma[c, 5] += 0.5 * l0 * r
                    cell_sigma[c, 3] += 0.5 * l2 * r
                else:
                    cell_sigma[c, 4] += 0.5 * l0 * r
                    cell_sigma[c, 3] += 0.5 * l1 * r
        ax = cell_plane[c]
        if ax >= 0:
            cell_sigma[c, ax] = 0.5 * (cell_sigma[c, (ax + 1) % 3] + cell_sigma[c, (ax + 2) % 3])
        x = cell_sigma[c]
        p = (x[0] + x[1] + x[2]) / 3.0
        s0, s1, s2 = x[0] - p, x[1] - p, x[2] - p
        j2 = 0.5 * (s0 * s0 + s1 * s1 + s2 * s2) + x[3] * x[3] + x[4] * x[4] + x[5] * x[5]
        kc = cell_k[c]
        if kc > 0.0 and j2 > kc * kc:
            a = RETURN_SHARE * (1.0 - kc / math.sqrt(j2)) / cell_2g[c]
            cell_dep[c, 0] = a * s0
            cell_dep[c, 1] = a * s1
            cell_dep[c, 2] = a * s2
            cell_dep[c, 3] = a * x[3]
            cell_dep[c, 4] = a * x[4]
            cell_dep[c, 5] = a * x[5]
        else:
            for k in range(6):
                cell_dep[c, k] = 0.0


@nb.njit(**JIT)
def strain_energy(springs, bs, hist):
    """Elastic energy held by the springs [J] at the current positions
    (output steps; one serial pass, no (S, 3) temporaries): ½ Σ k δ² for
    linear springs (hist None); with the history `hist`, ½ k (δ − δp)² with
    damage on tension and shear for intact springs, the closed contact's
    ½ kn δn² + ½ ks (δτ − slip)² for broken ones (δ the local gap,
    springs.spring_local_gap)."""
    spring_bodies = springs.spring_bodies
    spring_arm_a = springs.spring_arm_a
    spring_arm_b = springs.spring_arm_b
    spring_slot = springs.spring_slot
    face_frame0 = springs.face_frame0
    face_k = springs.face_k
    spring_area = springs.spring_area
    body_pos = bs.body_pos
    body_rot = bs.body_rot
    body_dq = bs.body_dq
    if hist is None:
        return 0.5 * _elastic_energy(spring_bodies, spring_arm_a, spring_arm_b, spring_slot,
                                     face_frame0, face_k, spring_area, body_pos, body_rot,
                                     body_dq)
    spring_state = hist.spring_state
    spring_dp = hist.spring_dp
    spring_dmg = hist.spring_dmg
    u = 0.0
    for s in range(spring_bodies.shape[0]):
        (d0, d1, d2, la0, la1, la2, lb0, lb1, lb2,
         G00, G01, G02, G10, G11, G12, G20, G21, G22, n2) = gap_and_scaled_frame(
            s, spring_bodies, spring_arm_a, spring_arm_b, spring_slot, face_frame0,
            body_pos, body_rot, body_dq)
        c = 1.0 / n2
        dn = c * (G00 * d0 + G10 * d1 + G20 * d2)
        ds = c * (G01 * d0 + G11 * d1 + G21 * d2)
        dt = c * (G02 * d0 + G12 * d1 + G22 * d2)
        f = spring_slot[s]
        area = spring_area[s]
        kn = face_k[f, 0] * area
        ks = face_k[f, 1] * area
        kt = face_k[f, 2] * area
        state = spring_state[s]
        en = dn - spring_dp[s, 0]
        es = ds - spring_dp[s, 1]
        et = dt - spring_dp[s, 2]
        if state < BROKEN:
            keep = 1.0 - spring_dmg[s]
            u += ((keep if en > 0.0 else 1.0) * kn * en * en
                  + keep * (ks * es * es + kt * et * et))
        elif state == CONTACT:
            dc = min(dn - min(spring_dp[s, 0], 0.0), 0.0)     # less a cap's compaction
            u += kn * dc * dc + ks * es * es + kt * et * et
    return 0.5 * u


@nb.njit(inline="always", **JIT)
def _elastic_energy(spring_bodies, spring_arm_a, spring_arm_b, spring_slot, face_frame0, face_k,
                    spring_area, body_pos, body_rot, body_dq):
    """Σ k δ² of linear springs (twice their energy, strain_energy)."""
    u = 0.0
    for s in range(spring_bodies.shape[0]):
        (d0, d1, d2, la0, la1, la2, lb0, lb1, lb2,
         G00, G01, G02, G10, G11, G12, G20, G21, G22, n2) = gap_and_scaled_frame(
            s, spring_bodies, spring_arm_a, spring_arm_b, spring_slot, face_frame0,
            body_pos, body_rot, body_dq)
        c = 1.0 / n2
        dn = c * (G00 * d0 + G10 * d1 + G20 * d2)
        ds = c * (G01 * d0 + G11 * d1 + G21 * d2)
        dt = c * (G02 * d0 + G12 * d1 + G22 * d2)
        f = spring_slot[s]
        area = spring_area[s]
        kn = face_k[f, 0] * area
        ks = face_k[f, 1] * area
        kt = face_k[f, 2] * area
        u += kn * dn * dn + ks * ds * ds + kt * dt * dt
    return u
