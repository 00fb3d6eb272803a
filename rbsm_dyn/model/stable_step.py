"""Stable step bound: Gershgorin row sums of the small-strain stiffness
(dof_row_sums), of the mass-scaled stiffness (scaled_row_sums), refined by
Collatz–Wielandt sweeps (omega_max_bound, Model.stable_dt)."""
import numba as nb
import numpy as np

from ..physics.poisson import poisson_abs_product
from ..physics.rotation import quat_mul
from ..threads import build_threads


@nb.njit(cache=True)
def _row_sums(spring_bodies, arm_w_a, arm_w_b, spring_k, frames, n, out):
    for s in range(spring_bodies.shape[0]):
        F = frames[s]
        K = np.zeros((3, 3))
        for r in range(3):
            for c in range(3):
                K[r, c] = abs(F[r, 0] * spring_k[s, 0] * F[c, 0] + F[r, 1] * spring_k[s, 1] * F[c, 1]
                              + F[r, 2] * spring_k[s, 2] * F[c, 2])
        # |B| = [I, |[r_a]×|, I, |[r_b]×|]; v = |B| 1
        ra = arm_w_a[s]
        rb = arm_w_b[s] * (0.0 if spring_bodies[s, 1] >= n else 1.0)  # ground: no rotation
        v = np.empty(3)
        for c in range(3):
            v[c] = 2.0 + abs(ra[(c + 1) % 3]) + abs(ra[(c + 2) % 3]) \
                + abs(rb[(c + 1) % 3]) + abs(rb[(c + 2) % 3])
        w = K @ v
        for e, r in ((0, ra), (1, rb)):
            body = spring_bodies[s, e]
            if body >= n:
                continue
            for c in range(3):
                out[body, c] += w[c]
                out[body, 3 + c] += abs(r[(c + 1) % 3]) * w[(c + 2) % 3] \
                    + abs(r[(c + 2) % 3]) * w[(c + 1) % 3]


def dof_row_sums(model, body_rot=None):
    """Row sums of |K| per body DOF (N, 6) of the small-strain stiffness,
    bounded by Σ_springs |B|ᵀ|K_s||B| (Gershgorin)."""
    from ..physics.rotation import quat_matrix_np
    n = model.n_bodies
    rot = quat_matrix_np(model.body_quat0) if body_rot is None else body_rot
    sb = model.spring_bodies
    arm_w_a = np.einsum("sij,sj->si", rot[sb[:, 0]], model.spring_arm_a)
    arm_w_b = np.einsum("sij,sj->si", rot[sb[:, 1]], model.spring_arm_b)
    frames = quat_matrix_np(model.spring_frame0)
    out = np.zeros((n, 6))
    _row_sums(sb, arm_w_a, arm_w_b, model.spring_k, frames, n, out)
    if model.poisson_on:
        out += poisson_abs_product(model.poisson, n, np.ones((n, 6)))
    return out


@nb.njit(cache=True)
def _scaled_row_sums(spring_bodies, spring_arm_a, spring_arm_b, rot, frames, spring_k,
                     body_mass, body_inertia, active, x, out):
    """(P x)_i = Σ_j P_ij x_j with P_ij = Σ_s |K_s,ij| / √(M_i M_j) per body DOF
    (rotations in principal axes; x = 1 gives the Gershgorin row sums), over
    the DOFs j of each body with active[body, j] = 1 (a plane model: x, y
    and the rotation about the principal axis along z):
    K_s = Bᵀ C B with C = F diag(k) Fᵀ and, for end e of the spring,
    B_e = ±[I, −R_e [r_e]×] (r_e the arm in the principal frame; Kawai 1978,
    eq. 8b)."""
    B = np.zeros((3, 12))
    C = np.zeros((3, 3))
    CB = np.zeros((3, 12))
    scale = np.zeros(12)
    for s in range(spring_bodies.shape[0]):
        Fm = frames[s]
        for r in range(3):
            for c in range(3):
                C[r, c] = (Fm[r, 0] * spring_k[s, 0] * Fm[c, 0] + Fm[r, 1] * spring_k[s, 1] * Fm[c, 1]
                           + Fm[r, 2] * spring_k[s, 2] * Fm[c, 2])
        _spring_rows(spring_bodies[s, 0], spring_bodies[s, 1], spring_arm_a[s], spring_arm_b[s],
                     C, rot, body_mass, body_inertia, active, x, out, B, CB, scale)


