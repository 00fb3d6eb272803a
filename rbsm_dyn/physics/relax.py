"""Dynamic relaxation kernel (static solutions).

Fictitious masses and a spherical fictitious inertia per body (mass scaling:
every body stable at a unit step, Underwood 1983, from Gershgorin row sums
of the stiffness), advanced at a unit step h = 1 with one of two dampings:

* ADAPTIVE (default): viscous damping c = 2 ω_min, critical for the lowest
  mode, with ω_min² re-estimated every iteration by Underwood's Rayleigh
  quotient uᵀK̃u / uᵀMu of the total displacement u, K̃ the diagonal
  stiffness seen in the last iteration, K̃_ii = −Δr_i/Δu_i (Underwood,
  "Dynamic relaxation", in Computational Methods for Transient Analysis,
  1983, eqs. 6–8).  Velocity update (central difference, h = 1):
      v ← ((2 − c) v + 2 r/m) / (2 + c).
* LOCAL: Cundall's local non-viscous damping (Cundall 1987; Itasca PFC
  "local damping"): each force component is reduced by β|F| against the
  velocity, F_d = F − β|F| sign(v).  Robust for frictional and softening
  problems, slow for smooth elastic ones.
"""
import math

import numba as nb

from .integrate import DISPLACEMENT, FIXED, FREE, refresh_rotation
from .rotation import quat_mul
from .passes import spring_forces

JIT = dict(cache=True, nogil=True, fastmath=False, error_model="numpy")

ADAPTIVE, LOCAL = 0, 1


@nb.njit(inline="always", **JIT)
def _sign(x):
    return 1.0 if x > 0.0 else (-1.0 if x < 0.0 else 0.0)


@nb.njit(inline="always", **JIT)
def _damped(v, f, m, kind, beta, c):
    """New (fictitious) velocity from v under force f, mass m, unit step."""
    if kind == LOCAL:
        return v + (f - beta * abs(f) * _sign(v)) / m
    return ((2.0 - c) * v + 2.0 * f / m) / (2.0 + c)


@nb.njit(inline="always", **JIT)
def _rayleigh(u, v_prev, f, f_prev, m, reset):
    """This DOF's share (uᵀK̃u, uᵀMu) of Underwood's quotient."""
    if reset or v_prev == 0.0:
        return 0.0, m * u * u
    return u * u * (f_prev - f) / v_prev, m * u * u


@nb.njit(inline="always", **JIT)
def _relax_translate(i, lam, kind, beta, c, reset, body_wrench, body_support, body_mass_real,
                     fict_mass, body_pos, body_pos0, body_vel, body_fext, gravity, dof_kind,
                     dof_value, body_reaction, body_rprev):
    """Body i's translations over one unit step (relax_body_pass); returns
    its running (residual, Rayleigh numerator, denominator)."""
    g = body_wrench[i]
    sup = body_support[i]
    m = fict_mass[i]
    res = 0.0
    num = 0.0
    den = 0.0
    for k in range(3):
        f = g[k] + lam * (body_fext[i, k] + body_mass_real[i] * gravity[k])
        dk = dof_kind[i, k]
        if dk == FREE:
            res += f * f
            v = body_vel[i, k]
            a, b = _rayleigh(body_pos[i, k] - body_pos0[i, k], v, f, body_rprev[i, k],
                             m, reset)
            num += a
            den += b
            body_rprev[i, k] = f
            v = _damped(v, f, m, kind, beta, c)
            body_vel[i, k] = v
            body_pos[i, k] += v
            body_reaction[i, k] = sup[k]
        else:
            body_reaction[i, k] = sup[k] - f
            body_vel[i, k] = 0.0
            if dk == DISPLACEMENT:
                body_pos[i, k] = body_pos0[i, k] + lam * dof_value[i, k]
    return res, num, den


@nb.njit(inline="always", **JIT)
def _relax_rotate(i, lam, kind, beta, c, reset, res, num, den, body_wrench, body_mext,
                  fict_inertia, dof_kind, arm_length, body_angmom, body_theta, body_rprev,
                  body_quat, body_quat0, body_rot, body_dq, body_resid, body_num, body_den):
    """Body i's rotations over one unit step (relax_body_pass), with the
    running sums of _relax_translate."""
    g = body_wrench[i]
    inertia = fict_inertia[i]
    for k in range(3):
        if dof_kind[i, 3 + k] == FIXED:
            body_angmom[i, k] = 0.0
            continue
        t = g[3 + k] + lam * body_mext[i, k]
        res += (t / arm_length) ** 2
        L = body_angmom[i, k]
        a, b = _rayleigh(body_theta[i, k], L / inertia, t, body_rprev[i, 3 + k],
                         inertia, reset)
        num += a
        den += b
        body_rprev[i, 3 + k] = t
        body_angmom[i, k] = _damped(L, t, 1.0, kind, beta, c)
    w0 = body_angmom[i, 0] / inertia
    w1 = body_angmom[i, 1] / inertia
    w2 = body_angmom[i, 2] / inertia
    body_theta[i, 0] += w0
    body_theta[i, 1] += w1
    body_theta[i, 2] += w2
    ang = math.sqrt(w0 * w0 + w1 * w1 + w2 * w2)
    if ang > 0.0:
        # exact rotation by ω·1 about the world axis ω/|ω|: q <- exp(ω/2) ⊗ q
        s = math.sin(0.5 * ang) / ang
        q = body_quat[i]
        a, b, cc, d = quat_mul(math.cos(0.5 * ang), w0 * s, w1 * s, w2 * s,
                               q[0], q[1], q[2], q[3])
        n = math.sqrt(a * a + b * b + cc * cc + d * d)
        q[0] = a / n
        q[1] = b / n
        q[2] = cc / n
        q[3] = d / n
        refresh_rotation(i, body_quat, body_quat0, body_rot, body_dq)
    body_resid[i] = res
    body_num[i] = num
    body_den[i] = den


