"""Overlap of two convex cells, or of a cell and the ground half-space, by
polygon clipping, compiled: the narrow phase of contact (physics/collide.py).

A cell is a convex polyhedron given by its faces' loops in its body frame
(global CSR arrays: cell c has the faces cell_face_ptr[c]..cell_face_ptr[c+1],
face f the loop rows loop_ptr[f]..loop_ptr[f+1] of loop_xyz, counter-
clockwise seen from outside) and its faces' planes face_plane (F, 4) =
outward unit normal n and offset d, n·x = d on the face, in the same frame;
the body at p with rotation R puts a local x at R x + p.

The overlap P = A ∩ B is bounded by the part of ∂A inside B and the part of
∂B inside A.  Each face of A, turned to the world, is clipped by every plane
of B (keep n·x ≤ d: Sutherland & Hodgman 1974, "Reentrant polygon
clipping", CACM 17(1)), and each face of B by the planes of A; the clipped
polygons close ∂P.  Each polygon f gives its area A_f and area centroid
c_f; with a point r near P (the area-weighted mean of the c_f, so that
every term below is of the size of P and none cancels), P is the union of
the pyramids from r over its faces: V_f = (c_f − r)·n_f A_f / 3 (the
divergence theorem, Mirtich 1996, "Fast and accurate computation of
polyhedral mass properties", J. Graphics Tools 1(2)), each with its
centroid 3/4 of the way from r to c_f, so V = Σ V_f and
c = r + (3/4) Σ V_f (c_f − r) / V.  S_B = Σ A_f n_f over the polygons on B's
faces is the area vector of the part of ∂P on ∂B: it points out of B into
A, and it is the gradient of V with respect to B's translation (moving B
by u sweeps its boundary inside A: dV = u·S_B), so a penalty on V pushes A
along S_B.  A ground half-space n·x ≤ d plays B with one face: its plane,
inside A a polygon got by clipping a square of side 4 r_A (r_A: A's
bounding radius about p), centred at the foot of p on the plane, by A's
planes; there S_B = n × the area of A's cross-section by the plane.

Faces of A and B in one plane (blocks side by side, a cell resting on
another or on the ground) are decided once for both sides: a face pair is
coplanar when each face's vertices lie within tol = FLAT (r_A + r_B) of the
other's plane (FLAT · 2 r_A against the ground).  Coplanar faces with
opposite normals touch: P is flat there and neither polygon counts.
Coplanar faces with the same normal bound P together: the polygon is taken
from A's face, and half of its area vector goes to S_B (V is not
differentiable there; the half is the mean of the two one-sided
derivatives across the plane, and it makes swapping A and B give −S_B).
Faces nearly but not quite coplanar (tilted by some tol/r to 100 tol/r)
are clipped at their exact planes from both sides with independent
round-off, a strip of width ≈ 1e-16 r / tilt in doubt: V is then good to
about 1e-8 rather than 1e-14.  B wholly inside A has S_B = 0 (∂B closed).

Early outs: bounding spheres apart; a face plane of either cell with all
the other cell's vertices outside it or within tol (separating axis among
the face normals: Gottschalk, Lin & Manocha 1996, "OBBTree", SIGGRAPH; an
edge-edge separation is found by the clipping, which leaves nothing); a
face whose bounding sphere lies outside one plane of the other cell, or
outside its bounding sphere.  P thinner than about tol (V ≤ tol × the area
of ∂P) counts as touching.  Either way all outputs are 0.

No array is allocated: each call works in ``scratch`` (rows, 3) float64,
rows ≥ SCRATCH_ROWS(max_rows, max_faces) for cells of at most max_rows
loop rows and max_faces faces; one per thread in a prange loop.
"""
import math

import numba as nb
import numpy as np

JIT = dict(cache=True, nogil=True, fastmath=False, error_model="numpy")

#: overlaps thinner than FLAT × (r_A + r_B) count as touching, and faces
#: whose vertices lie within that of each other's planes as coplanar: far
#: above the round-off of loop coordinates (≈ 1e-16 × their distance from
#: the world origin), far below any penetration a penalty acts on
FLAT = 1e-10

#: |n_f·n_g| above this: the pair of faces is tested for coplanarity
PARALLEL = 1.0 - 1e-6

