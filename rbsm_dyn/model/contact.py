"""Contact between any cells: what the model holds, what a run carries, and
the Python side of the broad phase (when to rebuild, how many steps a chunk
may take).  Kernels: physics/collide.py and physics/contact_geometry.py;
DESIGN.md §8.

Built only when the scene asks (case ``contact``, or a rigid part given an
initial velocity toward another part: contact_setting); otherwise
Model.contact is None and nothing here runs.
"""
from dataclasses import dataclass, field

import numba as nb
import numpy as np

from ..physics.collide import N_OUT, O_C, O_K, O_KT, O_N, body_pairs, broad_phase, carry_slip, neighbour_active
from ..physics.contact_geometry import SCRATCH_ROWS, planes_from_loops
from ..physics.rotation import quat_matrix_np
from .stable_step import _scaled_row_sums, scaled_row_sums

#: a cell whose own vertices lie outside one of its face planes by more
#: than this times its radius is not convex: contact takes its convex hull
CONVEX_TOL = 1e-9


def contact_setting(case, model):
    """(pairs, friction, stiffness, damping, skin, ground) of the scene, or None:
    the case's ``contact``; without one, contact (friction 0) between each
    rigid part given an initial velocity toward another part (its centroid
    moving toward that part's) and those parts.  pairs: "all" or a list of
    [part_a, part_b]; ground: None or (point, normal)."""
    c = case.contact
    if c is not None:
        ground = None if c.ground is None else (list(c.ground.point), list(c.ground.normal))
        return c.between, c.friction, c.stiffness, c.damping, c.skin, ground
    if case.solver.mode != "dynamic" or len(case.parts) < 2:
        return None
    centre = {name: model.body_pos0[model.groups[name]].mean(axis=0) for name in case.parts}
    pairs = []
    for item in case.initial:
        part = case.parts.get(item.group)
        if part is None or part.mesh.kind != "rigid" or not any(item.velocity):
            continue
        for other in case.parts:
            if other != item.group and np.dot(centre[other] - centre[item.group],
                                               item.velocity) > 0.0:
                pairs.append([item.group, other])
    return (pairs, 0.0, 1.0, 0.0, None, None) if pairs else None


@dataclass(frozen=True)
class ContactModel:
    """Per cell (N): its faces' loops in its principal frame (CSR:
    cell_face_ptr (N+1,) over faces, loop_ptr (F+1,) over loop rows,
    loop_xyz (L, 3) [m], cell_loop_ptr (N+1,) the cell's loop rows),
    face_plane (F, 4) outward unit normal and offset in that frame, radius
    (N,) [m] of the bounding sphere, vert_ptr (N+1,) and vert_xyz (V, 3)
    [m] each cell's vertices once (its frame), body_size (N,) [m] V^⅓ about the centroid, body_e, body_g (N,)
    [Pa] Young's and shear moduli, body_rigid (N,) uint8, body_part (N,)
    int32 and allowed (P, P) uint8: the parts that may meet.  Springs:
    nbr_key (K,) int64 the pairs a·(N+1) + b tied by springs, spring_pair
    (S,) int32 each spring's row there (−1: support).  ground (4,) n, d of
    the ground n·x ≤ d (has_ground), mu, kfac (stiffness factor), skin [m].
    """
    cell_face_ptr: np.ndarray
    loop_ptr: np.ndarray
    loop_xyz: np.ndarray
    cell_loop_ptr: np.ndarray
    face_plane: np.ndarray
    vert_ptr: np.ndarray
    vert_xyz: np.ndarray
    radius: np.ndarray
    body_size: np.ndarray
    body_e: np.ndarray
    body_g: np.ndarray
    body_rigid: np.ndarray
    body_part: np.ndarray
    allowed: np.ndarray
    nbr_key: np.ndarray
    spring_pair: np.ndarray
    ground: np.ndarray
    has_ground: bool
    mu: float
    kfac: float
    zeta: float
    skin: float
    n_hull: int = 0           # cells replaced by their convex hulls
    #: (N,) [m] how far a vertex lies from the cell's axes of turning: the
    #: radius, or in a plane model (turns about z alone) the distance in
    #: the plane, so that the rebuild test and the chunk length do not
    #: count the slab's thickness as a lever (rebuild, chunk_steps)
    turn_radius: np.ndarray = None