@nb.njit(cache=True, nogil=True)
def _face_row_sums(tables, inertia, active, x, out, g0, g1, pose):
    """_scaled_row_sums on the model's own tables, over the schedule's
    groups g0 … g1 − 1: each spring's C from its face's frame quaternion
    and stiffness per area (no per-spring frames or stiffnesses: 96 B a
    spring point).  tables = (spring_bodies, arm_a, arm_b, face_frame0,
    face_k, spring_slot, spring_area, group_ptr, phase_ptr); inertia = (rot,
    body_mass, body_inertia).  Without the GIL: scaled_row_sums runs the
    groups of a phase on threads (partition.py: no two share a body).

    pose = (body_pos, body_dq, spring_kappa, spring_state), all empty for
    the reference configuration, else the springs of that deformed state
    (rot then the state's body_rot) as the stiffness sees them: each
    spring's force acts at the midpoint m of its two material points
    (physics/springs.py deposit_b), so its levers are m − x_a = l_a + g/2
    and m − x_b = l_b − g/2 (g the world gap), given in each body's
    principal axes; its frame the mid rotation of the pair's increments
    applied to its reference frame (springs.gap_and_scaled_frame).  A
    broken spring acts only in contact, at a normal gap of about 0: its g
    is the tangential part (its slip); a parted one (spring_kappa = inf,
    physics/inelastic.py) has no stiffness.  With a gap of 0.87 mm on
    1.25 mm levers (cases/impulsive_beam.yaml at 25 mm deflection) the
    exact stable step falls to 0.64 of the undeformed one, which this
    geometry reproduces to 3 digits (tests/test_step_adapt.py).  Spring
    by spring, no per-spring arrays (they were 144 B a spring point)."""
    (spring_bodies, arm_a, arm_b, face_frame0, face_k, spring_slot, spring_area, group_ptr,
     phase_ptr) = tables
    rot, body_mass, body_inertia = inertia
    body_pos, body_dq, spring_kappa, spring_state = pose
    deformed = body_pos.shape[0] > 0
    inelastic = spring_state.shape[0] > 0
    for g in range(g0, g1):
        B = np.zeros((3, 12))
        C = np.zeros((3, 3))
        CB = np.zeros((3, 12))
        scale = np.zeros(12)
        F = np.empty((3, 3))
        la = np.empty(3)
        lb = np.empty(3)
        gap = np.empty(3)
        for s in range(group_ptr[g], group_ptr[g + 1]):
            f = spring_slot[s]
            a = spring_bodies[s, 0]
            b = spring_bodies[s, 1]
            # the face's frame (quat_matrix_np's formula) and k = k/A × A
            # (Model.spring_k); deformed: turned by the mid rotation of the
            # pair's increments and normalised (the docstring's pose)
            w, qx, qy, qz = (face_frame0[f, 0], face_frame0[f, 1], face_frame0[f, 2],
                             face_frame0[f, 3])
            n2 = 1.0
            if deformed:
                qa = body_dq[a]
                qb = body_dq[b]
                sg = (1.0 if qa[0] * qb[0] + qa[1] * qb[1] + qa[2] * qb[2] + qa[3] * qb[3] >= 0.0
                      else -1.0)
                w, qx, qy, qz = quat_mul(qa[0] + sg * qb[0], qa[1] + sg * qb[1],
                                         qa[2] + sg * qb[2], qa[3] + sg * qb[3], w, qx, qy, qz)
                n2 = w * w + qx * qx + qy * qy + qz * qz
            F[0, 0] = 1.0 - 2.0 * (qy * qy + qz * qz) / n2
            F[0, 1] = 2.0 * (qx * qy - w * qz) / n2
            F[0, 2] = 2.0 * (qx * qz + w * qy) / n2
            F[1, 0] = 2.0 * (qx * qy + w * qz) / n2
            F[1, 1] = 1.0 - 2.0 * (qx * qx + qz * qz) / n2
            F[1, 2] = 2.0 * (qy * qz - w * qx) / n2
            F[2, 0] = 2.0 * (qx * qz - w * qy) / n2
            F[2, 1] = 2.0 * (qy * qz + w * qx) / n2
            F[2, 2] = 1.0 - 2.0 * (qx * qx + qy * qy) / n2
            k0 = face_k[f, 0] * spring_area[s]
            k1 = face_k[f, 1] * spring_area[s]
            k2 = face_k[f, 2] * spring_area[s]
            if deformed:
                Ra = rot[a]
                Rb = rot[b]
                for r in range(3):
                    pa = Ra[r, 0] * arm_a[s, 0] + Ra[r, 1] * arm_a[s, 1] + Ra[r, 2] * arm_a[s, 2]
                    pb = Rb[r, 0] * arm_b[s, 0] + Rb[r, 1] * arm_b[s, 1] + Rb[r, 2] * arm_b[s, 2]
                    gap[r] = 0.5 * ((body_pos[b, r] + pb) - (body_pos[a, r] + pa))
                live = 1.0
                if inelastic and spring_state[s] >= 2:          # BROKEN, CONTACT
                    gn = gap[0] * F[0, 0] + gap[1] * F[1, 0] + gap[2] * F[2, 0]
                    for r in range(3):
                        gap[r] -= gn * F[r, 0]
                    if np.isinf(spring_kappa[s]):
                        live = 0.0
                for c in range(3):
                    la[c] = arm_a[s, c] + Ra[0, c] * gap[0] + Ra[1, c] * gap[1] + Ra[2, c] * gap[2]
                    lb[c] = arm_b[s, c] - (Rb[0, c] * gap[0] + Rb[1, c] * gap[1]
                                           + Rb[2, c] * gap[2])
                k0 *= live
                k1 *= live
                k2 *= live
            else:
                for c in range(3):
                    la[c] = arm_a[s, c]
                    lb[c] = arm_b[s, c]
            for r in range(3):
                for c in range(3):
                    C[r, c] = (F[r, 0] * k0 * F[c, 0] + F[r, 1] * k1 * F[c, 1]
                               + F[r, 2] * k2 * F[c, 2])
            _spring_rows(a, b, la, lb, C, rot, body_mass, body_inertia, active, x, out, B, CB,
                         scale)


