"""Contact between any cells of a plane model: the plane contact pass
(physics/collide.py in the x–y plane, DESIGN.md §8).

A plane model's cells are prisms of the case's thickness t one cell thick
(Model.plane): two of them overlap in a prism of depth t over the overlap
of their polygons, so the 3D contact's volume, centroid and area vector
are t times the polygons' area, its centroid and t times the length
vector of the overlap's boundary on B.  This pass computes them in the
plane (Sutherland & Hodgman 1974, "Reentrant polygon clipping", CACM
17(1), on convex polygons: A clipped by each edge line of B) and applies
collide.py's force law unchanged: a Winkler layer F_n = k V along
n = S_B/|S_B| at the overlap's centroid, an elastic slip spring returned
to the Coulomb cone (Cundall & Strack 1979), the normal dashpot, the
ground half-plane; every formula and its source are collide._pair_force's.
So a plane model with contact and its one-cell slab on the 3D passes take
the same forces to round-off (tests/test_plane_contact.py), at the plane
passes' price.

Its state is the 3D contact's (model/contact.py ContactState): the pairs
of the broad phase (run between chunks on the slab's arrays, lifted after
each chunk: solvers/plane.py), the slip (P, 3) with z = 0, the separating
face (a side face's row of the slab, so a pair's memory means the same to
either pass), the results `out` in collide's columns, body_friction and
body_dwrench (columns 0, 1, 5: f_x, f_y, m_z).  Output frames, checkpoints
and the stable-step check read it as they read the 3D pass's.

Geometry (PlaneContact, solvers/plane.py plane_contact_geometry): each
cell's polygon counter-clockwise, its vertices about the centroid in the
world axes at rest (poly_ptr, poly_xy; a non-convex cell's convex hull, as
the 3D contact takes), edge_face the slab's side face of each edge (edge
k from vertex k to k + 1), face_edge its inverse (−1: a cap face).

Gather: each body's pairs in pair order (collide.body_pairs), no atomics:
the same sums at any thread count.
"""
import math

import numba as nb
import numpy as np

from .collide import N_OUT, O_A, O_C, O_D, O_E, O_F, O_K, O_KT, O_N, O_W, contact_law
from .contact_geometry import FLAT
from .jit import NOALIAS

JIT = dict(cache=True, nogil=True, fastmath=False, error_model="numpy")


def SCRATCH_ROWS_2D(max_verts):
    """Rows of one call's (rows, 3) scratch for polygons of at most
    max_verts vertices: the two rings and two clipping buffers of
    2 max_verts + 4 rows (a convex k-gon clipped by m lines has at most
    k + m vertices)."""
    return 2 * max_verts + 2 * (2 * max_verts + 4)


@nb.njit(inline="always", **JIT)
def _ring(c, x, y, cs, poly_ptr, poly_xy, w, r0):
    """Cell c's polygon turned by (cos, sin) = cs[c] and put at (x, y) into
    w[r0:] (column 2: the label −1, an edge of A); returns its size."""
    co, si = cs[c, 0], cs[c, 1]
    k = r0
    for v in range(poly_ptr[c], poly_ptr[c + 1]):
        px, py = poly_xy[v, 0], poly_xy[v, 1]
        w[k, 0] = x + co * px - si * py
        w[k, 1] = y + si * px + co * py
        w[k, 2] = -1.0
        k += 1
    return k - r0


@nb.njit(inline="always", **JIT)
def _line(w, r0, m, k):
    """Outward unit normal and offset (n·x = d) of edge k of the ring
    w[r0:r0 + m] (counter-clockwise: n = (Δy, −Δx)/|Δ|); zero for a
    degenerate edge."""
    k1 = k + 1 if k + 1 < m else 0
    ax, ay = w[r0 + k, 0], w[r0 + k, 1]
    ex = w[r0 + k1, 0] - ax
    ey = w[r0 + k1, 1] - ay
    ln = math.sqrt(ex * ex + ey * ey)
    if ln == 0.0:
        return 0.0, 0.0, 0.0
    n0, n1 = ey / ln, -ex / ln
    return n0, n1, n0 * ax + n1 * ay


