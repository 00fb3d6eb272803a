"""Spring-point kernels: corotational kinematics and the elastic law.

One pass over spring points writes, per spring s, the force on body a
(`spring_force[s]`, world frame [N]; body b gets the opposite) and the
point where it acts (`spring_mid[s]`, the midpoint of the two material
points [m]).  Nothing is accumulated per body here: bodies gather their
springs through a CSR map (physics/integrate.py), so there are no atomics
and results do not depend on the thread count.

Kinematics (DESIGN.md §1): the material points of spring s are
p_a = x_a + R_a r_a and p_b = x_b + R_b r_b (arms r in the principal
frames); the gap d = p_b − p_a is resolved in the spring frame turned by the
mid rotation increment of the two bodies, Δq_m = normalize(Δq_a ± Δq_b),
Δq = q q0⁻¹.  A rigid motion of the pair gives δ = 0 at any rotation size.
Traction (Kawai 1978, eq. 13 form): σn = k_n δn, τs = k_s δs, τt = k_t δt;
`spring_k` already holds stiffness × area [N/m].
"""

import numba as nb
import numpy as np

from .rotation import quat_mul

JIT = dict(cache=True, nogil=True, fastmath=False, error_model="numpy")


@nb.njit(inline="always", **JIT)
def gap_and_scaled_frame(s, spring_bodies, spring_arm_a, spring_arm_b, spring_frame0,
                         body_pos, body_rot, body_dq):
    """World gap d, midpoint m, scaled spring frame G = n2·F (columns n, s, t)
    and the scale n2 of spring s.

    The mid increment m = Δq_a ± Δq_b is not normalised: p = m ⊗ q0 has
    |p|² = |m|² = n2 (q0 is a unit quaternion), and the homogeneous form of
    the rotation matrix gives G = n2·R(p/|p|) without a square root.  The
    kernels divide by n2 once, off the critical path: a sqrt followed by a
    division in the chain of every spring made the pass latency-bound
    (benchmarks/results/elastic.txt).

    Returns (d0, d1, d2, m0, m1, m2, G as 9 scalars row-major, n2)."""
    a = spring_bodies[s, 0]
    b = spring_bodies[s, 1]
    ax, ay, az = spring_arm_a[s, 0], spring_arm_a[s, 1], spring_arm_a[s, 2]
    bx, by, bz = spring_arm_b[s, 0], spring_arm_b[s, 1], spring_arm_b[s, 2]
    Ra = body_rot[a]
    Rb = body_rot[b]
    pa0 = body_pos[a, 0] + Ra[0, 0] * ax + Ra[0, 1] * ay + Ra[0, 2] * az
    pa1 = body_pos[a, 1] + Ra[1, 0] * ax + Ra[1, 1] * ay + Ra[1, 2] * az
    pa2 = body_pos[a, 2] + Ra[2, 0] * ax + Ra[2, 1] * ay + Ra[2, 2] * az
    pb0 = body_pos[b, 0] + Rb[0, 0] * bx + Rb[0, 1] * by + Rb[0, 2] * bz
    pb1 = body_pos[b, 1] + Rb[1, 0] * bx + Rb[1, 1] * by + Rb[1, 2] * bz
    pb2 = body_pos[b, 2] + Rb[2, 0] * bx + Rb[2, 1] * by + Rb[2, 2] * bz
    # mid rotation increment (DESIGN.md §1), sign-aligned quaternions
    qa0, qa1, qa2, qa3 = body_dq[a, 0], body_dq[a, 1], body_dq[a, 2], body_dq[a, 3]
    qb0, qb1, qb2, qb3 = body_dq[b, 0], body_dq[b, 1], body_dq[b, 2], body_dq[b, 3]
    if qa0 * qb0 + qa1 * qb1 + qa2 * qb2 + qa3 * qb3 < 0.0:
        qb0, qb1, qb2, qb3 = -qb0, -qb1, -qb2, -qb3
    m0, m1, m2, m3 = qa0 + qb0, qa1 + qb1, qa2 + qb2, qa3 + qb3
    n2 = m0 * m0 + m1 * m1 + m2 * m2 + m3 * m3
    f = spring_frame0[s]
    w, x, y, z = quat_mul(m0, m1, m2, m3, f[0], f[1], f[2], f[3])
    # homogeneous rotation matrix of the unnormalised quaternion p (|p|² = n2)
    G00 = n2 - 2.0 * (y * y + z * z)
    G01 = 2.0 * (x * y - w * z)
    G02 = 2.0 * (x * z + w * y)
    G10 = 2.0 * (x * y + w * z)
    G11 = n2 - 2.0 * (x * x + z * z)
    G12 = 2.0 * (y * z - w * x)
    G20 = 2.0 * (x * z - w * y)
    G21 = 2.0 * (y * z + w * x)
    G22 = n2 - 2.0 * (x * x + y * y)
    return (pb0 - pa0, pb1 - pa1, pb2 - pa2,
            0.5 * (pa0 + pb0), 0.5 * (pa1 + pb1), 0.5 * (pa2 + pb2),
            G00, G01, G02, G10, G11, G12, G20, G21, G22, n2)


