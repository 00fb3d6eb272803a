"""The linear solvers of the static Newton iteration (solvers/newton_system.py's
Newton uses them; nothing here imports the other Newton modules): K δU = r
with the iteration matrix, from one SuperLU factorisation updated by
Woodbury's identity while rotations stay small (_LowRank), or with the
whole matrix by conjugate gradients or GMRES preconditioned by an earlier
factorisation (_Full, _preconditioned_solve); the factorisation in
nested-dissection order (_factorize, _dof_order); BLAS on one thread
(one_blas_thread).
"""
import numpy as np
import scipy.sparse as sp
import scipy.linalg as sla
import scipy.sparse.linalg as spla

from ..physics.rotation import quat_matrix_np
from .assembly import assemble_triplets, changed_springs
from .passes import model_arrays

# (newton_tangent.py's local tangents take OPEN_FRACTION too: _local_tangents,
# _plastic_tangent)
OPEN_FRACTION = 1e-6    # secant stiffness of an open crack / the intact spring's
GMRES_MAX = 60          # GMRES iterations (no restart) before refactorising
CG_MAX = 30             # CG iterations before the preconditioner is refactorised
GEOMETRIC_RTOL = 1e-6  # relative residual a solve of _WithGeometric must reach
CG_RTOL = 1e-10         # relative residual of each linear solve
LOWRANK_MAX = 3000      # DOFs of the changed springs' bodies before K0 is refactorised
# columns of K0⁻¹ one growth of the changed set may take (when it also
# more than doubles the set); past it K0 is refactorised instead, which
# costs about as much (symmetric SuperLU in nested-dissection order: 0.37 s
# against 3.3 ms a column on the 1 760-cell beam of three-point bending,
# 0.89 s against 7.3 ms on the 2 866-cell one of benchmarks/quasi_static.py);
# a wild iterate that changes thousands of springs took 10-15 s of growth
GROW_MAX_COLUMNS = 120
MATRIX_GMRES = 20       # GMRES iterations on the capacitance matrix before it is refactorised
CAPACITANCE_RTOL = 1e-4  # relative residual of a low-rank solve (of its right-hand side)


def _preconditioned_solve(nt, A, b):
    """A x = b for the free block A of the present secant stiffness:
    conjugate gradients preconditioned by the SuperLU factors of an
    earlier A (the secant stiffness changes a little from one
    iteration to the next, so a stale factorisation is a very good
    preconditioner; GMRES when A is not symmetric: a damaging spring's
    tangent, the geometric stiffness), refactorised when CG_MAX (CG) or
    GMRES_MAX (GMRES) iterations are not enough; None if A is
    singular.  The factors and the counts are nt's (Newton: lu, symmetric,
    order, cg_iterations, factorizations), kept from one iteration to the
    next."""
    bn = np.linalg.norm(b)
    if bn == 0.0:
        return np.zeros_like(b)
    if nt.lu is not None:
        count = [0]

        def cb(_):
            count[0] += 1
        M = spla.LinearOperator(A.shape, matvec=nt.lu.solve, dtype=float)
        if nt.symmetric:
            x, info = spla.cg(A, b, x0=nt.lu.solve(b), rtol=CG_RTOL, maxiter=CG_MAX,
                              M=M, callback=cb)
        else:
            x, info = spla.gmres(A, b, x0=nt.lu.solve(b), rtol=CG_RTOL, restart=GMRES_MAX,
                                 maxiter=1, M=M, callback=cb, callback_type="pr_norm")
        nt.cg_iterations += count[0]
        if info == 0 and np.all(np.isfinite(x)):
            return x
    try:
        nt.lu = _factorize(A, nt.order, nt.symmetric)
    except RuntimeError:
        nt.lu = None
        return None
    nt.factorizations += 1
    x = nt.lu.solve(b)
    return x if np.all(np.isfinite(x)) else None


