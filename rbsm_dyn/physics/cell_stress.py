"""Cell stress: the Love–Weber average of the forces on each rigid cell.

    S_c = (1/V_c) Σ_{spring points p of c} l_p ⊗ f_p,     σ_c = ½ (S_c + S_cᵀ)   [Pa]

(Love, A Treatise on the Mathematical Theory of Elasticity, 4th ed., 1927,
the mean stress of a body from the forces on its surface; Weber 1966; for
an assembly of particles: Christoffersen, Mehrabadi & Nemat-Nasser,
J. Appl. Mech. 48 (1981) 339–344, and Bagi, "Stress and strain in granular
assemblies", Mech. Mater. 22 (1996) 165–177.)

* l_p = m_p − x_c: from the cell's centroid to the point m_p at which the
  spring's force acts (the midpoint of its two material points,
  physics/springs.py), in the current configuration, world axes;
* f_p: the force of the spring on c, world axes (state.spring_force is the
  force on body a; body b takes −f).  A support spring (b = the ground)
  counts for its cell a;
* V_c: the cell's volume (rigid: the reference volume is the current one).

**Surface loads** (loads on named surfaces) act on their faces, at each
face's area centroid x_f, not at the centroid: like a support spring they
count for their cell with the lever x_f − x_c (the reference one, as the
load's moment about the centroid is booked fixed, model/loads.py surface_load):
the `extra` term of cell_stress, built by the recorder
(solvers/output.py surface_load_levers).  A group load (at the
centroids, lever 0) adds nothing.

Tension is positive.  The antisymmetric part ½ (S − Sᵀ) is the net moment
of the springs about the centroid per unit volume (its axial vector is
(1/2V) Σ l × f): zero at equilibrium without applied moments (loads and
constraint reactions act at the centroid, where l = 0), not zero while a
cell spins up in a dynamic run.  σ_c keeps the symmetric part.

**Exact in the mean.**  Summing V_c S_c over the cells, the two ends of an
internal spring cancel except for their lever arms, and with each body's
equilibrium Σ_p f_p + F_c = 0 (F_c the loads and constraint forces at its
centroid):

    Σ_c V_c S_c = Σ_c x_c ⊗ F_c + Σ_supports m_p ⊗ f_p (+ Σ_faces (x_f − x_c) ⊗ F_f),

the virial of the external forces at their points of application, which
is V times the applied (boundary) average stress of the body (Bagi 1996;
Christoffersen et al. 1981).  It holds for any mesh, at equilibrium.

**Poisson correction** (physics/poisson.py).  Its auxiliary forces act on
the centroids: cell c's term pushes neighbour j with −p_c G_cj and c with
+p_c Σ_j G_cj (p_c = λ_c V_c χ_c θ_c).  Their virial, attributed to the
cell whose dilatation makes them, is the auxiliary stress

    σ_aux,c = (p_c / V_c) sym Σ_j (x_j − x_c) ⊗ G_cj   (= λ_c χ_c θ_c I at the
              reference, where Σ_j Δx_j ⊗ g_j = A_c A_c⁻¹ = I),

which is added to σ_c; with it the mean identity above holds for models
with the correction too.

Kernels: the spring gather runs in the spring schedule (partition.py): the
groups of one phase share no body, so they add into their bodies' rows in
parallel without atomics, and every cell gets its sum in one fixed order
whatever the thread count.  Output steps only: a run without the
`cell_stress` field never calls this module.
"""
import numba as nb
import numpy as np

from .springs import SERIAL_SPRINGS, material_points

JIT = dict(cache=True, nogil=True, fastmath={"contract"}, error_model="numpy")


@nb.njit(inline="always", **JIT)
def _gather_group(g, group_ptr, spring_bodies, spring_arm_a, spring_arm_b, spring_force,
                  body_pos, body_rot, out):
    """Add l ⊗ f of the springs of group g to their cells' rows of out
    (N+1, 9) [N m], row-major (l_i f_j at 3 i + j)."""
    ground = np.uint64(out.shape[0] - 1)
    for s in range(np.uint64(group_ptr[g]), np.uint64(group_ptr[g + 1])):
        # body ids are never negative: unsigned skips Numba's wraparound code
        a = np.uint64(spring_bodies[s, 0])
        b = np.uint64(spring_bodies[s, 1])
        d0, d1, d2, la0, la1, la2, lb0, lb1, lb2 = material_points(
            s, a, b, spring_arm_a, spring_arm_b, body_pos, body_rot)
        f0, f1, f2 = spring_force[s, 0], spring_force[s, 1], spring_force[s, 2]
        out[a, 0] += la0 * f0
        out[a, 1] += la0 * f1
        out[a, 2] += la0 * f2
        out[a, 3] += la1 * f0
        out[a, 4] += la1 * f1
        out[a, 5] += la1 * f2
        out[a, 6] += la2 * f0
        out[a, 7] += la2 * f1
        out[a, 8] += la2 * f2
        if b != ground:             # body b takes −f at the same point
            out[b, 0] -= lb0 * f0
            out[b, 1] -= lb0 * f1
            out[b, 2] -= lb0 * f2
            out[b, 3] -= lb1 * f0
            out[b, 4] -= lb1 * f1
            out[b, 5] -= lb1 * f2
            out[b, 6] -= lb2 * f0
            out[b, 7] -= lb2 * f1
            out[b, 8] -= lb2 * f2