@nb.njit(inline="always", **JIT)
def gap_and_frame(s, spring_bodies, spring_arm_a, spring_arm_b, spring_frame0,
                  body_pos, body_rot, body_dq):
    """World gap d, midpoint m and spring frame F (columns n, s, t) of spring s.

    Returns (d0, d1, d2, m0, m1, m2, F as 9 scalars row-major)."""
    (d0, d1, d2, m0, m1, m2,
     G00, G01, G02, G10, G11, G12, G20, G21, G22, n2) = gap_and_scaled_frame(
        s, spring_bodies, spring_arm_a, spring_arm_b, spring_frame0,
        body_pos, body_rot, body_dq)
    c = 1.0 / n2
    return (d0, d1, d2, m0, m1, m2,
            c * G00, c * G01, c * G02, c * G10, c * G11, c * G12, c * G20, c * G21, c * G22)


@nb.njit(parallel=True, **JIT)
def elastic_spring_pass(spring_bodies, spring_arm_a, spring_arm_b, spring_frame0, spring_k,
                        body_pos, body_rot, body_dq, spring_force, spring_mid):
    """Linear-elastic springs: force on body a, f = F diag(k) Fᵀ d [N]
    (with F = G/n2: f = G diag(k/n2²) Gᵀ d)."""
    for s in nb.prange(spring_bodies.shape[0]):
        (d0, d1, d2, m0, m1, m2,
         G00, G01, G02, G10, G11, G12, G20, G21, G22, n2) = gap_and_scaled_frame(
            s, spring_bodies, spring_arm_a, spring_arm_b, spring_frame0,
            body_pos, body_rot, body_dq)
        # local gap δ = Fᵀ d = Gᵀ d / n2, traction × area = k δ
        c = 1.0 / (n2 * n2)
        fn = (c * spring_k[s, 0]) * (G00 * d0 + G10 * d1 + G20 * d2)
        fs = (c * spring_k[s, 1]) * (G01 * d0 + G11 * d1 + G21 * d2)
        ft = (c * spring_k[s, 2]) * (G02 * d0 + G12 * d1 + G22 * d2)
        spring_force[s, 0] = G00 * fn + G01 * fs + G02 * ft
        spring_force[s, 1] = G10 * fn + G11 * fs + G12 * ft
        spring_force[s, 2] = G20 * fn + G21 * fs + G22 * ft
        spring_mid[s, 0] = m0
        spring_mid[s, 1] = m1
        spring_mid[s, 2] = m2


@nb.njit(parallel=True, **JIT)
def spring_local_gap(spring_bodies, spring_arm_a, spring_arm_b, spring_frame0,
                     body_pos, body_rot, body_dq, out_delta):
    """Local gap δ = (δn, δs, δt) of every spring [m] (output steps only)."""
    for s in nb.prange(spring_bodies.shape[0]):
        (d0, d1, d2, m0, m1, m2,
         G00, G01, G02, G10, G11, G12, G20, G21, G22, n2) = gap_and_scaled_frame(
            s, spring_bodies, spring_arm_a, spring_arm_b, spring_frame0,
            body_pos, body_rot, body_dq)
        c = 1.0 / n2
        out_delta[s, 0] = c * (G00 * d0 + G10 * d1 + G20 * d2)
        out_delta[s, 1] = c * (G01 * d0 + G11 * d1 + G21 * d2)
        out_delta[s, 2] = c * (G02 * d0 + G12 * d1 + G22 * d2)


def elastic_energy(spring_k, delta):
    """Strain energy ½ Σ k δ² [J] of linear springs (NumPy, output steps)."""
    return 0.5 * float(np.sum(spring_k * delta * delta))
