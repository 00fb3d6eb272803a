"""Contact between any cells (DESIGN.md §8): broad phase, pair forces, gather.

A scene that asks for contact (case ``contact``, model/contact.py) gets, on
top of its springs, a penalty contact between every pair of convex cells
that overlap and are not tied by springs (intact, or broken and still
close: those act as contact on their own face, physics/inelastic.py), and
between cells and a ground half-space (fixed, or moving with the case's
ground_motion: the ground's row of the body arrays, physics/integrate.py).

* Broad phase (``broad_phase``, serial, compiled): each cell's world
  bounding box and bounding sphere (radius r about its centroid), grown by
  half the skin, sorted along the axis of largest spread and swept (sort
  and sweep: Baraff 1992, "Dynamic simulation of non-penetrating rigid
  bodies", §6.2; Cohen et al. 1995, I-COLLIDE); candidate pairs (a < b,
  b = N for the ground) in ascending (a, b), whatever the thread count.
  Rebuilt when some cell has moved (its centroid, plus r times its turn)
  more than half the skin since the last build (model/contact.py rebuild):
  until then no vertex has left its grown box.
* Narrow phase (physics/contact_geometry.py): the overlap polytope P = A ∩ B
  of the two cells, its volume V, centroid c, and S_B, the outward area
  vector of the part of P's boundary on B's faces (the direction B pushes
  A; |S_B| = A_c, the contact area).
* Force (``contact_forces``, one pair per iteration, independent): a
  Winkler layer of stiffness k per area on the face pressed, F_n = k V
  along n = S_B/A_c at the overlap's centroid c (= k A_c d, d = V/A_c the
  mean depth, on a flat contact); it stores ½ k ∫δ² dA = k V z̄, z̄ the
  depth of c below the pressed face.  k: the two half-cells in series,
  1/(l_a/E_a + l_b/E_b), l = ½ V^⅓ (the stiffness of an internal face of
  the same cells, so a wave crosses a closed contact as it crosses the
  face: Kawai 1978 eq. 7 form), times ``stiffness``.  Tangential: an
  elastic slip spring k_t = A_c/(l_a/G_a + l_b/G_b) on the
  relative displacement at c,
  integrated from the half-step velocities, returned to the Coulomb cone
  |F_t| ≤ μ F_n with the excess as slip (Cundall & Strack 1979, the broken
  spring's law, laws/contact.py); the slip memory is kept per pair while
  the pair stays in the candidate list.  Both forces act at c on A, their
  opposites at c on B: momentum and angular momentum are conserved to
  round-off.  Energy: k V z̄ + ½ k_t |u|² is elastic (the strain term),
  μ F_n |Δslip| is dissipated (the contact_friction observable).
* Gather (``contact_gather``): per body, its pairs in pair order (a CSR
  built with the pairs), added to its wrench: no atomics, the same sums for
  any thread count.
"""
import math

import numba as nb
import numpy as np

from .arrays import flag
from .jit import NOALIAS
from .contact_geometry import overlap, overlap_halfspace

JIT = dict(cache=True, nogil=True, fastmath=False, error_model="numpy")

# columns of the per-pair result ``out`` (P, N_OUT)
O_F = 0          # force on a [N] (world), 3 columns
O_C = 3          # point of action c [m] (world), 3 columns
O_E = 6          # elastic energy of the pair [J]
O_W = 7          # friction dissipation of this step [J]
O_A = 8          # contact area [m²] (0: not touching)
O_K = 9          # normal stiffness k_n A_c [N/m]
O_D = 10         # dashpot force on a [N] (world), 3 columns (part of O_F)
O_N = 13         # contact normal n (world, out of b into a), 3 columns
O_KT = 16        # tangential stiffness k_t [N/m]
N_OUT = 17


@nb.njit(**JIT)
def neighbour_active(spring_pair, n_keys, inelastic, spring_kappa):
    """(K,) uint8: 1 for a pair of cells tied by springs that still act
    (any spring of the pair intact, or broken and not parted: spring_kappa
    < inf, physics/inelastic.py); such pairs are left to their springs."""
    act = np.zeros(n_keys, dtype=np.uint8)
    for s in range(spring_pair.shape[0]):
        k = spring_pair[s]
        if k < 0:
            continue
        if not inelastic or spring_kappa[s] != np.inf:
            act[k] = 1
    return act


