"""Spring-point kernels: corotational kinematics and the elastic law.

One pass over spring points adds, per spring s, its force [N] and its
moment about each body's centre [N m] (world frame; the force acts at the
midpoint of the two material points) straight into the two bodies'
accumulators `body_wrench` (and the support part into `body_support`).
The springs run in the schedule of partition.py: the groups of one phase
share no body, so they run in parallel without atomics, and every body
gets its sum in one fixed order whatever the thread count.  The body pass
then reads six numbers per body.

Kinematics (DESIGN.md §1): the material points of spring s are
p_a = x_a + R_a r_a and p_b = x_b + R_b r_b (arms r in the principal
frames); the gap d = p_b − p_a is resolved in the spring frame turned by the
mid rotation increment of the two bodies, Δq_m = normalize(Δq_a ± Δq_b),
Δq = q q0⁻¹.  A rigid motion of the pair gives δ = 0 at any rotation size.
Traction (Kawai 1978, eq. 13 form): σn = k_n δn, τs = k_s δs, τt = k_t δt;
The points of one face share its row of the face table (spring_slot):
frame, stiffness per area (k = face_k × area [N/m]), length, law.
"""

import numba as nb
import numpy as np

from .jit import NOALIAS
from .rotation import quat_mul

JIT = dict(cache=True, nogil=True, fastmath={"contract"}, error_model="numpy")


@nb.njit(inline="always", **JIT)
def material_points(s, a, b, spring_arm_a, spring_arm_b, body_pos, body_rot):
    """World gap d = p_b − p_a of spring s's two material points
    p = x + R r (bodies a, b as unsigned ids) and the lever arms from the
    two centres to the midpoint m = (p_a + p_b)/2 at which the spring's
    force acts: l_a = m − x_a = R_a r_a + d/2, l_b = m − x_b = R_b r_b − d/2
    (formed from the arms, not from differences of positions, so that a
    model far from the origin keeps its moments' digits).

    Returns (d0, d1, d2, la0, la1, la2, lb0, lb1, lb2)."""
    ax, ay, az = spring_arm_a[s, 0], spring_arm_a[s, 1], spring_arm_a[s, 2]
    bx, by, bz = spring_arm_b[s, 0], spring_arm_b[s, 1], spring_arm_b[s, 2]
    # (indexed in place: a view R = body_rot[a] costs a reference count)
    ua0 = body_rot[a, 0, 0] * ax + body_rot[a, 0, 1] * ay + body_rot[a, 0, 2] * az
    ua1 = body_rot[a, 1, 0] * ax + body_rot[a, 1, 1] * ay + body_rot[a, 1, 2] * az
    ua2 = body_rot[a, 2, 0] * ax + body_rot[a, 2, 1] * ay + body_rot[a, 2, 2] * az
    ub0 = body_rot[b, 0, 0] * bx + body_rot[b, 0, 1] * by + body_rot[b, 0, 2] * bz
    ub1 = body_rot[b, 1, 0] * bx + body_rot[b, 1, 1] * by + body_rot[b, 1, 2] * bz
    ub2 = body_rot[b, 2, 0] * bx + body_rot[b, 2, 1] * by + body_rot[b, 2, 2] * bz
    d0 = (body_pos[b, 0] - body_pos[a, 0]) + (ub0 - ua0)
    d1 = (body_pos[b, 1] - body_pos[a, 1]) + (ub1 - ua1)
    d2 = (body_pos[b, 2] - body_pos[a, 2]) + (ub2 - ua2)
    return (d0, d1, d2, ua0 + 0.5 * d0, ua1 + 0.5 * d1, ua2 + 0.5 * d2,
            ub0 - 0.5 * d0, ub1 - 0.5 * d1, ub2 - 0.5 * d2)