# rows of a face's record in the scratch (4 rows of 3 per face):
# 0: n (world); 1: d, bounding radius ρ, area A_f (after clipping);
# 2: bounding-sphere centre, then the area centroid c_f (after clipping);
# 3: first vertex row, vertex count, share of A_f n_f in S_B
REC = 4


def SCRATCH_ROWS(max_rows, max_faces):
    """Rows of the (rows, 3) float64 scratch of one call of ``overlap`` or
    ``overlap_halfspace`` for cells of at most max_rows loop rows and
    max_faces faces: the two cells' loop vertices (+4 for the ground's
    square), their face records (4 rows each) and two polygons plus their
    signed distances (3 × (max_rows + max_faces + 4) rows: a convex polygon
    of k sides clipped by m planes has at most k + m)."""
    return 5 * max_rows + 11 * max_faces + 20


def planes_from_loops(loop_ptr, loop_xyz):
    """(F, 4) outward unit normal and offset (n·x = d) of each face loop
    (rows loop_ptr[f]..loop_ptr[f+1] of loop_xyz, counter-clockwise seen
    from outside).  Newell's normal (Newell 1972, in Sutherland, Sproull &
    Schumacker 1974, "A characterization of ten hidden-surface
    algorithms", ACM Comput. Surv. 6(1)): n = Σ over edges i→j of
    ((y_i − y_j)(z_i + z_j), (z_i − z_j)(x_i + x_j), (x_i − x_j)(y_i + y_j)),
    twice the area vector of a planar loop, here about the loop's mean
    (the same sum, less round-off); d = n · the mean of its vertices."""
    loop_ptr = np.asarray(loop_ptr, dtype=np.int64)
    x = np.asarray(loop_xyz, dtype=np.float64)
    if loop_ptr.shape[0] < 2:
        return np.zeros((0, 4))
    start = loop_ptr[:-1]
    count = np.diff(loop_ptr)
    mean = np.add.reduceat(x, start, axis=0) / count[:, None]
    xc = x - np.repeat(mean, count, axis=0)
    nxt = np.arange(1, x.shape[0] + 1)
    nxt[loop_ptr[1:] - 1] = start            # the last row of a loop closes it
    a, b = xc, xc[nxt]
    dif = a - b
    sm = a + b
    term = np.stack([dif[:, 1] * sm[:, 2], dif[:, 2] * sm[:, 0], dif[:, 0] * sm[:, 1]], axis=1)
    n = np.add.reduceat(term, start, axis=0)
    n /= np.linalg.norm(n, axis=1)[:, None]
    out = np.empty((n.shape[0], 4))
    out[:, :3] = n
    out[:, 3] = np.einsum("ij,ij->i", n, mean)
    return out


@nb.njit(**JIT)
def _load(c, p, R, o, cell_face_ptr, loop_ptr, loop_xyz, face_plane, w, v0, f0):
    """Cell c's loop vertices into w[v0:] (world, less the origin o (3,))
    and its faces' records into w[f0:] (REC rows each: world plane,
    bounding sphere, vertex rows); returns the number of vertex rows."""
    tx, ty, tz = p[0] - o[0], p[1] - o[1], p[2] - o[2]
    fa, fb = cell_face_ptr[c], cell_face_ptr[c + 1]
    base = loop_ptr[fa]
    for f in range(fa, fb):
        k0, k1 = loop_ptr[f], loop_ptr[f + 1]
        mx = my = mz = 0.0
        for k in range(k0, k1):
            x, y, z = loop_xyz[k, 0], loop_xyz[k, 1], loop_xyz[k, 2]
            mx += x
            my += y
            mz += z
            r = v0 + k - base
            # x_world = R x + p
            w[r, 0] = R[0, 0] * x + R[0, 1] * y + R[0, 2] * z + tx
            w[r, 1] = R[1, 0] * x + R[1, 1] * y + R[1, 2] * z + ty
            w[r, 2] = R[2, 0] * x + R[2, 1] * y + R[2, 2] * z + tz
        m = 1.0 / (k1 - k0)
        mx *= m
        my *= m
        mz *= m
        rho2 = 0.0
        for k in range(k0, k1):
            dx, dy, dz = loop_xyz[k, 0] - mx, loop_xyz[k, 1] - my, loop_xyz[k, 2] - mz
            rho2 = max(rho2, dx * dx + dy * dy + dz * dz)
        a, b, e = face_plane[f, 0], face_plane[f, 1], face_plane[f, 2]
        nx = R[0, 0] * a + R[0, 1] * b + R[0, 2] * e
        ny = R[1, 0] * a + R[1, 1] * b + R[1, 2] * e
        nz = R[2, 0] * a + R[2, 1] * b + R[2, 2] * e
        q = f0 + REC * (f - fa)
        w[q, 0], w[q, 1], w[q, 2] = nx, ny, nz
        # n·(R x + t) = n_local·x + n·t
        w[q + 1, 0] = face_plane[f, 3] + nx * tx + ny * ty + nz * tz
        w[q + 1, 1] = math.sqrt(rho2)
        w[q + 1, 2] = 0.0
        w[q + 2, 0] = R[0, 0] * mx + R[0, 1] * my + R[0, 2] * mz + tx
        w[q + 2, 1] = R[1, 0] * mx + R[1, 1] * my + R[1, 2] * mz + ty
        w[q + 2, 2] = R[2, 0] * mx + R[2, 1] * my + R[2, 2] * mz + tz
        w[q + 3, 0] = v0 + k0 - base
        w[q + 3, 1] = k1 - k0
        w[q + 3, 2] = 0.0
    return loop_ptr[fb] - base