@nb.njit(inline="always", **JIT)
def _edge_separates(w, x0, nx, k, y0, ny, tol):
    """Whether edge k of ring x has every vertex of ring y outside its line
    (or within tol of it): a separating axis among the edge normals."""
    n0, n1, d = _line(w, x0, nx, k)
    if n0 == 0.0 and n1 == 0.0:
        return False
    lim = d - tol
    for j in range(ny):
        if n0 * w[y0 + j, 0] + n1 * w[y0 + j, 1] < lim:
            return False
    return True


@nb.njit(inline="always", **JIT)
def _clip(w, s0, ns, d0, n0, n1, d, lab, tol, cap):
    """Ring w[s0:s0 + ns] clipped to n·x ≤ d (+ tol) into w[d0:], each
    vertex labelled with the edge that leaves it (column 2: −1 an edge of
    A, k ≥ 0 B's edge line k, which the clip adds); returns its size (a
    convex ring gains at most one vertex a clip; never more than cap rows
    are written, whatever round-off does)."""
    m = 0
    for i in range(ns):
        if m + 2 > cap:
            break
        j = i + 1 if i + 1 < ns else 0
        sx, sy = w[s0 + i, 0], w[s0 + i, 1]
        ex, ey = w[s0 + j, 0], w[s0 + j, 1]
        ds = n0 * sx + n1 * sy - d
        de = n0 * ex + n1 * ey - d
        if de <= tol:
            if ds > tol:
                # entering: the crossing, on S→E (its label)
                t = min(max(ds / (ds - de), 0.0), 1.0)
                w[d0 + m, 0] = sx + t * (ex - sx)
                w[d0 + m, 1] = sy + t * (ey - sy)
                w[d0 + m, 2] = w[s0 + i, 2]
                m += 1
            w[d0 + m, 0] = ex
            w[d0 + m, 1] = ey
            w[d0 + m, 2] = w[s0 + j, 2]
            m += 1
        elif ds <= tol:
            # leaving: the crossing, then along the clip line to the next entry
            t = min(max(ds / (ds - de), 0.0), 1.0)
            w[d0 + m, 0] = sx + t * (ex - sx)
            w[d0 + m, 1] = sy + t * (ey - sy)
            w[d0 + m, 2] = lab
            m += 1
    return m


@nb.njit(inline="always", **JIT)
def _polygon(w, p0, m, b0, nb_, ground, g0, g1, gd, tol):
    """(area, centroid x, y, S_B x, y) of the clipped ring w[p0:p0 + m]:
    the shoelace about its first vertex; S_B = Σ (Δy, −Δx) over its edges
    on B (labels ≥ 0), plus half of each edge of A lying on a line of B
    with the same outward normal (collinear boundaries of A and B, as
    contact_geometry's coplanar faces: the mean of the two one-sided
    derivatives).  B: the ring w[b0:b0 + nb_], or the ground line
    (g0, g1)·x = gd when `ground`."""
    x0, y0 = w[p0, 0], w[p0, 1]
    a2 = 0.0
    cx = cy = 0.0
    sx = sy = 0.0
    per = 0.0
    for i in range(m):
        j = i + 1 if i + 1 < m else 0
        ax, ay = w[p0 + i, 0], w[p0 + i, 1]
        bx, by = w[p0 + j, 0], w[p0 + j, 1]
        ex, ey = bx - ax, by - ay
        per += math.sqrt(ex * ex + ey * ey)
        if 0 < i < m - 1:
            rx, ry = ax - x0, ay - y0
            qx, qy = bx - x0, by - y0
            cr = rx * qy - qx * ry
            a2 += cr
            cx += cr * (rx + qx)
            cy += cr * (ry + qy)
        if w[p0 + i, 2] >= 0.0:
            sx += ey
            sy -= ex
        elif ex != 0.0 or ey != 0.0:
            # an edge of A on a line of B with the same outward normal
            if ground:
                if (g0 * ey - g1 * ex > 0.0 and abs(g0 * ax + g1 * ay - gd) <= tol
                        and abs(g0 * bx + g1 * by - gd) <= tol):
                    sx += 0.5 * ey
                    sy -= 0.5 * ex
            else:
                for k in range(nb_):
                    n0, n1, d = _line(w, b0, nb_, k)
                    if (n0 * ey - n1 * ex > 0.0 and abs(n0 * ax + n1 * ay - d) <= tol
                            and abs(n0 * bx + n1 * by - d) <= tol):
                        sx += 0.5 * ey
                        sy -= 0.5 * ex
                        break
    area = 0.5 * a2
    if not area > tol * per:
        return 0.0, 0.0, 0.0, 0.0, 0.0
    return area, x0 + cx / (3.0 * a2), y0 + cy / (3.0 * a2), sx, sy


