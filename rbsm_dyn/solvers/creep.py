"""A static run in time (`solver: {mode: static, time: [...]}`): creep and
relaxation over days by Newton increments in time (issue 28, item 4).

Each increment goes from the last instant t0 to the next t1: loads and
prescribed displacements at their `history` amplitude at t1 (gravity
always whole), equilibrium by Newton's iterations (solvers/newton.py
_increment, at λ = 1), the viscous springs stepped over dt = t1 − t0 by
their exact integration (physics/viscous.py: the Maxwell branches'
exponential update and the Kelvin spring's, both exact for histories
linear over the step, so the step may be as long as the history is
straight: a creep curve over 1 000 days in a few dozen increments).  The
iteration matrix is the springs' stiffness times their algorithmic
factor for dt, 1 + Σ g_i (b_i − 1) for the branches and 1/(1 − b) for a
Kelvin spring (the derivative of the updates).  An increment that does
not converge is split in two (MAX_CUTS times at most); a frame at each
instant of `solver.time` (the frame's `time`, not λ).
"""
import time as _time

import numpy as np

from ..model import new_state
from ..physics.integrate import DISPLACEMENT, amplitude
from ..physics.laws import BROKEN
from ..physics.rotation import quat_matrix_np
from ..physics.viscous import viscous_pass
from .explicit import RunFailed, load_amplitude
from .newton import MAX_CUTS, NEWTON_MAX_IT, _increment, _set_reactions
from .newton_linear import one_blas_thread
from .newton_state import _restore, _save
from .newton_system import Newton
from .passes import (Options, body_state, model_arrays, parallel_arg, step_factors,
                     viscous_springs)
from .statics import record_frame


def loads_at(model, amp):
    """The applied loads (N, 6) [N, N m] with each body's amplitude amp (N,)
    (length 0: no loads), gravity whole; followers at their reference
    direction (stiffness.model_load's small-strain convention)."""
    m = model
    n = m.n_bodies
    a = amp[:, None] if len(amp) else np.zeros((n, 1))
    load = np.zeros((n, 6))
    load[:, :3] = a * m.body_fext + m.body_mass[:, None] * m.gravity[None, :]
    load[:, 3:] = a * m.body_mext
    if len(m.body_ffol):
        R0 = quat_matrix_np(m.body_quat0[:n])
        load[:, :3] += a * np.einsum("nij,nj->ni", R0, m.body_ffol)
        load[:, 3:] += a * np.einsum("nij,nj->ni", R0, m.body_mfol)
    return load


class TimeNewton(Newton):
    """Newton's iteration at an instant t1 reached from t0 (module docstring)."""

    def __init__(self, model):
        super().__init__(model)
        self.opt = Options.of(model)
        self.t = 0.0
        self.dt = 0.0
        self.factor = None
        self.amp = np.zeros(0)

    def at(self, t0, t1):
        """Aim the iteration at instant t1 from t0: loads, tangent factors."""
        m = self.m
        self.t, self.dt = float(t1), float(t1 - t0)
        self.amp = load_amplitude(m, self.t)
        self.F = loads_at(m, self.amp).reshape(-1)
        if m.viscous:
            _, b = step_factors(m.law_branch_tau, self.dt, True)
            factor = 1.0 + np.sum(m.law_branch_g * (b - 1.0), axis=1)
            kelvin = m.law_dashpot > 0.0
            _, kb = step_factors(m.law_dashpot[kelvin], self.dt, True)
            factor[kelvin] += 1.0 / (1.0 - kb) - 1.0
            self.factor = factor

    def set_prescribed(self, state, lam):
        """Prescribed displacements at their amplitude at t (λ unused)."""
        m = self.m
        d = m.dof_kind[:, :3] == DISPLACEMENT
        if not np.any(d):
            return
        hist = m.dof_hist[:, :3][d]
        amp = np.array([amplitude(int(h), self.t, m.hist_ptr, m.hist_t, m.hist_a)
                        for h in np.unique(hist)])
        amp = amp[np.searchsorted(np.unique(hist), hist)]
        state.body_pos[:-1][d] = m.body_pos0[:-1][d] + amp * m.dof_value[:, :3][d]

    def trial(self, state, commit=False):
        """The spring wrenches (Newton.trial) plus the viscous springs'
        stepped over dt from the committed state (commit: written)."""
        out = super().trial(state, commit)
        m = self.m
        visc = viscous_springs(m, state, self.opt, copy=not commit, dt=self.dt, static=True)
        if visc is not None:
            viscous_pass(model_arrays(m)[1], body_state(state), visc, True,
                         parallel_arg(self.opt))
        return out

    def local(self, state, tri):
        """The springs' local stiffnesses times their factor for dt."""
        k, frames, turned = super().local(state, tri)
        if self.factor is not None:
            f = self.factor[self.m.spring_law]
            if tri[0] is not None:
                f = np.where(tri[0] < BROKEN, f, 1.0)
            k = k * f[:, None, None]
        return k, frames, turned


def run(case, model, recorder, *, max_steps=None, progress=None):
    """Solve the static case at the instants of solver.time (module
    docstring), BLAS on one thread as newton.run."""
    with one_blas_thread():
        return _run(case, model, recorder, max_steps=max_steps, progress=progress)


def _run(case, model, recorder, *, max_steps=None, progress=None):
    sol = case.solver
    m = model
    try:
        nt = TimeNewton(m)
    except ValueError as exc:
        raise case.error(("boundary",), str(exc)) from None
    state = new_state(m)
    state.dt = 1.0
    t_wall = _time.perf_counter()
    instants = sol.instants()
    record_frame(recorder, m, state, 0, 0.0, 0.0, time=0.0, load=np.zeros((m.n_bodies, 6)),
                 amp=np.zeros(m.n_bodies))
    if progress:
        progress.start(100, 1.0)
    t0 = 0.0
    total = 0
    iterations = []
    for t1 in instants:
        pending = [t1]
        cuts = 0
        while pending:
            target = pending[-1]
            nt.at(t0, target)
            saved = _save(state)
            ok, _, its, ratio = _increment(nt, state, 1.0, 1.0, None, sol.tolerance, False)
            total += its
            if ok:
                nt.trial(state, commit=True)
                iterations.append(its)
                t0 = target
                pending.pop()
                continue
            _restore(state, saved)
            cuts += 1
            if cuts > MAX_CUTS or (max_steps is not None and total >= max_steps):
                msg = (f"the increment to t = {target:.4g} s did not converge in "
                       f"{NEWTON_MAX_IT} Newton iterations after {MAX_CUTS} halvings: "
                       f"residual ratio {ratio:.3g} > tolerance {sol.tolerance:g}")
                recorder.fail(msg)
                raise RunFailed(msg)
            pending.append(0.5 * (t0 + target))
        _set_reactions(nt, state, 1.0)
        amp = nt.amp if len(nt.amp) else np.ones(m.n_bodies)
        record_frame(recorder, m, state, total, 1.0, ratio, time=t1,
                     load=nt.F.reshape(m.n_bodies, 6), amp=amp)
        if progress:
            progress.update(100.0 * (instants.index(t1) + 1) / len(instants), t1, ratio,
                            label="residual")
        if max_steps is not None and total >= max_steps:
            return dict(iterations=iterations, wall_time=_time.perf_counter() - t_wall,
                        state=state, converged=False)
    return dict(iterations=iterations, wall_time=_time.perf_counter() - t_wall, state=state,
                converged=True)
