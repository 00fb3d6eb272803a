"""What the two static solvers share (relaxation, solvers/relax.py, and
Newton, solvers/newton.py): moving the bodies by an increment, the work of
the loads, and the frames of the load path."""
import numpy as np

from ..physics.integrate import refresh_all_rotations
from ..physics.rotation import quat_mul_np
from .explicit import spring_pass
from .output import rotation_vectors


def apply_increment(model, state, dU):
    """Move free components by dU (N, 6): translations added, rotations as an
    exact rotation by the world rotation vector θ, q <- exp(θ/2) ⊗ q."""
    n = model.n_bodies
    free = model.dof_kind == 0
    d = np.where(free, dU, 0.0)
    state.body_pos[:n] += d[:, :3]
    th = d[:, 3:]
    ang = np.linalg.norm(th, axis=1)
    turn = ang > 0
    if np.any(turn):
        axis = th[turn] / ang[turn, None]
        dq = np.concatenate([np.cos(0.5 * ang[turn])[:, None],
                             np.sin(0.5 * ang[turn])[:, None] * axis], axis=1)
        q = quat_mul_np(dq, state.body_quat[:n][turn])
        state.body_quat[np.nonzero(turn)[0]] = q / np.linalg.norm(q, axis=1)[:, None]
        refresh_all_rotations(n, state.body_quat, model.body_quat0, state.body_rot, state.body_dq)


def load_work(model, state, lam):
    """Work of the loads at factor lam and of prescribed displacements on the
    current displacement (static: F·u + M·θ, exact for a linear response
    only up to the factor ½ that the strain energy carries) [J]."""
    u = state.body_pos[:-1] - model.body_pos0[:-1]
    applied = lam * (model.body_fext + model.body_mass[:, None] * model.gravity)
    disp = model.dof_kind[:, :3] == 3
    work = float(np.sum(applied * u) + np.sum(state.body_reaction[disp] * u[disp]))
    if np.any(model.body_mext):
        work += float(np.sum(lam * model.body_mext * rotation_vectors(model, state.body_quat)))
    return work


def path_work(recorder, model, state, lam, load=None):
    """External work along the load path [J]: the trapezoidal sum over the
    recorded equilibrium states of ½ (f_k−1 + f_k)·(u_k − u_k−1), f the
    loads at factor λ and the constraint forces on prescribed
    displacements, u the displacements and rotation vectors.  At
    equilibrium it equals strain + plastic + fracture energy (exactly for a
    linear response, to O(Δλ²) otherwise), so a static run's energy
    balance means what a dynamic run's does (issue 13).  `load` (N, 6): the
    applied loads when they are not λ × the full ones (a run in time)."""
    n = model.n_bodies
    f = np.zeros((n, 6))
    if load is None:
        f[:, :3] = lam * (model.body_fext + model.body_mass[:, None] * model.gravity)
        f[:, 3:] = lam * model.body_mext
    else:
        f[:] = load
    disp = model.dof_kind[:, :3] == 3
    cons = state.body_reaction - state.body_support[:n]
    f[:, :3][disp] += cons[disp]
    u = np.zeros((n, 6))
    u[:, :3] = state.body_pos[:n] - model.body_pos0[:n]
    u[:, 3:] = rotation_vectors(model, state.body_quat)[:n]
    prev = getattr(recorder, "_path_work", None)
    if prev is None:
        work = 0.5 * float(np.sum(f * u))        # from the unloaded start
    else:
        f0, u0, w0 = prev
        work = w0 + 0.5 * float(np.sum((f0 + f) * (u - u0)))
    recorder._path_work = (f, u, work)
    return work


def record_frame(recorder, model, state, step, lam, ratio, time=None, load=None, amp=None):
    """One frame of a static solution at load factor lam (velocities zero);
    a run in time (solvers/creep.py): at `time` [s] under `load` (N, 6),
    the bodies' load amplitudes `amp` (N,)."""
    spring_pass(model, state, static=True)
    n = model.n_bodies
    zero = np.zeros((n, 3))
    work = path_work(recorder, model, state, lam, load)
    obs = {"kinetic": 0.0, "strain": recorder.strain_energy(state), "external_work": work,
           "damping": 0.0, "residual": float(ratio)}
    recorder.append(state, step, lam if time is None else time, zero, zero, obs,
                    np.full(n, lam) if amp is None else amp)