@nb.njit(**JIT)
def overlap_2d(a, b, pos, cs, poly_ptr, poly_xy, radius, face_edge, edge_face, hint, w):
    """Overlap of the polygons of cells a and b: (area [m²], centroid (world,
    less a's position) x, y [m], S_B x, y [m], the separating edge's face
    row or −1).  All 0 when they do not overlap or only touch; a separating
    edge (hint first: temporal coherence, Lin & Canny 1991) is returned as
    its slab face row."""
    ra, rb = radius[a], radius[b]
    ox, oy = pos[a, 0], pos[a, 1]
    na = _ring(a, 0.0, 0.0, cs, poly_ptr, poly_xy, w, 0)
    nb_ = _ring(b, pos[b, 0] - ox, pos[b, 1] - oy, cs, poly_ptr, poly_xy, w, na)
    tol = FLAT * (ra + rb)
    if hint >= 0:
        v = face_edge[hint]
        if poly_ptr[a] <= v < poly_ptr[a + 1]:
            if _edge_separates(w, 0, na, v - poly_ptr[a], na, nb_, tol):
                return 0.0, 0.0, 0.0, 0.0, 0.0, hint
        elif poly_ptr[b] <= v < poly_ptr[b + 1]:
            if _edge_separates(w, na, nb_, v - poly_ptr[b], 0, na, tol):
                return 0.0, 0.0, 0.0, 0.0, 0.0, hint
    for k in range(na):
        if _edge_separates(w, 0, na, k, na, nb_, tol):
            return 0.0, 0.0, 0.0, 0.0, 0.0, edge_face[poly_ptr[a] + k]
    for k in range(nb_):
        if _edge_separates(w, na, nb_, k, 0, na, tol):
            return 0.0, 0.0, 0.0, 0.0, 0.0, edge_face[poly_ptr[b] + k]
    cap = na + nb_ + 4
    src = na + nb_
    dst = src + cap
    for k in range(na):
        w[src + k, 0] = w[k, 0]
        w[src + k, 1] = w[k, 1]
        w[src + k, 2] = -1.0
    m = na
    for k in range(nb_):
        n0, n1, d = _line(w, na, nb_, k)
        if n0 == 0.0 and n1 == 0.0:
            continue
        m = _clip(w, src, m, dst, n0, n1, d, float(k), tol, cap)
        src, dst = dst, src
        if m < 3:
            return 0.0, 0.0, 0.0, 0.0, 0.0, -1
    area, c0, c1, s0, s1 = _polygon(w, src, m, na, nb_, False, 0.0, 0.0, 0.0, tol)
    return area, c0, c1, s0, s1, -1


