"""Poisson correction: an auxiliary volumetric stress λ tr(ε_c) per cell.

An elastically homogeneous lattice (k_s = k_n = E0/h, α = 1) reproduces a
uniform strain (almost) exactly with Lamé constants μ = E0/2, λ = 0
(VERIFICATION.md "General": ν = (1 − α)/(4 + α) = 0), so E0 = 2μ = E/(1+ν)
gives the shear modulus and the missing volumetric stiffness λ tr(ε) I is
added per cell (the auxiliary stress of Asahina, Aoyagi, Kim, Birkholzer &
Bolander, Computers and Geotechnics 81 (2017) 195–206; Eliáš, IJSS 2017 and
2020 adds the same kind of tensorial stress to a discrete model).  Here it
is derived from a potential, so that the stiffness stays symmetric, the
energy is strain energy and the forces conserve momentum:

    U_aux = Σ_c ½ λ_c V_c χ_c θ_c²,
    θ_c = Σ_j [(R_c g̃_j) · (x_j − x_c) − g_j · (x_j⁰ − x_c⁰)]    (j: c's links)

θ_c is the trace of the least-squares displacement gradient of cell c from
its linked neighbours' centroids: G_c = Σ_j w_j Δu_j Δx_jᵀ A_c⁺,
A_c = Σ_j w_j Δx_j Δx_jᵀ, w_j = A_f/|Δx_j|² (face area over squared
distance), so tr G_c = Σ_j g_j · Δu_j with g_j = w_j A_c⁺ Δx_j.  For an
affine displacement u = ε x it gives θ_c = tr(P_c ε), P_c = A_c⁺A_c the
projector on the directions the fit resolves (below): tr ε exactly in
every cell that resolves all three (in a bulk Voronoi mesh all interior
cells and most surface ones).  Its small-strain form does not see a rigid
rotation (tr(P W) = 0 for P symmetric, W antisymmetric).  For
finite rotations g_j is carried by the cell's rotation increment
(g̃_j = R0_cᵀ g_j is stored in the principal frame, R_c g̃_j = R_Δc g_j), so
a rigid motion of the whole neighbourhood gives θ_c = 0 exactly, at any
rotation size.

Links (build_poisson): cell c's fit uses the neighbours j of the same
material joined by a face none of whose spring points is broken at the
start.  A cut (`cuts`, a pre-broken face) is a crack: the displacement
jumps across it, so a fit across it would read the opening as strain
(a rigid separation of the two flanks would be loaded).  A face between two
materials is bonded, but the strain jumps across it (displacement and
traction are continuous, strain is not): a fit across it mixes the two
materials' strains, and a steel cell's λ would then act on a soft
neighbour's translations (Kalthoff–Winkler's slot, 10⁶ times softer than
steel, would carry volumetric stress of steel's size).  The one-sided fit
from c's own material is still exact for an affine field in it.  (Faces
that break during a run stay links: dropping them would change θ_c
discontinuously; χ_c below handles them.)

Unresolved directions: the fit cannot see a strain along a direction e in
which the links barely spread (A_c's eigenvalue μ_e small against its
largest): all neighbours of a cell of a slab one cell thick lie nearly in
its plane.  A plain pseudo-inverse then divides by μ_e: gains |g_j| ~
1/μ_e, a spurious ε_ee built from small out-of-plane offsets of the
centroids, and a stiffness ~1/μ_e that shrank the stable step of such a
slab about 9 times (Kalthoff–Winkler, 2 mm cells: 9.3e-9 s against 8.3e-8 s
at ν = 0); it also let ε_ee cancel the in-plane dilatation, so the slab's
in-plane ν came out 0.07 instead of 0.3.  So A_c⁺ is the truncated
pseudo-inverse (the truncated SVD of Hansen, Rank-Deficient and Discrete
Ill-Posed Problems, SIAM 1998): the eigen-directions with μ_e ≤
RCOND μ_max get no strain from the fit, which bounds the gains by
tr A_c⁺ ≤ (2 + 1/RCOND)/μ_max (3/μ_max for an isotropic stencil).  A
direction without links across it is bounded by free surface (a slab's
faces, a body's surface, a cut's flanks), so its normal stress vanishes
(an approximation only where the missing links are another material's):
with k such directions the cell's λ is condensed to λ_k = 2μλ/(2μ + kλ)
(condensed_lambda; k = 1 is plane stress), μ = α E0/2 the lattice's shear
modulus.  Dropping the direction without condensing would give the slab
plane-strain stiffness (in-plane ν → ν/(1 − ν)).  RCOND = 0.2: below the
smallest ratio μ_min/μ_max of the interior cells of bulk Voronoi meshes
(0.27–0.31 on unit cubes of 729–8000 cells, seeds 1, 2, 11: no interior
cell is touched; 1–5 % of the cells, all on the surface, are, and the
measured E/E and ν of tests/test_poisson.py move by at most 0.002); on a
one cell thick slab (ν = 0.3, 2 mm cells, 900 cells, seeds 1 and 2) the
in-plane ν is 0.21–0.22, 0.26, 0.27–0.28, 0.28 at RCOND = 0.05, 0.1,
0.2, 0.3 (converged from 0.2 on; in-plane E/E 1.05, the slab lattice's
own 1.06 at ν = 0), and 0.39–0.40 at RCOND = 0.2 without the
condensation.  The stable step (model/stable_step.py scaled_row_sums) bounds K_aux
from the same slot_gw and cell_lv as the kernel uses, so it follows the
truncated fit and stays a bound (Kalthoff–Winkler: 9.29e-8 s estimated,
1.275e-7 s exact; 8.30e-8 and 1.136e-7 s at ν = 0).

Forces (−∂U/∂x, −∂U/∂φ; p_c = λ_c V_c χ_c θ_c [N m], G_cj = R_c g̃_j [1/m]):

    on neighbour j of c:   −p_c G_cj
    on c:                  +p_c Σ_j G_cj,   torque −p_c Σ_j G_cj × (x_j − x_c)

Linear momentum: the forces of one cell's term sum to zero.  Angular
momentum: Σ_j (x_j − x_c) × (−p_c G_cj) + torque = 0 term by term.  So both
are conserved to round-off; U is invariant under rigid motion (Noether).
The forces act on the centroids (no lever arms); the small-strain tangent
at the reference is λ_c V_c b_c b_cᵀ on the translations only (the
rotation derivative Σ_j g_j × Δx_j⁰ = 0 because A_c⁺ A_c is symmetric).

Damage (inelastic models): χ_c = min over the spring points of c's links
of (1 − D), and 0 as soon as one of them is broken (spring_state ≥ 2).
A cell next to a damaged link therefore carries a proportionally smaller
auxiliary stress, and none at all once a face is broken: no auxiliary
tension crosses a crack.  Why per cell and not per face: scaling one face's
share of θ_c by (1 − D) makes U_aux at fixed positions rise when that
face's share has the opposite sign of θ_c, i.e. damage would create energy;
with χ_c a non-increasing function of time (damage never heals, a broken
spring stays broken) and θ_c independent of damage, U_aux at fixed
positions can only fall when damage grows.  That fall, ½ λ_c V_c Δχ_c θ_c²,
is dissipated with the crack and booked in the `fracture` observable
(cell_wf, _book_fall).  Unbooked, it was a quarter of the fracture energy
of a Voronoi bar broken in tension at ν = 0.3 (the balance lost 0.25 of
the booked fracture energy; 0.003 on blocks, where λ_c barely works) and
1.5–3 % of the work in Kalthoff–Winkler.  Yield
(plastic springs) leaves the auxiliary stress elastic: the volumetric
response stays elastic, as in J2 plasticity.

Step (physics/integrate.py run_dynamic, physics/relax.py run_relax): after
the spring pass, before the body pass, two parallel loops (no atomics; the
same sums in the same order for any thread count):

    1. per cell c: G_cj (stored per slot), p_c, Σ_j G_cj, Σ_j G_cj × Δx_cj;
    2. per body i: force p_i Σ_k G_ik − Σ_k p_j(k) G_j(k),rev(k),
       torque −p_i Σ_k G_ik × Δx_ik.

Arrays (PoissonArrays, built once by build_poisson; n_slots = 2 × links):
  cell_slot_ptr (N+1,) int32: slots of cell c are cell_slot_ptr[c]:cell_slot_ptr[c+1];
  slot_cell (n_slots,) int32 neighbour j; slot_rev (n_slots,) int32 the
  slot (j → c); slot_g (n_slots, 3) [1/m] g̃ in c's principal frame;
  slot_gw (n_slots, 3) [1/m] g in world axes (reference); cell_c0 (N,)
  Σ_j g_j · Δx_j⁰ (= tr P_c, the number of resolved directions);
  slot_s0, slot_s1 (n_slots,) int32 the face's spring points;
  cell_lv (N,) [J] λ_c V_c (λ_c condensed: condensed_lambda).
"""
from collections import namedtuple

