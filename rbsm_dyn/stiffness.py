"""Small-strain global stiffness and mass of a Model; linear static solve.

Kawai's assembled stiffness (Kawai 1978, eq. 8b), linearised about the
reference state (`body_pos0`, `body_quat0`).  Unknowns: 6 per body,

    U[i] = (ux, uy, uz, θx, θy, θz)    [m, rad], world axes, about the centroid,

flattened body-major: DOF 6 i + c.  The ground (body `n_bodies`) has no DOFs.

API (N bodies, S spring points, n = 6 N):

    stiffness_matrix(model) -> K          scipy.sparse CSR (n, n) [N/m, N, N m]
    mass_matrix(model) -> M               scipy.sparse CSR (n, n) [kg, kg m²]
    model_load(model) -> F (N, 6)         applied forces, moments [N, N m]
    solve_linear(model, load=None, *, K=None, kind=None, value=None)
        -> (U (N, 6), reaction (N, 6))    K U = F with Dirichlet DOFs removed
    rigid_modes(model) -> (6N, 6)         translations, rotations (null space
                                          of K for a model without supports)
    spring_forces(model, U) -> (S, 3)     linear force on body a [N], world
    uniaxial_moduli(model, axes=(0, 1, 2), core=0.25, stress=1.0, K=None,
                    interior=False)
        -> (E (len(axes),) [Pa], ν (len(axes),))   homogeneous uniaxial test

Kinematics (DESIGN.md §1, small rotation): spring s joins bodies a and b at
the material points p = x + R r (arms r = spring_arm_a/b in the principal
frames, R from body_quat0; ground frame = world).  Both points coincide at
rest, so the relative displacement at the spring point is

    d = (u_b + θ_b × r_b) − (u_a + θ_a × r_a),   r = p − x,

i.e. d = B_s U with B_s = [−I, [r_a]×, I, −[r_b]×] (3 × 12).  With the spring
frame F = R(spring_frame0[s]) (columns n, s, t) and the local stiffness
diag(spring_k[s]) [N/m] (stiffness per area × area),

    K_s = B_sᵀ C_s B_s,   C_s = F diag(k) Fᵀ.

The Numba kernel (physics/springs.py) turns the spring frame with the bodies
and applies the force at the midpoint of the two material points; both
effects are of second order at the unstressed reference, so K is the exact
tangent of the kernel there: K U = −(generalised spring force) to first
order (tested in tests/test_stiffness.py).
"""
import numpy as np
import scipy.sparse as sp
import scipy.sparse.linalg as spla

from .physics.integrate import DISPLACEMENT, FIXED, FREE, VELOCITY
from .physics.poisson import poisson_stiffness
from .physics.rotation import quat_matrix_np

__all__ = ["stiffness_matrix", "mass_matrix", "model_load", "solve_linear",
           "rigid_modes", "spring_forces", "uniaxial_moduli"]

_CHUNK = 65536      # spring points per assembly chunk (bounds memory: a few kB each)


def _skew(r):
    """[r]× (..., 3, 3): [r]× v = r × v."""
    z = np.zeros(r.shape[:-1])
    return np.stack([np.stack([z, -r[..., 2], r[..., 1]], -1),
                     np.stack([r[..., 2], z, -r[..., 0]], -1),
                     np.stack([-r[..., 1], r[..., 0], z], -1)], -2)


def _spring_geometry(model):
    """World arms r_a, r_b (S, 3) [m] and spring matrices C (S, 3, 3) [N/m]."""
    rot = quat_matrix_np(model.body_quat0)           # (N+1, 3, 3), ground = I
    sb = model.spring_bodies
    r_a = np.einsum("sij,sj->si", rot[sb[:, 0]], model.spring_arm_a)
    r_b = np.einsum("sij,sj->si", rot[sb[:, 1]], model.spring_arm_b)
    F = quat_matrix_np(model.spring_frame0)          # columns n, s, t
    C = np.einsum("sik,sk,sjk->sij", F, model.spring_k, F)   # F diag(k) Fᵀ
    return r_a, r_b, C


def _spring_B(r_a, r_b):
    """Blocks of B_s (Kawai 1978, eq. 8b): d = G_a U_a + G_b U_b, (S, 3, 6)."""
    eye = np.broadcast_to(np.eye(3), r_a.shape[:-1] + (3, 3))
    # u + θ × r = u − [r]× θ
    G_a = np.concatenate([-eye, _skew(r_a)], axis=-1)
    G_b = np.concatenate([eye, -_skew(r_b)], axis=-1)
    return G_a, G_b