class _Full:
    """Solves with the whole iteration matrix (_preconditioned_solve: conjugate
    gradients or GMRES preconditioned by an earlier factorisation)."""

    def __init__(self, nt, K):
        self.nt = nt
        f = nt.free
        self.Kff = sp.csr_matrix(K[f][:, f])
        self.Kfp = K[f][:, nt.disp]

    def solve(self, B):
        X = np.empty_like(B)
        for j in range(B.shape[1]):
            x = _preconditioned_solve(self.nt, self.Kff, B[:, j])
            if x is None:
                return None
            X[:, j] = x
        return X

    def prescribed(self):
        """K_fp U_p: the free DOFs' forces of the prescribed displacements
        at full amplitude."""
        return self.Kfp @ self.nt.Up[self.nt.disp]

    def solve_pair(self, r):
        """K⁻¹ [r, F − K_fp U_p] (free DOFs × 2); None if singular."""
        return self.solve(np.column_stack([r, self.nt.F[self.nt.free] - self.prescribed()]))


class _LowRank:
    """Solves with the iteration matrix K = K0 + ΔK of a small-rotation
    iteration from one factorisation.  K0 is the matrix factorised at some
    state (the first iteration, or the last renewal), ΔK = Σ B_sᵀ (k_s −
    k0_s) B_s over the springs whose local stiffness has changed since (the
    fracture process zone), in K0's geometry, nonzero on the DOFs of the set
    D of their bodies only.  Woodbury's identity (Hager 1989, "Updating the
    inverse of a matrix", SIAM Review 31; Golub & Van Loan, Matrix
    Computations, §2.1.4) with P the columns of D's free DOFs and A = Pᵀ ΔK P:
    (K0 + P A Pᵀ)⁻¹ = K0⁻¹ − K0⁻¹ P (I + A Z)⁻¹ A Pᵀ K0⁻¹, Z = Pᵀ K0⁻¹ P,
    Z grown by a multi-right-hand-side solve when bodies join D (a damage
    zone grows monotonically), I + A Z (dense, 6|D| square) solved by GMRES
    on the LU factors of an earlier one (_capacitance).  The
    geometry of K0 is that of its state: the frames and arms turn by at most
    GEOMETRIC_ANGLE meanwhile, a change of the Jacobian of that order (a
    modified Newton iteration; the residual is exact).  Renewed (K0 the
    present matrix) when D passes LOWRANK_MAX DOFs."""

    def __init__(self, nt, state, k, frames):
        m = nt.m
        self.nt = nt
        self.rot = quat_matrix_np(state.body_quat)
        self.frames = quat_matrix_np(frames)
        # K0 symmetric positive definite: a spring whose local stiffness is
        # not symmetric (a damage or friction tangent) enters K0 by its
        # diagonal, floored at OPEN_FRACTION of its elastic stiffness, and
        # the rest by the update (it is among the changed springs).  SuperLU
        # then keeps the nested-dissection order without pivoting: on the
        # 1 760-cell beam of three-point bending 5.5 M entries in the
        # factors against 18 M with partial pivoting, a factorisation in
        # 0.37 s against 3.1 s and a column of K0⁻¹ in 3.3 ms against 16 ms
        # (twice, K0⁻¹ and K0⁻ᵀ)
        k0 = k.copy()
        asym = np.flatnonzero(np.any(k != k.transpose(0, 2, 1), axis=(1, 2)))
        if asym.size:
            d = np.maximum(np.diagonal(k[asym], axis1=1, axis2=2), OPEN_FRACTION * nt.laws[0][asym])
            k0[asym] = 0.0
            k0[asym[:, None], [0, 1, 2], [0, 1, 2]] = d
        self.k0 = k0
        K = nt.pattern.matrix(m, state.body_quat, frames, k0)
        if nt.K_aux is not None:
            K = (K + nt.K_aux).tocsr()
        f = nt.free
        self.lu = _factorize(sp.csr_matrix(K[f][:, f]), nt.order, True)
        # K0⁻¹ (F − K0_fp U_p), the reference load's response in K0, once
        # (solve_pair)
        self.g0 = nt.F[f] - K[f][:, nt.disp] @ nt.Up[nt.disp]
        self.y0 = self.lu.solve(self.g0)
        self.free_pos = np.full(6 * nt.n, -1)
        self.n_free = int(f.sum())
        self.free_pos[f] = np.arange(self.n_free)
        self.slot = np.full(nt.n + 1, -1)
        self.bodies = np.zeros(0, dtype=np.int64)
        self.pos = np.zeros(0, dtype=np.int64)      # free positions of D's free DOFs
        self.Z = np.zeros((0, 0))
        self.loc = np.full(6 * nt.n, -1)           # a DOF's row in Z (D's free DOFs)
        self.A = None
        self.M = None
        self._changed = np.empty(m.n_springs, dtype=np.int64)

    def update(self, k, limit=True):
        """ΔK of the local stiffnesses k; False when D would pass
        LOWRANK_MAX DOFs, or (`limit`) when this growth alone would take
        more than GROW_MAX_COLUMNS columns of K0⁻¹ and more than D holds
        (a wild iterate: the caller renews)."""
        m = self.nt.m
        n = self.nt.n
        changed = self._changed[:changed_springs(k, self.k0, self._changed)]
        self.A = None
        if changed.size == 0:
            return True
        bodies = np.unique(m.spring_bodies[changed].reshape(-1))
        bodies = bodies[bodies < n]
        new = bodies[self.slot[bodies] < 0]
        if 6 * (len(self.bodies) + len(new)) > LOWRANK_MAX or (
                limit and 6 * len(new) > max(GROW_MAX_COLUMNS, len(self.pos))):
            return False
        if new.size:
            self._grow(new)
        nv = 144 * len(changed)
        rows = np.empty(nv, dtype=np.int64)
        cols = np.empty(nv, dtype=np.int64)
        vals = np.empty(nv)
        assemble_triplets(changed, model_arrays(m)[1], self.rot, self.frames,
                          k[changed] - self.k0[changed], rows, cols, vals)
        ok = rows >= 0
        rows, cols, vals = rows[ok], cols[ok], vals[ok]
        lr, lc = self.loc[rows], self.loc[cols]
        d = len(self.pos)
        inner = (lr >= 0) & (lc >= 0)
        # A is block-sparse (a body's few neighbours)
        self.A = sp.csr_matrix((vals[inner], (lr[inner], lc[inner])), shape=(d, d))
        pres = (lr >= 0) & self.nt.disp[cols]
        self.A_up = np.bincount(lr[pres], vals[pres] * self.nt.Up[cols[pres]], minlength=d)
        return True

    def _capacitance(self, R, tol):
        """V = (I + A Z)⁻¹ R to a residual ≤ tol (per column): GMRES preconditioned by the LU factors of an
        earlier I + A Z (the damage zone changes a little from one iteration
        to the next), refactorised when MATRIX_GMRES iterations are not
        enough."""
        d = len(self.pos)
        op = spla.LinearOperator((d, d), matvec=lambda v: v + self.A @ (self.Z @ v),
                                 dtype=float)
        if self.M is not None and self.M[0].shape[0] == d:
            pre = spla.LinearOperator((d, d), dtype=float,
                                      matvec=lambda v: sla.lu_solve(self.M, v,
                                                                    check_finite=False))
            V = np.empty_like(R)
            for j in range(R.shape[1]):
                r = R[:, j]
                x, _ = spla.gmres(op, r, x0=pre.matvec(r), M=pre, rtol=0.0, atol=0.1 * tol[j],
                                  restart=MATRIX_GMRES, maxiter=1)
                # an inexact Newton step (Dembo, Eisenstat & Steihaug 1982):
                # a linear residual far below the Newton residual is enough
                # (GMRES's own test, on the preconditioned residual, can fail
                # on an ill-conditioned I + A Z when the true one is small)
                if not np.linalg.norm(op.matvec(x) - r) <= tol[j]:
                    break
                V[:, j] = x
            else:
                return V
        M = self.A @ self.Z
        M[np.diag_indices_from(M)] += 1.0
        self.M = sla.lu_factor(M, overwrite_a=True, check_finite=False)
        return sla.lu_solve(self.M, R, check_finite=False)

    def _grow(self, new):
        """Add bodies to D: Z's new rows and columns, K0⁻¹ at D's DOFs."""
        self.slot[new] = len(self.bodies) + np.arange(len(new))
        self.bodies = np.concatenate([self.bodies, new])
        dofs = (new[:, None] * 6 + np.arange(6)).reshape(-1)
        p_new = self.free_pos[dofs]
        p_new = p_new[p_new >= 0]
        E = np.zeros((self.n_free, len(p_new)))
        E[p_new, np.arange(len(p_new))] = 1.0
        X = self.lu.solve(E)
        p_old = self.pos
        # (K0 symmetric: Z's new rows are its new columns transposed)
        self.Z = np.block([[self.Z, X[p_old]], [X[p_old].T, X[p_new]]])
        self.pos = np.concatenate([p_old, p_new])
        fd = dofs[self.free_pos[dofs] >= 0]
        self.loc[fd] = len(p_old) + np.arange(len(fd))

    def solve(self, B):
        """K⁻¹ B (B: free DOFs × columns)."""
        Y = self.lu.solve(B)
        if self.A is None:
            return Y
        # the residual of the whole solve is P times the capacitance
        # system's, (K0 + P A Pᵀ)(Y − K0⁻¹ P V) = B − P ((I + A Z) V − A Y_D):
        # held to CAPACITANCE_RTOL of the right-hand side
        v = self._capacitance(self.A @ Y[self.pos],
                              CAPACITANCE_RTOL * np.linalg.norm(B, axis=0))
        E = np.zeros_like(Y)
        E[self.pos] = v
        return Y - self.lu.solve(E)

    def solve_pair(self, r):
        """K⁻¹ [r, g] (free DOFs × 2), g = F − K_fp U_p the reference load's column
        (indirect control), in two solves with K0 instead of solve()'s
        four columns: with a = A_up (ΔK's prescribed forces, on D), g = g0
        − P a and K⁻¹ g = y0 − K0⁻¹ P (a + v₂), y0 = K0⁻¹ g0 kept from the
        factorisation, v₂ the capacitance solution of A (y0_D − Z a)."""
        y1 = self.lu.solve(r)
        if self.A is None:
            return np.column_stack([y1, self.y0])
        pos = self.pos
        a = self.A_up
        g = self.g0.copy()
        g[pos] -= a
        R = self.A @ np.column_stack([y1[pos], self.y0[pos] - self.Z @ a])
        v = self._capacitance(R, CAPACITANCE_RTOL * np.array([np.linalg.norm(r),
                                                              np.linalg.norm(g)]))
        E = np.zeros((self.n_free, 2))
        E[pos, 0] = v[:, 0]
        E[pos, 1] = a + v[:, 1]
        W = self.lu.solve(E)
        return np.column_stack([y1, self.y0]) - W


