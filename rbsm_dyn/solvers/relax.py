"""Static mode: dynamic relaxation in load steps.

For load step j = 1..n the loads and prescribed displacements are scaled by
λ_j = j/n and the damped fictitious dynamics (physics/relax.py) iterate
until the unbalanced-force ratio ‖r‖ / (‖F_applied‖ + ‖M_applied‖/ℓ +
‖reactions‖) is at most (moments enter divided by ℓ, the median spring arm)
`solver.tolerance` and the fictitious kinetic energy is at most 1e-8 × the
external work (VERIFICATION.md, general).  Each converged load step is one
history frame, whose `time` is the load factor λ (dimensionless) and `step`
the total iteration count.  A load step that does not converge within
`solver.max_iterations` stops the run with a clear message.
"""
import time as _time

import numpy as np

from ..model import dof_row_sums, new_state
from ..physics.arrays import Relaxation
from ..physics.relax import ADAPTIVE, LOCAL, run_relax
from .explicit import RunFailed  # noqa: F401  (re-exported)
from .passes import Options, aux_stress, body_state, history, model_arrays, parallel_arg
from .statics import apply_increment, load_work, record_frame  # noqa: F401 (re-exported)

GERSHGORIN_SAFETY = 0.81   # λ_max(M⁻¹K) ≤ 4·0.81 at a unit step


def fictitious_masses(model, beta):
    """Per-body masses and spherical inertias stable at a unit step.  Local
    damping scales a force by up to (1 + β) when it opposes the velocity,
    so the Gershgorin bound is raised by that factor."""
    rows = dof_row_sums(model) * (1.0 + beta)
    m = rows[:, :3].max(axis=1) / (4 * GERSHGORIN_SAFETY)
    inertia = rows[:, 3:].max(axis=1) / (4 * GERSHGORIN_SAFETY)
    m[m <= 0] = 1.0
    inertia[inertia <= 0] = 1.0
    return m, inertia