@nb.njit(parallel=True, **JIT)
def _gather_phase(lo, hi, group_ptr, spring_bodies, spring_arm_a, spring_arm_b, spring_force,
                  body_pos, body_rot, out):
    for g in nb.prange(lo, hi):
        _gather_group(g, group_ptr, spring_bodies, spring_arm_a, spring_arm_b, spring_force,
                      body_pos, body_rot, out)


@nb.njit(**JIT)
def _gather_serial(lo, hi, group_ptr, spring_bodies, spring_arm_a, spring_arm_b, spring_force,
                   body_pos, body_rot, out):
    for g in range(lo, hi):
        _gather_group(g, group_ptr, spring_bodies, spring_arm_a, spring_arm_b, spring_force,
                      body_pos, body_rot, out)


@nb.njit(parallel=True, **JIT)
def _finish(moment, body_volume, out):
    """σ_c = sym(S_c) = sym(moment_c)/V_c into out (N, 3, 3)."""
    for c in nb.prange(out.shape[0]):
        iv = 1.0 / body_volume[c]
        for i in range(3):
            for j in range(3):
                out[c, i, j] = 0.5 * iv * (moment[c, 3 * i + j] + moment[c, 3 * j + i])


def spring_moment(phase_ptr, group_ptr, spring_bodies, spring_arm_a, spring_arm_b,
                  spring_force, body_pos, body_rot):
    """M_c = Σ_{p of c} l_p ⊗ f_p (N+1, 9) [N m], row-major, not symmetrised
    (row N: the ground, left zero).  spring_force (S, 3) [N]: the force on
    body a of every spring at body_pos, body_rot (as the spring kernels
    write it at output steps)."""
    out = np.zeros((body_pos.shape[0], 9))
    n_groups = phase_ptr[-1]
    if spring_bodies.shape[0] < SERIAL_SPRINGS:
        _gather_serial(0, n_groups, group_ptr, spring_bodies, spring_arm_a, spring_arm_b,
                       spring_force, body_pos, body_rot, out)
        return out
    for ph in range(len(phase_ptr) - 1):
        _gather_phase(phase_ptr[ph], phase_ptr[ph + 1], group_ptr, spring_bodies,
                      spring_arm_a, spring_arm_b, spring_force, body_pos, body_rot, out)
    return out


@nb.njit(parallel=True, **JIT)
def _aux_moment(cell_slot_ptr, slot_cell, slot_g, p, body_pos, body_rot, out):
    """Add p_c Σ_j (x_j − x_c) ⊗ R_c g̃_j of every cell c to out (N+1, 9)."""
    for c in nb.prange(p.shape[0]):
        R = body_rot[c]
        s00 = s01 = s02 = s10 = s11 = s12 = s20 = s21 = s22 = 0.0
        for k in range(cell_slot_ptr[c], cell_slot_ptr[c + 1]):
            j = slot_cell[k]
            a0, a1, a2 = slot_g[k, 0], slot_g[k, 1], slot_g[k, 2]
            G0 = R[0, 0] * a0 + R[0, 1] * a1 + R[0, 2] * a2
            G1 = R[1, 0] * a0 + R[1, 1] * a1 + R[1, 2] * a2
            G2 = R[2, 0] * a0 + R[2, 1] * a1 + R[2, 2] * a2
            d0 = body_pos[j, 0] - body_pos[c, 0]
            d1 = body_pos[j, 1] - body_pos[c, 1]
            d2 = body_pos[j, 2] - body_pos[c, 2]
            s00 += d0 * G0
            s01 += d0 * G1
            s02 += d0 * G2
            s10 += d1 * G0
            s11 += d1 * G1
            s12 += d1 * G2
            s20 += d2 * G0
            s21 += d2 * G1
            s22 += d2 * G2
        pc = p[c]
        out[c, 0] += pc * s00
        out[c, 1] += pc * s01
        out[c, 2] += pc * s02
        out[c, 3] += pc * s10
        out[c, 4] += pc * s11
        out[c, 5] += pc * s12
        out[c, 6] += pc * s20
        out[c, 7] += pc * s21
        out[c, 8] += pc * s22


def cell_stress(model, state, out=None, extra=None):
    """σ_c (N, 3, 3) [Pa] of every cell now (module docstring): the
    symmetrised Love–Weber average of its spring forces, plus the auxiliary
    stress of the Poisson correction when the model has it.

    state.spring_force must hold the forces at state.body_pos/body_rot (the
    solvers' spring_pass at an output step writes them).  extra: (cells
    (K,), moments (K, 9) [N m]) added to those cells' Σ l ⊗ f (the surface
    loads' lever ⊗ force at their present amplitude), or None."""
    m = model
    moment = spring_moment(m.phase_ptr, m.group_ptr, m.spring_bodies, m.spring_arm_a,
                           m.spring_arm_b, state.spring_force, state.body_pos, state.body_rot)
    if m.poisson_on:
        from .poisson import cell_dilatation
        aux = m.poisson
        theta, chi = cell_dilatation(aux, state.body_pos, state.body_rot,
                                     state.spring_state, state.spring_dmg)
        _aux_moment(aux.cell_slot_ptr, aux.slot_cell, aux.slot_g, aux.cell_lv * chi * theta,
                    state.body_pos, state.body_rot, moment)
    if extra is not None:
        np.add.at(moment, extra[0], extra[1])
    if out is None:
        out = np.empty((m.n_bodies, 3, 3))
    _finish(moment, m.body_volume, out)
    return out