import numba as nb
import numpy as np
import scipy.sparse as sp

from .arrays import PoissonSlots, flag
from .laws import BROKEN

JIT = dict(cache=True, nogil=True, fastmath={"contract"}, error_model="numpy")
IDX = np.int32

PoissonArrays = namedtuple("PoissonArrays", "cell_slot_ptr slot_cell slot_rev slot_g slot_gw "
                                            "cell_c0 slot_s0 slot_s1 cell_lv")

# relative eigenvalue cutoff of the least-squares fit (build_poisson)
RCOND = 0.2


def empty_poisson(n_bodies):
    """The arrays of a model without the correction (length 0: nothing to pay)."""
    z = np.zeros(0, dtype=IDX)
    return PoissonArrays(np.zeros(1, dtype=IDX), z, z, np.zeros((0, 3)), np.zeros((0, 3)),
                         np.zeros(0), z, z, np.zeros(0))


def build_poisson(face_cells, face_area, cell_centroid, cell_volume, cell_lambda, body_rot0,
                  spring_face, cell_shear, cell_material=None, spring_state0=None,
                  rcond=RCOND):
    """PoissonArrays of a mesh (all NumPy, no loop over cells or faces).

    face_cells (F, 2), face_area (F,) [m²]: internal faces; cell_centroid
    (N, 3) [m]; cell_volume (N,) [m³]; cell_lambda (N,) [Pa] auxiliary Lamé
    constant per cell; body_rot0 (N, 3, 3) principal axes (columns);
    spring_face (S,) face of every spring point (< 0: support), in the
    model's spring order: the points of one face must be consecutive;
    cell_shear (N,) [Pa] the lattice's shear modulus μ (α E0/2), for the
    condensation of unresolved directions; cell_material (N,) int: a face
    between two materials is no link of the fit (None: one material);
    spring_state0 (S,) int8 initial spring states: a face with a spring
    point broken at the start (a cut) is no link either (None: all
    intact); rcond: the relative eigenvalue cutoff of the fit (RCOND)."""
    n = len(cell_volume)
    F = len(face_cells)
    fa = np.asarray(face_cells[:, 0], dtype=np.int64)
    fb = np.asarray(face_cells[:, 1], dtype=np.int64)
    # spring points of each face (consecutive in the model's order)
    sf = np.asarray(spring_face)
    internal = np.nonzero(sf >= 0)[0]
    s0 = np.full(F, len(sf), dtype=np.int64)
    s1 = np.zeros(F, dtype=np.int64)
    np.minimum.at(s0, sf[internal], internal)
    np.maximum.at(s1, sf[internal], internal + 1)
    count = np.bincount(sf[internal], minlength=F)
    if np.any(s1 - s0 != count):
        raise ValueError("the spring points of a face are not consecutive")
    # the links of the fit: faces inside one material, not cut
    link = np.ones(F, dtype=bool)
    if cell_material is not None:
        mat = np.asarray(cell_material)
        link &= mat[fa] == mat[fb]
    if spring_state0 is not None:
        cut = np.asarray(spring_state0)[internal] >= BROKEN
        link &= np.bincount(sf[internal], cut, minlength=F) == 0
    keep = np.nonzero(link)[0]
    c = np.concatenate([fa[keep], fb[keep]])
    j = np.concatenate([fb[keep], fa[keep]])
    face = np.concatenate([keep, keep])
    order = np.lexsort((j, c))
    c, j, face = c[order], j[order], face[order]
    ptr = np.concatenate([[0], np.cumsum(np.bincount(c, minlength=n))]).astype(IDX)
    key = c * n + j
    rev = np.searchsorted(key, j * n + c).astype(IDX)
    # least-squares gradient from the neighbours' centroids (the weighted
    # least-squares reconstruction of finite-volume codes, e.g. Blazek,
    # Computational Fluid Dynamics, §5.3.3): G = Σ w Δu Δxᵀ A⁻¹, weight w = A_f/|Δx|²
    dx = cell_centroid[j] - cell_centroid[c]
    w = face_area[face] / np.einsum("ki,ki->k", dx, dx)
    # (per component: no (n_slots, 3, 3) temporaries on large models)
    A = np.empty((n, 3, 3))
    for p in range(3):
        for q in range(p, 3):
            A[:, p, q] = A[:, q, p] = np.bincount(c, w * dx[:, p] * dx[:, q], minlength=n)
    Ainv, rank = _truncated_inverse(A, rcond)
    g = np.empty_like(dx)
    for p in range(3):
        g[:, p] = w * sum(Ainv[c, p, q] * dx[:, q] for q in range(3))
    # Σ_j g_j · Δx_j⁰ per cell (= tr(A⁺A): the rank of the fit, 3 in the bulk)
    cell_c0 = np.bincount(c, np.einsum("ki,ki->k", g, dx), minlength=n)
    g_body = np.empty_like(g)                                   # R0ᵀ g
    for p in range(3):
        g_body[:, p] = sum(body_rot0[c, q, p] * g[:, q] for q in range(3))
    lam = condensed_lambda(np.asarray(cell_lambda, float), np.asarray(cell_shear, float),
                           3 - rank)
    return PoissonArrays(ptr, j.astype(IDX), rev, np.ascontiguousarray(g_body),
                         np.ascontiguousarray(g), cell_c0, s0[face].astype(IDX),
                         s1[face].astype(IDX), np.asarray(lam * cell_volume, float))