@nb.njit(parallel=True, **JIT)
def _relax_bodies_parallel(lam, c, reset, bodies, loads, bs, relax):
    # the fields into locals before the prange (physics/arrays.py)
    body_mass_real, body_inertia, body_pos0, body_quat0 = bodies
    (body_fext, body_mext, body_ffol, body_mfol, body_load_hist, gravity, dof_kind, dof_value,
     dof_hist, hist_ptr, hist_t, hist_a, ground_hist, ground_dir) = loads
    (body_pos, body_quat, body_vel, body_angmom, body_rot, body_dq, body_wrench, body_support,
     body_work, body_damp, body_reaction, spring_force) = bs
    (fict_mass, fict_inertia, arm_length, kind, beta, body_resid, body_theta, body_rprev,
     body_num, body_den) = relax
    for i in nb.prange(fict_mass.shape[0]):
        res, num, den = _relax_translate(i, lam, kind, beta, c, reset, body_wrench,
                                         body_support, body_mass_real, fict_mass, body_pos,
                                         body_pos0, body_vel, body_fext, gravity, dof_kind,
                                         dof_value, body_reaction, body_rprev)
        _relax_rotate(i, lam, kind, beta, c, reset, res, num, den, body_wrench, body_mext,
                      fict_inertia, dof_kind, arm_length, body_angmom, body_theta, body_rprev,
                      body_quat, body_quat0, body_rot, body_dq, body_resid, body_num, body_den)


@nb.njit(**JIT)
def _relax_bodies_serial(lam, c, reset, bodies, loads, bs, relax):
    body_mass_real, body_inertia, body_pos0, body_quat0 = bodies
    (body_fext, body_mext, body_ffol, body_mfol, body_load_hist, gravity, dof_kind, dof_value,
     dof_hist, hist_ptr, hist_t, hist_a, ground_hist, ground_dir) = loads
    (body_pos, body_quat, body_vel, body_angmom, body_rot, body_dq, body_wrench, body_support,
     body_work, body_damp, body_reaction, spring_force) = bs
    (fict_mass, fict_inertia, arm_length, kind, beta, body_resid, body_theta, body_rprev,
     body_num, body_den) = relax
    for i in range(fict_mass.shape[0]):
        res, num, den = _relax_translate(i, lam, kind, beta, c, reset, body_wrench,
                                         body_support, body_mass_real, fict_mass, body_pos,
                                         body_pos0, body_vel, body_fext, gravity, dof_kind,
                                         dof_value, body_reaction, body_rprev)
        _relax_rotate(i, lam, kind, beta, c, reset, res, num, den, body_wrench, body_mext,
                      fict_inertia, dof_kind, arm_length, body_angmom, body_theta, body_rprev,
                      body_quat, body_quat0, body_rot, body_dq, body_resid, body_num, body_den)


@nb.njit(**JIT)
def relax_body_pass(lam, c, reset, bodies, loads, bs, relax, parallel):
    """One unit step of damped fictitious dynamics at load factor lam
    (bodies, loads: the Model's, body_mass the real masses for gravity;
    relax: arrays.Relaxation, the fictitious masses and the iteration's
    arrays).  `parallel` None: one thread (the same numbers).

    body_resid[i] gets |unbalanced force|² + |unbalanced moment/arm_length|²
    over the free components; body_reaction the support/constraint force.
    body_theta (N, 3): total rotation (sum of the increments) [rad];
    body_rprev (N, 6): unbalanced force of the previous iteration (`reset`:
    a new load step, no estimate this iteration); body_num, body_den (N,):
    this body's part of the Rayleigh quotient."""
    if parallel is None:
        _relax_bodies_serial(lam, c, reset, bodies, loads, bs, relax)
    else:
        _relax_bodies_parallel(lam, c, reset, bodies, loads, bs, relax)


@nb.njit(**JIT)
def run_relax(n_iter, lam, c, reset, bodies, springs, loads, bs, hist, aux, relax, parallel):
    """n_iter relaxation steps inside compiled code: the force passes of
    the explicit step (physics/passes.py: springs, then the auxiliary stress
    if `aux`), then the relaxation's body pass.  `reset` starts a load step
    (no quotient from its first iteration).  Returns (kinetic energy of the
    fictitious motion after the last step, the damping coefficient c to
    continue with)."""
    kind = relax.kind
    body_num = relax.body_num
    body_den = relax.body_den
    fict_mass = relax.fict_mass
    fict_inertia = relax.fict_inertia
    body_vel = bs.body_vel
    body_angmom = bs.body_angmom
    for it in range(n_iter):
        first = reset and it == 0
        # constants: a spring pass compiled for them (physics/integrate.py)
        spring_forces(springs, bs, hist, aux, False, 0.0, parallel)
        relax_body_pass(lam, c, first, bodies, loads, bs, relax, parallel)
        if kind == ADAPTIVE:
            # Underwood's quotient -> ω_min², c = 2 ω_min
            # (Underwood 1983); serial sum so that any thread count agrees
            num = 0.0
            den = 0.0
            for i in range(body_num.shape[0]):
                num += body_num[i]
                den += body_den[i]
            if den > 0.0 and num > 0.0:
                c = min(2.0 * math.sqrt(num / den), 1.9)
    ek = 0.0
    for i in range(fict_mass.shape[0]):
        for k in range(3):
            ek += 0.5 * fict_mass[i] * body_vel[i, k] ** 2
            ek += 0.5 * body_angmom[i, k] ** 2 / fict_inertia[i]
    return ek, c