@nb.njit(**JIT)
def _separated(w, f0, nf, v0, nv, tol):
    """Whether one of the nf planes at w[f0:] has all the vertices
    w[v0:v0+nv] outside it or within tol of it (a separating axis among
    the face normals)."""
    for i in range(nf):
        q = f0 + REC * i
        nx, ny, nz = w[q, 0], w[q, 1], w[q, 2]
        lim = w[q + 1, 0] - tol
        sep = True
        for k in range(v0, v0 + nv):
            if nx * w[k, 0] + ny * w[k, 1] + nz * w[k, 2] < lim:
                sep = False
                break
        if sep:
            return True
    return False


@nb.njit(**JIT)
def _coplanar(w, qf, qg, tol):
    """+1 (same normal) or −1 (opposite) if the faces with records at qf
    and qg are coplanar: each one's vertices within tol of the other's
    plane; 0 otherwise."""
    dot = w[qf, 0] * w[qg, 0] + w[qf, 1] * w[qg, 1] + w[qf, 2] * w[qg, 2]
    if abs(dot) < PARALLEL:
        return 0
    for qa, qb in ((qf, qg), (qg, qf)):
        nx, ny, nz, d = w[qb, 0], w[qb, 1], w[qb, 2], w[qb + 1, 0]
        v0 = np.int64(w[qa + 3, 0])
        for k in range(v0, v0 + np.int64(w[qa + 3, 1])):
            if abs(nx * w[k, 0] + ny * w[k, 1] + nz * w[k, 2] - d) > tol:
                return 0
    return 1 if dot > 0.0 else -1


@nb.njit(**JIT)
def _clip(w, src, n, dst, ps, cap):
    """Sutherland & Hodgman 1974: the polygon w[src:src+n] (signed
    distances in w[ps:ps+n, 0]) less its part with s > 0, into w[dst:];
    returns its vertex count (at most cap).  An edge is cut from its inside
    end, so the two faces sharing it cut it at the same point."""
    m = 0
    j = n - 1
    sj = w[ps + j, 0]
    for i in range(n):
        si = w[ps + i, 0]
        if (si <= 0.0) != (sj <= 0.0):
            if si <= 0.0:
                a, b, sa, sb = src + i, src + j, si, sj
            else:
                a, b, sa, sb = src + j, src + i, sj, si
            t = sa / (sa - sb)              # sa ≤ 0 < sb: t in [0, 1]
            if m < cap:
                w[dst + m, 0] = w[a, 0] + t * (w[b, 0] - w[a, 0])
                w[dst + m, 1] = w[a, 1] + t * (w[b, 1] - w[a, 1])
                w[dst + m, 2] = w[a, 2] + t * (w[b, 2] - w[a, 2])
                m += 1
        if si <= 0.0 and m < cap:
            w[dst + m, 0] = w[src + i, 0]
            w[dst + m, 1] = w[src + i, 1]
            w[dst + m, 2] = w[src + i, 2]
            m += 1
        j = i
        sj = si
    return m