class _WithGeometric:
    """Solves with the whole present matrix K (the material part at the
    springs' present tangents plus the geometric stiffness of their forces,
    solvers/assembly.py _geometric) by GMRES preconditioned by the
    small-rotation solver `inner` (_LowRank, which leaves the geometric
    stiffness out): under large spring forces and a softened process zone
    (a Brazilian disc near its peak) the missing initial-stress term alone
    keeps the modified Newton iteration from converging."""

    def __init__(self, nt, K, inner, renew):
        self.nt = nt
        self.inner = inner
        self.renew = renew
        f = nt.free
        self.Kff = sp.csr_matrix(K[f][:, f])
        self.Kfp = K[f][:, nt.disp]

    def solve(self, B):
        """K⁻¹ B; the inner factors renewed once (at the present state) when
        GMRES_MAX iterations leave a relative residual above
        GEOMETRIC_RTOL; None if that fails too."""
        X = self._gmres(B)
        if X is None:
            self.inner = self.renew()
            X = self._gmres(B)
        return X

    def _gmres(self, B):
        n = self.Kff.shape[0]
        pre = spla.LinearOperator((n, n), dtype=float,
                                  matvec=lambda v: self.inner.solve(v[:, None])[:, 0])
        X = np.empty_like(B)
        for j in range(B.shape[1]):
            b = B[:, j]
            x, _ = spla.gmres(self.Kff, b, x0=pre.matvec(b), M=pre, rtol=CG_RTOL,
                              restart=GMRES_MAX, maxiter=1)
            # (the inner solve is inexact, CAPACITANCE_RTOL: GMRES's own flag
            # can fail where the true residual is small; judged on that)
            if not (np.all(np.isfinite(x)) and np.linalg.norm(self.Kff @ x - b)
                    <= GEOMETRIC_RTOL * np.linalg.norm(b)):
                return None
            X[:, j] = x
        return X

    def prescribed(self):
        return self.Kfp @ self.nt.Up[self.nt.disp]

    def solve_pair(self, r):
        """K⁻¹ [r, F − K_fp U_p] (free DOFs × 2); None if singular."""
        return self.solve(np.column_stack([r, self.nt.F[self.nt.free] - self.prescribed()]))