@nb.njit(inline="always", **JIT)
def mid_increment(a, b, body_dq):
    """Unnormalised mid rotation increment q = Δq_a ± Δq_b (sign-aligned,
    DESIGN.md §1) of the pair (a, b) and n2 = |q|².

    q is not normalised: a rotation by q/|q| is the homogeneous quadratic
    form in q divided by n2, so the kernels need no square root and divide
    by n2 once, off the critical path (a sqrt followed by a division in the
    chain of every spring made the pass latency-bound,
    benchmarks/results/elastic.txt).

    Returns (q0, q1, q2, q3, n2)."""
    qa0, qa1, qa2, qa3 = body_dq[a, 0], body_dq[a, 1], body_dq[a, 2], body_dq[a, 3]
    qb0, qb1, qb2, qb3 = body_dq[b, 0], body_dq[b, 1], body_dq[b, 2], body_dq[b, 3]
    if qa0 * qb0 + qa1 * qb1 + qa2 * qb2 + qa3 * qb3 < 0.0:
        qb0, qb1, qb2, qb3 = -qb0, -qb1, -qb2, -qb3
    q0, q1, q2, q3 = qa0 + qb0, qa1 + qb1, qa2 + qb2, qa3 + qb3
    return q0, q1, q2, q3, q0 * q0 + q1 * q1 + q2 * q2 + q3 * q3


@nb.njit(inline="always", **JIT)
def gap_and_mid(s, spring_bodies, spring_arm_a, spring_arm_b, body_pos, body_rot, body_dq):
    """World gap d, lever arms l_a, l_b and the unnormalised mid rotation
    increment q with n2 = |q|² of spring s (material_points, mid_increment).

    Returns (d0, d1, d2, la0, la1, la2, lb0, lb1, lb2, q0, q1, q2, q3, n2)."""
    # body ids are never negative: unsigned skips Numba's wraparound code
    a = np.uint64(spring_bodies[s, 0])
    b = np.uint64(spring_bodies[s, 1])
    d0, d1, d2, la0, la1, la2, lb0, lb1, lb2 = material_points(
        s, a, b, spring_arm_a, spring_arm_b, body_pos, body_rot)
    q0, q1, q2, q3, n2 = mid_increment(a, b, body_dq)
    return d0, d1, d2, la0, la1, la2, lb0, lb1, lb2, q0, q1, q2, q3, n2


@nb.njit(inline="always", **JIT)
def gap_and_scaled_frame(s, spring_bodies, spring_arm_a, spring_arm_b, spring_slot, face_frame0,
                         body_pos, body_rot, body_dq):
    """World gap d, lever arms l_a, l_b, scaled spring frame G = n2·F (columns n, s, t)
    and the scale n2 of spring s: the frame is p = q ⊗ q0 with q the
    unnormalised mid increment (gap_and_mid), |p|² = n2, and the homogeneous
    form of the rotation matrix gives G = n2·R(p/|p|).

    Returns (d0, d1, d2, la0, la1, la2, lb0, lb1, lb2, G as 9 scalars row-major, n2)."""
    (d0, d1, d2, la0, la1, la2, lb0, lb1, lb2, q0, q1, q2, q3, n2) = gap_and_mid(
        s, spring_bodies, spring_arm_a, spring_arm_b, body_pos, body_rot, body_dq)
    f = face_frame0[spring_slot[s]]
    G00, G01, G02, G10, G11, G12, G20, G21, G22 = scaled_frame(
        q0, q1, q2, q3, n2, f[0], f[1], f[2], f[3])
    return (d0, d1, d2, la0, la1, la2, lb0, lb1, lb2,
            G00, G01, G02, G10, G11, G12, G20, G21, G22, n2)


@nb.njit(inline="always", **JIT)
def scaled_frame(q0, q1, q2, q3, n2, f0, f1, f2, f3):
    """G = n2·R(p/|p|) of p = q ⊗ f (q the unnormalised mid increment with
    |q|² = n2, f a unit reference frame): the homogeneous form of the
    rotation matrix, no square root.  Returns G row-major (9 scalars)."""
    w, x, y, z = quat_mul(q0, q1, q2, q3, f0, f1, f2, f3)
    return (n2 - 2.0 * (y * y + z * z), 2.0 * (x * y - w * z), 2.0 * (x * z + w * y),
            2.0 * (x * y + w * z), n2 - 2.0 * (x * x + z * z), 2.0 * (y * z - w * x),
            2.0 * (x * z - w * y), 2.0 * (y * z + w * x), n2 - 2.0 * (x * x + y * y))