@nb.njit(**JIT)
def _clip_face(w, qf, g0, ng, tol, first, p0, cap):
    """Clip the face with record qf by the ng planes with records from g0
    (the other cell); store its area and area centroid in its record.
    first: the face is the first cell's (a coplanar face of the other
    with the same normal keeps it, with half its area vector to S_B);
    otherwise a coplanar face drops it.  Returns that share of S_B."""
    w[qf + 1, 2] = 0.0
    nfx, nfy, nfz = w[qf, 0], w[qf, 1], w[qf, 2]
    rho = w[qf + 1, 1]
    cx, cy, cz = w[qf + 2, 0], w[qf + 2, 1], w[qf + 2, 2]
    v0 = np.int64(w[qf + 3, 0])
    n = np.int64(w[qf + 3, 1])
    src, dst, ps = p0, p0 + cap, p0 + 2 * cap
    for k in range(n):
        w[src + k, 0] = w[v0 + k, 0]
        w[src + k, 1] = w[v0 + k, 1]
        w[src + k, 2] = w[v0 + k, 2]
    share = 0.0
    for i in range(ng):
        qg = g0 + REC * i
        gx, gy, gz, gd = w[qg, 0], w[qg, 1], w[qg, 2], w[qg + 1, 0]
        sc = gx * cx + gy * cy + gz * cz - gd
        if sc + rho < -tol:
            continue                        # the face is inside this plane, clear of it
        if sc - rho > tol:
            return 0.0                      # the face is outside
        cp = _coplanar(w, qf, qg, tol)
        if cp != 0:
            if first and cp > 0:
                share = 0.5
                continue
            return 0.0
        smin = np.inf
        smax = -np.inf
        for k in range(n):
            s = gx * w[src + k, 0] + gy * w[src + k, 1] + gz * w[src + k, 2] - gd
            w[ps + k, 0] = s
            smin = min(smin, s)
            smax = max(smax, s)
        if smax <= 0.0:
            continue
        if smin > 0.0:
            return 0.0
        n = _clip(w, src, n, dst, ps, cap)
        src, dst = dst, src
        if n < 3:
            return 0.0
    # area and area centroid by the fan of triangles from the first vertex,
    # signed along the face normal (each triangle: (e1 × e2)/2, centroid
    # (x0 + x1 + x2)/3)
    x0, y0, z0 = w[src, 0], w[src, 1], w[src, 2]
    a2 = mx = my = mz = 0.0
    for k in range(1, n - 1):
        ax, ay, az = w[src + k, 0] - x0, w[src + k, 1] - y0, w[src + k, 2] - z0
        bx, by, bz = w[src + k + 1, 0] - x0, w[src + k + 1, 1] - y0, w[src + k + 1, 2] - z0
        t = (nfx * (ay * bz - az * by) + nfy * (az * bx - ax * bz)
             + nfz * (ax * by - ay * bx))
        a2 += t
        mx += t * (ax + bx)
        my += t * (ay + by)
        mz += t * (az + bz)
    if not a2 > 0.0:
        return 0.0
    w[qf + 1, 2] = 0.5 * a2
    w[qf + 2, 0] = x0 + mx / (3.0 * a2)
    w[qf + 2, 1] = y0 + my / (3.0 * a2)
    w[qf + 2, 2] = z0 + mz / (3.0 * a2)
    return share


@nb.njit(**JIT)
def _sphere_apart(w, qf, cx, cy, cz, r):
    """Whether the bounding sphere of the face at qf misses the ball (c, r)."""
    dx, dy, dz = w[qf + 2, 0] - cx, w[qf + 2, 1] - cy, w[qf + 2, 2] - cz
    rr = w[qf + 1, 1] + r
    return dx * dx + dy * dy + dz * dz > rr * rr