@nb.njit(**JIT)
def cell_boxes(body_pos, body_rot, cell_loop_ptr, loop_xyz, margin):
    """(N, 6) world bounding box (lo, hi) of each cell's vertices, grown by
    `margin` on every side."""
    n = cell_loop_ptr.shape[0] - 1
    box = np.empty((n, 6))
    for c in range(n):
        R = body_rot[c]
        for k in range(3):
            box[c, k] = np.inf
            box[c, 3 + k] = -np.inf
        for r in range(cell_loop_ptr[c], cell_loop_ptr[c + 1]):
            for k in range(3):
                x = (R[k, 0] * loop_xyz[r, 0] + R[k, 1] * loop_xyz[r, 1]
                     + R[k, 2] * loop_xyz[r, 2])
                box[c, k] = min(box[c, k], x)
                box[c, 3 + k] = max(box[c, 3 + k], x)
        for k in range(3):
            box[c, k] += body_pos[c, k] - margin
            box[c, 3 + k] += body_pos[c, k] + margin
    return box


@nb.njit(inline="always", **JIT)
def _push(out, m, a, b):
    """Row m of the pair list set to (a, b), the list doubled when full;
    returns the list."""
    if m == out.shape[0]:
        grown = np.empty((2 * m, 2), dtype=np.int32)
        grown[:m] = out[:m]
        out = grown
    out[m, 0] = a
    out[m, 1] = b
    return out


@nb.njit(**JIT)
def broad_phase(body_pos, body_rot, cell_loop_ptr, loop_xyz, radius, skin, body_part,
                allowed, nbr_key, nbr_active, ground, has_ground):
    """Candidate pairs (P, 2) int32 in ascending (a, b): bodies whose
    bounding boxes grown by skin/2 overlap (a cell that then moves, with its
    turn, by less than skin/2 stays inside its box) and whose spheres
    (radius + skin/2) do, whose parts may meet (allowed), and that are not
    neighbours with acting springs; (i, N) for a body within r + skin/2 of
    the ground plane n·x = d (ground (4,) = n, d)."""
    n = radius.shape[0]
    if n == 0:
        return np.zeros((0, 2), dtype=np.int32)
    box = cell_boxes(body_pos, body_rot, cell_loop_ptr, loop_xyz, 0.5 * skin)
    # axis of largest spread of the centres
    ax = 0
    best = -1.0
    for k in range(3):
        lo = np.inf
        hi = -np.inf
        for i in range(n):
            x = body_pos[i, k]
            lo = min(lo, x)
            hi = max(hi, x)
        if hi - lo > best:
            best = hi - lo
            ax = k
    h = 0.5 * skin
    low = np.empty(n)
    for i in range(n):
        low[i] = box[i, ax]
    order = np.argsort(low, kind="mergesort")
    out = np.empty((8 * n + 16, 2), dtype=np.int32)
    m = 0
    nk = np.int64(n + 1)
    for ii in range(n):
        i = order[ii]
        top = box[i, 3 + ax]
        for jj in range(ii + 1, n):
            j = order[jj]
            if low[j] > top:
                break
            if allowed[body_part[i], body_part[j]] == 0:
                continue
            if (box[j, 0] > box[i, 3] or box[i, 0] > box[j, 3] or box[j, 1] > box[i, 4]
                    or box[i, 1] > box[j, 4] or box[j, 2] > box[i, 5] or box[i, 2] > box[j, 5]):
                continue
            reach = radius[i] + radius[j] + skin
            d0 = body_pos[j, 0] - body_pos[i, 0]
            d1 = body_pos[j, 1] - body_pos[i, 1]
            d2 = body_pos[j, 2] - body_pos[i, 2]
            if d0 * d0 + d1 * d1 + d2 * d2 > reach * reach:
                continue
            a = min(i, j)
            b = max(i, j)
            key = a * nk + b
            pos = np.searchsorted(nbr_key, key)
            if pos < nbr_key.shape[0] and nbr_key[pos] == key and nbr_active[pos]:
                continue
            out = _push(out, m, a, b)
            m += 1
    if has_ground:
        for i in range(n):
            dist = (ground[0] * body_pos[i, 0] + ground[1] * body_pos[i, 1]
                    + ground[2] * body_pos[i, 2] - ground[3])
            if dist <= radius[i] + h:
                out = _push(out, m, i, n)
                m += 1
    keys = np.empty(m, dtype=np.int64)
    for p in range(m):
        keys[p] = out[p, 0] * nk + out[p, 1]
    srt = np.argsort(keys, kind="mergesort")
    pairs = np.empty((m, 2), dtype=np.int32)
    for p in range(m):
        pairs[p, 0] = out[srt[p], 0]
        pairs[p, 1] = out[srt[p], 1]
    return pairs


