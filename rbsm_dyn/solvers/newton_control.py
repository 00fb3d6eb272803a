"""The path control of the static Newton solver (solvers/newton.py's
docstring, "Control"): a relative-displacement probe's value and
linearisation (probe_functional), the step of indirect displacement
control, δU = δU_r + δλ δU_F (_direction, _combine), the load for
`stop_fraction` (_load), and the switch of plain displacement control to
the opening of the first crack (_cracking, _auto_control, its increment
_auto_increment, and its first increment's start on the branch that
started cracking, _branch_predictor).  The increment loop that uses them
is newton.py's; nothing here imports it.
"""
import numpy as np

from ..physics.laws import BROKEN, P_EPSCR, P_FT, P_GF
from ..physics.rotation import quat_matrix_np, quat_mul_np
from ..physics.springs import spring_local_gap
from .newton_state import _restore, _save
from .newton_system import _conj
from .passes import body_state, model_arrays
from .statics import apply_increment


def probe_functional(model, state, plan):
    """(value, c (N·6)) of a relative-displacement probe: its present value
    and its linearisation δτ = c·δU (translations; a material point's
    rotation lever r × e)."""
    n = model.n_bodies
    kind, a, b, proj = plan[:4]
    if isinstance(proj, str):
        if proj == "magnitude":
            raise ValueError("a probe with component magnitude cannot control a static run: "
                             "give a component x, y or z, or a direction")
        e = np.eye(3)["xyz".index(proj)]
    else:
        e = np.asarray(proj, float)
    c = np.zeros((n, 6))
    if kind == "groups":
        for ids, s in ((a, -1.0), (b, 1.0)):
            c[ids, :3] += s * e / len(ids)
        du = (np.mean(state.body_pos[b] - model.body_pos0[b], axis=0)
              - np.mean(state.body_pos[a] - model.body_pos0[a], axis=0))
    else:
        du = np.zeros(3)
        for (i, arm, p), s in ((a, -1.0), (b, 1.0)):
            r = state.body_rot[i] @ arm
            c[i, :3] += s * e
            c[i, 3:] += s * np.cross(r, e)
            du += s * (state.body_pos[i] + r - p)
    return float(du @ e), c.reshape(-1)


def _cracking(m, state):
    """The springs damaged since the start (a cut's or an interface's are
    broken from the start: not cracking)."""
    return (state.spring_dmg > 0.0) & (m.spring_state0 < BROKEN)


def _auto_control(nt, state):
    """Indirect control for a run given by prescribed displacements alone
    (no solver.control), once cracking starts: the path parameter becomes
    the normal opening of the most open damaged spring between two cells
    at `state` (the increment in which cracking started), a relative
    displacement that only grows while the crack runs, so the softening
    branch and a snap-back are followed (de Borst 1987's indirect
    displacement control, on the most opening point of the process zone).
    Returns the plan for probe_functional, None when only supports are
    damaged."""
    m = nt.m
    n = m.n_bodies
    gap = np.empty((m.n_springs, 3))
    spring_local_gap(model_arrays(m)[1], body_state(state), gap)
    sb = m.spring_bodies
    damaged = (_cracking(m, state) & np.isfinite(state.spring_kappa) & (sb[:, 1] < n))
    if not np.any(damaged):
        return None                   # (only supports damaged: no crack to follow)
    s = int(np.flatnonzero(damaged)[np.argmax(gap[damaged, 0])])
    a, b = int(sb[s, 0]), int(sb[s, 1])
    R0 = quat_matrix_np(m.body_quat0[[a, b]])
    pa = m.body_pos0[a] + R0[0] @ m.spring_arm_a[s]
    pb = m.body_pos0[b] + R0[1] @ m.spring_arm_b[s]
    normal = quat_matrix_np(m.spring_frame0[s][None])[0][:, 0]
    return ("points", (a, m.spring_arm_a[s], pa), (b, m.spring_arm_b[s], pb), normal, s)


