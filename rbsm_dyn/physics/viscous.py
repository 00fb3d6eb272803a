"""Viscous springs: Kelvin's dashpot (and Rayleigh's β) and Maxwell
branches on each spring point, a pass of their own after the spring pass
(physics/integrate.py run_dynamic; DESIGN.md §11 "[viscous springs]").

The spring pass gives every spring its instantaneous force k δ, with k
from the material's `young` = the instantaneous (glassy) modulus E.  This
pass adds, in the spring's local frame (n, s, t), per component c with
k_c = face_k × area:

    f_v = τ_d k δ̇  +  Σ_i (q_i − g_i k δ)

* a dashpot in parallel with the spring (Kelvin–Voigt; stiffness-
  proportional Rayleigh damping c = β K is the same dashpot with τ_d = β,
  Chopra, Dynamics of Structures, §11.4): τ_d = Kelvin's retardation time
  plus β, δ̇ = (δ_n − δ_{n−1})/dt the last step's rate;
* Maxwell branches (a spring g_i k in series with a dashpot of time τ_i)
  replacing the share g_i of the instantaneous spring: the long-term
  modulus is E (1 − Σ g_i), the relaxation modulus E(t) = E (1 − Σ g_i
  (1 − e^{−t/τ_i})) (generalized Maxwell, a Prony series).  Each branch's
  force q_i follows q̇ + q/τ = g k δ̇, integrated exactly for δ linear over
  the step (Simo & Hughes, Computational Inelasticity, 1998, §10.3.2,
  eq. 10.3.13):  q_{n} = a q_{n−1} + b g k (δ_n − δ_{n−1}),
  a = e^{−dt/τ}, b = τ (1 − a)/dt; stable for any τ (a ∈ (0, 1)).

Energy: spring_wv accumulates the work of f_v on the spring,
½ (f_v,n−1 + f_v,n)·(δ_n − δ_{n−1}) (trapezoidal); the branches' stored
energy is Σ q²/(2 g k) − ½ g k δ² beyond the spring pass's ½ k δ², so the
dissipated energy is spring_wv minus it (solvers/output.py).

A static run in time (solvers/creep.py) takes steps of days: there the
dashpot's rate would be a backward Euler step, so the Kelvin spring
σ = k (δ + τ δ̇) is integrated exactly instead (kelvin_a, kelvin_b; the
branches as above): both exact for histories linear over each step.

A broken spring (spring_state ≥ BROKEN: a crack, a cut) carries no
viscous force: its branches and rate are dropped.  Maxwell branches are
for materials without yield or rupture (case/check.py says why).
"""
import numba as nb
import numpy as np

from .jit import NOALIAS
from .laws import BROKEN
from .springs import add_wrench, flush_a, material_points, mid_increment, scaled_frame

JIT = dict(cache=True, nogil=True, fastmath={"contract"}, error_model="numpy")


@nb.njit(inline="always", **JIT)
def _component(s, c, law, dj, k, td, inv_dt, law_g, law_a, law_b, kelvin_a, kelvin_b,
               spring_gap, spring_q, spring_fv):
    """Component c of spring s: its viscous force at the gap dj [m] (the
    branches and the gap updated); returns (force [N], work of the step [J])."""
    delta = dj - spring_gap[s, c]
    if kelvin_a.shape[0] > 0:
        # static in time: the Kelvin spring σ = k (δ + τ δ̇) integrated exactly
        # for σ linear over the step, δ1 = a δ0 + (b − a) σ0/k + (1 − b) σ1/k
        # (a = e^(−dt/τ), b = τ (1 − a)/dt; Bažant's exponential algorithm,
        # Bažant & Wu 1973), solved for σ1; a = 1, b = 0 gives back σ0
        fv = 0.0
        if td > 0.0:
            a = kelvin_a[law]
            b = kelvin_b[law]
            d0 = spring_gap[s, c]
            s0 = k * d0 + spring_fv[s, c]
            fv = (k * (dj - a * d0) - (b - a) * s0) / (1.0 - b) - k * dj
    else:
        fv = td * k * delta * inv_dt
    for i in range(law_g.shape[1]):
        g = law_g[law, i]
        if g == 0.0:
            break
        kg = g * k
        q = law_a[law, i] * spring_q[s, i, c] + law_b[law, i] * kg * delta
        spring_q[s, i, c] = q
        fv += q - kg * dj
    w = 0.5 * (spring_fv[s, c] + fv) * delta
    spring_fv[s, c] = fv
    spring_gap[s, c] = dj
    return fv, w