@nb.njit(**JIT)
def overlap_ground_2d(a, pos, cs, poly_ptr, poly_xy, radius, g0, g1, gd, w):
    """Overlap of cell a's polygon and the ground half-plane
    (g0, g1)·x ≤ gd (world): (area, centroid less a's position, S_B) as
    overlap_2d; S_B = n × the chord of the polygon on the ground line."""
    ra = radius[a]
    ox, oy = pos[a, 0], pos[a, 1]
    d = gd - (g0 * ox + g1 * oy)            # the line relative to a
    if -d >= ra:
        return 0.0, 0.0, 0.0, 0.0, 0.0
    na = _ring(a, 0.0, 0.0, cs, poly_ptr, poly_xy, w, 0)
    tol = FLAT * 2.0 * ra
    m = _clip(w, 0, na, na, g0, g1, d, 0.0, tol, na + 4)
    if m < 3:
        return 0.0, 0.0, 0.0, 0.0, 0.0
    return _polygon(w, na, m, 0, 0, True, g0, g1, d, tol)


@nb.njit(inline="always", **JIT)
def _edge_depth(a, b, n0, n1, c0, c1, pos, cs, poly_ptr, poly_xy):
    """Depth of the point c (world) below the edge that faces the contact
    most squarely: b's edge whose outward normal is closest to n (out of b
    into a), or a's closest to −n if closer (collide._face_depth)."""
    best = -2.0
    depth = 0.0
    for side in range(2):
        c = b if side == 0 else a
        s = 1.0 if side == 0 else -1.0
        co, si = cs[c, 0], cs[c, 1]
        v0 = poly_ptr[c]
        m = poly_ptr[c + 1] - v0
        for k in range(m):
            k1 = k + 1 if k + 1 < m else 0
            px, py = poly_xy[v0 + k, 0], poly_xy[v0 + k, 1]
            qx, qy = poly_xy[v0 + k1, 0], poly_xy[v0 + k1, 1]
            ex, ey = qx - px, qy - py
            ln = math.sqrt(ex * ex + ey * ey)
            if ln == 0.0:
                continue
            # the outward normal at rest, turned
            r0, r1 = ey / ln, -ex / ln
            m0 = co * r0 - si * r1
            m1 = si * r0 + co * r1
            cos = s * (m0 * n0 + m1 * n1)
            if cos > best:
                best = cos
                wx = pos[c, 0] + co * px - si * py
                wy = pos[c, 1] + si * px + co * py
                depth = m0 * (wx - c0) + m1 * (wy - c1)
    return depth