@nb.njit(inline="always", **JIT)
def deposit_b(s, a, f0, f1, f2, r0, r1, r2, spring_bodies, body_wrench, body_support):
    """Add the wrench of spring s on body b (force −f at the point m, moment
    r × (−f) with the lever arm r = m − x_b) to b's accumulator; for a support (b is the ground)
    add f to body_support[a] instead.  Body a's share is summed by the
    caller while the springs of a run (they are sorted by a, partition.py)."""
    b = np.uint64(spring_bodies[s, 1])
    if b == body_support.shape[0] - 1:
        body_support[a, 0] += f0
        body_support[a, 1] += f1
        body_support[a, 2] += f2
        return
    body_wrench[b, 0] -= f0
    body_wrench[b, 1] -= f1
    body_wrench[b, 2] -= f2
    body_wrench[b, 3] -= r1 * f2 - r2 * f1
    body_wrench[b, 4] -= r2 * f0 - r0 * f2
    body_wrench[b, 5] -= r0 * f1 - r1 * f0


@nb.njit(inline="always", **JIT)
def flush_a(a, w0, w1, w2, w3, w4, w5, body_wrench):
    """Add a run's summed wrench on body a to its accumulator."""
    body_wrench[a, 0] += w0
    body_wrench[a, 1] += w1
    body_wrench[a, 2] += w2
    body_wrench[a, 3] += w3
    body_wrench[a, 4] += w4
    body_wrench[a, 5] += w5


@nb.njit(inline="always", **JIT)
def add_wrench(s, a, cur, w0, w1, w2, w3, w4, w5, f0, f1, f2, la0, la1, la2, lb0, lb1, lb2,
               spring_bodies, body_wrench, body_support):
    """Book the force f [N] of spring s (acting on body a at the midpoint m,
    −f on body b; lever arms l_a = m − x_a, l_b = m − x_b) for both bodies.  Body a's share goes into the running sum
    (w, of body `cur`; flushed when the springs of a new body a start: they
    are sorted by a, partition.py), body b's straight into its accumulator
    (deposit_b).  Returns the new (cur, w0..w5)."""
    if a != cur:
        flush_a(cur, w0, w1, w2, w3, w4, w5, body_wrench)
        cur = a
        w0 = w1 = w2 = w3 = w4 = w5 = 0.0
    # force f at m on body a: moment l_a × f
    w0 += f0
    w1 += f1
    w2 += f2
    w3 += la1 * f2 - la2 * f1
    w4 += la2 * f0 - la0 * f2
    w5 += la0 * f1 - la1 * f0
    deposit_b(s, a, f0, f1, f2, lb0, lb1, lb2, spring_bodies, body_wrench, body_support)
    return cur, w0, w1, w2, w3, w4, w5


# below this many springs the passes run on one thread: the same order of
# sums (so the same result), without the parallel regions' launch cost,
# which is larger than the work on small models (solvers/passes.py Options)
SERIAL_SPRINGS = 4096


@nb.njit(inline="always", **JIT)
def part_range(p, parts, n):
    """Bodies [i0, i1) of part p of n bodies: those with i·parts // n = p
    (partition.spring_schedule)."""
    return (p * n + parts - 1) // parts, ((p + 1) * n + parts - 1) // parts


@nb.njit(inline="always", **JIT)
def clear_part(p, parts, body_wrench, body_support):
    """Zero the accumulators of the bodies of part p (bodies i with
    i·parts // N = p, partition.py), by the thread that runs phase 0's group
    p: the first to add to them in a pass, and the one whose cache they
    stay in (a serial clear of all bodies made every other thread fetch its
    bodies' lines from the clearing core)."""
    i0, i1 = part_range(p, parts, body_wrench.shape[0] - 1)   # last row: the ground's
    for i in range(i0, i1):
        for k in range(6):
            body_wrench[i, k] = 0.0
        for k in range(3):
            body_support[i, k] = 0.0


