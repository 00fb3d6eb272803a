"""Continuum yield under static Newton (solvers/newton.py).

With continuum yield (physics/laws/plastic.py, docs/theory.md "Yield")
each cell's plastic strain e (C, 6) moves its springs' plastic gaps, and a
face's force depends on its cells' stress, which the springs' own tangent
does not hold.  An increment is solved here with e as unknowns beside the
displacements U (newton_increment), Newton iterations on

    r(U, e) = 0                      (equilibrium, the exact residual)
    R(U, e) = e − Φ(s̃) = 0,  s̃ = s_c(U, e) + c 2G e

where s_c is the deviator of each cell's Love–Weber stress (physics/
inelastic.py finish_cell_stress) and Φ the radial return of J2 plasticity,
Φ(s̃) = max(0, 1 − k/√J2(s̃)) s̃/(c 2G) (Simo & Hughes 1998, §3.3.1:
backward Euler, so a cell that unloads within the increment gives its
plastic strain back; c = TRIAL_FACTOR); at the root each plastic cell
sits on √J2 = k.  The first increment starts from the elastic predictor
(Newton with e nil), the later ones from the tangent predictor (the last
increment's plastic cells and Φ' in the first iteration).  The
Jacobian is the consistent one in the reference configuration (small
strains): the springs' gaps d = B U (Kawai 1978, eq. 8b), plastic gaps
o = O e (plastic_offset), forces C (d − o), the cells' stress as linear
maps of the forces (CellOperators), and Φ's derivative at the plastic
cells (a semismooth Newton method: Hintermüller, Ito & Kunisch 2002; the
cells off the yield surface take e = 0 in one step).  Each cell's
plastic strain is written in an orthonormal basis of the strains its flow
takes (_deviator_basis: five deviators, two in a plane-strain cell).  The
linear solve: SuperLU (each cell's plastic strain beside its body in
METIS's nested-dissection order, no pivoting: the displacement block is
positive definite and the plastic one near the identity), or GMRES
preconditioned by an earlier iteration's factors while the plastic cells
have changed little since (_krylov).  Quadratic near the root; on
Prandtl's punch 6-17 iterations an increment, 1.0 s, 3.8 s and 60-65 s
at 32 × 16, 64 × 32 and 128 × 64 blocks on one core.  The plastic work is
booked by the trapezoid (book_plastic_work).

Indirect control (solver.control) is refused with continuum yield
(case/check.py): λ would be one more unknown of the system.
"""
import numpy as np
import scipy.sparse as sp
import scipy.sparse.linalg as sla

from ..physics.laws import BROKEN
from .newton_linear import body_order
from .newton_state import _restore, _save_motion
from .statics import apply_increment

#: the plastic strain's equation is met when no cell's e − Φ(s̃) passes this
#: share of its yield strain k/(2G)
PLASTIC_TOL = 1e-3


def _deviator(sig):
    """(s (C, 6), √J2 (C,)) of the stresses sig (C, 6), xx yy zz yz xz xy."""
    p = sig[:, :3].mean(axis=1)
    s = sig.copy()
    s[:, :3] -= p[:, None]
    j2 = 0.5 * (s[:, :3] ** 2).sum(axis=1) + (s[:, 3:] ** 2).sum(axis=1)
    return s, np.sqrt(j2)


def _P(l):
    """(S, 6, 3): sym(l ⊗ f) = P(l) f in the order xx yy zz yz xz xy."""
    z = np.zeros(l.shape[0])
    h0, h1, h2 = 0.5 * l[:, 0], 0.5 * l[:, 1], 0.5 * l[:, 2]
    return np.stack([np.stack([l[:, 0], z, z], -1), np.stack([z, l[:, 1], z], -1),
                     np.stack([z, z, l[:, 2]], -1), np.stack([z, h2, h1], -1),
                     np.stack([h2, z, h0], -1), np.stack([h1, h0, z], -1)], 1)


def _M(c):
    """(S, 3, 6): E c = M(c) e for the symmetric E = e (xx yy zz yz xz xy)."""
    z = np.zeros(c.shape[0])
    c0, c1, c2 = c[:, 0], c[:, 1], c[:, 2]
    return np.stack([np.stack([c0, z, z, z, c2, c1], -1),
                     np.stack([z, c1, z, c2, z, c0], -1),
                     np.stack([z, z, c2, c1, c0, z], -1)], 1)


