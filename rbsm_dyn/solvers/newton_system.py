"""The system the static Newton iteration solves (solvers/newton.py's
docstring): the iteration object Newton of one model, its residual r =
f_springs(x) + λ F from the spring kernels' trial forces (IMPL-EX's held
damage and held normal status among them: hold_damage, hold_status), the
force scale of the convergence ratio, the springs' local stiffnesses
(solvers/newton_tangent.py) and the iteration matrix with the geometric
stiffness past GEOMETRIC_ANGLE (solvers/assembly.py), and the choice of
its linear solver (solvers/newton_linear.py); a model no support holds is
held at one body, its loads' resultant balanced by inertia relief
(_hold_rigid_motion).  The increments and their iterations are
newton.py's; nothing here imports it.
"""
import numpy as np
import scipy.linalg as sla

from ..physics.integrate import DISPLACEMENT, FREE, VELOCITY
from ..physics.laws import BROKEN, P_RUPT
from ..physics.laws.rupture import MIXED, SOFTENING
from ..physics.passes import spring_forces
from ..physics.rotation import quat_matrix_np, quat_mul_np
from ..physics.springs import spring_local_gap
from ..stiffness import free_rigid_modes, model_load, world_inertia
from .newton_contact import _contact_faces, _contact_status
from .newton_linear import OPEN_FRACTION, _Full, _LowRank, _WithGeometric, _dof_order
from .newton_tangent import _local_tangents
from .passes import Options, aux_stress, body_state, history, model_arrays, parallel_arg

SLIP_FLOOR = 1e-2       # a slipping face's tangent along the slip / its secant (regularisation)
GEOMETRIC_ANGLE = 1e-2    # rotation [rad] beyond which the geometric stiffness is added
REF_FLOOR = 1e-3        # the force scale's floor, a share of the largest met (Newton.reference)