@nb.njit(inline="always", **JIT)
def _elastic_group(g, group_ptr, spring_bodies, spring_arm_a, spring_arm_b,
                   spring_slot, face_frame0, face_k, spring_area, body_pos, body_rot, body_dq, body_wrench,
                   body_support, store, spring_force):
    """The springs of group g, in order (partition.py).

    The spring points of one face follow each other (same face id, hence
    the same a, b and frame): their mid rotation and turned normal are
    computed once per face; the rest normal n0 is the first column of the
    face's frame R(q0) (held by no array: 24 B per spring point less)."""
    s0 = group_ptr[g]
    s1 = group_ptr[g + 1]
    if s1 == s0:
        return
    cur = np.uint64(spring_bodies[s0, 0])
    w0 = w1 = w2 = w3 = w4 = w5 = 0.0
    held = np.int64(spring_slot[s0]) + 1    # the face whose q, N are held: not the first
    r0 = r1 = r2 = r3 = 0.0
    q0 = q1 = q2 = q3 = n2 = inv = N0 = N1 = N2 = 0.0
    for s in range(np.uint64(s0), np.uint64(s1)):
        # body ids are never negative: unsigned skips Numba's wraparound code
        a = np.uint64(spring_bodies[s, 0])
        b = np.uint64(spring_bodies[s, 1])
        d0, d1, d2, la0, la1, la2, lb0, lb1, lb2 = material_points(
            s, a, b, spring_arm_a, spring_arm_b, body_pos, body_rot)
        f = np.int64(spring_slot[s])
        if f != held:
            held = f
            r0, r1, r2, r3 = (face_frame0[f, 0], face_frame0[f, 1], face_frame0[f, 2],
                              face_frame0[f, 3])
            # n0 = R(q0) e1 (quaternion q0 = (w, x, y, z) of the frame)
            e0 = 1.0 - 2.0 * (r2 * r2 + r3 * r3)
            e1 = 2.0 * (r1 * r2 + r0 * r3)
            e2 = 2.0 * (r1 * r3 - r0 * r2)
            q0, q1, q2, q3, n2 = mid_increment(a, b, body_dq)
            # n2·n = R(q) n0 by the homogeneous rotation formula of the
            # unnormalised q: (q0² − |v|²) n0 + 2 (v·n0) v + 2 q0 (v × n0)
            # (v = (q1, q2, q3))
            cq = q0 * q0 - (q1 * q1 + q2 * q2 + q3 * q3)
            vn = 2.0 * (q1 * e0 + q2 * e1 + q3 * e2)
            h0 = 2.0 * q0
            N0 = cq * e0 + vn * q1 + h0 * (q2 * e2 - q3 * e1)
            N1 = cq * e1 + vn * q2 + h0 * (q3 * e0 - q1 * e2)
            N2 = cq * e2 + vn * q3 + h0 * (q1 * e1 - q2 * e0)
            inv = 1.0 / (n2 * n2)
        # f = F diag(k) Fᵀ d = k_s d + (k_n − k_s) n (n·d) + (k_t − k_s) t (t·d):
        # the shear pair only needs the normal n when k_t = k_s.
        area = spring_area[s]
        kn = face_k[f, 0] * area
        ks = face_k[f, 1] * area
        kt = face_k[f, 2] * area
        cn = (kn - ks) * inv * (N0 * d0 + N1 * d1 + N2 * d2)
        f0 = ks * d0 + cn * N0
        f1 = ks * d1 + cn * N1
        f2 = ks * d2 + cn * N2
        if kt != ks:
            # a support held in some directions only: t = R(q ⊗ q0) e3
            w, x, y, z = quat_mul(q0, q1, q2, q3, r0, r1, r2, r3)
            T0 = 2.0 * (x * z + w * y)
            T1 = 2.0 * (y * z - w * x)
            T2 = n2 - 2.0 * (x * x + y * y)
            ct = (kt - ks) * inv * (T0 * d0 + T1 * d1 + T2 * d2)
            f0 += ct * T0
            f1 += ct * T1
            f2 += ct * T2
        cur, w0, w1, w2, w3, w4, w5 = add_wrench(
            s, a, cur, w0, w1, w2, w3, w4, w5, f0, f1, f2, la0, la1, la2, lb0, lb1, lb2,
            spring_bodies, body_wrench, body_support)
        if store:
            spring_force[s, 0] = f0
            spring_force[s, 1] = f1
            spring_force[s, 2] = f2
    flush_a(cur, w0, w1, w2, w3, w4, w5, body_wrench)