def _blocks(rows, cols, blk, shape):
    """A sparse matrix of the dense blocks blk (S, p, q) at block rows
    `rows`·p and columns `cols`·q."""
    S, p, q = blk.shape
    r = (p * rows)[:, None, None] + np.arange(p)[None, :, None]
    c = (q * cols)[:, None, None] + np.arange(q)[None, None, :]
    return sp.coo_matrix((blk.ravel(), (np.broadcast_to(r, blk.shape).ravel(),
                                        np.broadcast_to(c, blk.shape).ravel())),
                         shape=shape).tocsr()


class CellOperators:
    """The linear maps of continuum yield in the reference configuration
    (small strains and rotations): the spring gaps d = B U (stiffness.py,
    Kawai 1978 eq. 8b), the plastic gaps o = O e (physics/inelastic.py
    plastic_offset), the forces f = C (d − o) and the cells' stress
    σ = S f (finish_cell_stress: Love–Weber, the held cells' reactions,
    the plane axis at the mean), deviatoric: SCB = Dev S C B, SCO = Dev S C
    O and BtCO = Bᵀ C O."""

    def __init__(self, m, free, intact):
        from ..stiffness import _spring_B, _spring_geometry
        self.intact = intact.copy()
        n = m.n_bodies
        sb = m.spring_bodies.astype(np.int64)
        a, b = sb[:, 0], sb[:, 1]
        inner = b < n
        S = len(sb)
        s_idx = np.arange(S)
        r_a, r_b, C = _spring_geometry(m)
        # a broken spring (a cut, a crack) carries no force that its cells'
        # flow moves, and takes no plastic gap (inelastic.py: intact only)
        C = np.where(intact[:, None, None], C, 0.0)
        G_a, G_b = _spring_B(r_a, r_b)
        CB = (_blocks(s_idx, a, C @ G_a, (3 * S, 6 * n))
              + _blocks(s_idx[inner], b[inner], (C @ G_b)[inner], (3 * S, 6 * n)))
        c = np.where(inner[:, None], r_a - r_b, 2.0 * r_a)
        CM = 0.5 * (C @ _M(c))
        CO = (_blocks(s_idx, a, CM, (3 * S, 6 * n))
              + _blocks(s_idx[inner], b[inner], CM[inner], (3 * S, 6 * n)))
        iv = m.cell_ivol  # (N+1,), the ground 0
        L = (_blocks(a, s_idx, iv[a, None, None] * _P(r_a), (6 * n, 3 * S))
             - _blocks(b[inner], s_idx[inner], (iv[b, None, None] * _P(r_b))[inner],
                       (6 * n, 3 * S)))
        # the held cells' reactions: σ_c += −sym(l_k ⊗ e_k) W_k(c)/V_c, W_k(c)
        # the springs' force on c along k (finish_cell_stress)
        lev = m.cell_lever[:n]
        rows, cols, vals = [], [], []
        for k in range(3):
            held = np.flatnonzero(np.any(lev[:, k] != 0.0, axis=1))
            if held.size == 0:
                continue
            Pk = _P(lev[held, k])[:, :, k] * (-iv[held])[:, None]     # (h, 6)
            where = np.full(n + 1, -1)
            where[held] = np.arange(held.size)
            for side, sign in ((a, 1.0), (b, -1.0)):
                hit = np.flatnonzero(where[side] >= 0)
                h = where[side[hit]]
                rows.append((6 * held[h])[:, None] + np.arange(6)[None])
                cols.append(np.broadcast_to((3 * hit + k)[:, None], (hit.size, 6)))
                vals.append(sign * Pk[h])
        if rows:
            L = L + sp.coo_matrix((np.concatenate(vals).ravel(),
                                   (np.concatenate(rows).ravel(), np.concatenate(cols).ravel())),
                                  shape=(6 * n, 3 * S)).tocsr()
        # the plane axis: σ_ax = (σ_(ax+1) + σ_(ax+2))/2; then the deviator
        Q = np.tile(np.eye(6), (n, 1, 1))
        ax = m.cell_plane[:n].astype(np.int64)
        pl = np.flatnonzero(ax >= 0)
        Q[pl, ax[pl], :] = 0.0
        Q[pl, ax[pl], (ax[pl] + 1) % 3] = 0.5
        Q[pl, ax[pl], (ax[pl] + 2) % 3] = 0.5
        D = np.eye(6)
        D[:3, :3] -= 1.0 / 3.0
        cells = np.arange(n)
        DQ = _blocks(cells, cells, D @ Q, (6 * n, 6 * n))
        SE = DQ @ L
        self.SCB = (SE @ CB).tocsr()
        self.SCO = (SE @ CO).tocsr()
        fr = np.flatnonzero(free)
        self.SCB_f = self.SCB[:, fr].tocsr()
        self.BtCO_f = _BtCO(G_a, G_b, C, CM, a, b, inner, n).tocsr()[fr].tocsc()   # (column slices)
        # an orthonormal basis of each cell's plastic strains: the deviators
        # (5), in plane strain those in the plane (2: the flow of a cell
        # whose out-of-plane stress is the mean of the other two)
        self.q, self.T = _deviator_basis(m.cell_plane[:n])
        self.q_ptr = np.concatenate([[0], np.cumsum(self.q)])
        # the bodies in nested-dissection order (newton_linear.body_order),
        # each body's free DOFs then its cell's plastic strains together
        perm = body_order(m)
        self.perm = np.arange(n) if perm is None else perm
        self.body_of_free = fr // 6

    def order(self, free, p):
        """The fill-reducing order of the unknowns (free DOFs, then the
        plastic cells' strains in their bases) of the iteration's matrix."""
        nf = free.size
        body = np.concatenate([self.body_of_free, np.repeat(p, self.q[p])])
        rank = np.empty(self.perm.size, dtype=np.int64)
        rank[self.perm] = np.arange(self.perm.size)
        key = rank[body] * 2 + (np.arange(body.size) >= nf)
        return np.argsort(key, kind="stable")


    def columns(self, p):
        """The columns of T (and the unknowns' offsets) of the cells p."""
        return _ranges(self.q_ptr[p], self.q[p])