def _truncated_inverse(A, rcond):
    """A⁺ (N, 3, 3) of symmetric positive semi-definite A (N, 3, 3) keeping
    only the eigen-directions with eigenvalue > rcond × the cell's largest,
    and the number kept (N,) int (0 for a cell without links)."""
    mu, vec = np.linalg.eigh(A)
    top = mu[:, -1:]
    kept = (mu > rcond * top) & (top > 0)
    inv = np.where(kept, 1.0 / np.where(kept, mu, 1.0), 0.0)
    return np.einsum("npk,nk,nqk->npq", vec, inv, vec), kept.sum(axis=1)


def condensed_lambda(lam, mu, k):
    """The auxiliary λ of a cell whose fit resolves 3 − k directions: the
    k unresolved ones carry no normal stress (σ_ee = 0, plane stress for
    k = 1, uniaxial stress for k = 2), so condensing them out of
    σ = 2μ ε + λ tr(ε) I leaves 2μ ε + λ_k θ I on the resolved subspace,

        λ_k = 2μλ / (2μ + kλ)        (k = 0: λ; k = 1: the plane-stress λ*)

    (σ_ee = 2μ ε_ee + λ tr ε = 0 gives ε_ee = −λ tr ε/(2μ) for each
    unresolved e, so tr ε = 2μθ/(2μ + kλ); k = 1 is the plane-stress
    λ* = 2μλ/(λ + 2μ) of the elasticity texts, e.g. Timoshenko & Goodier,
    Theory of Elasticity, on plane stress).
    lam, mu (N,) [Pa], k (N,) int."""
    return np.where(lam > 0, 2.0 * mu * lam / np.maximum(2.0 * mu + k * lam, 1e-300), 0.0)