def run(case, model, recorder, *, max_steps=None, progress=None, check_every=200):
    """Solve the static case; returns figures (iterations per load step).
    `solver.method: newton` goes to solvers/newton.py, a run in time
    (`solver.time`) to solvers/creep.py."""
    sol = case.solver
    if getattr(sol, "time", None) is not None:
        from . import creep
        return creep.run(case, model, recorder, max_steps=max_steps, progress=progress)
    if getattr(sol, "method", "relaxation") == "newton":
        from . import newton
        return newton.run(case, model, recorder, max_steps=max_steps, progress=progress)
    state = new_state(model)
    state.dt = 1.0
    m = model
    kind = LOCAL if sol.relaxation == "local" else ADAPTIVE
    beta = sol.damping_factor if kind == LOCAL else 0.0
    fm, fi = fictitious_masses(m, beta)
    n = m.n_bodies
    theta, rprev = np.zeros((n, 3)), np.zeros((n, 6))
    num, den = np.zeros(n), np.zeros(n)
    arm = float(np.median(np.linalg.norm(m.spring_arm_a, axis=1))) or 1.0
    resid = np.zeros(m.n_bodies)
    relax = Relaxation(fm, fi, arm, kind, float(beta), resid, theta, rprev, num, den)
    opt = Options.of(m)
    bodies, springs, loads = model_arrays(m)
    par = parallel_arg(opt)
    n_steps = sol.load_steps
    iterations = []
    total = 0
    t_wall = _time.perf_counter()
    record_frame(recorder, m, state, 0, 0.0, 0.0)
    if progress:
        progress.start(n_steps, 1.0)
    step_u = elastic_predictor(m) if sol.predictor else None
    c = 0.0
    for j in range(1, n_steps + 1):
        lam = j / n_steps
        if step_u is not None:
            apply_increment(m, state, step_u / n_steps)
            theta += np.where(m.dof_kind[:, 3:] == 0, step_u[:, 3:] / n_steps, 0.0)
        # prescribed displacements take their value before the first spring pass
        disp = m.dof_kind[:, :3] == 3
        state.body_pos[:-1][disp] = m.body_pos0[:-1][disp] + lam * m.dof_value[:, :3][disp]
        it = 0
        while True:
            k = min(check_every, sol.max_iterations - it)
            if max_steps is not None:
                k = min(k, max(0, int(max_steps) - total))
            ek, c = run_relax(k, lam, c, it == 0, bodies, springs, loads, body_state(state),
                              history(state, opt), aux_stress(m, state, opt), relax, par)
            it += k
            total += k
            if not np.all(np.isfinite(state.body_pos)):
                msg = f"dynamic relaxation diverged in load step {j} after {it} iterations"
                recorder.fail(msg)
                raise RunFailed(msg)
            applied = lam * (m.body_fext + m.body_mass[:, None] * m.gravity)
            ref = (np.sqrt(np.sum(applied ** 2)) + lam * np.sqrt(np.sum(m.body_mext ** 2)) / arm
                   + np.sqrt(np.sum(state.body_reaction ** 2)))
            ratio = np.sqrt(resid.sum()) / max(ref, 1e-300)
            work = abs(load_work(m, state, lam))
            # converged: forces in balance and the model at rest (kinetic
            # energy below KINETIC_FRACTION of the work of the loads)
            done = ratio <= sol.tolerance and ek <= KINETIC_FRACTION * max(work, 1e-300)
            if progress:
                progress.update(j - 1 + min(1.0, sol.tolerance / max(ratio, 1e-300)), lam, ratio,
                                label="residual")
            if done:
                break
            if max_steps is not None and total >= max_steps:
                record_frame(recorder, m, state, total, lam, ratio)
                return dict(iterations=iterations + [it], wall_time=_time.perf_counter() - t_wall,
                            state=state, converged=False)
            if it >= sol.max_iterations:
                msg = (f"load step {j}/{n_steps} (λ = {lam:.3g}) did not converge in {it} "
                       f"iterations: {_unmet(ratio, sol.tolerance, ek, work)}")
                record_frame(recorder, m, state, total, lam, ratio)
                recorder.fail(msg)
                raise RunFailed(msg)
        iterations.append(it)
        record_frame(recorder, m, state, total, lam, ratio)
    return dict(iterations=iterations, wall_time=_time.perf_counter() - t_wall, state=state,
                converged=True)


#: a load step of dynamic relaxation is at rest when its kinetic energy is
#: below this fraction of the work of the loads
KINETIC_FRACTION = 1e-8


def _unmet(ratio, tolerance, ek, work):
    """The convergence criteria a load step did not meet, each with its
    value, and what to do."""
    unmet = []
    if not ratio <= tolerance:
        unmet.append(f"residual ratio {ratio:.3g} > tolerance {tolerance:g}")
    if not ek <= KINETIC_FRACTION * max(work, 1e-300):
        unmet.append(f"kinetic energy {ek:.3g} J > {KINETIC_FRACTION:g} × the work of the "
                     f"loads ({work:.3g} J): the model still moves")
    return ("; ".join(unmet) + "; raise solver.max_iterations, or use solver.method: newton "
            "(path following, few iterations per load step)")


PREDICTOR_MAX_BODIES = 5_000     # above this the sparse direct solve costs more than it saves
                                 # (benchmarks/results/linear.txt: 5.7 s at 2 000 bodies)


def elastic_predictor(model):
    """Small-strain linear solution U (N, 6) [m, rad] of the full load and
    prescribed displacements (Kawai's assembled K, rbsm_dyn/stiffness.py),
    or None when K is singular (a mechanism) or the model is too large.

    Each load step starts from the previous equilibrium moved by its share
    of U (an elastic predictor, as in implicit codes): an elastic problem is
    then already in equilibrium, and a prescribed displacement reaches the
    whole body at once instead of straining the springs next to it first,
    which in a plastic model would yield them spuriously."""
    from ..stiffness import solve_linear
    if model.n_bodies > PREDICTOR_MAX_BODIES:
        return None
    try:
        U, _ = solve_linear(model)
    except ValueError:
        return None
    return U if np.all(np.isfinite(U)) else None