def _ranges(start, count):
    """The concatenated ranges start[i] … start[i] + count[i] − 1."""
    total = int(count.sum())
    if total == 0:
        return np.zeros(0, dtype=np.int64)
    off = np.repeat(np.cumsum(count) - count, count)
    return np.repeat(start, count) + np.arange(total) - off


def _deviator_basis(plane):
    """(q (C,), T (6C × Σq) sparse): each cell's orthonormal basis of the
    strains its plastic flow takes (xx yy zz yz xz xy, tensor components):
    the five deviators; in a plane-strain cell (plane[c] = its held axis)
    the two in the plane, (e_ii − e_jj)/√2 and e_ij."""
    C = plane.size
    r2, r6 = 1.0 / np.sqrt(2.0), 1.0 / np.sqrt(6.0)
    full = np.zeros((6, 5))
    full[[0, 1], 0] = r2, -r2
    full[[0, 1, 2], 1] = r6, r6, -2.0 * r6
    full[3, 2] = full[4, 3] = full[5, 4] = 1.0
    shear = {0: 3, 1: 4, 2: 5}          # the in-plane shear of each held axis
    q = np.where(plane >= 0, 2, 5)
    ptr = np.concatenate([[0], np.cumsum(q)])
    rows, cols, vals = [], [], []
    for c in range(C):
        ax = int(plane[c])
        if ax >= 0:
            i, j = (ax + 1) % 3, (ax + 2) % 3
            rows += [6 * c + i, 6 * c + j, 6 * c + shear[ax]]
            cols += [ptr[c], ptr[c], ptr[c] + 1]
            vals += [r2, -r2, 1.0]
        else:
            nz = np.nonzero(full)
            rows += list(6 * c + nz[0])
            cols += list(ptr[c] + nz[1])
            vals += list(full[nz])
    return q, sp.csr_matrix((vals, (rows, cols)), shape=(6 * C, int(ptr[-1])))


#: SuperLU's threshold for the diagonal pivot: none, the order kept (0.1:
#: the 64 × 32 punch 77 s against 14 s)
PIVOT = 0.0


