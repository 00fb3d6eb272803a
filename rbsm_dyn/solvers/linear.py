"""Linear mode: Kawai's stiffness method, K U = F (Kawai 1978, eq. 14).

The small-strain stiffness K (stiffness.py, Kawai eq. 8b: Σ_s B_sᵀ C_s B_s
over spring points, supports on faces included) is assembled once; the
constrained DOFs (fixed components, prescribed displacements at their full
amplitude) are moved to the right-hand side and the free block is solved

    K_ff U_f = F_f − K_fp U_p.

Method (`solve(..., method="auto")`): a sparse direct solve (SuperLU,
COLAMD ordering with symmetric-mode pivoting, two steps of iterative
refinement; minimum degree on K + Kᵀ fills 3.6× more and is 10× slower on
Voronoi meshes, measured) up to
`DIRECT_MAX_DOFS` free DOFs; above it conjugate gradients with a 6 × 6
block-Jacobi preconditioner (the inverse of each body's own block of K_ff,
which also removes the scale difference between translations [m] and
rotations [rad]), to a relative residual ‖K_ff U − b‖ ≤ `CG_RTOL`·‖b‖.
The threshold is measured in benchmarks/bench_linear.py: on a compact
Voronoi block of 2 000 bodies (12 000 DOFs) SuperLU takes 5.7 s and CG
0.6 s (335 iterations), and the factorisation's fill grows much faster
than CG's cost; the direct solve is kept for small models, where it is
quick and immune to the slow CG convergence of slender structures.

Loads: every load at its full amplitude (load histories are ignored: a
linear static answer scales with the load), gravity included.  A
prescribed velocity has no static meaning (an error naming the boundary
item).  Initial velocities are ignored.

History (same layout as a static run, docs/history.md): frame 0 the
undeformed state (time = load factor 0), frame 1 the solution (time = 1,
step = 1).  Positions x0 + u; orientations q = exp(θ) q0, the exact
rotation by the rotation vector θ of the solution (so the `rotation`
probe reads θ back).  Probes and reactions as in a static run:
`reaction` = support-spring forces on the body (linear, C_s B_s U) plus the
constraint force K U − F on its constrained components.  Observables:
strain = ½ UᵀKU, external_work = ½ (F + R)ᵀU (the work of the loads and
of the constraint forces on prescribed displacements along the
proportional path from the unloaded state: = strain in a linear
solution, so the energy balance closes), residual = ‖K_ff U_f − b‖/‖b‖, kinetic = damping = 0.
"""
import time as _time

import numpy as np
import scipy.sparse as sp
import scipy.sparse.linalg as spla

from ..model import new_state
from ..physics.integrate import DISPLACEMENT, FIXED, FREE, VELOCITY, refresh_all_rotations
from ..physics.rotation import quat_mul_np
from .explicit import RunFailed
from ..stiffness import _free_rigid_motion, model_load, spring_forces, stiffness_matrix

__all__ = ["LinearSolution", "solve", "run", "rotation_quat", "block_jacobi",
           "factorize", "DIRECT_MAX_DOFS", "CG_RTOL"]

DIRECT_MAX_DOFS = 12_000    # free DOFs up to which SuperLU is used (bench_linear.py)
DIRECT_MAX_DOFS_PLANE = 300_000   # ... in a plane model (Kirsch plate, 18 909 DOFs: SuperLU
                                  # 1.0 s, block-Jacobi CG 988 iterations 30 s, beside a
                                  # busy process)
CG_RTOL = 1e-10             # relative residual of the CG solve
REFINE = 2                  # steps of iterative refinement after the direct solve


class LinearSolution:
    """U (N, 6) [m, rad]; reaction (N, 6) [N, N m] constraint force K U − F
    on constrained DOFs (0 on free ones); support (N, 3) [N] support-spring
    force on each body; method ("direct" | "cg"); iterations (CG, 0 for
    direct); residual (relative); K the assembled stiffness; times (s)."""

    def __init__(self, **kw):
        self.__dict__.update(kw)

    @property
    def body_reaction(self):
        """Force of the ground on each body (N, 3) [N]: supports + constraints."""
        return self.support + self.reaction[:, :3]


def factorize(A):
    """SuperLU factors of a sparse symmetric positive definite A (COLAMD
    ordering, diagonal pivots preferred)."""
    return spla.splu(sp.csc_matrix(A), permc_spec="COLAMD",
                     options=dict(SymmetricMode=True))