@nb.njit(**JIT)
def carry_slip(old_pairs, old_slip, old_sep, old_out, pairs, n):
    """Slip memory (P, 3), separating face (P,) and results (P, N_OUT) of
    the new pair list: a pair that was in the old list keeps its slip, its
    face and its slip spring's stiffness (O_KT, the step's energy of the
    spring: _pair_force; both lists ascending in (a, b)), a new one starts
    at 0, −1 and 0."""
    slip = np.zeros((pairs.shape[0], 3))
    sep = np.full(pairs.shape[0], -1, dtype=np.int32)
    out = np.zeros((pairs.shape[0], N_OUT))
    nk = np.int64(n + 1)
    j = 0
    for p in range(pairs.shape[0]):
        key = pairs[p, 0] * nk + pairs[p, 1]
        while j < old_pairs.shape[0] and old_pairs[j, 0] * nk + old_pairs[j, 1] < key:
            j += 1
        if j < old_pairs.shape[0] and old_pairs[j, 0] * nk + old_pairs[j, 1] == key:
            slip[p, 0] = old_slip[j, 0]
            slip[p, 1] = old_slip[j, 1]
            slip[p, 2] = old_slip[j, 2]
            sep[p] = old_sep[j]
            out[p, O_KT] = old_out[j, O_KT]
    return slip, sep, out


@nb.njit(**JIT)
def body_pairs(pairs, n):
    """CSR of each body's pairs, in pair order: ptr (N+1,), entry (E,) =
    2 p for body a of pair p, 2 p + 1 for body b (ground pairs: a only)."""
    ptr = np.zeros(n + 1, dtype=np.int64)
    for p in range(pairs.shape[0]):
        ptr[pairs[p, 0] + 1] += 1
        if pairs[p, 1] < n:
            ptr[pairs[p, 1] + 1] += 1
    for i in range(n):
        ptr[i + 1] += ptr[i]
    fill = ptr[:-1].copy()
    entry = np.empty(ptr[n], dtype=np.int64)
    for p in range(pairs.shape[0]):
        a = pairs[p, 0]
        entry[fill[a]] = 2 * p
        fill[a] += 1
        b = pairs[p, 1]
        if b < n:
            entry[fill[b]] = 2 * p + 1
            fill[b] += 1
    return ptr, entry


@nb.njit(**JIT)
def _plane_separates(f, c, Rc, pc, o, Ro, po, face_plane, vert_ptr, vert_xyz, tol):
    """Whether face f of cell c (at pc, turned by Rc) has every vertex of
    cell o (at po, Ro) outside its plane (or within tol of it)."""
    # o's vertices in c's frame: Rcᵀ (Ro x + po − pc)
    t0, t1, t2 = po[0] - pc[0], po[1] - pc[1], po[2] - pc[2]
    n0, n1, n2 = face_plane[f, 0], face_plane[f, 1], face_plane[f, 2]
    # the plane in world (n_w = Rc n), then in o's frame: n_o = Roᵀ n_w
    w0 = Rc[0, 0] * n0 + Rc[0, 1] * n1 + Rc[0, 2] * n2
    w1 = Rc[1, 0] * n0 + Rc[1, 1] * n1 + Rc[1, 2] * n2
    w2 = Rc[2, 0] * n0 + Rc[2, 1] * n1 + Rc[2, 2] * n2
    m0 = Ro[0, 0] * w0 + Ro[1, 0] * w1 + Ro[2, 0] * w2
    m1 = Ro[0, 1] * w0 + Ro[1, 1] * w1 + Ro[2, 1] * w2
    m2 = Ro[0, 2] * w0 + Ro[1, 2] * w1 + Ro[2, 2] * w2
    # n_w·(Ro x + po) ≥ d + n_w·pc  ⇔  n_o·x ≥ d − n_w·(po − pc)
    lim = face_plane[f, 3] - (w0 * t0 + w1 * t1 + w2 * t2) - tol
    for k in range(vert_ptr[o], vert_ptr[o + 1]):
        if m0 * vert_xyz[k, 0] + m1 * vert_xyz[k, 1] + m2 * vert_xyz[k, 2] < lim:
            return False
    return True