class _Permuted:
    """SuperLU factors of P A Pᵀ (a fill-reducing order p of the unknowns)
    answering solves with A."""

    def __init__(self, lu, p):
        self.lu, self.p = lu, p

    def solve(self, b, trans="N"):
        x = np.empty_like(b)
        x[self.p] = self.lu.solve(b[self.p], trans=trans)
        return x


def _factorize(A, order, symmetric):
    """SuperLU factors of the free block A: in the nested-dissection order
    of the body graph when there is one (METIS through pymetis: on the
    1 760-cell notched beam 5.4 M nonzeros in the factors against COLAMD's
    9.0 M, factorisation 0.95 s against 2.0 s, solves 18 ms against 32 ms),
    else with SuperLU's COLAMD."""
    if order is None:
        return spla.splu(sp.csc_matrix(A), permc_spec="COLAMD",
                         options=dict(SymmetricMode=symmetric))
    Ap = sp.csc_matrix(sp.csr_matrix(A)[order][:, order])
    lu = spla.splu(Ap, permc_spec="NATURAL", options=dict(SymmetricMode=symmetric),
                   diag_pivot_thresh=0.0 if symmetric else 1.0)
    return _Permuted(lu, order)


def body_order(model):
    """The bodies in METIS's nested-dissection order of the graph of bodies
    joined by springs (George 1973), or None without pymetis or a graph."""
    try:
        import pymetis
    except ImportError:
        return None
    n = model.n_bodies
    sb = model.spring_bodies
    inner = (sb[:, 0] < n) & (sb[:, 1] < n) & (sb[:, 0] != sb[:, 1])
    if n < 2 or not inner.any():
        return None
    G = sp.coo_matrix((np.ones(int(inner.sum()), dtype=np.int8), (sb[inner, 0], sb[inner, 1])),
                      shape=(n, n)).tocsr()
    G = (G + G.T).tocsr()
    G.sum_duplicates()
    G.data[:] = 1
    perm, _ = pymetis.nested_dissection(pymetis.CSRAdjacency(G.indptr, G.indices))
    return np.asarray(perm, dtype=np.int64)


def _dof_order(model, free):
    """Nested-dissection order of the free DOFs (a body's six together, the
    bodies in body_order), or None without pymetis."""
    perm = body_order(model)
    if perm is None:
        return None
    n = model.n_bodies
    dof = (perm[:, None] * 6 + np.arange(6)).reshape(-1)
    where = np.full(6 * n, -1)
    where[np.flatnonzero(free)] = np.arange(int(free.sum()))
    order = where[dof]
    return order[order >= 0]


def one_blas_thread():
    """A context in which BLAS runs on one thread (newton.run's docstring: the
    Newton iteration's answer then does not depend on the machine)."""
    from threadpoolctl import threadpool_limits
    return threadpool_limits(limits=1, user_api="blas")