def _krylov(J, b, lu, p, nf, ops):
    """J x = b by GMRES preconditioned with the factors lu = (factors, p_old)
    of an earlier iteration's matrix (its plastic cells p_old: a cell
    plastic now and not then is preconditioned by the identity, one
    plastic then and not now is left out); None when it does not converge
    in KRYLOV_MAX iterations (then the caller factorises J)."""
    F, p_old = lu
    both = np.intersect1d(p, p_old)

    def rows(cells):
        # the unknowns of `both` among those of `cells` (each cell's q)
        off = np.cumsum(ops.q[cells]) - ops.q[cells]
        at = np.searchsorted(cells, both)
        return nf + _ranges(off[at], ops.q[both])
    new_rows, old_rows = rows(p), rows(p_old)
    n_old = nf + int(ops.q[p_old].sum())

    def apply(v):
        w = np.zeros(n_old)
        w[:nf] = v[:nf]
        w[old_rows] = v[new_rows]
        y = F.solve(w)
        z = v.copy()
        z[:nf] = y[:nf]
        z[new_rows] = y[old_rows]
        return z
    M = sla.LinearOperator(J.shape, matvec=apply)
    x, info = sla.gmres(J, b, M=M, rtol=KRYLOV_RTOL, atol=0.0, restart=KRYLOV_MAX,
                        maxiter=1)
    return x if info == 0 and np.all(np.isfinite(x)) else None


class _Factors:
    """SuperLU factors of J in the given order (no pivoting: PIVOT)."""

    def __init__(self, J, order):
        self.order = order
        self.lu = sla.splu(sp.csc_matrix(sp.csr_matrix(J)[order][:, order]),
                           permc_spec="NATURAL", diag_pivot_thresh=PIVOT)

    def solve(self, b):
        x = np.empty_like(b)
        x[self.order] = self.lu.solve(b[self.order])
        return x


def _BtCO(G_a, G_b, C, CM, a, b, inner, n):
    """Bᵀ C O (6N × 6N): the bodies' forces of the plastic gaps."""
    S = len(a)
    s_idx = np.arange(S)
    Bt = (_blocks(a, s_idx, np.transpose(G_a, (0, 2, 1)), (6 * n, 3 * S))
          + _blocks(b[inner], s_idx[inner], np.transpose(G_b, (0, 2, 1))[inner], (6 * n, 3 * S)))
    CO = (_blocks(s_idx, a, CM, (3 * S, 6 * n))
          + _blocks(s_idx[inner], b[inner], CM[inner], (3 * S, 6 * n)))
    return Bt @ CO