# --------------------------------------------------------------------------
# kernels


@nb.njit(inline="always", **JIT)
def _cell_pressure(c, damaged, cell_slot_ptr, slot_cell, slot_g, cell_c0, slot_s0, slot_s1,
                   spring_state, spring_dmg, body_pos, body_rot, aux_g, aux_p, sums):
    """θ_c and χ_c of cell c.  Stores its slots' G = R_c g̃ in aux_g and,
    if `sums`, Σ_j G_cj in aux_p[1:4, c] and Σ_j G_cj × (x_j − x_c) in
    aux_p[4:7, c] (the body pass then needs no positions)."""
    # indices are never negative: unsigned skips Numba's wraparound code
    # (physics/springs.py)
    c = np.uint64(c)
    R = body_rot[c]
    xc0, xc1, xc2 = body_pos[c, 0], body_pos[c, 1], body_pos[c, 2]
    th = 0.0
    chi = 1.0
    s0 = s1 = s2 = m0 = m1 = m2 = 0.0
    for k in range(np.uint64(cell_slot_ptr[c]), np.uint64(cell_slot_ptr[c + np.uint64(1)])):
        j = np.uint64(slot_cell[k])
        a0, a1, a2 = slot_g[k, 0], slot_g[k, 1], slot_g[k, 2]
        G0 = R[0, 0] * a0 + R[0, 1] * a1 + R[0, 2] * a2
        G1 = R[1, 0] * a0 + R[1, 1] * a1 + R[1, 2] * a2
        G2 = R[2, 0] * a0 + R[2, 1] * a1 + R[2, 2] * a2
        aux_g[k, 0] = G0
        aux_g[k, 1] = G1
        aux_g[k, 2] = G2
        d0 = body_pos[j, 0] - xc0
        d1 = body_pos[j, 1] - xc1
        d2 = body_pos[j, 2] - xc2
        th += G0 * d0 + G1 * d1 + G2 * d2
        s0 += G0
        s1 += G1
        s2 += G2
        m0 += G1 * d2 - G2 * d1
        m1 += G2 * d0 - G0 * d2
        m2 += G0 * d1 - G1 * d0
        if damaged:
            for s in range(slot_s0[k], slot_s1[k]):
                x = 0.0 if spring_state[s] >= 2 else 1.0 - spring_dmg[s]
                chi = min(chi, x)
    if sums:
        aux_p[1, c] = s0
        aux_p[2, c] = s1
        aux_p[3, c] = s2
        aux_p[4, c] = m0
        aux_p[5, c] = m1
        aux_p[6, c] = m2
    return th - cell_c0[c], chi