@nb.njit(inline="always", cache=True)
def _spring_rows(ba, bb, arm_a, arm_b, C, rot, body_mass, body_inertia, active, x, out, B, CB,
                 scale):
    """One spring's share of (P x) on its bodies ba, bb (_scaled_row_sums)."""
    n = body_mass.shape[0]
    for e in range(2):
        body = ba if e == 0 else bb
        if body >= n:
            for j in range(6):
                scale[6 * e + j] = 0.0
                for r in range(3):
                    B[r, 6 * e + j] = 0.0
            continue
        sign = -1.0 if e == 0 else 1.0
        arm = arm_a if e == 0 else arm_b
        R = rot[body]
        # column j of [r]× is r × e_j; θ × r = −r × θ  ->  −R [r]× θ_body
        for j in range(3):
            cx = arm[1] * (1.0 if j == 2 else 0.0) - arm[2] * (1.0 if j == 1 else 0.0)
            cy = arm[2] * (1.0 if j == 0 else 0.0) - arm[0] * (1.0 if j == 2 else 0.0)
            cz = arm[0] * (1.0 if j == 1 else 0.0) - arm[1] * (1.0 if j == 0 else 0.0)
            for r in range(3):
                B[r, 6 * e + j] = sign * (1.0 if r == j else 0.0)
                B[r, 6 * e + 3 + j] = -sign * (R[r, 0] * cx + R[r, 1] * cy + R[r, 2] * cz)
        m = body_mass[body]
        for j in range(3):
            scale[6 * e + j] = active[body, j] / np.sqrt(m)
            scale[6 * e + 3 + j] = active[body, 3 + j] / np.sqrt(body_inertia[body, j])
    for r in range(3):
        for j in range(12):
            CB[r, j] = C[r, 0] * B[0, j] + C[r, 1] * B[1, j] + C[r, 2] * B[2, j]
    for e in range(2):
        body = ba if e == 0 else bb
        if body >= n:
            continue
        for r in range(6):
            i = 6 * e + r
            acc = 0.0
            for j in range(12):
                if scale[j] == 0.0:
                    continue
                kij = B[0, i] * CB[0, j] + B[1, i] * CB[1, j] + B[2, i] * CB[2, j]
                acc += abs(kij) * scale[j] * x[ba if j < 6 else bb, j % 6]
            out[body, r] += acc * scale[i]


