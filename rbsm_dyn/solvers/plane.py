"""A plane model's explicit steps on the plane passes (physics/plane.py).

The model and the state stay those of the slab (model/core.py: prisms, z,
rx, ry held), which output, checkpoints, Newton and the modal solver read;
a run's chunks of steps go through the plane kernels on the in-plane
projection of both:

    plane_arrays(model)    PlaneBodies, PlaneSprings, PlaneLoads (once per model)
    plane_contact_arrays(model, cs)
                           PlaneContact of a contact state (each chunk: the
                           broad phase may have changed the pairs)
    plane_state(model, s)  the PlaneState of a State, kept on it between chunks
    lift(model, s)         the State's slab arrays from the PlaneState

Which scenes step on the plane passes (plane_ready): elastic and
inelastic springs (yield, rupture, cuts, interfaces), contact between
cells (physics/plane_contact.py; its broad phase runs between chunks on
the slab's arrays, as in 3D) and viscous springs (dashpots, Rayleigh's
β, Maxwell branches: physics/plane_viscous.py); a plane scene with the
Poisson correction steps on the 3D passes of its slab (the same answer,
the 3D price).
"""
import numpy as np

from ..physics.arrays import PlaneBodies, PlaneContact, PlaneLoads, PlaneSprings, PlaneState
from ..physics.integrate import refresh_all_rotations
from ..physics.rotation import quat_matrix_np, quat_mul_np


def plane_ready(model, options):
    """True when the plane passes cover the model's physics."""
    return bool(model.plane) and not options.poisson


def _z_column(rot):
    """Index of the principal axis along z of each body (N,): the column of
    R0 with the largest z component (a prism's mid-plane is a plane of
    symmetry, so z is a principal axis)."""
    return np.argmax(np.abs(rot[:, 2, :]), axis=1)


def plane_arrays(model):
    """(PlaneBodies, PlaneSprings, PlaneLoads) of a plane model (built once,
    kept on it)."""
    got = model.__dict__.get("_plane_arrays")
    if got is not None:
        return got
    m = model
    n = m.n_bodies
    rot = quat_matrix_np(m.body_quat0)                      # (N+1, 3, 3), ground: I
    kz = _z_column(rot[:n])
    jz = m.body_inertia[np.arange(n), kz]
    sb = m.spring_bodies
    arm_a = np.einsum("sij,sj->si", rot[sb[:, 0]], m.spring_arm_a)[:, :2]
    arm_b = np.einsum("sij,sj->si", rot[sb[:, 1]], m.spring_arm_b)[:, :2]
    frames = quat_matrix_np(m.face_frame0)                  # columns n, s, t
    nrm = frames[:, :, 0]
    tau = np.stack([-nrm[:, 1], nrm[:, 0], np.zeros(len(nrm))], axis=1)
    # stiffness along n and along the in-plane tangent τ = e_z × n of the
    # face's K = F diag(k) Fᵀ (a support holding some components: k = 0 there)
    proj = np.einsum("fij,fi->fj", frames, tau)             # τ in the frame
    ks = np.einsum("fj,fj->f", m.face_k, proj * proj)
    face_k = np.ascontiguousarray(np.stack([m.face_k[:, 0], ks], axis=1))
    f64 = np.ascontiguousarray
    bodies = PlaneBodies(f64(m.body_mass), f64(jz), f64(m.body_pos0[:, :2]))
    springs = PlaneSprings(m.spring_bodies, f64(arm_a), f64(arm_b), m.spring_slot,
                           m.spring_area, f64(nrm[:, :2]), face_k, m.face_h, m.face_law,
                           m.law_params, m.group_ptr, m.phase_ptr, m.cell_ivol, m.cell_plane,
                           m.cell_lever, m.cell_k, m.cell_2g)
    fext = np.concatenate([m.body_fext[:, :2], m.body_mext[:, 2:3]], axis=1)
    if len(m.body_ffol):
        # follower loads in the principal frame -> the body's rest axes
        f = np.einsum("nij,nj->ni", rot[:n], m.body_ffol)[:, :2]
        mz = np.einsum("nij,nj->ni", rot[:n], m.body_mfol)[:, 2:3]
        ffol = np.concatenate([f, mz], axis=1)
    else:
        ffol = np.zeros((0, 3))
    cols = [0, 1, 5]
    loads = PlaneLoads(f64(fext), f64(ffol), m.body_load_hist, f64(m.gravity[:2]),
                       f64(m.dof_kind[:, cols]), f64(m.dof_value[:, cols]),
                       f64(m.dof_hist[:, cols]), m.hist_ptr, m.hist_t, m.hist_a,
                       m.ground_hist, f64(m.ground_dir[:2]))
    got = (bodies, springs, loads)
    model.__dict__["_plane_arrays"] = got
    return got