@nb.njit(**JIT)
def _separating_face(a, b, body_pos, body_rot, cell_face_ptr, face_plane, vert_ptr, vert_xyz,
                     radius, hint):
    """A face of a or b whose plane has the other cell wholly outside (a
    separating axis among the face normals), trying `hint` (the one found
    at the last step, or −1) first: its index, or −1 if none (the cells may
    overlap).  Temporal coherence: a pair that stays apart is settled by
    one plane test per step (Lin & Canny 1991; Baraff 1992 §6)."""
    tol = 1e-10 * (radius[a] + radius[b])
    pa, pb = body_pos[a], body_pos[b]
    Ra, Rb = body_rot[a], body_rot[b]
    if hint >= 0:
        if cell_face_ptr[a] <= hint < cell_face_ptr[a + 1]:
            if _plane_separates(hint, a, Ra, pa, b, Rb, pb, face_plane, vert_ptr, vert_xyz,
                                tol):
                return hint
        elif _plane_separates(hint, b, Rb, pb, a, Ra, pa, face_plane, vert_ptr, vert_xyz, tol):
            return hint
    for f in range(cell_face_ptr[a], cell_face_ptr[a + 1]):
        if _plane_separates(f, a, Ra, pa, b, Rb, pb, face_plane, vert_ptr, vert_xyz, tol):
            return f
    for f in range(cell_face_ptr[b], cell_face_ptr[b + 1]):
        if _plane_separates(f, b, Rb, pb, a, Ra, pa, face_plane, vert_ptr, vert_xyz, tol):
            return f
    return -1


@nb.njit(**JIT)
def _face_depth(a, b, n0, n1, n2, c0, c1, c2, body_pos, body_rot, cell_face_ptr, face_plane):
    """Depth of the point c below the face (of b, or of a) that faces the
    contact most squarely: b's face whose outward normal is closest to n
    (n points out of b into a), or a's closest to −n if that one is
    closer."""
    best = -2.0
    depth = 0.0
    for side in range(2):
        c = b if side == 0 else a
        s = 1.0 if side == 0 else -1.0
        R = body_rot[c]
        for f in range(cell_face_ptr[c], cell_face_ptr[c + 1]):
            q0, q1, q2 = face_plane[f, 0], face_plane[f, 1], face_plane[f, 2]
            m0 = R[0, 0] * q0 + R[0, 1] * q1 + R[0, 2] * q2
            m1 = R[1, 0] * q0 + R[1, 1] * q1 + R[1, 2] * q2
            m2 = R[2, 0] * q0 + R[2, 1] * q1 + R[2, 2] * q2
            cos = s * (m0 * n0 + m1 * n1 + m2 * n2)
            if cos > best:
                best = cos
                # plane m·x = d + m·p_c (world); c lies inside the cell
                off = face_plane[f, 3] + m0 * body_pos[c, 0] + m1 * body_pos[c, 1] \
                    + m2 * body_pos[c, 2]
                depth = off - (m0 * c0 + m1 * c1 + m2 * c2)
    return depth


@nb.njit(inline="always", **JIT)
def _spin(i, body_rot, body_angmom, body_inertia):
    """World angular velocity ω = R I⁻¹ Rᵀ L of body i (principal axes)."""
    R = body_rot[i]
    L0, L1, L2 = body_angmom[i, 0], body_angmom[i, 1], body_angmom[i, 2]
    b0 = (R[0, 0] * L0 + R[1, 0] * L1 + R[2, 0] * L2) / body_inertia[i, 0]
    b1 = (R[0, 1] * L0 + R[1, 1] * L1 + R[2, 1] * L2) / body_inertia[i, 1]
    b2 = (R[0, 2] * L0 + R[1, 2] * L1 + R[2, 2] * L2) / body_inertia[i, 2]
    return (R[0, 0] * b0 + R[0, 1] * b1 + R[0, 2] * b2,
            R[1, 0] * b0 + R[1, 1] * b1 + R[1, 2] * b2,
            R[2, 0] * b0 + R[2, 1] * b1 + R[2, 2] * b2)