def stiffness_matrix(model):
    """Global small-strain stiffness K (6N × 6N, CSR), K = Σ_s B_sᵀ C_s B_s
    (Kawai 1978, eq. 8b).  Rows/columns 6i..6i+2 are forces/translations
    [N, m], 6i+3..6i+5 moments/rotations [N m, rad] of body i (world axes,
    about its centroid).  Support springs (b = ground) add to body a only.
    With the Poisson correction, K also holds the auxiliary-stress term
    Bᵀ diag(λ V) B (physics/poisson.py: the Hessian of U_aux at the
    reference)."""
    n = model.n_bodies
    sb = model.spring_bodies.astype(np.int64)
    r_a, r_b, C = _spring_geometry(model)
    idx6 = np.arange(6)
    K = sp.csr_matrix((6 * n, 6 * n))
    for lo in range(0, len(sb), _CHUNK):
        sl = slice(lo, lo + _CHUNK)
        G_a, G_b = _spring_B(r_a[sl], r_b[sl])
        CG_a = C[sl] @ G_a
        CG_b = C[sl] @ G_b
        a = sb[sl, 0]
        b = sb[sl, 1]
        ground = b >= n
        blocks = [(a, a, np.einsum("ski,skj->sij", G_a, CG_a), np.ones(len(a), bool))]
        inner = ~ground
        K_ab = np.einsum("ski,skj->sij", G_a, CG_b)
        blocks += [(a, b, K_ab, inner), (b, a, K_ab.transpose(0, 2, 1), inner),
                   (b, b, np.einsum("ski,skj->sij", G_b, CG_b), inner)]
        rows, cols, vals = [], [], []
        for i, j, blk, keep in blocks:
            i, j, blk = i[keep], j[keep], blk[keep]
            rows.append(np.broadcast_to((6 * i)[:, None, None] + idx6[None, :, None],
                                        blk.shape).ravel())
            cols.append(np.broadcast_to((6 * j)[:, None, None] + idx6[None, None, :],
                                        blk.shape).ravel())
            vals.append(blk.ravel())
        # summed chunk by chunk: memory stays at K plus one chunk's entries
        K = K + sp.coo_matrix((np.concatenate(vals), (np.concatenate(rows), np.concatenate(cols))),
                              shape=(6 * n, 6 * n)).tocsr()
    if model.poisson is not None and len(model.poisson.slot_cell):
        K = K + poisson_stiffness(model.poisson, n)
    K.sum_duplicates()
    return K


def mass_matrix(model):
    """Lumped (block-diagonal) mass M (6N × 6N, CSR): m I₃ for the
    translations [kg] and the world inertia R diag(I) Rᵀ [kg m²] about the
    centroid for the rotations (R from body_quat0)."""
    n = model.n_bodies
    J = world_inertia(model)
    blocks = np.zeros((n, 6, 6))
    blocks[:, [0, 1, 2], [0, 1, 2]] = model.body_mass[:, None]
    blocks[:, 3:, 3:] = J
    return sp.block_diag(list(blocks), format="csr") if n else sp.csr_matrix((0, 0))


def world_inertia(model):
    """(N, 3, 3) [kg m²] each body's inertia about its centroid in world
    axes, R diag(I) Rᵀ from its principal moments (R from body_quat0)."""
    R = quat_matrix_np(model.body_quat0[:model.n_bodies])
    return np.einsum("nik,nk,njk->nij", R, model.body_inertia, R)


def model_load(model):
    """Applied generalised load (N, 6) of a model: body_fext + m g, body_mext
    (full amplitude of any load history); follower loads at their reference
    direction R0·f (small strain: the load stiffness is left out)."""
    load = np.zeros((model.n_bodies, 6))
    load[:, :3] = model.body_fext + model.body_mass[:, None] * model.gravity[None, :]
    load[:, 3:] = model.body_mext
    if len(model.body_ffol):
        R0 = quat_matrix_np(model.body_quat0[:model.n_bodies])
        load[:, :3] += np.einsum("nij,nj->ni", R0, model.body_ffol)
        load[:, 3:] += np.einsum("nij,nj->ni", R0, model.body_mfol)
    return load