def scaled_row_sums(model, x=None, state=None):
    """P x (N, 6) [1/s²] for the entrywise |M^-½ K M^-½| bound P (see
    Model.stable_dt); x = 1 (default): the Gershgorin row sums.  The
    auxiliary stress of the Poisson correction adds its bound
    |B|ᵀ diag(λV) |B| (physics/poisson.py) on the translations.
    `state`: the springs of that deformed state (_face_row_sums' pose),
    else those of the reference configuration."""
    from ..physics.rotation import quat_matrix_np
    n = model.n_bodies
    out = np.zeros((n, 6))
    xx = np.ones((n + 1, 6))
    if x is not None:
        xx[:n] = x
    rot = quat_matrix_np(model.body_quat0)
    active = np.ones((n, 6))
    if model.plane:
        # x, y and the rotation about z: a prism's principal axis along z
        # (its mid-plane is a plane of symmetry) is the one whose column of
        # R has the largest z component
        active[:, 2:] = 0.0
        active[np.arange(n), 3 + np.argmax(np.abs(rot[:n, 2, :]), axis=1)] = 1.0
    springs = (model.spring_bodies, model.spring_arm_a, model.spring_arm_b,
               model.face_frame0, model.face_k, model.spring_slot, model.spring_area,
               model.group_ptr, model.phase_ptr)
    if state is None:
        none = np.zeros((0, 4))
        pose = (none[:, :3], none, np.zeros(0), np.zeros(0, dtype=np.int8))
    else:
        rot = state.body_rot
        pose = (state.body_pos, state.body_dq,
                state.spring_kappa if state.spring_kappa is not None else np.zeros(0),
                state.spring_state if state.spring_state is not None
                else np.zeros(0, dtype=np.int8))
    bodies = (rot, model.body_mass, model.body_inertia)
    ph = model.phase_ptr
    nt = build_threads() if model.n_springs >= 100_000 else 1
    if nt <= 1:
        _face_row_sums(springs, bodies, active, xx, out, 0, int(ph[-1]), pose)
    else:
        # the groups of a phase share no body: each body's sums come in the
        # serial order, so the result is the serial one bit for bit
        from concurrent.futures import ThreadPoolExecutor
        with ThreadPoolExecutor(nt) as ex:
            for p in range(len(ph) - 1):
                list(ex.map(lambda g: _face_row_sums(springs, bodies, active, xx, out, g, g + 1,
                                                     pose), range(ph[p], ph[p + 1])))
    if model.poisson_on:
        s = np.zeros((n, 6))
        s[:, :3] = 1.0 / np.sqrt(model.body_mass)[:, None]
        out += s * poisson_abs_product(model.poisson, n, s * xx[:n])
    return out


STABLE_DT_SWEEPS = 2   # Collatz–Wielandt refinements (one pass over the springs each)


def omega_max_bound(model, sweeps=STABLE_DT_SWEEPS, state=None):
    """Upper bound on ω_max² = λ_max(M^-½ K M^-½) [1/s²].

    P = Σ_s |M^-½ K_s M^-½| (entrywise) is nonnegative with λ_max ≤ ρ(P),
    and for any positive x, ρ(P) ≤ max_i (P x)_i / x_i (Collatz–Wielandt;
    Horn & Johnson, Matrix Analysis, 8.1.26).  x = 1 is Gershgorin; a few
    power sweeps x ← P x tighten the bound on irregular meshes, where one
    row stands out, and it stays safe for any x > 0."""
    px = scaled_row_sums(model, state=state)
    bound = float(px.max(initial=0.0))
    if bound <= 0.0:
        return 0.0
    x = np.ones_like(px)
    for _ in range(sweeps):
        # keep x strictly positive (a DOF with no springs has (P x)_i = 0)
        x = px / bound + 1e-3
        px = scaled_row_sums(model, x, state=state)
        bound = min(bound, float((px / x).max()))
    return bound