@nb.njit(inline="always", **JIT)
def _body_wrench(i, cell_slot_ptr, slot_cell, slot_rev, aux_g, aux_p, body_wrench):
    """Add the auxiliary force and torque on body i: its own term
    (p_i Σ G_ik, −p_i Σ G_ik × Δx_ik, summed by _cell_pressure) and its
    neighbours' terms (−p_j G_j,rev(k), in slot order)."""
    i = np.uint64(i)
    f0 = f1 = f2 = 0.0
    for k in range(np.uint64(cell_slot_ptr[i]), np.uint64(cell_slot_ptr[i + np.uint64(1)])):
        r = np.uint64(slot_rev[k])
        pj = aux_p[0, np.uint64(slot_cell[k])]
        f0 += pj * aux_g[r, 0]
        f1 += pj * aux_g[r, 1]
        f2 += pj * aux_g[r, 2]
    p = aux_p[0, i]
    body_wrench[i, 0] += p * aux_p[1, i] - f0
    body_wrench[i, 1] += p * aux_p[2, i] - f1
    body_wrench[i, 2] += p * aux_p[3, i] - f2
    body_wrench[i, 3] -= p * aux_p[4, i]
    body_wrench[i, 4] -= p * aux_p[5, i]
    body_wrench[i, 5] -= p * aux_p[6, i]


@nb.njit(inline="always", **JIT)
def _book_fall(c, chi, th, cell_lv, cell_chi, cell_wf):
    """The energy ½ λ_c V_c (χ_old − χ_c) θ_c² that the fall of χ_c since
    the last step released (module docstring: damage and the auxiliary
    stress), booked in cell_wf, at this step's θ_c as the springs' damage
    is at their gap (physics/inelastic.py, Y ΔD)."""
    old = cell_chi[c]
    if chi < old:
        cell_wf[c] += 0.5 * cell_lv[c] * (old - chi) * th * th
        cell_chi[c] = chi