def plane_state(model, state):
    """The PlaneState of `state`: the one kept on it by the last chunk, or
    made from the slab's arrays (positions, velocities, reactions: they
    round-trip exactly) and the state's θ, ω (body_theta, body_omega),
    which are taken from the slab's rotations and angular momenta first
    unless they hold the plane state's already (state.plane_synced: after
    a chunk, or restored by a restart, bit for bit)."""
    ps = state.plane
    if ps is not None:
        return ps
    n = model.n_bodies
    bodies, _, _ = plane_arrays(model)
    theta, omega = state.body_theta, state.body_omega
    if not state.plane_synced:
        dq = state.body_dq                                  # q q0⁻¹: a turn about z
        theta[:] = 2.0 * np.arctan2(dq[:, 3], dq[:, 0])
        omega[:n] = state.body_angmom[:n, 2] / bodies.body_jz
        omega[n] = 0.0
        state.plane_synced = True
    ps = PlaneState(body_pos=np.ascontiguousarray(state.body_pos[:, :2]), body_theta=theta,
                    body_cs=np.ascontiguousarray(np.stack([np.cos(theta), np.sin(theta)], 1)),
                    body_vel=np.ascontiguousarray(state.body_vel[:, :2]), body_omega=omega,
                    body_wrench=np.zeros((n + 1, 3)), body_support=np.zeros((n + 1, 2)),
                    body_work=state.body_work, body_damp=state.body_damp,
                    body_reaction=np.ascontiguousarray(state.body_reaction[:, :2]),
                    spring_force=np.zeros((model.n_springs, 2)))
    state.plane = ps
    return ps


def lift(model, state):
    """Write the PlaneState kept on `state` into its slab arrays (positions,
    rotations, velocities, angular momenta, reactions); body_work and
    body_damp are the same arrays."""
    ps = state.plane
    n = model.n_bodies
    bodies, _, _ = plane_arrays(model)
    state.body_pos[:, :2] = ps.body_pos
    half = 0.5 * ps.body_theta
    qz = np.zeros((n + 1, 4))
    qz[:, 0] = np.cos(half)
    qz[:, 3] = np.sin(half)
    state.body_quat[:] = quat_mul_np(qz, model.body_quat0)
    state.body_vel[:, :2] = ps.body_vel
    state.body_angmom[:n, 2] = bodies.body_jz * ps.body_omega[:n]
    state.body_reaction[:, :2] = ps.body_reaction
    # the wrench of the last step (a contact run's chunk length reads it:
    # model/contact.py chunk_steps)
    state.body_wrench[:, :2] = ps.body_wrench[:, :2]
    state.body_wrench[:, 5] = ps.body_wrench[:, 2]
    refresh_all_rotations(n + 1, state.body_quat, model.body_quat0, state.body_rot,
                          state.body_dq)