def _branch_predictor(nt, state, saved, lam_saved, branch, pos, goal):
    """The start of the first increment of the crack-opening control: the
    converged state `saved` (λ = lam_saved, opening `pos`) moved along the
    displacement increment that started cracking (branch: its converged
    motion, Δλ, Δτ) scaled to the goal, s = (goal − pos)/Δτ ≤ 1 (Crisfield
    vol. 1 §9.5-9.6: the predictor follows the previous increment's
    direction).  From `saved` itself the first matrix holds a notch's faces,
    touching at zero gap, closed, the beam uncracked, the crack-tip spring
    near its neutral axis: δλ = gap/(c·δU_F) came out huge and negative, a
    spurious branch with the load reversed (a plane notched beam, 10 mm
    cells: λ = −118).  Returns (the start state, its λ); `state` is left
    there."""
    m = nt.m
    n = nt.n
    motion, dlam, dtau = branch
    s = min(max((goal - pos) / dtau, 0.0), 1.0)
    dU = np.zeros((n, 6))
    dU[:, :3] = motion["body_pos"][:n] - saved["body_pos"][:n]
    dq = quat_mul_np(motion["body_quat"][:n], _conj(saved["body_quat"][:n]))
    dq[dq[:, 0] < 0] *= -1
    sn = np.linalg.norm(dq[:, 1:], axis=1)
    ang = 2.0 * np.arctan2(sn, dq[:, 0])
    with np.errstate(invalid="ignore", divide="ignore"):
        fac = np.where(sn > 1e-300, ang / sn, 2.0)
    dU[:, 3:] = dq[:, 1:] * fac[:, None]
    _restore(state, saved)
    apply_increment(m, state, s * dU)
    lam = lam_saved + s * dlam
    nt.set_prescribed(state, lam)
    return _save(state), lam


def _auto_increment(nt, state, plan, done):
    """The increment of the crack-opening control: a twentieth of the opening
    at which the spring's law has lost its strength (linear softening,
    2 G_f/f_t: Hillerborg's characteristic opening; a strain law's ε_cr h),
    or the opening's mean growth per increment so far when larger."""
    m = nt.m
    s = plan[4]
    P = m.law_params[m.spring_law[s]]
    w_c = 0.0
    if P[P_FT] > 0.0 and np.isfinite(P[P_GF]):
        w_c = 2.0 * P[P_GF] / P[P_FT]
    elif P[P_EPSCR] > 0.0:
        w_c = P[P_EPSCR] * m.spring_h[s]
    tau, _ = probe_functional(m, state, plan)
    return max(0.05 * w_c, abs(tau) / max(done, 1), 1e-12)


def _direction(nt, lin, r, controlled):
    """(δU_r, δU_F) of the iteration's linear solver: K δU_r = r, and under
    indirect control K δU_F = F − K_fp U_p (the response to a unit rise of
    λ, the prescribed DOFs at full amplitude; None without control); None
    when the solve fails."""
    free = nt.free
    if controlled:
        X = lin.solve_pair(r[free])
    else:
        X = lin.solve(r[free][:, None])
    if X is None or not np.all(np.isfinite(X)):
        return None
    dU = np.zeros(6 * nt.n)
    dU[free] = X[:, 0]
    dF = None
    if controlled:
        dF = np.zeros(6 * nt.n)
        dF[free] = X[:, 1]
        dF[nt.disp] = nt.Up[nt.disp]
    return dU, dF


def _combine(dU_r, dF, gap, cr, den, alpha):
    """α δU_r + δλ δU_F with δλ = (gap − α c·δU_r)/(c·δU_F): the step that
    keeps the linearised constraint; (step, δλ)."""
    dl = (gap - alpha * cr) / den
    return alpha * dU_r + dl * dF, dl


def _load(nt, state, lam):
    """The load the path parameter λ scales, for `stop_fraction`: with
    prescribed displacements, the constraint force along them (the
    reaction's work-conjugate of λ, R·U_p/|U_p| [N]); with loads only, λ |F|."""
    up = nt.Up[nt.disp]
    norm = float(np.linalg.norm(up))
    if norm > 0.0:
        r = state.body_wrench[:nt.n].reshape(-1)[nt.disp] + lam * nt.F[nt.disp]
        return -float(r @ up) / norm
    return lam * float(np.linalg.norm(nt.F))