@nb.njit(parallel=True, **JIT)
def _pressures_parallel(aux, bs, spring_state, spring_dmg, cell_chi, cell_wf, damaged):
    # the fields into locals before the prange (physics/arrays.py)
    cell_slot_ptr = aux.cell_slot_ptr
    slot_cell = aux.slot_cell
    slot_g = aux.slot_g
    cell_c0 = aux.cell_c0
    slot_s0 = aux.slot_s0
    slot_s1 = aux.slot_s1
    cell_lv = aux.cell_lv
    aux_g = aux.aux_g
    aux_p = aux.aux_p
    body_pos = bs.body_pos
    body_rot = bs.body_rot
    for c in nb.prange(cell_lv.shape[0]):
        th, chi = _cell_pressure(c, damaged, cell_slot_ptr, slot_cell, slot_g, cell_c0,
                                 slot_s0, slot_s1, spring_state, spring_dmg,
                                 body_pos, body_rot, aux_g, aux_p, True)
        if damaged:
            _book_fall(c, chi, th, cell_lv, cell_chi, cell_wf)
        aux_p[0, c] = cell_lv[c] * chi * th


@nb.njit(parallel=True, **JIT)
def _wrenches_parallel(aux, bs):
    cell_slot_ptr = aux.cell_slot_ptr
    slot_cell = aux.slot_cell
    slot_rev = aux.slot_rev
    aux_g = aux.aux_g
    aux_p = aux.aux_p
    body_wrench = bs.body_wrench
    for i in nb.prange(aux_p.shape[1]):
        _body_wrench(i, cell_slot_ptr, slot_cell, slot_rev, aux_g, aux_p, body_wrench)


@nb.njit(**JIT)
def _poisson_serial(aux, bs, spring_state, spring_dmg, cell_chi, cell_wf, damaged):
    cell_slot_ptr = aux.cell_slot_ptr
    slot_cell = aux.slot_cell
    slot_rev = aux.slot_rev
    slot_g = aux.slot_g
    cell_c0 = aux.cell_c0
    slot_s0 = aux.slot_s0
    slot_s1 = aux.slot_s1
    cell_lv = aux.cell_lv
    aux_g = aux.aux_g
    aux_p = aux.aux_p
    body_pos = bs.body_pos
    body_rot = bs.body_rot
    body_wrench = bs.body_wrench
    n = cell_lv.shape[0]
    for c in range(n):
        th, chi = _cell_pressure(c, damaged, cell_slot_ptr, slot_cell, slot_g, cell_c0,
                                 slot_s0, slot_s1, spring_state, spring_dmg,
                                 body_pos, body_rot, aux_g, aux_p, True)
        if damaged:
            _book_fall(c, chi, th, cell_lv, cell_chi, cell_wf)
        aux_p[0, c] = cell_lv[c] * chi * th
    for i in range(n):
        _body_wrench(i, cell_slot_ptr, slot_cell, slot_rev, aux_g, aux_p, body_wrench)


@nb.njit(**JIT)
def poisson_pass(aux, bs, hist, parallel):
    """Add the auxiliary-stress wrenches (module docstring) to the bodies'
    wrenches (aux: arrays.PoissonSlots, bs: arrays.BodyState).  With the
    spring history `hist` (inelastic models; None otherwise) each cell's
    term is scaled by χ_c from its springs' state and damage, and the
    energy a fall of χ_c releases is booked in hist.cell_wf.  `parallel`
    None: one thread (small models; the same sums, solvers/passes.py).
    Scratch: aux_g (n_slots, 3) [1/m], aux_p (7, N): p_c [N m], Σ_j G_cj
    [1/m], Σ_j G_cj × Δx_cj [1]."""
    if hist is None:
        # nothing read: the loops skip spring_state, spring_dmg when not damaged
        no = flag(False)
        if parallel is None:
            _poisson_serial(aux, bs, aux.slot_s0, aux.cell_lv, aux.cell_lv, aux.cell_lv, no)
        else:
            _pressures_parallel(aux, bs, aux.slot_s0, aux.cell_lv, aux.cell_lv, aux.cell_lv,
                                no)
            _wrenches_parallel(aux, bs)
        return
    yes = flag(True)
    if parallel is None:
        _poisson_serial(aux, bs, hist.spring_state, hist.spring_dmg, hist.cell_chi,
                        hist.cell_wf, yes)
    else:
        _pressures_parallel(aux, bs, hist.spring_state, hist.spring_dmg, hist.cell_chi,
                            hist.cell_wf, yes)
        _wrenches_parallel(aux, bs)