def block_jacobi(A, body):
    """Inverse of the diagonal blocks of A (body-wise) as a LinearOperator.

    A: (n, n) sparse symmetric (the free block of K); body (n,): body index of
    each row.  Rows of one body form one block (up to 6 × 6)."""
    n = A.shape[0]
    uniq, local = np.unique(body, return_inverse=True)
    # position of each row inside its body's block
    order = np.argsort(local, kind="stable")
    start = np.searchsorted(local[order], np.arange(len(uniq)))
    pos = np.empty(n, dtype=np.int64)
    pos[order] = np.arange(n) - start[local[order]]
    C = A.tocoo()
    same = local[C.row] == local[C.col]
    blocks = np.zeros((len(uniq), 6, 6))
    blocks[:, np.arange(6), np.arange(6)] = 1.0          # padding: identity
    sizes = np.bincount(local, minlength=len(uniq))
    for k in range(6):                                   # clear the used diagonal
        blocks[sizes > k, k, k] = 0.0
    np.add.at(blocks, (local[C.row[same]], pos[C.row[same]], pos[C.col[same]]), C.data[same])
    inv = np.linalg.inv(blocks)

    def matvec(x):
        x = np.asarray(x).reshape(-1)
        pad = np.zeros((len(uniq), 6))
        pad[local, pos] = x
        y = np.einsum("bij,bj->bi", inv, pad)
        return y[local, pos]

    return spla.LinearOperator((n, n), matvec=matvec, dtype=float)


def solve(model, *, K=None, load=None, method="auto", rtol=CG_RTOL, maxiter=None):
    """K U = F for `model` (loads at full amplitude; fixed and prescribed
    DOFs from model.dof_kind/dof_value).  Returns a LinearSolution.
    Raises ValueError on a prescribed velocity, an unrestrained rigid-body
    motion or a singular reduced stiffness; RunFailed when CG does not reach
    `rtol` within `maxiter` (default 20 000) iterations."""
    t0 = _time.perf_counter()
    n = model.n_bodies
    if K is None:
        K = stiffness_matrix(model)
    K = sp.csr_matrix(K)
    t_asm = _time.perf_counter() - t0
    load = model_load(model) if load is None else np.asarray(load, float)
    kind = model.dof_kind.reshape(-1)
    if np.any(kind == VELOCITY):
        raise ValueError("a prescribed velocity has no meaning in a linear static solve")
    F = load.reshape(-1)
    free = kind == FREE
    pres = ~free
    U = np.zeros(6 * n)
    disp = kind == DISPLACEMENT
    U[disp] = model.dof_value.reshape(-1)[disp]
    U[kind == FIXED] = 0.0
    if _free_rigid_motion(model, K, pres):
        raise ValueError("the stiffness is singular: a rigid-body motion is not restrained "
                         "(add supports or fixed components)")
    Kf = K[free]
    Kff = Kf[:, free]
    b = F[free] - Kf[:, pres] @ U[pres]
    nf = Kff.shape[0]
    if method == "auto":
        # a plane model's matrix factors with the fill-in of a 2D mesh
        # (nested dissection: O(n log n) entries): direct far beyond the 3D limit
        limit = DIRECT_MAX_DOFS_PLANE if getattr(model, "plane", "") else DIRECT_MAX_DOFS
        method = "direct" if nf <= limit else "cg"
    t1 = _time.perf_counter()
    iterations = 0
    if nf:
        if method == "direct":
            lu = factorize(Kff)
            x = lu.solve(b)
            for _ in range(REFINE):                      # iterative refinement
                x = x + lu.solve(b - Kff @ x)
        elif method == "cg":
            body = np.nonzero(free)[0] // 6
            P = block_jacobi(Kff, body)
            count = [0]

            def step(_):
                count[0] += 1
            x, info = spla.cg(Kff, b, rtol=rtol, atol=0.0, M=P,
                              maxiter=maxiter or 20_000, callback=step)
            iterations = count[0]
            if info != 0:
                raise RunFailed(f"conjugate gradients did not converge in {iterations} "
                                 f"iterations (relative residual {_rel(Kff, x, b):.3g})")
        else:
            raise ValueError(f"unknown method {method!r} (direct, cg, auto)")
        if not np.all(np.isfinite(x)):
            raise ValueError("the reduced stiffness is singular (a mechanism)")
        U[free] = x
    residual = _rel(Kff, U[free], b) if nf else 0.0
    t_solve = _time.perf_counter() - t1
    R = K @ U - F
    R[free] = 0.0
    U = U.reshape(n, 6)
    f = spring_forces(model, U)
    sup = model.is_support
    support = np.zeros((n, 3))
    np.add.at(support, model.spring_bodies[sup, 0], f[sup])
    return LinearSolution(U=U, reaction=R.reshape(n, 6), support=support, method=method,
                          iterations=iterations, residual=residual, K=K, load=load,
                          n_free=nf, assembly_time=t_asm, solve_time=t_solve)