def build_contact(case, model, setting):
    """ContactModel of a built model and its contact_setting."""
    from ..case import scene_parts
    pairs, mu, kfac, zeta, skin, ground = setting
    mesh = model.mesh
    n = model.n_bodies
    cpp = np.asarray(mesh.cell_poly_ptr, dtype=np.int64)
    pptr = np.asarray(mesh.poly_ptr, dtype=np.int64)
    poly_cell = np.repeat(np.arange(n), np.diff(cpp))
    row_cell = np.repeat(poly_cell, np.diff(pptr))
    R0 = quat_matrix_np(model.body_quat0[:n])
    world = mesh.vertices[np.asarray(mesh.poly_vertex, dtype=np.int64)]
    local = np.einsum("nki,nk->ni", R0[row_cell], world - model.body_pos0[row_cell])
    cpp, pptr, local, n_hull = _convex(cpp, pptr, local, n)
    vptr = np.asarray(mesh.cell_vertex_ptr, dtype=np.int64)
    vcell = np.repeat(np.arange(n), np.diff(vptr))
    vert = np.einsum("nki,nk->ni", R0[vcell], mesh.vertices - model.body_pos0[vcell])
    cell_loop_ptr = pptr[cpp]
    plane = planes_from_loops(pptr, local)
    dist = np.sqrt(np.einsum("ij,ij->i", local, local))
    radius = np.maximum.reduceat(dist, cell_loop_ptr[:-1])
    turn_radius = radius
    if model.plane:
        # the vertices' distance from the z axis through the centroid
        # (world axes at rest: R0 x of the principal-frame vertex x)
        xy = np.einsum("nik,nk->ni", R0[vcell], vert)[:, :2]
        turn_radius = np.sqrt(np.maximum.reduceat(np.einsum("ij,ij->i", xy, xy), vptr[:-1]))

    parts = scene_parts(case)
    names = [p.name for p in parts]
    body_part = (np.zeros(n, dtype=np.int32) if mesh.cell_part is None
                 else np.asarray(mesh.cell_part, dtype=np.int32))
    allowed = np.zeros((len(parts), len(parts)), dtype=np.uint8)
    if pairs == "all":
        allowed[:] = 1
    else:
        for pa, pb in pairs:
            i, j = names.index(pa), names.index(pb)
            allowed[i, j] = allowed[j, i] = 1
    rigid = np.array([p.mesh.kind == "rigid" for p in parts])[body_part].astype(np.uint8)
    young = np.array([m["young"] for m in model.materials])[model.body_material]
    nu = np.array([m["poisson"] for m in model.materials])[model.body_material]

    sb = model.spring_bodies.astype(np.int64)
    inner = sb[:, 1] < n
    keys = sb[:, 0] * (n + 1) + sb[:, 1]
    nbr_key = np.unique(keys[inner])
    spring_pair = np.where(inner, np.searchsorted(nbr_key, keys), -1).astype(np.int32)

    g = np.zeros(4)
    if ground is not None:
        nrm = np.asarray(ground[1], float)
        nrm = nrm / np.linalg.norm(nrm)
        g[:3] = nrm
        g[3] = float(nrm @ np.asarray(ground[0], float))
    if skin is None:
        # a fifth of the smallest deformable cell's size (V^⅓)
        vol = model.body_volume[rigid == 0] if np.any(rigid == 0) else model.body_volume
        skin = 0.2 * float(np.min(vol)) ** (1.0 / 3.0)
    return ContactModel(
        cell_face_ptr=cpp, loop_ptr=pptr, loop_xyz=np.ascontiguousarray(local),
        cell_loop_ptr=np.ascontiguousarray(cell_loop_ptr), face_plane=plane,
        vert_ptr=vptr, vert_xyz=np.ascontiguousarray(vert),
        radius=radius, body_size=np.cbrt(model.body_volume), body_e=young, body_g=young / (2.0 * (1.0 + nu)), body_rigid=rigid,
        body_part=body_part, allowed=allowed, nbr_key=nbr_key, spring_pair=spring_pair,
        ground=g, has_ground=ground is not None, mu=float(mu), kfac=float(kfac),
        zeta=float(zeta),
        skin=float(skin), n_hull=n_hull, turn_radius=turn_radius)