@nb.njit(inline="always", **JIT)
def _viscous_group(g, group_ptr, spring_bodies, spring_arm_a, spring_arm_b, spring_slot,
                   face_frame0, face_k, face_law, spring_area, body_pos, body_rot, body_dq,
                   body_wrench, body_support, store, spring_force, spring_state, law_dashpot,
                   law_g, law_a, law_b, kelvin_a, kelvin_b, inv_dt, spring_gap, spring_q,
                   spring_fv, spring_wv):
    """The springs of group g, in order (partition.py), as the spring pass."""
    s0 = group_ptr[g]
    s1 = group_ptr[g + 1]
    if s1 == s0:
        return
    cur = np.uint64(spring_bodies[s0, 0])
    w0 = w1 = w2 = w3 = w4 = w5 = 0.0
    check = spring_state.shape[0] > 0
    branches = law_g.shape[1] > 0
    held = np.int64(spring_slot[s0]) + 1    # the face whose frame is held: not the first
    G00 = G01 = G02 = G10 = G11 = G12 = G20 = G21 = G22 = inv = 0.0
    for s in range(np.uint64(s0), np.uint64(s1)):
        f = np.int64(spring_slot[s])
        law = face_law[f]
        td = law_dashpot[law]
        if td == 0.0 and not (branches and law_g[law, 0] != 0.0):
            continue
        if check and spring_state[s] >= BROKEN:
            # a crack carries no viscous stress: branches and rate dropped
            for c in range(3):
                spring_fv[s, c] = 0.0
                for i in range(spring_q.shape[1]):
                    spring_q[s, i, c] = 0.0
            continue
        a = np.uint64(spring_bodies[s, 0])
        b = np.uint64(spring_bodies[s, 1])
        d0, d1, d2, la0, la1, la2, lb0, lb1, lb2 = material_points(
            s, a, b, spring_arm_a, spring_arm_b, body_pos, body_rot)
        if f != held:
            # the points of a face share its frame: turned once per face
            held = f
            q0, q1, q2, q3, n2 = mid_increment(a, b, body_dq)
            G00, G01, G02, G10, G11, G12, G20, G21, G22 = scaled_frame(
                q0, q1, q2, q3, n2, face_frame0[f, 0], face_frame0[f, 1], face_frame0[f, 2],
                face_frame0[f, 3])
            inv = 1.0 / n2
        area = spring_area[s]
        # local gap δ = Fᵀ d (F = G / n2)
        c0, w_0 = _component(s, 0, law, inv * (G00 * d0 + G10 * d1 + G20 * d2),
                             face_k[f, 0] * area, td, inv_dt, law_g, law_a, law_b,
                             kelvin_a, kelvin_b, spring_gap, spring_q, spring_fv)
        c1, w_1 = _component(s, 1, law, inv * (G01 * d0 + G11 * d1 + G21 * d2),
                             face_k[f, 1] * area, td, inv_dt, law_g, law_a, law_b,
                             kelvin_a, kelvin_b, spring_gap, spring_q, spring_fv)
        c2, w_2 = _component(s, 2, law, inv * (G02 * d0 + G12 * d1 + G22 * d2),
                             face_k[f, 2] * area, td, inv_dt, law_g, law_a, law_b,
                             kelvin_a, kelvin_b, spring_gap, spring_q, spring_fv)
        spring_wv[s] += w_0 + w_1 + w_2
        # the force on body a in world axes, F f_v (as the spring pass's F k δ)
        f0 = inv * (G00 * c0 + G01 * c1 + G02 * c2)
        f1 = inv * (G10 * c0 + G11 * c1 + G12 * c2)
        f2 = inv * (G20 * c0 + G21 * c1 + G22 * c2)
        cur, w0, w1, w2, w3, w4, w5 = add_wrench(
            s, a, cur, w0, w1, w2, w3, w4, w5, f0, f1, f2, la0, la1, la2, lb0, lb1, lb2,
            spring_bodies, body_wrench, body_support)
        if store:
            spring_force[s, 0] += f0
            spring_force[s, 1] += f1
            spring_force[s, 2] += f2
    flush_a(cur, w0, w1, w2, w3, w4, w5, body_wrench)