def _rel(A, x, b):
    nb_ = np.linalg.norm(b)
    return float(np.linalg.norm(A @ x - b) / nb_) if nb_ > 0 else float(np.linalg.norm(A @ x))


def rotation_quat(theta):
    """Unit quaternions (N, 4) of the exact rotations by rotation vectors
    theta (N, 3) [rad] (axis θ/|θ|, angle |θ|)."""
    ang = np.linalg.norm(theta, axis=1)
    half = 0.5 * ang
    with np.errstate(invalid="ignore", divide="ignore"):
        fac = np.where(ang > 1e-300, np.sin(half) / ang, 0.5)
    return np.column_stack([np.cos(half), theta * fac[:, None]])


def displaced_state(model, U):
    """State at the displacement U (N, 6): x = x0 + u, q = exp(θ) q0."""
    n = model.n_bodies
    state = new_state(model)
    state.body_pos[:n] = model.body_pos0[:n] + U[:, :3]
    q = quat_mul_np(rotation_quat(U[:, 3:]), model.body_quat0[:n])
    q /= np.linalg.norm(q, axis=1)[:, None]
    state.body_quat[:n] = q
    refresh_all_rotations(n + 1, state.body_quat, model.body_quat0, state.body_rot, state.body_dq)
    return state


def run(case, model, recorder, *, max_steps=None, progress=None):
    """Solve the linear static case and write two frames (undeformed and
    solved).  `max_steps` is ignored (a direct solve has no steps)."""
    from .explicit import spring_pass
    n = model.n_bodies
    try:
        sol = solve(model)
    except ValueError as exc:
        raise _case_error(case, str(exc)) from None
    zero = np.zeros((n, 3))
    state0 = new_state(model)
    spring_pass(model, state0)
    obs0 = {"kinetic": 0.0, "strain": 0.0, "external_work": 0.0, "damping": 0.0,
            "n_broken": 0.0, "residual": 0.0}
    recorder.append(state0, 0, 0.0, zero, zero, obs0, np.zeros(n))
    state = displaced_state(model, sol.U)
    spring_pass(model, state)              # spring_force field (kernel, at x0 + u)
    state.body_reaction[:] = sol.body_reaction
    Uf = sol.U.reshape(-1)
    strain = 0.5 * float(Uf @ (sol.K @ Uf))                   # ½ UᵀKU
    work = 0.5 * float((sol.load.reshape(-1) + sol.reaction.reshape(-1)) @ Uf)  # ½ (F + R)ᵀU
    obs = {"kinetic": 0.0, "strain": strain, "external_work": work, "damping": 0.0,
           "n_broken": 0.0, "residual": sol.residual}
    recorder.append(state, 1, 1.0, zero, zero, obs, np.ones(n))
    return dict(method=sol.method, iterations=sol.iterations, residual=sol.residual,
                n_free=sol.n_free, assembly_time=sol.assembly_time, solve_time=sol.solve_time,
                strain=strain, external_work=work, solution=sol)


def _case_error(case, message):
    """A CaseError naming the boundary (or the solver mode) for a solve
    that the case's supports and constraints make impossible."""
    from ..case import GroupVelocity
    for i, b in enumerate(case.boundary):
        if isinstance(b, GroupVelocity) and "velocity" in message:
            return case.error(("boundary", i, "velocity"),
                              f"not usable in mode {case.solver.mode}: {message}")
    path = ("boundary",) if case.boundary else ("solver", "mode")
    return case.error(path, f"mode {case.solver.mode}: {message}")
