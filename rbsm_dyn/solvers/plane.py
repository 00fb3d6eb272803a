"""A plane model's explicit steps on the plane passes (physics/plane.py).

The model and the state stay those of the slab (model/core.py: prisms, z,
rx, ry held), which output, checkpoints, Newton and the modal solver read;
a run's chunks of steps go through the plane kernels on the in-plane
projection of both:

    plane_arrays(model)    PlaneBodies, PlaneSprings, PlaneLoads (once per model)
    plane_state(model, s)  the PlaneState of a State, kept on it between chunks
    lift(model, s)         the State's slab arrays from the PlaneState

Which scenes step on the plane passes (plane_ready): elastic and
inelastic springs (yield, rupture, cuts, interfaces), without contact
between cells; a plane scene with `contact` steps on the 3D passes of its
slab (the same answer, the 3D price) until the plane mode has a contact
pass too.
"""
import numpy as np

from ..physics.arrays import PlaneBodies, PlaneLoads, PlaneSprings, PlaneState
from ..physics.integrate import refresh_all_rotations
from ..physics.rotation import quat_matrix_np, quat_mul_np


def plane_ready(model, options):
    """True when the plane passes cover the model's physics."""
    return bool(model.plane) and not (options.poisson or options.contact or options.viscous)


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
    refresh_all_rotations(n + 1, state.body_quat, model.body_quat0, state.body_rot,
                          state.body_dq)