@nb.njit(cache=True)
def _nonconvex(cell_face_ptr, loop_ptr, cell_loop_ptr, loop_xyz, plane, radius, tol):
    """(N,) bool: cells with a vertex outside one of their own face planes."""
    n = cell_face_ptr.shape[0] - 1
    bad = np.zeros(n, dtype=np.bool_)
    for c in range(n):
        lim = tol * radius[c]
        for f in range(cell_face_ptr[c], cell_face_ptr[c + 1]):
            for k in range(cell_loop_ptr[c], cell_loop_ptr[c + 1]):
                x = (plane[f, 0] * loop_xyz[k, 0] + plane[f, 1] * loop_xyz[k, 1]
                     + plane[f, 2] * loop_xyz[k, 2] - plane[f, 3])
                if x > lim:
                    bad[c] = True
                    break
            if bad[c]:
                break
    return bad


def _convex(cpp, pptr, local, n):
    """The loops with every non-convex cell (a clipped cell at a concave
    corner of its solid, a non-convex rigid part) replaced by the triangles
    of its convex hull (scipy's Qhull; a loop over those cells only)."""
    cell_loop_ptr = pptr[cpp]
    plane = planes_from_loops(pptr, local)
    radius = np.maximum.reduceat(np.sqrt(np.einsum("ij,ij->i", local, local)),
                                 cell_loop_ptr[:-1])
    bad = _nonconvex(cpp, pptr, cell_loop_ptr, local, plane, radius, CONVEX_TOL)
    if not np.any(bad):
        return cpp, pptr, local, 0
    from scipy.spatial import ConvexHull
    n_faces = np.diff(cpp)
    rows_per_face = np.diff(pptr)
    faces_new = np.where(bad, 0, n_faces)
    tri = []
    for c in np.nonzero(bad)[0]:
        pts = local[cell_loop_ptr[c]:cell_loop_ptr[c + 1]]
        hull = ConvexHull(pts)
        t = hull.simplices.copy()
        # outward: counter-clockwise seen from outside (Qhull's normals)
        e = np.cross(pts[t[:, 1]] - pts[t[:, 0]], pts[t[:, 2]] - pts[t[:, 0]])
        flip = np.einsum("ij,ij->i", e, hull.equations[:, :3]) < 0
        t[flip] = t[flip][:, ::-1]
        tri.append((c, pts[t].reshape(-1, 3)))
        faces_new[c] = len(t)
    # cells in order: the kept faces of good cells, the hull triangles of bad ones
    blocks_xyz, blocks_len = [], []
    starts = cell_loop_ptr
    hull_of = dict(tri)
    # runs of consecutive good cells are copied at once
    edges = np.flatnonzero(np.diff(np.r_[0, bad.astype(np.int8), 0]))
    prev = 0
    runs = []
    for k in range(0, len(edges), 2):
        runs.append((prev, edges[k]))
        runs.append(("hull", edges[k], edges[k + 1]))
        prev = edges[k + 1]
    runs.append((prev, n))
    for r in runs:
        if r[0] == "hull":
            for c in range(r[1], r[2]):
                blocks_xyz.append(hull_of[c])
                blocks_len.append(np.full(len(hull_of[c]) // 3, 3))
        elif r[1] > r[0]:
            blocks_xyz.append(local[starts[r[0]]:starts[r[1]]])
            blocks_len.append(rows_per_face[cpp[r[0]]:cpp[r[1]]])
    new_local = np.concatenate(blocks_xyz)
    new_pptr = np.r_[0, np.cumsum(np.concatenate(blocks_len))].astype(np.int64)
    new_cpp = np.r_[0, np.cumsum(faces_new)].astype(np.int64)
    return new_cpp, new_pptr, new_local, int(bad.sum())


@dataclass
class ContactState:
    """What a run carries for contact: the candidate pairs (P, 2) int32,
    their slip memory (P, 3) [m], the face that separated them at the
    last step (P,) int32 (−1: none; collide._separating_face), their last results out (P, N_OUT), each
    body's pairs (ptr, entry: collide.body_pairs), body_friction (N,) [J]
    friction dissipated so far, the positions and orientations at the last
    broad phase (x_build, q_build), per-thread scratch, builds so far."""
    pairs: np.ndarray
    slip: np.ndarray
    sep: np.ndarray
    out: np.ndarray
    ptr: np.ndarray
    entry: np.ndarray
    body_friction: np.ndarray
    body_dwrench: np.ndarray
    x_build: np.ndarray
    q_build: np.ndarray
    scratch: np.ndarray
    builds: int = 0
    stiff_warning: str = field(default="")
    spring_rows: np.ndarray = None      # the springs' row sums (stiffness_check)
    # a trial copy (an output frame's, explicit.spring_pass): its out holds
    # the pairs at the frame, whose dissipation of the step (O_W) the step
    # from there books (solvers/output.py spring_observables)
    is_trial: bool = False

    def trial(self):
        """A copy whose commits (slip, friction) do not touch this one."""
        return ContactState(self.pairs, self.slip.copy(), self.sep.copy(), self.out.copy(),
                            self.ptr, self.entry, self.body_friction.copy(),
                            self.body_dwrench.copy(), self.x_build, self.q_build, self.scratch,
                            self.builds, is_trial=True)


def new_contact_state(model):
    cm = model.contact
    n = model.n_bodies
    nblk = max(1, nb.get_num_threads())
    max_rows = int(np.max(np.diff(cm.cell_loop_ptr))) if n else 0
    max_faces = int(np.max(np.diff(cm.cell_face_ptr))) if n else 0
    return ContactState(
        pairs=np.zeros((0, 2), dtype=np.int32), slip=np.zeros((0, 3)),
        sep=np.zeros(0, dtype=np.int32), out=np.zeros((0, N_OUT)),
        ptr=np.zeros(n + 1, dtype=np.int64), entry=np.zeros(0, dtype=np.int64),
        body_friction=np.zeros(n), body_dwrench=np.zeros((n, 6)), x_build=np.full((n + 1, 3), np.inf), q_build=np.zeros((n, 4)),
        scratch=np.zeros((nblk, SCRATCH_ROWS(max_rows, max_faces), 3)))


def rebuild(model, state, force=False):
    """Broad phase again when some cell has moved more than half the skin
    since the last one (its centroid, plus its radius times the angle it
    has turned), or when `force`.  Returns True when it ran."""
    cm = model.contact
    cs = state.contact
    n = model.n_bodies
    # the ground half-space where the ground is now (its row n of body_pos
    # moves with a ground_motion: physics/integrate.py)
    ground = cm.ground.copy()
    ground[3] += float(ground[:3] @ state.body_pos[n])
    if not force and cs.builds:
        moved = np.linalg.norm(state.body_pos[:n] - cs.x_build[:n], axis=1)
        dot = np.abs(np.einsum("ij,ij->i", state.body_quat[:n], cs.q_build))
        moved += cm.turn_radius * 2.0 * np.arccos(np.minimum(dot, 1.0))
        if cm.has_ground:
            # the ground's move towards or away from the cells
            moved += abs(float(cm.ground[:3] @ (state.body_pos[n] - cs.x_build[n])))
        if moved.max(initial=0.0) <= 0.5 * cm.skin:
            return False
    active = neighbour_active(cm.spring_pair, len(cm.nbr_key), model.inelastic,
                              state.spring_kappa)
    pairs = broad_phase(state.body_pos, state.body_rot, cm.cell_loop_ptr, cm.loop_xyz,
                        cm.radius, cm.skin, cm.body_part, cm.allowed, cm.nbr_key, active,
                        ground, cm.has_ground)
    cs.slip, cs.sep, cs.out = carry_slip(cs.pairs, cs.slip, cs.sep, cs.out, pairs, n)
    cs.pairs = pairs
    cs.ptr, cs.entry = body_pairs(pairs, n)
    cs.x_build = state.body_pos.copy()          # (N+1, 3): the ground's row too
    cs.q_build = state.body_quat[:n].copy()
    cs.builds += 1
    return True


def chunk_steps(model, state, dt, gravity):
    """Steps the run may take before the next broad-phase check: no cell
    moves more than a quarter skin, at its present speed (centroid plus
    radius × spin) and acceleration (its last wrench and gravity)."""
    cm = model.contact
    n = model.n_bodies
    R = state.body_rot[:n]
    L = state.body_angmom[:n]
    wb = np.einsum("nki,nk->ni", R, L) / model.body_inertia
    spin = np.linalg.norm(wb, axis=1)
    v = np.linalg.norm(state.body_vel[:n], axis=1) + spin * cm.turn_radius
    a = (np.linalg.norm(state.body_wrench[:n, :3], axis=1) / model.body_mass
         + float(np.linalg.norm(gravity)))
    vmax, amax = float(v.max(initial=0.0)), float(a.max(initial=0.0))
    room = 0.25 * cm.skin
    # vmax t + ½ amax t² = room
    if amax > 0:
        t = (-vmax + np.sqrt(vmax * vmax + 2.0 * amax * room)) / amax
    elif vmax > 0:
        t = room / vmax
    else:
        return 1 << 30
    return max(1, int(t / dt))


def stiffness_check(model, state, dt, est):
    """The stable step with the present contacts: the Gershgorin row sums
    of the mass-scaled stiffness (stable_step.scaled_row_sums, Model.stable_dt)
    per body DOF, the springs' (at rest) plus those of the closed contacts
    as springs (k_n, k_t, k_t) at their points in their frames (n, t, t);
    the springs' refined bound (2/est)² scaled by how much the largest row
    grows.  A message when dt exceeds the step that gives, else ""."""
    cs = state.contact
    if not len(cs.pairs):
        return ""
    on = cs.out[:, O_K] > 0
    if not np.any(on):
        return ""
    n = model.n_bodies
    if cs.spring_rows is None:
        cs.spring_rows = (scaled_row_sums(model) if model.n_springs
                          else np.zeros((n, 6)))
    pairs = np.ascontiguousarray(cs.pairs[on])
    out = cs.out[on]
    c = out[:, O_C:O_C + 3]
    rot = state.body_rot
    pos = state.body_pos
    # arms in each body's (present) frame: Rᵀ (c − x); the ground's: none
    arm_a = np.einsum("pki,pk->pi", rot[pairs[:, 0]], c - pos[pairs[:, 0]])
    arm_b = np.einsum("pki,pk->pi", rot[pairs[:, 1]], c - pos[pairs[:, 1]])
    nrm = out[:, O_N:O_N + 3]
    t1 = np.cross(nrm, np.where(np.abs(nrm[:, :1]) < 0.9, [[1.0, 0, 0]], [[0, 1.0, 0]]))
    t1 /= np.linalg.norm(t1, axis=1)[:, None]
    frames = np.ascontiguousarray(np.stack([nrm, t1, np.cross(nrm, t1)], axis=2))
    k = np.ascontiguousarray(np.stack([out[:, O_K], out[:, O_KT], out[:, O_KT]], axis=1))
    rows = np.zeros((n, 6))
    _scaled_row_sums(pairs, arm_a, arm_b, rot, frames, k, model.body_mass,
                     model.body_inertia, np.ones((n, 6)), np.ones((n + 1, 6)), rows)
    g_s = float(cs.spring_rows.max(initial=0.0))
    g_sc = float((cs.spring_rows + rows).max())
    lam_s = (2.0 / est) ** 2 if np.isfinite(est) and est > 0 else 0.0
    lam = lam_s * g_sc / g_s if g_s > 0 and lam_s > 0 else g_sc
    limit = 2.0 / np.sqrt(lam)
    if dt <= limit:
        return ""
    return (f"contact stiffness lowers the stable step bound to {limit:.4g} s at "
            f"t = {state.time:.6g} s (dt = {dt:.4g} s): lower contact.stiffness or "
            "solver.dt_safety if the run diverges")


def contact_stable_dt(model):
    """A stable step bound [s] for a model whose only stiffness is contact
    (no springs: rigid blocks on the ground): each cell against a rigid
    partner over at most half its surface (the largest area a convex cell
    can press on: its projection, ≤ S/2), the penalty k = kfac E/(½ V^⅓)
    per area of physics/collide.py, at a lever of its radius:
    ω² ≤ 2 k (S/2) (1/m + r²/I_min) (the Gershgorin form of
    stiffness_check)."""
    cm = model.contact
    n = model.n_bodies
    loc = cm.loop_xyz
    # vector area of each loop: ½ Σ x_i × x_i+1 (Newell), its length summed per cell
    nxt = np.arange(len(loc)) + 1
    ends = cm.loop_ptr[1:] - 1
    nxt[ends] = cm.loop_ptr[:-1]
    va = 0.5 * np.add.reduceat(np.cross(loc, loc[nxt]), cm.loop_ptr[:-1], axis=0)
    area = np.add.reduceat(np.linalg.norm(va, axis=1), cm.cell_face_ptr[:-1])
    k = cm.kfac * cm.body_e / (0.5 * cm.body_size)
    lam = 2.0 * k * 0.5 * area * (1.0 / model.body_mass
                                  + cm.radius ** 2 / model.body_inertia.min(axis=1))
    lam_max = float(lam.max(initial=0.0)) if n else 0.0
    return np.inf if lam_max <= 0 else 2.0 / np.sqrt(lam_max)