@nb.njit(inline="always", **JIT)
def _pair_force_2d(p, pairs, slip, sep, out, dt, pos, cs, vel, omega, mass, poly_ptr, poly_xy,
                   face_edge, edge_face, radius, body_size, body_e, body_g, body_rigid, ground,
                   mu, kfac, zeta, t, w):
    """collide._pair_force in the plane: the same law, the same columns of
    `out` (z components 0)."""
    n = radius.shape[0]
    a = pairs[p, 0]
    b = pairs[p, 1]
    kt_old = out[p, O_KT]
    u0, u1 = slip[p, 0], slip[p, 1]
    et_old = 0.5 * kt_old * (u0 * u0 + u1 * u1)
    for k in range(N_OUT):
        out[p, k] = 0.0
    gd = 0.0
    if b < n:
        d0 = pos[b, 0] - pos[a, 0]
        d1 = pos[b, 1] - pos[a, 1]
        reach = radius[a] + radius[b]
        if d0 * d0 + d1 * d1 >= reach * reach:
            slip[p, 0] = slip[p, 1] = slip[p, 2] = 0.0
            out[p, O_W] = et_old
            return
        ar, c0, c1, s0, s1, f = overlap_2d(a, b, pos, cs, poly_ptr, poly_xy, radius,
                                           face_edge, edge_face, sep[p], w)
        sep[p] = f
        if f >= 0:
            slip[p, 0] = slip[p, 1] = slip[p, 2] = 0.0
            out[p, O_W] = et_old
            return
    else:
        # the ground half-plane moves with the ground's row of pos
        gd = ground[3] + ground[0] * pos[n, 0] + ground[1] * pos[n, 1]
        ar, c0, c1, s0, s1 = overlap_ground_2d(a, pos, cs, poly_ptr, poly_xy, radius,
                                               ground[0], ground[1], gd, w)
    # the prisms' overlap: V = t × area, S_B = t × the length vector
    vol = t * ar
    s0 *= t
    s1 *= t
    area = math.sqrt(s0 * s0 + s1 * s1)
    if not (vol > 0.0 and area > 0.0):
        slip[p, 0] = slip[p, 1] = slip[p, 2] = 0.0
        out[p, O_W] = et_old
        return
    c0 += pos[a, 0]
    c1 += pos[a, 1]
    n0, n1 = s0 / area, s1 / area
    # compliance per area of the two half-cells in series (collide.py)
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
    kpa = kfac / cn
    kn = kpa * area
    kt = kfac / ct * area
    fn = kpa * vol
    if b == n:
        zbar = gd - (ground[0] * c0 + ground[1] * c1)
    else:
        zbar = _edge_depth(a, b, n0, n1, c0, c1, pos, cs, poly_ptr, poly_xy)
    # relative velocity of a's material point at c against b's (half step)
    wa = omega[a]
    v0 = vel[a, 0] - wa * (c1 - pos[a, 1])
    v1 = vel[a, 1] + wa * (c0 - pos[a, 0])
    if b < n:
        wb = omega[b]
        v0 -= vel[b, 0] - wb * (c1 - pos[b, 1])
        v1 -= vel[b, 1] + wb * (c0 - pos[b, 0])
    else:
        v0 -= vel[n, 0]
        v1 -= vel[n, 1]
    vn = v0 * n0 + v1 * n1
    # collide.py's dashpot and slip spring, z components 0
    fn, fd, u0, u1, _, f0, f1, _, diss = contact_law(
        fn, kn, mass[a], mass[b] if b < n else 0.0, b == n, zeta, u0, u1, 0.0, n0, n1, 0.0,
        v0, v1, 0.0, vn, dt, kt, kt_old, et_old, mu)
    slip[p, 0] = u0
    slip[p, 1] = u1
    slip[p, 2] = 0.0
    out[p, O_F] = fn * n0 + f0
    out[p, O_F + 1] = fn * n1 + f1
    out[p, O_C] = c0
    out[p, O_C + 1] = c1
    out[p, O_E] = kpa * vol * max(zbar, 0.0) + 0.5 * kt * (u0 * u0 + u1 * u1)
    out[p, O_W] = diss
    out[p, O_A] = area
    out[p, O_K] = kn
    out[p, O_N] = n0
    out[p, O_N + 1] = n1
    out[p, O_KT] = kt
    out[p, O_D] = fd * n0
    out[p, O_D + 1] = fd * n1


@nb.njit(**JIT, **NOALIAS)
def _pairs_range_2d(t, pc, pbodies, ps, dt):
    """Block t of the pairs, in order (collide._pairs_range); the fields
    into locals before the loop (physics/arrays.py)."""
    poly_ptr = pc.poly_ptr
    poly_xy = pc.poly_xy
    face_edge = pc.face_edge
    edge_face = pc.edge_face
    radius = pc.radius
    body_size = pc.body_size
    body_e = pc.body_e
    body_g = pc.body_g
    body_rigid = pc.body_rigid
    ground = pc.ground
    mu = pc.mu
    kfac = pc.kfac
    zeta = pc.zeta
    thickness = pc.thickness
    pairs = pc.pairs
    slip = pc.slip
    sep = pc.sep
    out = pc.out
    scratch = pc.scratch
    pos = ps.body_pos
    cs = ps.body_cs
    vel = ps.body_vel
    omega = ps.body_omega
    mass = pbodies.body_mass
    n_pairs = pairs.shape[0]
    nblk = scratch.shape[0]
    p0 = t * n_pairs // nblk
    p1 = (t + 1) * n_pairs // nblk
    for p in range(p0, p1):
        _pair_force_2d(p, pairs, slip, sep, out, dt, pos, cs, vel, omega, mass, poly_ptr,
                       poly_xy, face_edge, edge_face, radius, body_size, body_e, body_g,
                       body_rigid, ground, mu, kfac, zeta, thickness, scratch[t])