def newton_increment(solve, nt, state, lam, goal, plan, tol, controlled, saved, log=None):
    """One increment by Newton on displacements and plastic strains
    together (module docstring)."""
    intact = state.spring_state < BROKEN
    if getattr(nt, "cell_ops", None) is None or not np.array_equal(intact, nt.cell_ops.intact):
        nt.cell_ops = CellOperators(nt.m, nt.free, intact)
    ops = nt.cell_ops
    Kff = None
    m = nt.m
    n = nt.n
    k = m.cell_k[:n]
    g2 = m.cell_2g[:n]
    h2 = TRIAL_FACTOR * g2
    on = k > 0.0
    free = np.flatnonzero(nt.free)
    nt.deps[:] = 0.0
    tangent = getattr(nt, "plastic_tangent", None)
    if tangent is None:
        # the elastic predictor (the first increment): equilibrium with the
        # increment's plastic strain nil
        ok, lam1, its, ratio = solve(nt, state, lam, goal, plan, tol, controlled, saved)
        if not ok:
            return ok, lam1, its, ratio
    else:
        # the tangent predictor: the first iteration takes the plastic cells
        # and Φ' of the last converged increment (the consistent tangent
        # predictor of plasticity, Simo & Hughes 1998, §3.3; the elastic
        # predictor put 414 cells of the 128 × 64 punch over yield, the
        # Newton steps cycled between 300 and 430 and the increment was cut)
        lam1, its, ratio = goal, 0, np.inf
    # (a diverged iterate's forces must not raise the force scale of the
    # increments after it: Newton.reference)
    ref_max = nt.ref_max
    best = np.inf
    back = None
    # (factors, the plastic cells they were made for): kept from the last
    # increment, whose plastic cells and Φ' the tangent predictor takes
    lu = getattr(nt, "plastic_lu", None)
    for j in range(1, NEWTON_PLASTIC_IT + 1):
        nt.set_prescribed(state, lam1)
        r, tri = nt.residual(state, lam1)
        ref = nt.reference(r, lam1, state.body_support[:n])
        ratio = nt.norm(r) / max(ref, 1e-300)
        e = nt.deps[:n]
        s, _ = _deviator(nt.sigma[:n])
        st = s + h2[:, None] * e
        st, jt = _deviator(st)
        p = np.flatnonzero(on & (jt > k))
        phi = np.zeros_like(e)
        fac = (1.0 - k[p] / jt[p]) / h2[p]
        phi[p] = fac[:, None] * st[p]
        Re = e - phi
        change = float(np.max(np.abs(Re).max(axis=1) * np.where(on, g2 / np.where(on, k, 1), 0)))
        if log is not None:
            log(j, p.size, change, ratio)
        # Φ' = [(1 − k/j) I + (k/j²) s̃ ⊗ n]/2G, n = ∂j/∂s̃
        nv = st[p].copy()
        nv[:, 3:] *= 2.0
        nv /= (2.0 * jt[p])[:, None]
        dphi = (fac[:, None, None] * np.eye(6)[None]
                + (k[p] / jt[p] ** 2 / h2[p])[:, None, None] * st[p][:, :, None] * nv[:, None, :])
        if ratio <= tol and change <= PLASTIC_TOL and j > 1:
            nt.plastic_tangent = (p, dphi)
            return True, lam1, its, ratio
        if j == 1 and tangent is not None:
            p, dphi = tangent
        merit = max(ratio / tol, change / PLASTIC_TOL)
        if not np.isfinite(merit) or merit > DIVERGED * best:
            nt.ref_max = ref_max
            return False, lam1, its, ratio
        if back is not None and j >= BACK_FROM and merit > back[2] and back[3] < BACK_HALVINGS:
            # the step raised the merit past the second iteration (an active
            # set cycling at the plastic zone's edge): halved (Dennis &
            # Schnabel 1983, §6.3)
            motion, deps0, m0, tries, dU, de = back
            _restore(state, motion)
            nt.deps[:] = deps0
            dU, de = 0.5 * dU, 0.5 * de
            apply_increment(m, state, dU.reshape(n, 6))
            nt.deps[:n] += de
            back = (motion, deps0, m0, tries + 1, dU, de)
            continue
        best = min(best, merit)
        its += 1
        pr = (6 * p[:, None] + np.arange(6)[None]).ravel()
        npm = np.ones(n, bool)
        npm[p] = False
        de_np = -Re[npm].ravel()
        Dp = _blocks(np.arange(p.size), np.arange(p.size), dphi, (6 * p.size, 6 * p.size))
        if Kff is None:
            Kff = nt.stiffness(state, tri).tocsr()[free][:, free]
        BtCO = ops.BtCO_f
        pc = ops.columns(p)
        Tp = ops.T[pr][:, pc]
        A_ue = -(BtCO[:, pr] @ Tp)
        SCOp = ops.SCO[pr]
        A_eu = -(Tp.T @ (Dp @ ops.SCB_f[pr]))
        A_ee = Tp.T @ ((sp.identity(6 * p.size) - Dp @ (sp.diags(np.repeat(h2[p], 6))
                                                         - SCOp[:, pr])) @ Tp)
        # (the elastic cells' step δe = −e, as a whole vector: no column slices)
        d_np = np.where(npm[:, None], -Re, 0.0).ravel()
        rhs_u = r[free] + BtCO @ d_np
        rhs_e = Tp.T @ (-Re[p].ravel() - Dp @ (SCOp @ d_np))
        b = np.concatenate([rhs_u, rhs_e])
        J = sp.bmat([[Kff, A_ue], [A_eu, A_ee]], format="csr") if p.size else Kff
        x = None
        if lu is not None and np.setxor1d(p, lu[1]).size <= KRYLOV_CHANGE:
            x = _krylov(J, b, lu, p, free.size, ops)
        if x is None:
            lu = (_Factors(J, ops.order(free, p)), p)
            nt.plastic_lu = lu
            x = lu[0].solve(b)
        if not np.all(np.isfinite(x)):
            nt.ref_max = ref_max
            return False, lam1, its, ratio
        dU = np.zeros(6 * n)
        dU[free] = x[:free.size]
        de = np.zeros((n, 6))
        de[npm] = de_np.reshape(-1, 6)
        de[p] = (Tp @ x[free.size:]).reshape(-1, 6)
        back = (_save_motion(state), nt.deps.copy(), merit, 0, dU, de)
        apply_increment(m, state, dU.reshape(n, 6))
        nt.deps[:n] += de
    nt.ref_max = ref_max
    return False, lam1, its, ratio


