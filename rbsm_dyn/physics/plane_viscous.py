"""Viscous springs of a plane model: Kelvin's dashpot (and Rayleigh's β)
and Maxwell branches on each spring point, a pass after the plane spring
and contact passes, as physics/viscous.py is after the 3D ones.

The same law per component (viscous._component: the dashpot τ_d k δ̇,
the branches' exact step, Simo & Hughes 1998 eq. 10.3.13) on the two
in-plane components of the gap, resolved in the face frame (n, e_z × n)
turned by the mid rotation (physics/plane.py's kinematics, normalised
here: the branches keep their forces in the frame's unit axes).  The
state is the 3D pass's (spring_gap, spring_q, spring_fv (S, 3): the
plane model's components 0 and 1, its component 2 (z) zero as on the
held slab; spring_wv), so output frames, restarts and the energy terms
read it as they read the slab's.  Same contracts as the plane spring
pass: per group in the schedule of partition.py, no atomics.
"""
import math

import numba as nb
import numpy as np

from .jit import NOALIAS
from .laws import BROKEN
from .viscous import _component

JIT = dict(cache=True, nogil=True, fastmath={"contract"}, error_model="numpy")


@nb.njit(inline="always", **JIT)
def _group(g, group_ptr, spring_bodies, spring_arm_a, spring_arm_b, spring_slot, face_n0,
           face_k, face_law, spring_area, body_pos, body_cs, body_wrench, body_support,
           store, spring_force, spring_state, law_dashpot, law_g, law_a, law_b, kelvin_a,
           kelvin_b, inv_dt, spring_gap, spring_q, spring_fv, spring_wv):
    """The viscous springs of group g in order: the force F = f_n n + f_s t
    on body a at the midpoint of the two material points, −F on body b."""
    s0 = group_ptr[g]
    s1 = group_ptr[g + 1]
    if s1 == s0:
        return
    ground = body_support.shape[0] - 1
    cur = np.uint64(spring_bodies[s0, 0])
    w0 = w1 = w2 = 0.0
    check = spring_state.shape[0] > 0
    branches = law_g.shape[1] > 0
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
        # the face normal turned by the mid rotation (plane.py), unit here
        u0 = ca + cb
        u1 = sa + sb
        inv = 1.0 / math.sqrt(u0 * u0 + u1 * u1)
        n0x, n0y = face_n0[f, 0], face_n0[f, 1]
        nx = (u0 * n0x - u1 * n0y) * inv
        ny = (u1 * n0x + u0 * n0y) * inv
        area = spring_area[s]
        # local gap (n, t = e_z × n): δ_n = n·d, δ_t = t·d
        cn, wn = _component(s, 0, law, nx * d0 + ny * d1, face_k[f, 0] * area, td, inv_dt,
                            law_g, law_a, law_b, kelvin_a, kelvin_b, spring_gap, spring_q,
                            spring_fv)
        ct, wt = _component(s, 1, law, nx * d1 - ny * d0, face_k[f, 1] * area, td, inv_dt,
                            law_g, law_a, law_b, kelvin_a, kelvin_b, spring_gap, spring_q,
                            spring_fv)
        spring_wv[s] += wn + wt
        f0 = cn * nx - ct * ny
        f1 = cn * ny + ct * nx
        if a != cur:
            body_wrench[cur, 0] += w0
            body_wrench[cur, 1] += w1
            body_wrench[cur, 2] += w2
            cur = a
            w0 = w1 = w2 = 0.0
        # lever arms to the midpoint, as the plane spring pass
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
            spring_force[s, 0] += f0
            spring_force[s, 1] += f1
    body_wrench[cur, 0] += w0
    body_wrench[cur, 1] += w1
    body_wrench[cur, 2] += w2


@nb.njit(**JIT, **NOALIAS)
def _range(lo, hi, psprings, ps, visc, store):
    """Groups lo..hi in order, the group inlined (the fields into locals
    before the loop, physics/arrays.py)."""
    group_ptr = psprings.group_ptr
    spring_bodies = psprings.spring_bodies
    spring_arm_a = psprings.spring_arm_a
    spring_arm_b = psprings.spring_arm_b
    spring_slot = psprings.spring_slot
    face_n0 = psprings.face_n0
    face_k = psprings.face_k
    face_law = psprings.face_law
    spring_area = psprings.spring_area
    body_pos = ps.body_pos
    body_cs = ps.body_cs
    body_wrench = ps.body_wrench
    body_support = ps.body_support
    spring_force = ps.spring_force
    (law_dashpot, law_g, law_a, law_b, kelvin_a, kelvin_b, spring_state, spring_gap, spring_q,
     spring_fv, spring_wv, inv_dt) = visc
    for g in range(lo, hi):
        _group(g, group_ptr, spring_bodies, spring_arm_a, spring_arm_b, spring_slot, face_n0,
               face_k, face_law, spring_area, body_pos, body_cs, body_wrench, body_support,
               store, spring_force, spring_state, law_dashpot, law_g, law_a, law_b, kelvin_a,
               kelvin_b, inv_dt, spring_gap, spring_q, spring_fv, spring_wv)


@nb.njit(parallel=True, **JIT)
def _phase(lo, hi, psprings, ps, visc, store):
    """Groups lo..hi of one phase in parallel (they share no body)."""
    for g in nb.prange(lo, hi):
        _range(np.int64(g), np.int64(g) + 1, psprings, ps, visc, store)


@nb.njit(**JIT)
def plane_viscous_pass(psprings, ps, visc, store, parallel):
    """Add the viscous springs' wrenches (module docstring) to the bodies'
    accumulators after the plane spring pass has filled them (visc:
    arrays.ViscousSprings, its state advanced to the present positions;
    `store`: also add each spring's viscous force to ps.spring_force).
    `parallel` None: one thread in group order (the same sums)."""
    phase_ptr = psprings.phase_ptr
    if parallel is None:
        _range(np.int64(0), np.int64(phase_ptr[phase_ptr.shape[0] - 1]), psprings, ps, visc,
               store)
        return
    for ph in range(phase_ptr.shape[0] - 1):
        _phase(phase_ptr[ph], phase_ptr[ph + 1], psprings, ps, visc, store)