@nb.njit(**JIT)
def _polytope(w, A, B, p0, cap, tol, o):
    """Clip A's faces by B's planes and B's by A's (A, B: the first face
    record, the number of faces, the bounding sphere's centre and radius),
    and sum: V, centroid (world: + o), S_B, |S_B| (see module)."""
    fa0, na, ca, ra = A
    fb0, nb_, cb, rb = B
    for i in range(na):
        q = fa0 + REC * i
        if _sphere_apart(w, q, cb[0], cb[1], cb[2], rb):
            w[q + 1, 2] = 0.0
        else:
            w[q + 3, 2] = _clip_face(w, q, fb0, nb_, tol, True, p0, cap)
    for i in range(nb_):
        q = fb0 + REC * i
        if _sphere_apart(w, q, ca[0], ca[1], ca[2], ra):
            w[q + 1, 2] = 0.0
        else:
            _clip_face(w, q, fa0, na, tol, False, p0, cap)
            w[q + 3, 2] = 1.0
    # reference point r: the area-weighted mean of the polygons' centroids
    at = rx = ry = rz = 0.0
    for q0, nf in ((fa0, na), (fb0, nb_)):
        for i in range(nf):
            q = q0 + REC * i
            a = w[q + 1, 2]
            if a > 0.0:
                at += a
                rx += a * w[q + 2, 0]
                ry += a * w[q + 2, 1]
                rz += a * w[q + 2, 2]
    if not at > 0.0:
        return 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0
    rx /= at
    ry /= at
    rz /= at
    # pyramids from r over the polygons: V_f = (c_f − r)·n_f A_f / 3
    # (divergence theorem, Mirtich 1996), centroid r + 3/4 (c_f − r)
    vol = mx = my = mz = sx = sy = sz = 0.0
    for q0, nf in ((fa0, na), (fb0, nb_)):
        for i in range(nf):
            q = q0 + REC * i
            a = w[q + 1, 2]
            if a > 0.0:
                dx, dy, dz = w[q + 2, 0] - rx, w[q + 2, 1] - ry, w[q + 2, 2] - rz
                vf = (dx * w[q, 0] + dy * w[q, 1] + dz * w[q, 2]) * a / 3.0
                vol += vf
                mx += vf * dx
                my += vf * dy
                mz += vf * dz
                s = w[q + 3, 2] * a
                sx += s * w[q, 0]
                sy += s * w[q, 1]
                sz += s * w[q, 2]
    if not vol > tol * at:
        return 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0
    k = 0.75 / vol
    return (vol, o[0] + rx + k * mx, o[1] + ry + k * my, o[2] + rz + k * mz, sx, sy, sz,
            math.sqrt(sx * sx + sy * sy + sz * sz))


@nb.njit(**JIT)
def overlap(ca, pa, Ra, cb, pb, Rb, cell_face_ptr, loop_ptr, loop_xyz, face_plane, radius,
            scratch):
    """Overlap of cells ca (at pa (3,), turned by Ra (3, 3)) and cb (pb, Rb):
    (V [m³], c (world) [m] ×3, S_B [m²] ×3, |S_B| [m²]), S_B the area vector
    of the part of ∂(A ∩ B) on B's faces (out of B into A: the direction B
    pushes A; the gradient of V with respect to B's position).  All 0 when
    the cells do not overlap or only touch.  radius (N,): each cell's
    bounding radius about its body origin (max |loop_xyz|); scratch
    (rows, 3) float64, rows ≥ SCRATCH_ROWS(max_rows, max_faces)."""
    ra, rb = radius[ca], radius[cb]
    dx, dy, dz = pb[0] - pa[0], pb[1] - pa[1], pb[2] - pa[2]
    if dx * dx + dy * dy + dz * dz >= (ra + rb) * (ra + rb):
        return 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0
    na = cell_face_ptr[ca + 1] - cell_face_ptr[ca]
    nb_ = cell_face_ptr[cb + 1] - cell_face_ptr[cb]
    la = loop_ptr[cell_face_ptr[ca + 1]] - loop_ptr[cell_face_ptr[ca]]
    lb = loop_ptr[cell_face_ptr[cb + 1]] - loop_ptr[cell_face_ptr[cb]]
    cap = max(la, lb) + max(na, nb_) + 4
    fa0 = la + lb
    fb0 = fa0 + REC * na
    p0 = fb0 + REC * nb_
    if p0 + 3 * cap > scratch.shape[0]:
        raise ValueError("overlap: scratch has fewer rows than SCRATCH_ROWS")
    tol = FLAT * (ra + rb)
    # coordinates relative to pa: small numbers near the contact
    _load(ca, pa, Ra, pa, cell_face_ptr, loop_ptr, loop_xyz, face_plane,
          scratch, 0, fa0)
    _load(cb, pb, Rb, pa, cell_face_ptr, loop_ptr, loop_xyz, face_plane,
          scratch, la, fb0)
    if _separated(scratch, fa0, na, la, lb, tol) or _separated(scratch, fb0, nb_, 0, la, tol):
        return 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0
    return _polytope(scratch, (fa0, na, (0.0, 0.0, 0.0), ra), (fb0, nb_, (dx, dy, dz), rb),
                     p0, cap, tol, (pa[0], pa[1], pa[2]))