def solve_linear(model, load=None, *, K=None, kind=None, value=None):
    """Solve K U = F for the free DOFs (scipy.sparse.linalg.spsolve).

    load: (N, 6) or (N, 6, m) applied forces and moments [N, N m] (world,
      moments about the centroids); default `model_load(model)`.  A trailing
      axis of m columns solves m load cases with one matrix.
    K: the stiffness (default `stiffness_matrix(model)`).
    kind, value: (N, 6) DOF kinds and values (default model.dof_kind,
      model.dof_value): FIXED (1) components are held at 0, DISPLACEMENT
      (3) components at `value` (the full amplitude) [m, rad]; VELOCITY (2)
      has no static meaning and is refused (ValueError).
    Returns U (N, 6) [m, rad] and the reaction K U − F (N, 6) [N, N m],
    zero on the free DOFs (same trailing axis as `load`).
    Raises ValueError when a rigid-body motion of the whole model is left
    free by the supports and constrained DOFs (checked on the six rigid
    modes: K φ ≈ 0 with φ = 0 on every constrained DOF), or when SuperLU
    meets an exactly singular matrix.  Other near-mechanisms (e.g. k_s = 0
    on a block lattice) are not detected: check U."""
    n = model.n_bodies
    if K is None:
        K = stiffness_matrix(model)
    if load is None:
        load = model_load(model)
    kind = model.dof_kind if kind is None else np.asarray(kind)
    value = model.dof_value if value is None else np.asarray(value, float)
    if np.any(kind == VELOCITY):
        raise ValueError("a prescribed velocity has no meaning in a linear static solve")
    load = np.asarray(load, float)
    multi = load.ndim == 3
    F = load.reshape(6 * n, -1)
    kflat = kind.reshape(-1)
    free = kflat == FREE
    pres = ~free
    U = np.zeros_like(F)
    U[kflat == DISPLACEMENT] = value.reshape(-1)[kflat == DISPLACEMENT][:, None]
    U[kflat == FIXED] = 0.0
    K = sp.csr_matrix(K)
    if _free_rigid_motion(model, K, pres):
        raise ValueError("the stiffness is singular: a rigid-body motion is not restrained "
                         "(add supports or fixed DOFs)")
    Kff = K[free][:, free].tocsc()
    rhs = F[free] - K[free][:, pres] @ U[pres]
    if Kff.shape[0]:
        sol = np.asarray(spla.spsolve(Kff, rhs)).reshape(rhs.shape)
        if not np.all(np.isfinite(sol)):
            raise ValueError("the reduced stiffness is singular (a mechanism)")
        U[free] = sol
    reaction = K @ U - F
    reaction[free] = 0.0
    shape = (n, 6, F.shape[1]) if multi else (n, 6)
    return U.reshape(shape), reaction.reshape(shape)


def rigid_modes(model):
    """The six rigid-body modes (6N, 6): translations along x, y, z, then
    small rotations about x, y, z through the centroid c of the bodies,
    u_i = e × (x_i − c) / L, θ_i = e / L (L the bodies' extent, so that
    all columns are O(1))."""
    n = model.n_bodies
    x = model.body_pos0[:n]
    c = x.mean(axis=0)
    L = max(float(np.ptp(x, axis=0).max()) if n else 0.0, 1e-300)
    phi = np.zeros((n, 6, 6))
    for j in range(3):
        e = np.eye(3)[j]
        phi[:, j, j] = 1.0
        phi[:, :3, 3 + j] = np.cross(e, x - c) / L
        phi[:, 3 + j, 3 + j] = 1.0 / L
    return phi.reshape(6 * n, 6)


def _free_rigid_motion(model, K, pres):
    """True if some rigid mode vanishes on the constrained DOFs `pres` and
    is also (to round-off) in the null space of K (no support holds it)."""
    return free_rigid_modes(model, pres, K).shape[1] > 0


def free_rigid_modes(model, pres, K=None):
    """The rigid motions (6N, r) no constraint or support holds: the
    combinations of rigid_modes that vanish on the constrained DOFs `pres`
    and lie (to round-off) in the null space of K (the matrix; None: a
    rigid motion strains no spring between two bodies, so without support
    springs every such combination is free, else K is assembled).  r = 0
    for a supported model."""
    phi = rigid_modes(model)
    held = phi[pres]
    # vt (6, 6) of the held rows: the full U (rows × rows) is never needed
    # (a plane model holds 3 DOFs of every body: full_matrices took 43 s
    # and 2.9 GB for 6 300 cells); only fewer than 6 rows need the full vt
    _, sv, vt = np.linalg.svd(held, full_matrices=held.shape[0] < 6)
    rank = int(np.sum(sv > 1e-10 * max(1.0, sv.max(initial=0.0))))
    combos = vt[rank:].T                               # (6, 6 - rank)
    if combos.shape[1] == 0:
        return phi[:, :0]
    modes = phi @ combos
    if K is None:
        if not np.any(model.spring_bodies[:, 1] == model.n_bodies):
            return modes
        K = stiffness_matrix(model)
    scale = abs(K).sum(axis=1).max()
    # the null space of K on the span of the combinations (some may be
    # held by springs to the ground or support springs, others not)
    _, sv, v = np.linalg.svd(K @ modes, full_matrices=False)
    return modes @ v[sv <= 1e-9 * scale * np.linalg.norm(modes, axis=0).max()].T