class Newton:
    """The iteration of one model: residuals and secant stiffnesses."""

    def __init__(self, model):
        m = model
        self.m = m
        n = m.n_bodies
        self.n = n
        self.F = model_load(m).reshape(-1)                 # reference load (N·6)
        kind = m.dof_kind.reshape(-1)
        if np.any(kind == VELOCITY):
            raise ValueError("a prescribed velocity has no meaning in a static solve "
                             "(use displacement)")
        self.free = kind == FREE
        self.disp = kind == DISPLACEMENT
        self.Up = np.where(self.disp, m.dof_value.reshape(-1), 0.0)   # full amplitude
        # a model nothing holds (a disc between two pressures): its free
        # rigid motions are held at one body and the loads' imbalance is
        # balanced by inertia relief (_hold_rigid_motion)
        self.held, self.relief, self.note = _hold_rigid_motion(m, self.free, self.F)
        if self.relief is not None:
            self.free[self.held] = False
            self.F = self.F - self.relief
        self.arm = float(np.median(np.linalg.norm(m.spring_arm_a, axis=1))) or 1.0
        # the norm weights: moments divided by the median arm (as relax.py)
        w = np.ones((n, 6))
        w[:, 3:] = 1.0 / self.arm
        self.w = w.reshape(-1)
        from .assembly import BlockPattern
        self.pattern = BlockPattern(m)
        self.order = _dof_order(m, self.free)
        # the springs' per-point constants (Model's properties gather them
        # from the faces at every access)
        self.laws = (m.spring_k, m.spring_area, m.spring_h, m.spring_law, m.law_params)
        self._laws, self._frozen = self.laws, None
        # continuum yield (solvers/newton_plastic.py): the plastic strain
        # (C+1, 6) the present increment has given each cell so far, which
        # every trial adds to its springs' plastic gaps, and the cells'
        # stress at the last trial
        self.continuum = m.cell_k.shape[0] > 0 and bool(np.any(m.cell_k > 0.0))
        self.deps = np.zeros((m.cell_k.shape[0], 6)) if self.continuum else None
        self.sigma = None
        self.K_aux = None
        if m.poisson_on:
            from ..physics.poisson import poisson_stiffness
            self.K_aux = poisson_stiffness(m.poisson, n)

    # -- state -------------------------------------------------------------
    def set_prescribed(self, state, lam):
        d = self.m.dof_kind[:, :3] == DISPLACEMENT
        state.body_pos[:-1][d] = self.m.body_pos0[:-1][d] + lam * self.m.dof_value[:, :3][d]

    #: IMPL-EX (Oliver, Huespe & Cante 2008): the damage (S,) the present
    #: increment's iterations hold fixed, None: the implicit law
    implex = None

    def hold_damage(self, dmg):
        """Iterate the next increment at the damage `dmg` (S,) held fixed
        (IMPL-EX: the damaging laws then act as damaged elastic springs,
        their secant the exact tangent); None: the implicit laws again."""
        self.implex = dmg
        self.hold = None
        if dmg is None:
            self.laws = self._laws
            return
        if self._frozen is None:
            P = self.m.law_params.copy()
            soft = np.isin(P[:, P_RUPT], (SOFTENING, MIXED))
            P[soft, P_RUPT] = 0.0
            self._frozen = P
        self.laws = self._laws[:4] + (self._frozen,)

    def trial(self, state, commit=False):
        """Spring wrenches at the present positions from the committed
        history (commit: write the new history into the state); returns the
        trial spring states and damage (for the secant stiffness).  With a
        held damage (hold_damage) the damaging springs take it and do not
        grow it."""
        m = self.m
        opt = Options.of(m)
        bodies, springs, loads = model_arrays(m)
        hist = history(state, opt, copy=not commit)
        if self.implex is not None:
            springs = springs._replace(law_params=self._frozen)
            hist.spring_dmg[:] = self.implex
        if self.continuum:
            hist.cell_dep[:] = self.deps
        spring_forces(springs, body_state(state), hist, aux_stress(m, state, opt), True, 0.0,
                      parallel_arg(opt))
        if self.continuum:
            self.sigma = hist.cell_sigma.copy()
            if commit:
                # (the increment's plastic strain is in the gaps now)
                hist.cell_dep[:] = 0.0
        sstate, dmg = (None, None) if hist is None else (hist.spring_state, hist.spring_dmg)
        return sstate, dmg

    def residual(self, state, lam):
        """r (N·6) = spring wrenches + λ F, and the trial spring states."""
        tri = self.trial(state)
        if self.hold is not None:
            self._held_wrench(state)
        r = state.body_wrench[:self.n].reshape(-1) + lam * self.F
        return r, tri

    #: (damaged (H,), tension (H,) bool, faces (C,), closed (C,) bool):
    #: the springs whose normal status an IMPL-EX increment holds once it has
    #: iterated HOLD_AFTER times (hold_status), None: each at its present gap
    hold = None

    def hold_status(self, state, tri):
        """Hold the normal status of the damaged intact springs and of the
        contact faces at their present gaps for the rest of the increment: a
        damaged spring in tension at (1 − D) kn, in compression at kn, a face
        closed at kn, open at nothing, whichever side of zero its gap goes
        (IMPL-EX's explicit treatment of the unilateral and contact
        conditions, Oliver, Huespe & Cante 2008: with the damage held, the
        increment is then smooth; the springs that would flip sit at a gap
        near zero, where the two forces differ little)."""
        en, _, gap = self._normal_gap(state)
        idx = np.flatnonzero((tri[0] < BROKEN) & (self.implex > 0.0) & (self.implex < 1.0))
        faces = _contact_faces(self, state, tri)
        self.hold = (idx, en[idx] > 0.0, faces, _contact_status(self, state, gap, faces) > 0)

    def _normal_gap(self, state):
        """(e_n, g_n, gap): an intact spring's normal gap less its plastic
        one, a contact face's less its compaction (the zero it closes at:
        _contact_status), (S,) [m], and the local gaps (S, 3)."""
        m = self.m
        gap = np.empty((m.n_springs, 3))
        spring_local_gap(model_arrays(m)[1], body_state(state), gap)
        dp = state.spring_dp[:, 0]
        return gap[:, 0] - dp, gap[:, 0] - np.minimum(dp, 0.0), gap

    def _held_wrench(self, state):
        """Add to body_wrench the forces by which the held springs
        (hold_status) differ from the kernel's, which took each at its
        present gap: ∓D kn e_n along the normal of a damaged spring, kn e_n
        for a held-closed face that opened, minus the whole contact force
        of a held-open face that closed."""
        m = self.m
        idx, tension, faces, closed = self.hold
        en, g0, gap = self._normal_gap(state)
        flip = np.flatnonzero(tension != (en[idx] > 0.0))
        s1 = idx[flip]
        dfn = np.where(tension[flip], -1.0, 1.0) * self.implex[s1] * m.spring_k[s1, 0] * en[s1]
        now = _contact_status(self, state, gap, faces) > 0
        opened = faces[closed & ~now]
        shut = faces[~closed & now]
        if s1.size + opened.size + shut.size == 0:
            return
        s = np.concatenate([s1, opened, shut])
        n = self.n
        sb = m.spring_bodies[s]
        dq = quat_mul_np(state.body_quat[sb[:, 0]], _conj(m.body_quat0[sb[:, 0]]))
        normal = quat_matrix_np(quat_mul_np(dq, m.spring_frame0[s]))[:, :, 0]
        dfn = np.concatenate([dfn, m.spring_k[opened, 0] * g0[opened], np.zeros(shut.size)])
        df = normal * dfn[:, None]
        df[s1.size + opened.size:] = -state.spring_force[shut]
        R = state.body_rot
        ra = np.einsum("sij,sj->si", R[sb[:, 0]], m.spring_arm_a[s])
        rb = np.einsum("sij,sj->si", R[sb[:, 1]], m.spring_arm_b[s])
        w = state.body_wrench
        np.add.at(w[:, :3], sb[:, 0], df)
        np.add.at(w[:, 3:], sb[:, 0], np.cross(ra, df))
        inner = sb[:, 1] < n
        np.add.at(w[:, :3], sb[inner, 1], -df[inner])
        np.add.at(w[:, 3:], sb[inner, 1], -np.cross(rb[inner], df[inner]))

    def norm(self, r):
        return float(np.linalg.norm((r * self.w)[self.free]))

    def _step_scale(self, dlam):
        """The largest prescribed translation [m] of a change dlam of λ."""
        up = self.Up.reshape(self.n, 6)[:, :3] if self.n else np.zeros((0, 3))
        return float(abs(dlam) * np.max(np.linalg.norm(up, axis=1))) if up.size else 0.0

    ref_max = 0.0           # the largest force scale met so far

    def reference(self, r, lam, support):
        """Scale of the forces for the convergence ratio: the applied loads
        and the constraint forces (reactions), plus the support springs'
        (support (N, 3) [N]); at least REF_FLOOR of the largest met so far,
        so that a specimen broken through (no force left) converges on
        forces small against those it carried, not on round-off."""
        applied = np.linalg.norm((lam * self.F * self.w))
        cons = np.linalg.norm((r * self.w)[~self.free])
        ref = applied + cons + np.linalg.norm(support)
        self.raw = ref
        self.ref_max = max(self.ref_max, ref)
        return max(ref, REF_FLOOR * self.ref_max)

    # -- linear solves -----------------------------------------------------
    # (lu, cg_iterations, factorizations: kept by newton_linear.py's
    # _preconditioned_solve from one iteration to the next; symmetric: read by it)
    lu = None
    use_tangent = True
    #: slipping contact faces at their secant μ|σn|/|τ*| K along the slip
    #: (not SLIP_FLOOR of it) for the rest of the increment: set when a
    #: correction had to be shortened (newton._increment, STEP_LIMIT)
    slip_secant = False
    active = None           # the gaps (S, 3) the contact faces' tangents are taken at, None: the present
    symmetric = True
    cg_iterations = 0
    factorizations = 0

    # -- stiffness ---------------------------------------------------------
    def local(self, state, tri):
        """(k, frames, turned) of the present iteration: every spring's local
        stiffness (S, 3, 3) at its trial state (_local_tangents), the spring
        frames (S, 4) turned with body a (the mid frame to first order), and
        whether some body has turned by more than GEOMETRIC_ANGLE."""
        m = self.m
        sstate, dmg = tri
        self.tangent = False
        k = np.zeros((m.n_springs, 3, 3))
        if sstate is not None:
            gap = np.empty((m.n_springs, 3))
            spring_local_gap(model_arrays(m)[1], body_state(state), gap)
            cgap = gap if self.active is None else self.active
            self.tangent = bool(_local_tangents(
                self.laws,
                (sstate, dmg), (state.spring_dmg, state.spring_kappa, state.spring_dp), gap,
                cgap, OPEN_FRACTION, 1.0 if self.slip_secant else SLIP_FLOOR, self.use_tangent,
                k))
        else:
            k[:, [0, 1, 2], [0, 1, 2]] = self.laws[0]
        if self.hold is not None:
            idx, tension, faces, closed = self.hold
            kn = self.laws[0][idx, 0]
            k[idx, 0, 0] = np.where(tension, (1.0 - self.implex[idx]) * kn, kn)
            # a held-open face: open_fraction of its stiffness; a held-closed
            # one that has opened: its normal spring whole
            op = faces[~closed]
            k[op] = 0.0
            k[op[:, None], [0, 1, 2], [0, 1, 2]] = OPEN_FRACTION * self.laws[0][op]
            cl = faces[closed]
            k[cl, 0, 0] = self.laws[0][cl, 0]
        n = self.n
        dq = quat_mul_np(state.body_quat[:n], _conj(m.body_quat0[:n]))
        dq = np.vstack([dq, [[1.0, 0, 0, 0]]])
        frames = quat_mul_np(dq[m.spring_bodies[:, 0]], m.spring_frame0)
        angle = 2.0 * np.arccos(np.clip(np.abs(dq[:n, 0]), 0.0, 1.0))
        return k, frames, bool(angle.size and angle.max() > GEOMETRIC_ANGLE)

    def stiffness(self, state, tri, local=None):
        """Iteration matrix (6N × 6N) in the present configuration: the
        springs' local stiffnesses (_local_tangents), their geometric
        stiffness once rotations are finite."""
        m = self.m
        k, frames, turned = self.local(state, tri) if local is None else local
        # the geometric stiffness of the spring forces (solvers/assembly.py
        # _geometric) once some body has turned by more than GEOMETRIC_ANGLE:
        # the exact Jacobian of an elastic residual (checked against finite
        # differences, tests/test_newton.py), not symmetric
        self.symmetric = not turned and not self.tangent
        if not turned:
            K = self.pattern.matrix(m, state.body_quat, frames, k)
        else:
            sb = m.spring_bodies
            R = state.body_rot
            pa = state.body_pos[sb[:, 0]] + np.einsum("sij,sj->si", R[sb[:, 0]], m.spring_arm_a)
            pb = state.body_pos[sb[:, 1]] + np.einsum("sij,sj->si", R[sb[:, 1]], m.spring_arm_b)
            K = self.pattern.matrix(m, state.body_quat, frames, k, force=state.spring_force,
                                    gap=pb - pa)
        return K if self.K_aux is None else (K + self.K_aux).tocsr()

    # -- the iteration's linear solver ---------------------------------------
    low_rank = None          # _LowRank, kept while rotations stay small
    #: the iteration's matrix is the whole present one, with the geometric
    #: stiffness of the spring forces (IMPL-EX: _WithGeometric; past
    #: GEOMETRIC_ANGLE: _Full), else the low-rank modified Newton's
    #: (_LowRank); switched by newton._increment_or_retry
    whole = True
    #: _Full served an iteration of the present increment
    full_used = False

    def linear(self, state, tri):
        """The linear solver of this iteration: _LowRank (one factorisation
        updated by the springs that changed) while no body has turned by
        more than GEOMETRIC_ANGLE or `whole` is off, else _Full (the whole
        matrix with the geometric stiffness assembled); under IMPL-EX
        _WithGeometric on the low-rank factors while `whole` is on."""
        local = self.local(state, tri)
        k, frames, turned = local
        if not turned or not self.whole or self.implex is not None:
            if self.low_rank is None or not self.low_rank.update(k):
                try:
                    self.low_rank = _LowRank(self, state, k, frames)
                except RuntimeError:          # singular: _Full says so
                    self.low_rank = None
                    return _Full(self, self.stiffness(state, tri, local))
                self.factorizations += 1
                self.low_rank.update(k, limit=False)
            if self.implex is not None and self.whole:
                # (IMPL-EX: the geometric stiffness of the spring forces
                # too, solved on the low-rank factors, renewed here when
                # they no longer precondition; newton.py's docstring)
                def renew():
                    self.low_rank = _LowRank(self, state, k, frames)
                    self.factorizations += 1
                    self.low_rank.update(k, limit=False)
                    return self.low_rank
                return _WithGeometric(self, self.stiffness(state, tri, (k, frames, True)),
                                      self.low_rank, renew)
            return self.low_rank
        self.full_used = True
        return _Full(self, self.stiffness(state, tri, local))