@nb.njit(inline="always", **JIT)
def contact_law(fn, kn, ma, mb, ground, zeta, u0, u1, u2, n0, n1, n2, v0, v1, v2, vn, dt, kt,
                kt_old, et_old, mu):
    """The normal dashpot and the slip spring of a pair (one law for the 3D
    pass and the plane pass, physics/plane_contact.py, which calls it with
    z components 0): the penalty force fn [N] and normal stiffness kn, the
    masses of a and b (ground: b is the ground), the slip u of the last
    step, the normal n (out of b into a), a's material point's velocity
    against b's v and its normal part vn, the slip spring's stiffness kt
    now and at the last step (kt_old, its energy then et_old), the
    friction μ.  Returns (fn with the dashpot, the dashpot force fd, the
    new slip u ×3, the tangential force f ×3, the energy dissipated in the
    step)."""
    fd = 0.0
    if zeta > 0.0:
        # normal dashpot 2ζ√(k m*) (m* = m_a m_b/(m_a + m_b), the ground
        # infinitely heavy), never pulling: F_n ≥ 0 (Cundall & Strack 1979)
        ms = ma if ground else ma * mb / (ma + mb)
        fd = -2.0 * zeta * math.sqrt(kn * ms) * vn
        if fn + fd < 0.0:
            fd = -fn
        fn += fd
    # slip spring: the old one turned into the present tangent plane
    # (projected, its length kept), plus the tangential motion of the step
    un = u0 * n0 + u1 * n1 + u2 * n2
    old = math.sqrt(u0 * u0 + u1 * u1 + u2 * u2)
    u0 -= un * n0
    u1 -= un * n1
    u2 -= un * n2
    new = math.sqrt(u0 * u0 + u1 * u1 + u2 * u2)
    if new > 0.0:
        u0 *= old / new
        u1 *= old / new
        u2 *= old / new
    # k_t follows the contact area, so ½ k_t |u|² is no potential: a
    # stiffer spring at the same u would create energy.  The force is kept
    # when the area grows (the new part comes in unstressed: u scaled by
    # k_old/k_t) and falls with k_t when it shrinks (the part that left
    # takes its share); either way the spring's energy falls, by
    # E_old (1 − k_min/k_max), booked as dissipated with the friction, so
    # that the contact never makes energy: the incremental shear force of
    # Cundall & Strack (1979), F_t += −k_t Δu, with a lost area's share
    # dropped (docs/theory.md, "Contact between cells").
    diss = 0.0
    if kt_old > 0.0 and kt != kt_old:
        if kt > kt_old:
            ratio = kt_old / kt
            u0 *= ratio
            u1 *= ratio
            u2 *= ratio
        else:
            ratio = kt / kt_old
        diss = et_old * (1.0 - ratio)
    u0 += (v0 - vn * n0) * dt
    u1 += (v1 - vn * n1) * dt
    u2 += (v2 - vn * n2) * dt
    f0, f1, f2 = -kt * u0, -kt * u1, -kt * u2
    ft = math.sqrt(f0 * f0 + f1 * f1 + f2 * f2)
    fmax = mu * fn
    if ft > fmax:
        r = fmax / ft if ft > 0.0 else 0.0
        # the slip takes the excess (return to the Coulomb cone)
        diss += fmax * (ft - fmax) / kt
        f0 *= r
        f1 *= r
        f2 *= r
        u0 *= r
        u1 *= r
        u2 *= r
    return fn, fd, u0, u1, u2, f0, f1, f2, diss