#: the factors of an earlier iteration's matrix precondition GMRES on the
#: present one (Saad 2003, §9.3: right preconditioning) while it converges
#: to KRYLOV_RTOL in KRYLOV_MAX iterations; else the matrix is factorised
#: while at most KRYLOV_CHANGE cells have entered or left the plastic set
#: since (the 64 × 32 punch: GMRES converged in 12 iterations for 61 of 62
#: such matrices, 4 of 10 at 3-5 changed, none of 78 beyond)
KRYLOV_RTOL = 1e-5
KRYLOV_MAX = 12
KRYLOV_CHANGE = 2
#: c of the trial s̃ = s + c 2G e and Φ = max(0, 1 − k/√J2) s̃/(c 2G): any
#: c > 0 has the same roots (there s = k s̃/√J2(s̃)), the iteration not:
#: c = 1 cycled between active sets at the plastic zone's edge (the 64 × 32
#: punch cut its 20 increments into 33), 2 and 4 worse (94, 231), 0.5,
#: 0.25, 0.1 not (20-21); 0.25 the fewest iterations at 64 × 32 (172) and
#: 128 × 64 (507, 30 increments)
TRIAL_FACTOR = 0.25
#: from this iteration on a step that raised the merit is halved, once
#: (Dennis & Schnabel 1983, §6.3: a backtracking line search; from the
#: second, up to three halvings, doubled the 32 × 16 punch's iterations)
BACK_FROM = 3
BACK_HALVINGS = 1
#: iterations of one increment before it is cut (newton.py halves it)
NEWTON_PLASTIC_IT = 40
#: max(residual ratio/tolerance, plastic change/PLASTIC_TOL) this many times
#: the increment's best: diverged, cut (a halving from 23 to 46 active cells
#: then 512 on the 32 × 16 punch)
DIVERGED = 1e3


def book_plastic_work(nt, state, f0, dp0):
    """After an increment's commit: the plastic work of the continuum springs
    by the trapezoid, ½ (f_0 + f_1)·Δp, where the spring pass booked the
    end force f_1·Δp (backward Euler): the path work of the loads is a
    trapezoid too (statics.record_frame), and on the 128 × 64 punch the
    two rules differed by 1.6 % of the work in 20 increments.  f0 (S, 3)
    [N] the springs' world forces and dp0 (S, 3) [m] their local plastic
    gaps at the increment's start."""
    from ..physics.laws import P_MODEL
    from ..physics.laws.plastic import CONTINUUM
    from ..physics.rotation import quat_matrix_np, quat_mul_np
    m = nt.m
    cont = m.law_params[m.spring_law, P_MODEL] == CONTINUUM
    d = np.where(cont[:, None], state.spring_dp - dp0, 0.0)
    s = np.flatnonzero(np.any(d != 0.0, axis=1))
    if s.size == 0:
        return
    a = m.spring_bodies[s, 0]
    q = np.vstack([state.body_quat[:nt.n], [[1.0, 0.0, 0.0, 0.0]]])
    q0 = np.vstack([m.body_quat0[:nt.n], [[1.0, 0.0, 0.0, 0.0]]])
    dq = quat_mul_np(q[a], q0[a] * np.array([1.0, -1.0, -1.0, -1.0]))
    F = quat_matrix_np(quat_mul_np(dq, m.spring_frame0[s]))       # columns n, s, t
    dw = np.einsum("sij,sj->si", F, d[s])
    state.spring_wp[s] += 0.5 * np.einsum("si,si->s", f0[s] - state.spring_force[s], dw)