def plane_contact_geometry(model):
    """(poly_ptr, poly_xy, edge_face, face_edge, radius, thickness) of a
    plane model's contact (arrays.PlaneContact; built once, kept on it):
    each cell's polygon from its prism's vertices on the upper cap (world
    axes at rest, about its centroid), counter-clockwise by angle about
    their mean, near-duplicates dropped; a cell whose ring is not convex
    gets its convex hull (as model/contact.py gives the 3D contact);
    each edge's side face of the slab: the face whose outward normal is
    the edge's."""
    got = model.__dict__.get("_plane_contact_geometry")
    if got is not None:
        return got
    cm = model.contact
    n = model.n_bodies
    rot = quat_matrix_np(model.body_quat0[:n])
    vptr = np.asarray(cm.vert_ptr, dtype=np.int64)
    vcell = np.repeat(np.arange(n), np.diff(vptr))
    world = np.einsum("vij,vj->vi", rot[vcell], cm.vert_xyz)
    thickness = 2.0 * float(np.max(world[:, 2]))
    top = world[:, 2] > 0.25 * thickness
    cell = vcell[top]
    xy = world[top, :2]
    cnt = np.bincount(cell, minlength=n)
    mean = np.stack([np.bincount(cell, xy[:, k], minlength=n) for k in range(2)], 1)
    mean /= np.maximum(cnt, 1)[:, None]
    ang = np.arctan2(xy[:, 1] - mean[cell, 1], xy[:, 0] - mean[cell, 0])
    order = np.lexsort((ang, cell))
    cell, xy = cell[order], xy[order]
    r_cell = np.sqrt(np.maximum.reduceat(np.einsum("ij,ij->i", xy, xy),
                                         np.r_[0, np.cumsum(cnt)[:-1]]))
    # near-duplicates (the same corner twice in the cell's vertex list)
    prev = np.r_[-1, cell[:-1]]
    dup = (prev == cell) & (np.linalg.norm(xy - np.r_[xy[:1], xy[:-1]], axis=1)
                            <= 1e-9 * r_cell[cell])
    cell, xy = cell[~dup], xy[~dup]
    cnt = np.bincount(cell, minlength=n)
    ptr = np.r_[0, np.cumsum(cnt)].astype(np.int64)
    # convexity: every turn left (cross ≥ −tol r²)
    nxt = np.arange(len(xy)) + 1
    nxt[ptr[1:] - 1] = ptr[:-1]
    prv = np.arange(len(xy)) - 1
    prv[ptr[:-1]] = ptr[1:] - 1
    e1 = xy - xy[prv]
    e2 = xy[nxt] - xy
    cross = e1[:, 0] * e2[:, 1] - e1[:, 1] * e2[:, 0]
    bad = np.zeros(n, dtype=bool)
    np.logical_or.at(bad, cell, cross < -1e-9 * r_cell[cell] ** 2)
    if np.any(bad):
        from scipy.spatial import ConvexHull
        rings = np.split(xy, ptr[1:-1])
        for c in np.nonzero(bad)[0]:
            h = ConvexHull(rings[c])
            rings[c] = rings[c][h.vertices]           # counter-clockwise in 2D
        cnt = np.array([len(r) for r in rings])
        ptr = np.r_[0, np.cumsum(cnt)].astype(np.int64)
        xy = np.concatenate(rings)
        cell = np.repeat(np.arange(n), cnt)
        nxt = np.arange(len(xy)) + 1
        nxt[ptr[1:] - 1] = ptr[:-1]
    radius = np.sqrt(np.maximum.reduceat(np.einsum("ij,ij->i", xy, xy), ptr[:-1]))
    # each edge's side face: the cell's face whose rest normal is the edge's
    e = xy[nxt] - xy
    en = np.stack([e[:, 1], -e[:, 0]], 1)
    en /= np.maximum(np.linalg.norm(en, axis=1), 1e-300)[:, None]
    fptr = np.asarray(cm.cell_face_ptr, dtype=np.int64)
    fcell = np.repeat(np.arange(n), np.diff(fptr))
    fn = np.einsum("fij,fj->fi", rot[fcell], cm.face_plane[:, :3])
    nf = np.diff(fptr)
    width = int(nf.max(initial=1))
    cand = fptr[cell][:, None] + np.arange(width)[None, :]
    valid = cand < fptr[cell + 1][:, None]
    cand = np.where(valid, cand, 0)
    dots = np.einsum("ek,ewk->ew", en, fn[cand][:, :, :2])
    dots[~valid] = -2.0
    dots[np.abs(fn[cand][:, :, 2]) > 0.5] = -2.0
    best = np.argmax(dots, axis=1)
    ok = dots[np.arange(len(xy)), best] > 1.0 - 1e-6
    edge_face = np.where(ok, cand[np.arange(len(xy)), best], -1).astype(np.int32)
    face_edge = np.full(len(fn), -1, dtype=np.int32)
    face_edge[edge_face[ok]] = np.nonzero(ok)[0]
    got = (ptr, np.ascontiguousarray(xy), edge_face, face_edge, radius, thickness)
    model.__dict__["_plane_contact_geometry"] = got
    return got


def plane_contact_arrays(model, cs):
    """The PlaneContact of a contact state cs (model/contact.py ContactState)."""
    import numba

    from ..physics.plane_contact import SCRATCH_ROWS_2D
    from .passes import launch_threads
    launch_threads()
    cm = model.contact
    ptr, xy, edge_face, face_edge, radius, thickness = plane_contact_geometry(model)
    nblk = max(1, numba.get_num_threads())
    scratch = model.__dict__.get("_plane_contact_scratch")
    if scratch is None or scratch.shape[0] != nblk:
        rows = SCRATCH_ROWS_2D(int(np.max(np.diff(ptr), initial=3)))
        scratch = np.zeros((nblk, rows, 3))
        model.__dict__["_plane_contact_scratch"] = scratch
    return PlaneContact(cs.pairs, cs.slip, cs.sep, cs.out, cs.ptr, cs.entry, cs.body_friction,
                        cs.body_dwrench, ptr, xy, edge_face, face_edge, radius, cm.body_size,
                        cm.body_e, cm.body_g, cm.body_rigid, cm.ground, float(cm.mu),
                        float(cm.kfac), float(cm.zeta), thickness, scratch, model.n_springs == 0)