def _hold_rigid_motion(m, free, F):
    """(held DOFs, relief (N·6) or None, note) for a model whose supports
    leave r > 0 rigid motions free (stiffness.free_rigid_modes; a body
    under self-balancing loads): r components of the body nearest the
    centre of mass are held (those on which the free motions are
    independent: a QR with column pivoting), which removes the motions and
    nothing else, and the loads' resultant on the free motions is
    balanced by inertia relief, the d'Alembert forces of the rigid
    acceleration it gives the free body, F − M Φ (Φᵀ M Φ)⁻¹ Φᵀ F (MSC
    Nastran Linear Static Analysis User's Guide, "Inertia Relief"): the
    held components then carry no force, and a run in equilibrium is the
    quasi-static one of the free body."""
    n = m.n_bodies
    modes = free_rigid_modes(m, ~free)
    r = modes.shape[1]
    if r == 0:
        return np.zeros(0, dtype=np.int64), None, ""
    # M Φ, M the bodies' mass and world inertia (stiffness.mass_matrix)
    J = world_inertia(m)
    P = modes.reshape(n, 6, r)
    MP = np.empty_like(P)
    MP[:, :3] = m.body_mass[:, None, None] * P[:, :3]
    MP[:, 3:] = np.einsum("nij,njr->nir", J, P[:, 3:])
    MP = MP.reshape(6 * n, r)
    relief = MP @ np.linalg.solve(modes.T @ MP, modes.T @ F)
    x = m.body_pos0[:n]
    c = np.average(x, axis=0, weights=m.body_mass)
    # the body: one whose free components carry every free motion (all six
    # in 3D, u, v, θ in a plane model), the nearest the centre of mass
    fb = free.reshape(n, 6)
    able = fb.sum(axis=1) >= r
    if not np.any(able):
        raise ValueError("nothing holds the model's rigid motion and no body is free to hold "
                         "it: add supports")
    i = int(np.argmin(np.where(able, np.linalg.norm(x - c, axis=1), np.inf)))
    rows = np.flatnonzero(fb[i])
    _, _, piv = sla.qr(modes[6 * i + rows].T, pivoting=True)
    held = 6 * i + np.sort(rows[piv[:r]])
    net = np.linalg.norm(relief.reshape(n, 6)[:, :3].sum(axis=0))
    total = 0.5 * np.abs(F.reshape(n, 6)[:, :3]).sum()
    note = (f"no support holds {r} rigid motion{'s' * (r > 1)} of the model: Newton holds them "
            f"at body {i} (the one nearest the centre of mass), which carries no force, and "
            f"balances the loads' resultant ({net:.3g} N, {net / max(total, 1e-300):.2%} of "
            f"half the loads' absolute sum) by inertia relief")
    return held, relief, note


def _conj(q):
    return q * np.array([1.0, -1.0, -1.0, -1.0])