@nb.njit(**JIT, **NOALIAS)
def _viscous_range(lo, hi, springs, bs, visc, store):
    """Groups lo..hi in order, the group inlined: the one compiled loop of
    the pass, on one thread (small models) or for each group of a phase
    (physics/jit.py)."""
    # the fields into locals before the loop (physics/arrays.py)
    group_ptr = springs.group_ptr
    spring_bodies = springs.spring_bodies
    spring_arm_a = springs.spring_arm_a
    spring_arm_b = springs.spring_arm_b
    spring_slot = springs.spring_slot
    face_frame0 = springs.face_frame0
    face_k = springs.face_k
    face_law = springs.face_law
    spring_area = springs.spring_area
    body_pos = bs.body_pos
    body_rot = bs.body_rot
    body_dq = bs.body_dq
    body_wrench = bs.body_wrench
    body_support = bs.body_support
    spring_force = bs.spring_force
    (law_dashpot, law_g, law_a, law_b, kelvin_a, kelvin_b, spring_state, spring_gap, spring_q,
     spring_fv, spring_wv, inv_dt) = visc
    for g in range(lo, hi):
        _viscous_group(g, group_ptr, spring_bodies, spring_arm_a, spring_arm_b, spring_slot,
                       face_frame0, face_k, face_law, spring_area, body_pos, body_rot,
                       body_dq, body_wrench, body_support, store, spring_force, spring_state,
                       law_dashpot, law_g, law_a, law_b, kelvin_a, kelvin_b, inv_dt,
                       spring_gap, spring_q, spring_fv, spring_wv)


@nb.njit(parallel=True, **JIT)
def _viscous_phase(lo, hi, springs, bs, visc, store):
    """Groups lo..hi of one phase in parallel (they share no body)."""
    for g in nb.prange(lo, hi):
        _viscous_range(np.int64(g), np.int64(g) + 1, springs, bs, visc, store)


@nb.njit(**JIT)
def _viscous_serial(springs, bs, visc, store):
    """Every group in order, one thread (small models)."""
    phase_ptr = springs.phase_ptr
    _viscous_range(np.int64(0), np.int64(phase_ptr[phase_ptr.shape[0] - 1]), springs, bs,
                   visc, store)


@nb.njit(**JIT)
def viscous_pass(springs, bs, visc, store, parallel):
    """Add the viscous springs' wrenches (module docstring) to the bodies'
    accumulators, after the spring pass has filled them (visc:
    arrays.ViscousSprings, its state advanced to the present positions;
    `store`: also add each spring's viscous force to bs.spring_force).
    `parallel` None: one thread in group order (the same sums)."""
    if parallel is None:
        _viscous_serial(springs, bs, visc, store)
        return
    phase_ptr = springs.phase_ptr
    for ph in range(phase_ptr.shape[0] - 1):
        _viscous_phase(phase_ptr[ph], phase_ptr[ph + 1], springs, bs, visc, store)