@nb.njit(inline="always", **JIT)
def _pair_force(p, pairs, slip, sep, out, dt, body_pos, body_rot, body_vel, body_angmom,
                body_inertia, body_mass, cell_face_ptr, loop_ptr, loop_xyz, face_plane,
                cell_loop_ptr, vert_ptr, vert_xyz, radius, body_size, body_e, body_g,
                body_rigid, ground, mu, kfac, zeta, scratch):
    n = radius.shape[0]
    a = pairs[p, 0]
    b = pairs[p, 1]
    # the slip spring's stiffness at the last step and its stored energy
    # ½ k_t |u|², which is released (booked as dissipated) when the pair
    # parts or its contact area shrinks (below)
    kt_old = out[p, O_KT]
    u0, u1, u2 = slip[p, 0], slip[p, 1], slip[p, 2]
    et_old = 0.5 * kt_old * (u0 * u0 + u1 * u1 + u2 * u2)
    for k in range(N_OUT):
        out[p, k] = 0.0
    if b < n:
        d0 = body_pos[b, 0] - body_pos[a, 0]
        d1 = body_pos[b, 1] - body_pos[a, 1]
        d2 = body_pos[b, 2] - body_pos[a, 2]
        reach = radius[a] + radius[b]
        if d0 * d0 + d1 * d1 + d2 * d2 >= reach * reach:
            slip[p, 0] = slip[p, 1] = slip[p, 2] = 0.0
            out[p, O_W] = et_old
            return
        sep[p] = _separating_face(a, b, body_pos, body_rot, cell_face_ptr, face_plane,
                                  vert_ptr, vert_xyz, radius, sep[p])
        if sep[p] >= 0:
            slip[p, 0] = slip[p, 1] = slip[p, 2] = 0.0
            out[p, O_W] = et_old
            return
    # the ground half-space n·x ≤ d moves with the ground's row of body_pos
    # (at rest at 0 unless the case has a ground_motion: integrate.py)
    gd = ground[3] + ground[0] * body_pos[n, 0] + ground[1] * body_pos[n, 1] \
        + ground[2] * body_pos[n, 2]
    if b == n:
        vol, c0, c1, c2, s0, s1, s2, area = overlap_halfspace(
            a, body_pos[a], body_rot[a], ground[:3], gd, cell_face_ptr, loop_ptr,
            loop_xyz, face_plane, radius, scratch)
    else:
        vol, c0, c1, c2, s0, s1, s2, area = overlap(
            a, body_pos[a], body_rot[a], b, body_pos[b], body_rot[b], cell_face_ptr,
            loop_ptr, loop_xyz, face_plane, radius, scratch)
    if not (vol > 0.0 and area > 0.0):
        slip[p, 0] = slip[p, 1] = slip[p, 2] = 0.0
        out[p, O_W] = et_old
        return
    n0, n1, n2 = s0 / area, s1 / area, s2 / area
    depth = vol / area
    # compliance per area of the two half-cells in series, l = ½ V^⅓ each
    # (a rigid cell adds nothing unless both are rigid; the ground nothing)
    la = 0.5 * body_size[a]
    cn = la / body_e[a]
    ct = la / body_g[a]
    both_rigid = body_rigid[a] != 0 and (b == n or body_rigid[b] != 0)
    if body_rigid[a] != 0 and not both_rigid:
        cn = ct = 0.0
    if b < n and (body_rigid[b] == 0 or both_rigid):
        lb = 0.5 * body_size[b]
        cn += lb / body_e[b]
        ct += lb / body_g[b]
    kpa = kfac / cn                   # [N/m³]
    kn = kpa * area                   # [N/m]
    kt = kfac / ct * area
    # a Winkler layer (k per area) on the flat face the other cell presses
    # into: F = k ∫δ dA = k V at the overlap's centroid, and it stores
    # ½ k ∫δ² dA = k V z̄, z̄ the depth of the centroid below that face
    # (∫δ² dA = 2 ∫_V z dV); the face: the one of a or b whose normal is
    # closest to ∓n (a face pressed by an edge or a corner of the other)
    fn = kpa * vol
    if b == n:
        zbar = gd - (ground[0] * c0 + ground[1] * c1 + ground[2] * c2)
    else:
        zbar = _face_depth(a, b, n0, n1, n2, c0, c1, c2, body_pos, body_rot, cell_face_ptr,
                           face_plane)
    # relative velocity of a's material point at c against b's (half step)
    wa0, wa1, wa2 = _spin(a, body_rot, body_angmom, body_inertia)
    ra0, ra1, ra2 = c0 - body_pos[a, 0], c1 - body_pos[a, 1], c2 - body_pos[a, 2]
    v0 = body_vel[a, 0] + wa1 * ra2 - wa2 * ra1
    v1 = body_vel[a, 1] + wa2 * ra0 - wa0 * ra2
    v2 = body_vel[a, 2] + wa0 * ra1 - wa1 * ra0
    if b < n:
        wb0, wb1, wb2 = _spin(b, body_rot, body_angmom, body_inertia)
        rb0, rb1, rb2 = c0 - body_pos[b, 0], c1 - body_pos[b, 1], c2 - body_pos[b, 2]
        v0 -= body_vel[b, 0] + wb1 * rb2 - wb2 * rb1
        v1 -= body_vel[b, 1] + wb2 * rb0 - wb0 * rb2
        v2 -= body_vel[b, 2] + wb0 * rb1 - wb1 * rb0
    else:
        # the ground translates (its row of body_vel: 0 unless it moves)
        v0 -= body_vel[n, 0]
        v1 -= body_vel[n, 1]
        v2 -= body_vel[n, 2]
    vn = v0 * n0 + v1 * n1 + v2 * n2
    fn, fd, u0, u1, u2, f0, f1, f2, diss = contact_law(
        fn, kn, body_mass[a], body_mass[b] if b < n else 0.0, b == n, zeta, u0, u1, u2,
        n0, n1, n2, v0, v1, v2, vn, dt, kt, kt_old, et_old, mu)
    slip[p, 0] = u0
    slip[p, 1] = u1
    slip[p, 2] = u2
    out[p, O_F] = fn * n0 + f0
    out[p, O_F + 1] = fn * n1 + f1
    out[p, O_F + 2] = fn * n2 + f2
    out[p, O_C] = c0
    out[p, O_C + 1] = c1
    out[p, O_C + 2] = c2
    out[p, O_E] = kpa * vol * max(zbar, 0.0) + 0.5 * kt * (u0 * u0 + u1 * u1 + u2 * u2)
    out[p, O_W] = diss
    out[p, O_A] = area
    out[p, O_K] = kn
    out[p, O_N] = n0
    out[p, O_N + 1] = n1
    out[p, O_N + 2] = n2
    out[p, O_KT] = kt
    out[p, O_D] = fd * n0
    out[p, O_D + 1] = fd * n1
    out[p, O_D + 2] = fd * n2