def spring_forces(model, U):
    """Linear spring forces on body a (S, 3) [N], world frame: f = C_s B_s U
    (the kernel's F diag(k) Fᵀ d to first order; body b gets −f)."""
    n = model.n_bodies
    U = np.asarray(U, float).reshape(n, 6)
    Ug = np.vstack([U, np.zeros((1, 6))])            # ground: no motion
    r_a, r_b, C = _spring_geometry(model)
    sb = model.spring_bodies
    ua, ub = Ug[sb[:, 0]], Ug[sb[:, 1]]
    d = (ub[:, :3] + np.cross(ub[:, 3:], r_b)) - (ua[:, :3] + np.cross(ua[:, 3:], r_a))
    return np.einsum("sij,sj->si", C, d)


def uniaxial_moduli(model, axes=(0, 1, 2), core=0.25, stress=1.0, K=None, interior=False):
    """Effective Young's modulus and Poisson ratio of a box specimen under
    homogeneous uniaxial stress (docs/calibration.md), one value per axis.

    The model must be a box with no supports and no constraints (the test
    sets its own).  For each axis k a uniform traction ±σ e_k acts on the two
    faces normal to e_k (a force σ·A_f at each boundary face's area
    centroid, i.e. force and moment on its cell); the loads are
    self-equilibrated, so the rigid motion is removed by holding the six
    DOFs of the cell nearest the box centre (its reactions are round-off).
    By equilibrium the mean axial stress on every cross-section is σ.  The
    strain is the symmetric part of the volume-weighted least-squares fit
    u ≈ u0 + G x over the cells whose centroids lie in the central part of
    the specimen along e_k (a fraction `core` of the length trimmed at each
    end, away from the loaded boundary layers), all cells across the
    section; `interior`: the central part along every axis (the trimmed
    fraction `core` of each side, so also away from the free lateral
    surface: the bulk lattice's E and ν, issue 30):

        E = σ / ε_kk,   ν = −(ε_ii + ε_jj) / (2 ε_kk).

    stress: σ [Pa] (the result does not depend on it: linear).
    K: the stiffness (default `stiffness_matrix(model)`).
    A plane model (Model.plane) is tested in its plane: axes x and y, the
    strain fitted in x–y, ν = −ε_jj/ε_kk (the in-plane ν*; z, rx, ry held
    as the model holds them).
    Returns E (len(axes),) [Pa] and ν (len(axes),)."""
    plane = bool(getattr(model, "plane", ""))
    held = model.dof_kind.copy()
    if plane:
        held[:, 2:5] = FREE
        axes = tuple(k for k in axes if k < 2)
    if np.any(model.is_support) or np.any(held != FREE):
        raise ValueError("uniaxial_moduli needs a model without supports or constraints")
    mesh = model.mesh
    n = model.n_bodies
    x = model.body_pos0[:n]
    box_lo, box_hi = np.asarray(mesh.box, float)
    centre = 0.5 * (box_lo + box_hi)
    load = np.zeros((n, 6, len(axes)))
    for col, k in enumerate(axes):
        for side, sgn in ((2 * k, -1.0), (2 * k + 1, 1.0)):
            sel = mesh.bface_side == side
            cell = mesh.bface_cell[sel]
            f = np.zeros((sel.sum(), 3))
            f[:, k] = sgn * stress * mesh.bface_area[sel]
            m = np.cross(mesh.bface_centroid[sel] - x[cell], f)
            np.add.at(load[:, :3, col], cell, f)
            np.add.at(load[:, 3:, col], cell, m)
    pin = int(np.argmin(np.linalg.norm(x - centre, axis=1)))
    kind = np.zeros((n, 6), dtype=np.int8)
    kind[pin] = FIXED
    if plane:
        kind[:, 2:5] = FIXED
    U, _ = solve_linear(model, load, K=K, kind=kind, value=np.zeros((n, 6)))
    E = np.empty(len(axes))
    nu = np.empty(len(axes))
    w = model.body_volume
    for col, k in enumerate(axes):
        dim = 2 if plane else 3
        sel = np.ones(n, dtype=bool)
        for j in (range(dim) if interior else (k,)):
            length = box_hi[j] - box_lo[j]
            sel &= (x[:, j] >= box_lo[j] + core * length) & (x[:, j] <= box_hi[j] - core * length)
        A = np.hstack([np.ones((sel.sum(), 1)), (x[sel] - centre)[:, :dim]])
        sw = np.sqrt(w[sel])[:, None]
        coef, *_ = np.linalg.lstsq(A * sw, U[sel, :dim, col] * sw, rcond=None)
        G = coef[1:].T                                  # G[i, j] = ∂u_i/∂x_j
        eps = 0.5 * (G + G.T)
        lat = [j for j in range(dim) if j != k]
        E[col] = stress / eps[k, k]
        nu[col] = -sum(eps[j, j] for j in lat) / (len(lat) * eps[k, k])
    return E, nu