@nb.njit(parallel=True, **JIT)
def _forces_2d(pc, pbodies, ps, dt):
    """Every pair's force into pc.out, in len(scratch) blocks (each pair's
    result its own: the same numbers at any thread count)."""
    nblk = pc.scratch.shape[0]
    for t in nb.prange(nblk):
        _pairs_range_2d(np.int64(t), pc, pbodies, ps, dt)


@nb.njit(parallel=True, **JIT)
def _gather_2d(pc, ps, dt, overwrite):
    """Each body's contact forces and moments about z (pair order) added
    to its wrench (overwrite: set); the step's friction and the dashpots'
    work booked as collide.contact_gather does (the plane pass always
    commits: it runs only in explicit steps)."""
    ptr = pc.ptr
    entry = pc.entry
    pairs = pc.pairs
    out = pc.out
    body_friction = pc.body_friction
    body_dwrench = pc.body_dwrench
    pos = ps.body_pos
    vel = ps.body_vel
    omega = ps.body_omega
    body_wrench = ps.body_wrench
    body_support = ps.body_support
    body_damp = ps.body_damp
    n = ptr.shape[0] - 1
    vg0, vg1 = vel[n, 0], vel[n, 1]
    for i in nb.prange(n):
        w0 = w1 = w2 = 0.0
        d0 = d1 = d2 = 0.0
        s0 = s1 = 0.0
        gdv = 0.0
        wf = 0.0
        for e in range(ptr[i], ptr[i + 1]):
            p = entry[e] >> 1
            sgn = 1.0 if (entry[e] & 1) == 0 else -1.0
            f0 = sgn * out[p, O_F]
            f1 = sgn * out[p, O_F + 1]
            r0 = out[p, O_C] - pos[i, 0]
            r1 = out[p, O_C + 1] - pos[i, 1]
            w0 += f0
            w1 += f1
            w2 += r0 * f1 - r1 * f0
            wf += out[p, O_W] * (1.0 if pairs[p, 1] == n else 0.5)
            g0 = sgn * out[p, O_D]
            g1 = sgn * out[p, O_D + 1]
            if pairs[p, 1] == n:
                s0 += f0
                s1 += f1
                gdv += g0 * vg0 + g1 * vg1
            d0 += g0
            d1 += g1
            d2 += r0 * g1 - r1 * g0
        if overwrite:
            body_wrench[i, 0] = w0
            body_wrench[i, 1] = w1
            body_wrench[i, 2] = w2
            body_support[i, 0] = s0
            body_support[i, 1] = s1
        else:
            body_wrench[i, 0] += w0
            body_wrench[i, 1] += w1
            body_wrench[i, 2] += w2
            body_support[i, 0] += s0
            body_support[i, 1] += s1
        body_friction[i] += wf
        body_damp[i] += dt * gdv
        q = body_dwrench[i]
        body_damp[i] -= 0.5 * dt * ((q[0] + d0) * vel[i, 0] + (q[1] + d1) * vel[i, 1]
                                    + (q[5] + d2) * omega[i])
        q[0] = d0
        q[1] = d1
        q[5] = d2


@nb.njit(**JIT)
def plane_contact_step(pc, pbodies, ps, dt):
    """One explicit step's contact of a plane model (pc: arrays.PlaneContact,
    ps: arrays.PlaneState): the pair forces, then each body's sum added to
    its wrench, the slip memory, friction and dashpot work committed."""
    if pc.pairs.shape[0] == 0:
        if pc.overwrite:
            ps.body_wrench[:] = 0.0
            ps.body_support[:] = 0.0
        _gather_2d(pc, ps, dt, False)
        return
    _forces_2d(pc, pbodies, ps, dt)
    _gather_2d(pc, ps, dt, pc.overwrite)