@nb.njit(**JIT, **NOALIAS)
def _pairs_range(t, contact, bodies, bs, dt):
    """Block t of the pairs (one of len(scratch) equal blocks, with its row
    of scratch), in order, the pair inlined: the one compiled loop of
    contact_forces (physics/jit.py)."""
    # the fields into locals before the loop (physics/arrays.py)
    pairs = contact.pairs
    slip = contact.slip
    sep = contact.sep
    out = contact.out
    cell_face_ptr = contact.cell_face_ptr
    loop_ptr = contact.loop_ptr
    loop_xyz = contact.loop_xyz
    face_plane = contact.face_plane
    cell_loop_ptr = contact.cell_loop_ptr
    vert_ptr = contact.vert_ptr
    vert_xyz = contact.vert_xyz
    radius = contact.radius
    body_size = contact.body_size
    body_e = contact.body_e
    body_g = contact.body_g
    body_rigid = contact.body_rigid
    ground = contact.ground
    mu = contact.mu
    kfac = contact.kfac
    zeta = contact.zeta
    scratch = contact.scratch
    body_pos = bs.body_pos
    body_rot = bs.body_rot
    body_vel = bs.body_vel
    body_angmom = bs.body_angmom
    body_inertia = bodies.body_inertia
    body_mass = bodies.body_mass
    n_pairs = pairs.shape[0]
    nblk = scratch.shape[0]
    p0 = t * n_pairs // nblk
    p1 = (t + 1) * n_pairs // nblk
    for p in range(p0, p1):
        _pair_force(p, pairs, slip, sep, out, dt, body_pos, body_rot, body_vel,
                    body_angmom, body_inertia, body_mass, cell_face_ptr, loop_ptr,
                    loop_xyz, face_plane, cell_loop_ptr, vert_ptr, vert_xyz, radius,
                    body_size, body_e, body_g, body_rigid, ground, mu, kfac, zeta, scratch[t])


@nb.njit(parallel=True, **JIT)
def contact_forces(contact, bodies, bs, dt):
    """Force of every candidate pair (see module) into ``out`` (P, N_OUT),
    slip memory updated in ``slip`` (contact: arrays.ContactArrays).  Pairs
    split into len(scratch) equal blocks, one per block of scratch: each
    pair's result depends on it alone, so any thread count gives the same
    numbers."""
    nblk = contact.scratch.shape[0]
    for t in nb.prange(nblk):
        _pairs_range(np.int64(t), contact, bodies, bs, dt)


