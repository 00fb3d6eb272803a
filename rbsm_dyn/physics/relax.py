"""Dynamic relaxation kernel (static solutions).

Fictitious masses and a spherical fictitious inertia per body (mass scaling:
every body stable at a unit step, Underwood 1983, from Gershgorin row sums
of the stiffness), and Cundall's local non-viscous damping (Cundall 1987;
Itasca PFC/UDEC "local damping"): each force component is reduced by
β|F| against the direction of the velocity, F_d = F − β|F| sign(v).
"""
import math

import numba as nb
import numpy as np

from .integrate import DISPLACEMENT, FIXED, FREE, gather, refresh_rotation
from .rotation import quat_mul
from .springs import elastic_spring_pass

JIT = dict(cache=True, nogil=True, fastmath=False, error_model="numpy")


@nb.njit(inline="always", **JIT)
def _sign(x):
    return 1.0 if x > 0.0 else (-1.0 if x < 0.0 else 0.0)


@nb.njit(parallel=True, **JIT)
def relax_body_pass(lam, beta, ground, csr_ptr, csr_spring, csr_sign, spring_bodies,
                    spring_force, spring_mid, body_mass_real, fict_mass, fict_inertia,
                    body_pos, body_pos0, body_quat, body_quat0, body_vel, body_angmom,
                    body_rot, body_dq, body_fext, body_mext, gravity,
                    dof_kind, dof_value, arm_length, body_resid, body_reaction):
    """One unit step of damped fictitious dynamics at load factor lam.

    body_resid[i] gets |unbalanced force|² + |unbalanced moment/arm_length|²
    over the free components; body_reaction the support/constraint force."""
    for i in nb.prange(fict_mass.shape[0]):
        g = gather(i, ground, csr_ptr, csr_spring, csr_sign, spring_bodies, spring_force,
                   spring_mid, body_pos)
        m = fict_mass[i]
        res = 0.0
        for k in range(3):
            f = g[k] + lam * (body_fext[i, k] + body_mass_real[i] * gravity[k])
            kind = dof_kind[i, k]
            if kind == FREE:
                res += f * f
                v = body_vel[i, k]
                v += (f - beta * abs(f) * _sign(v)) / m
                body_vel[i, k] = v
                body_pos[i, k] += v
                body_reaction[i, k] = g[6 + k]
            else:
                body_reaction[i, k] = g[6 + k] - f
                body_vel[i, k] = 0.0
                if kind == DISPLACEMENT:
                    body_pos[i, k] = body_pos0[i, k] + lam * dof_value[i, k]
        inertia = fict_inertia[i]
        w0 = w1 = w2 = 0.0
        for k in range(3):
            if dof_kind[i, 3 + k] == FIXED:
                body_angmom[i, k] = 0.0
                continue
            t = g[3 + k] + lam * body_mext[i, k]
            res += (t / arm_length) ** 2
            L = body_angmom[i, k]
            L += t - beta * abs(t) * _sign(L)
            body_angmom[i, k] = L
        w0 = body_angmom[i, 0] / inertia
        w1 = body_angmom[i, 1] / inertia
        w2 = body_angmom[i, 2] / inertia
        ang = math.sqrt(w0 * w0 + w1 * w1 + w2 * w2)
        if ang > 0.0:
            # exact rotation by ω·1 about the world axis ω/|ω|: q <- exp(ω/2) ⊗ q
            s = math.sin(0.5 * ang) / ang
            q = body_quat[i]
            a, b, c, d = quat_mul(math.cos(0.5 * ang), w0 * s, w1 * s, w2 * s,
                                  q[0], q[1], q[2], q[3])
            n = math.sqrt(a * a + b * b + c * c + d * d)
            q[0] = a / n
            q[1] = b / n
            q[2] = c / n
            q[3] = d / n
            refresh_rotation(i, body_quat, body_quat0, body_rot, body_dq)
        body_resid[i] = res


@nb.njit(**JIT)
def run_relax(n_iter, lam, beta, ground,
              spring_bodies, spring_arm_a, spring_arm_b, spring_frame0, spring_k,
              spring_force, spring_mid, csr_ptr, csr_spring, csr_sign,
              body_mass_real, fict_mass, fict_inertia, body_pos, body_pos0, body_quat,
              body_quat0, body_vel, body_angmom, body_rot, body_dq, body_fext, body_mext,
              gravity, dof_kind, dof_value, arm_length, body_resid, body_reaction):
    """n_iter relaxation steps inside compiled code; returns the kinetic energy
    of the fictitious motion after the last one."""
    for _ in range(n_iter):
        elastic_spring_pass(spring_bodies, spring_arm_a, spring_arm_b, spring_frame0,
                            spring_k, body_pos, body_rot, body_dq, spring_force, spring_mid)
        relax_body_pass(lam, beta, ground, csr_ptr, csr_spring, csr_sign, spring_bodies,
                        spring_force, spring_mid, body_mass_real, fict_mass, fict_inertia,
                        body_pos, body_pos0, body_quat, body_quat0, body_vel, body_angmom,
                        body_rot, body_dq, body_fext, body_mext, gravity, dof_kind,
                        dof_value, arm_length, body_resid, body_reaction)
    ek = 0.0
    for i in range(fict_mass.shape[0]):
        for k in range(3):
            ek += 0.5 * fict_mass[i] * body_vel[i, k] ** 2
            ek += 0.5 * body_angmom[i, k] ** 2 / fict_inertia[i]
    return ek