@nb.njit(parallel=True, **JIT)
def _theta_chi(pa, body_pos, body_rot, spring_state, spring_dmg, damaged, scratch, out_theta,
               out_chi):
    """θ_c, χ_c of every cell (pa: PoissonArrays)."""
    cell_slot_ptr = pa.cell_slot_ptr
    slot_cell = pa.slot_cell
    slot_g = pa.slot_g
    cell_c0 = pa.cell_c0
    slot_s0 = pa.slot_s0
    slot_s1 = pa.slot_s1
    for c in nb.prange(out_theta.shape[0]):
        th, chi = _cell_pressure(c, damaged, cell_slot_ptr, slot_cell, slot_g, cell_c0,
                                 slot_s0, slot_s1, spring_state, spring_dmg,
                                 body_pos, body_rot, scratch, scratch, False)
        out_theta[c] = th
        out_chi[c] = chi


def cell_dilatation(aux, body_pos, body_rot, spring_state=None, spring_dmg=None):
    """θ_c (N,) and χ_c (N,) now (output steps, tests)."""
    n = len(aux.cell_lv)
    damaged = spring_state is not None and len(spring_state) > 0
    st = spring_state if damaged else np.zeros(0, dtype=np.int8)
    dm = spring_dmg if damaged else np.zeros(0)
    theta, chi = np.empty(n), np.empty(n)
    _theta_chi(aux, body_pos, body_rot, st, dm, damaged, np.empty((len(aux.slot_cell), 3)),
               theta, chi)
    return theta, chi


def poisson_energy(aux, body_pos, body_rot, spring_state=None, spring_dmg=None):
    """U_aux = Σ_c ½ λ_c V_c χ_c θ_c² [J] (output steps)."""
    if len(aux.cell_lv) == 0:
        return 0.0
    theta, chi = cell_dilatation(aux, body_pos, body_rot, spring_state, spring_dmg)
    return 0.5 * float(np.sum(aux.cell_lv * chi * theta * theta))


# --------------------------------------------------------------------------
# small-strain matrices (stiffness.py, the stable-step bound, relaxation masses)


def poisson_B(aux, n_bodies):
    """B (N × 6N, CSR): θ = B U to first order, U the 6-per-body DOFs of
    stiffness.py (row c: g_j on the translations of each neighbour j,
    −Σ_j g_j on c's own)."""
    ptr = aux.cell_slot_ptr.astype(np.int64)
    cnt = np.diff(ptr)
    c = np.repeat(np.arange(n_bodies), cnt)
    g = aux.slot_gw
    own = np.zeros((n_bodies, 3))
    np.add.at(own, c, g)
    rows = np.concatenate([np.repeat(c, 3), np.repeat(np.arange(n_bodies), 3)])
    cols = np.concatenate([(6 * aux.slot_cell.astype(np.int64))[:, None] + np.arange(3),
                           (6 * np.arange(n_bodies))[:, None] + np.arange(3)]).ravel()
    vals = np.concatenate([g.ravel(), -own.ravel()])
    return sp.csr_matrix((vals, (rows, cols)), shape=(n_bodies, 6 * n_bodies))


def poisson_stiffness(aux, n_bodies):
    """K_aux = Bᵀ diag(λ V) B (6N × 6N, CSR) [N/m]: the Hessian of U_aux at
    the reference (χ = 1)."""
    B = poisson_B(aux, n_bodies)
    return (B.T @ sp.diags(aux.cell_lv) @ B).tocsr()


def poisson_abs_product(aux, n_bodies, x):
    """|B|ᵀ diag(λ V) |B| x for x (N, 6) -> (N, 6): bounds the row sums of
    |K_aux| entrywise (|Σ_c w b bᵀ| ≤ Σ_c w |b||b|ᵀ), for Gershgorin."""
    B = abs(poisson_B(aux, n_bodies))
    return (B.T @ (aux.cell_lv * (B @ x.reshape(-1)))).reshape(n_bodies, 6)


def poisson_slots(pa, aux_g, aux_p):
    """The pass's container (arrays.PoissonSlots) of a model's PoissonArrays
    and a state's scratch."""
    return PoissonSlots(pa.cell_slot_ptr, pa.slot_cell, pa.slot_rev, pa.slot_g, pa.cell_c0,
                        pa.slot_s0, pa.slot_s1, pa.cell_lv, aux_g, aux_p)