@nb.njit(parallel=True, **JIT)
def contact_gather(contact, bodies, bs, dt, overwrite, commit):
    """Add each body's contact forces and their moments about its centre
    (pair order) to body_wrench (overwrite: set it, for a model without
    springs); with ``commit``, book the step's friction dissipation, half to
    each body of a pair (all to the body on the ground), and the dashpots'
    work: the leapfrog's kinetic energy changes by f_n·(v_n-½ + v_n+½) dt/2
    (Belytschko, Liu & Moran 2000, §6.2.4), so the dashpot wrench D_n of a
    body (kept in body_dwrench) is booked half with the velocities before
    the step and half with those after it, at the next step."""
    # the fields into locals before the prange (physics/arrays.py)
    ptr = contact.ptr
    entry = contact.entry
    pairs = contact.pairs
    out = contact.out
    body_friction = contact.body_friction
    body_dwrench = contact.body_dwrench
    body_pos = bs.body_pos
    body_vel = bs.body_vel
    body_angmom = bs.body_angmom
    body_rot = bs.body_rot
    body_wrench = bs.body_wrench
    body_support = bs.body_support
    body_damp = bs.body_damp
    body_inertia = bodies.body_inertia
    n = ptr.shape[0] - 1
    # the ground's velocity (its row of body_vel: 0 unless it moves)
    vg0, vg1, vg2 = body_vel[n, 0], body_vel[n, 1], body_vel[n, 2]
    for i in nb.prange(n):
        w0 = w1 = w2 = w3 = w4 = w5 = 0.0
        d0 = d1 = d2 = d3 = d4 = d5 = 0.0
        s0 = s1 = s2 = 0.0
        gdv = 0.0
        wf = 0.0
        for e in range(ptr[i], ptr[i + 1]):
            p = entry[e] >> 1
            sgn = 1.0 if (entry[e] & 1) == 0 else -1.0
            f0 = sgn * out[p, O_F]
            f1 = sgn * out[p, O_F + 1]
            f2 = sgn * out[p, O_F + 2]
            r0 = out[p, O_C] - body_pos[i, 0]
            r1 = out[p, O_C + 1] - body_pos[i, 1]
            r2 = out[p, O_C + 2] - body_pos[i, 2]
            w0 += f0
            w1 += f1
            w2 += f2
            w3 += r1 * f2 - r2 * f1
            w4 += r2 * f0 - r0 * f2
            w5 += r0 * f1 - r1 * f0
            # friction: half to each body, all to a body on the ground
            wf += out[p, O_W] * (1.0 if pairs[p, 1] == n else 0.5)
            g0 = sgn * out[p, O_D]
            g1 = sgn * out[p, O_D + 1]
            g2 = sgn * out[p, O_D + 2]
            if pairs[p, 1] == n:
                # the ground's force is a support's (the reaction, and the
                # moving ground's work f · v_g: integrate.py); its dashpot
                # dissipates −D · (v − v_g), booked below against v alone
                s0 += f0
                s1 += f1
                s2 += f2
                gdv += g0 * vg0 + g1 * vg1 + g2 * vg2
            d0 += g0
            d1 += g1
            d2 += g2
            d3 += r1 * g2 - r2 * g1
            d4 += r2 * g0 - r0 * g2
            d5 += r0 * g1 - r1 * g0
        if overwrite:
            body_wrench[i, 0] = w0
            body_wrench[i, 1] = w1
            body_wrench[i, 2] = w2
            body_wrench[i, 3] = w3
            body_wrench[i, 4] = w4
            body_wrench[i, 5] = w5
            body_support[i, 0] = s0
            body_support[i, 1] = s1
            body_support[i, 2] = s2
        else:
            body_wrench[i, 0] += w0
            body_wrench[i, 1] += w1
            body_wrench[i, 2] += w2
            body_wrench[i, 3] += w3
            body_wrench[i, 4] += w4
            body_wrench[i, 5] += w5
            body_support[i, 0] += s0
            body_support[i, 1] += s1
            body_support[i, 2] += s2
        if commit:
            body_friction[i] += wf
            body_damp[i] += dt * gdv
            o0, o1, o2 = _spin(i, body_rot, body_angmom, body_inertia)
            q = body_dwrench[i]
            body_damp[i] -= 0.5 * dt * ((q[0] + d0) * body_vel[i, 0] + (q[1] + d1) * body_vel[i, 1]
                                        + (q[2] + d2) * body_vel[i, 2] + (q[3] + d3) * o0
                                        + (q[4] + d4) * o1 + (q[5] + d5) * o2)
            q[0], q[1], q[2], q[3], q[4], q[5] = d0, d1, d2, d3, d4, d5


@nb.njit(**JIT)
def contact_step(contact, bodies, bs, dt, commit):
    """One step's contact: the pair forces, then each body's sum added to
    its wrench (contact: arrays.ContactArrays; with ``commit`` the slip
    memory, friction and dashpot work of the step are kept)."""
    overwrite = contact.overwrite
    if contact.pairs.shape[0] == 0:
        if overwrite:
            bs.body_wrench[:] = 0.0
            bs.body_support[:] = 0.0
        if commit:
            contact_gather(contact, bodies, bs, dt, flag(False), commit)
        return
    contact_forces(contact, bodies, bs, dt)
    contact_gather(contact, bodies, bs, dt, overwrite, commit)