@nb.njit(**JIT, **NOALIAS)
def _elastic_range(lo, hi, parts, springs, bs, store):
    """Groups lo..hi in order, the group inlined: the one compiled loop of
    the pass, on one thread (small models) or for each group of a phase
    (physics/jit.py)."""
    # the fields into locals before the loop (physics/arrays.py)
    group_ptr = springs.group_ptr
    spring_bodies = springs.spring_bodies
    spring_arm_a = springs.spring_arm_a
    spring_arm_b = springs.spring_arm_b
    spring_slot = springs.spring_slot
    face_frame0 = springs.face_frame0
    face_k = springs.face_k
    spring_area = springs.spring_area
    body_pos = bs.body_pos
    body_rot = bs.body_rot
    body_dq = bs.body_dq
    body_wrench = bs.body_wrench
    body_support = bs.body_support
    spring_force = bs.spring_force
    for g in range(lo, hi):
        if g < parts:
            clear_part(g, parts, body_wrench, body_support)
        _elastic_group(g, group_ptr, spring_bodies, spring_arm_a, spring_arm_b, spring_slot,
                       face_frame0, face_k, spring_area, body_pos, body_rot, body_dq,
                       body_wrench, body_support, store, spring_force)


@nb.njit(parallel=True, **JIT)
def _elastic_phase(lo, hi, parts, springs, bs, store):
    """Groups lo..hi of one phase in parallel (they share no body), a range
    call per group (the containers whole into a compiled call)."""
    for g in nb.prange(lo, hi):
        _elastic_range(np.int64(g), np.int64(g) + 1, parts, springs, bs, store)


@nb.njit(**JIT)
def _elastic_serial(springs, bs, store):
    """Every group in order, one thread (small models: SERIAL_SPRINGS)."""
    phase_ptr = springs.phase_ptr
    _elastic_range(np.int64(0), np.int64(phase_ptr[phase_ptr.shape[0] - 1]), phase_ptr[1],
                   springs, bs, store)


@nb.njit(**JIT)
def elastic_spring_pass(springs, bs, store, parallel):
    """Linear-elastic springs: force on body a, f = F diag(k) Fᵀ d [N]
    (Kawai 1978, eq. 13 form) with the spring frame F turned by the mid
    rotation, summed into the bodies' wrenches (bs: arrays.BodyState);
    `store`: also write each spring's force (output steps).  Phase 0's
    groups first zero their parts' accumulators (clear_part).  `parallel`
    None: one thread in group order (the same sums, so the same result:
    chosen for small models, solvers/passes.py); else phase by phase."""
    if parallel is None:
        _elastic_serial(springs, bs, store)
        return
    phase_ptr = springs.phase_ptr
    parts = phase_ptr[1]
    for ph in range(phase_ptr.shape[0] - 1):
        _elastic_phase(phase_ptr[ph], phase_ptr[ph + 1], parts, springs, bs, store)


@nb.njit(parallel=True, **JIT)
def spring_local_gap(springs, bs, out_delta):
    """Local gap δ = (δn, δs, δt) of every spring [m] (output steps only)."""
    spring_bodies = springs.spring_bodies
    spring_arm_a = springs.spring_arm_a
    spring_arm_b = springs.spring_arm_b
    spring_slot = springs.spring_slot
    face_frame0 = springs.face_frame0
    body_pos = bs.body_pos
    body_rot = bs.body_rot
    body_dq = bs.body_dq
    for s in nb.prange(spring_bodies.shape[0]):
        (d0, d1, d2, la0, la1, la2, lb0, lb1, lb2,
         G00, G01, G02, G10, G11, G12, G20, G21, G22, n2) = gap_and_scaled_frame(
            s, spring_bodies, spring_arm_a, spring_arm_b, spring_slot, face_frame0,
            body_pos, body_rot, body_dq)
        c = 1.0 / n2
        out_delta[s, 0] = c * (G00 * d0 + G10 * d1 + G20 * d2)
        out_delta[s, 1] = c * (G01 * d0 + G11 * d1 + G21 * d2)
        out_delta[s, 2] = c * (G02 * d0 + G12 * d1 + G22 * d2)