@nb.njit(**JIT)
def overlap_halfspace(ca, pa, Ra, n, d, cell_face_ptr, loop_ptr, loop_xyz, face_plane, radius,
                      scratch):
    """Overlap of cell ca (at pa, turned by Ra) and the ground n·x ≤ d (n
    (3,) unit, world): as ``overlap``, B the ground: S_B = n × the area of
    A's cross-section by the plane n·x = d (plus half of a face of A lying
    in that plane with normal n, see module)."""
    ra = radius[ca]
    h = n[0] * pa[0] + n[1] * pa[1] + n[2] * pa[2] - d      # height of pa
    if h >= ra:
        return 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0
    na = cell_face_ptr[ca + 1] - cell_face_ptr[ca]
    la = loop_ptr[cell_face_ptr[ca + 1]] - loop_ptr[cell_face_ptr[ca]]
    cap = la + max(na, 1) + 4
    fa0 = la + 4
    fb0 = fa0 + REC * na
    p0 = fb0 + REC
    if p0 + 3 * cap > scratch.shape[0]:
        raise ValueError("overlap_halfspace: scratch has fewer rows than SCRATCH_ROWS")
    tol = FLAT * 2.0 * ra
    w = scratch
    _load(ca, pa, Ra, pa, cell_face_ptr, loop_ptr, loop_xyz, face_plane,
          w, 0, fa0)
    # the ground as one face: its plane relative to pa, and a square of
    # side 4 r_A about the foot q = −h n of pa, counter-clockwise about n
    # (t1 × t2 = n)
    nx, ny, nz = n[0], n[1], n[2]
    if abs(nx) < 0.6:
        ux, uy, uz = 0.0, nz, -ny           # t1 ∝ n × e_x
    else:
        ux, uy, uz = -nz, 0.0, nx           # t1 ∝ n × e_y (|n_x| ≥ 0.6)
    u = math.sqrt(ux * ux + uy * uy + uz * uz)
    ux, uy, uz = ux / u, uy / u, uz / u
    vx, vy, vz = ny * uz - nz * uy, nz * ux - nx * uz, nx * uy - ny * ux
    s = 2.0 * ra
    for k in range(4):
        a = s if k == 1 or k == 2 else -s
        b = s if k >= 2 else -s
        w[la + k, 0] = -h * nx + a * ux + b * vx
        w[la + k, 1] = -h * ny + a * uy + b * vy
        w[la + k, 2] = -h * nz + a * uz + b * vz
    w[fb0, 0], w[fb0, 1], w[fb0, 2] = nx, ny, nz
    w[fb0 + 1, 0] = -h
    w[fb0 + 1, 1] = s * math.sqrt(2.0)
    w[fb0 + 1, 2] = 0.0
    w[fb0 + 2, 0], w[fb0 + 2, 1], w[fb0 + 2, 2] = -h * nx, -h * ny, -h * nz
    w[fb0 + 3, 0] = la
    w[fb0 + 3, 1] = 4.0
    w[fb0 + 3, 2] = 0.0
    # all of A above the plane (or within tol of it): apart or touching
    if _separated(w, fb0, 1, 0, la, tol):
        return 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0
    return _polytope(w, (fa0, na, (0.0, 0.0, 0.0), ra),
                     (fb0, 1, (-h * nx, -h * ny, -h * nz), np.inf), p0, cap, tol,
                     (pa[0], pa[1], pa[2]))
