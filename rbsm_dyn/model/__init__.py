"""Model (immutable structure-of-arrays) and State (what changes each step).

Built from a validated Case and its Mesh: bodies with real mass and full
principal inertia, spring points between neighbouring cells, support springs
to the ground (body index `n_bodies`), constraints, loads.  Kernels in
physics/ take these arrays; nothing here is read by a kernel as an object.

Index type: int32 throughout (DESIGN.md §5); state float64.
"""
import dataclasses
from dataclasses import dataclass, field

import numba as nb
import numpy as np

from ..calibration import stiffness_rule
from ..fracture_calibration import fracture_ratios
from ..mesh import block_mesh, principal_axes, spring_points, voronoi_mesh, voronoi_seeds
from ..partition import spring_schedule
from ..physics.integrate import DISPLACEMENT, FIXED, VELOCITY, refresh_all_rotations
from ..physics.laws import (BROKEN, CONTACT_OFF, CRITERIA, ELASTIC, N_PARAMS, P_COH, P_CRIT,
                           P_EPSCR, P_FT, P_GF, P_GS, P_MU, P_RS, P_RUPT, P_SY, P_TANPHI,
                           P_TENSION, RUPTURE_KINDS)
from ..physics.poisson import build_poisson, empty_poisson, poisson_abs_product
from ..physics.rotation import frames_from_normals, matrix_to_quat, quat_matrix_np

IDX = np.int32
FACES = ("xmin", "xmax", "ymin", "ymax", "zmin", "zmax")
COMPONENTS = ("x", "y", "z", "rx", "ry", "rz")


@dataclass(frozen=True)
class Model:
    """Static description of a run.  N bodies, S spring points.

    Bodies (rows 0..N-1; pos0/quat0 have one more row, the ground):
      body_mass (N,) [kg]; body_inertia (N, 3) principal moments [kg m²];
      body_volume (N,) [m³]; body_material (N,) int32;
      body_pos0 (N+1, 3) [m] centroids; body_quat0 (N+1, 4) principal axes.
    Springs:
      spring_bodies (S, 2) int32 (a, b), b == N for a support (ground);
      spring_arm_a, spring_arm_b (S, 3) [m] arms in the principal frames
      (the ground's frame is the world frame); spring_area (S,) [m²];
      spring_slot (S,) int32: the row of the spring's face in the face table.
    Face table (F rows, one per face that carries spring points, in spring
    order: what the points of one face share, held once):
      face_frame0 (F, 4) quaternion of the reference frame (n, s, t) with n
      from a to b; face_k (F, 3) [N/m³] stiffness per area (k_n, k_s, k_t);
      face_h (F,) [m] spring length; face_law (F,) int32 row of law_params;
      face_ref (F,) int32 internal face id, or −1 − boundary face id for
      supports.
    Per spring point, computed when asked (output, export, assembly; the
    kernels read the face table): spring_frame0 (S, 4), spring_k (S, 3)
      [N/m] = face_k × area, spring_h, spring_law, spring_face (S,),
      spring_point, spring_normal (= spring_n0) (S, 3): the rest position
      (on body a) and the frame's n.
    Spring laws (physics/laws/): face_law (spring_law) rows of law_params
      (n_laws, N_PARAMS) [Pa, 1, J/m²]; row 0 is purely elastic, row 1 + k
      is law slot k (a (material, part) pair in use: the fracture
      calibration depends on the part's mesh kind and cell size), row
      1 + K + k slot k without rupture (K slots; a support spring takes its
      cell's slot: a clamp can yield at the face, where beam theory puts
      the hinge; it breaks only when the support says `breakable: true`),
      then one row per interface with a law of its own (contact, or bonded
      with a material);
      spring_state0 (S,) int8 initial state (cuts: 2, broken);
      inelastic: bool, True when any law or cut needs the inelastic kernel.
    Schedule (partition.py): springs are stored by group, then (a, b);
      group_ptr (G+1,) spring ranges of the groups, phase_ptr (F+1,) group
      ranges of the phases (groups of a phase share no body).
    Constraints: dof_kind (N, 6) int8 (0 free, 1 fixed, 2 velocity, 3
      displacement), dof_value (N, 6), dof_hist (N, 6) int32.
    Loads: body_fext, body_mext (N, 3) [N, N m] world, fixed in space (dead);
      body_ffol, body_mfol (N, 3) [N, N m] follower loads in the body's
      principal frame (world R·f: they turn with the cell), (0, 3) when the
      case has none; body_load_hist (N,) int32 amplitude of both;
      gravity (3,) [m/s²]; amplitude tables hist_ptr, hist_t, hist_a.
    Poisson correction (physics/poisson.py): poisson, a PoissonArrays of
      per-cell least-squares strain geometry and λ_c V_c; length 0 (and
      poisson_on False) when no material has an auxiliary λ.
    """
    n_bodies: int
    body_mass: np.ndarray
    body_inertia: np.ndarray
    body_volume: np.ndarray
    body_material: np.ndarray
    body_pos0: np.ndarray
    body_quat0: np.ndarray
    spring_bodies: np.ndarray
    spring_arm_a: np.ndarray
    spring_arm_b: np.ndarray
    spring_slot: np.ndarray
    spring_area: np.ndarray
    face_frame0: np.ndarray
    face_k: np.ndarray
    face_h: np.ndarray
    face_law: np.ndarray
    face_ref: np.ndarray
    group_ptr: np.ndarray
    phase_ptr: np.ndarray
    dof_kind: np.ndarray
    dof_value: np.ndarray
    dof_hist: np.ndarray
    body_fext: np.ndarray
    body_mext: np.ndarray
    body_ffol: np.ndarray
    body_mfol: np.ndarray
    body_load_hist: np.ndarray
    gravity: np.ndarray
    hist_ptr: np.ndarray
    hist_t: np.ndarray
    hist_a: np.ndarray
    groups: dict
    materials: list
    mesh: object = field(repr=False)
    n_cut: int = 0
    law_params: np.ndarray = None
    spring_state0: np.ndarray = None
    inelastic: bool = False
    poisson: object = None
    warnings: tuple = ()          # messages for the user (conflicting constraints, ...)
    contact: object = None        # contact_model.ContactModel, None: no contact

    @property
    def poisson_on(self):
        """True when the auxiliary-stress pass runs (physics/poisson.py)."""
        return self.poisson is not None and len(self.poisson.slot_cell) > 0

    @property
    def spring_frame0(self):
        """(S, 4) reference frame quaternion of each spring point (its face's)."""
        return self.face_frame0[self.spring_slot]

    @property
    def spring_k(self):
        """(S, 3) [N/m] stiffness of each spring point: its face's per area × its area."""
        return self.face_k[self.spring_slot] * self.spring_area[:, None]

    @property
    def spring_h(self):
        """(S,) [m] length of each spring point (its face's)."""
        return self.face_h[self.spring_slot]

    @property
    def spring_law(self):
        """(S,) int32 law_params row of each spring point (its face's)."""
        return self.face_law[self.spring_slot]

    @property
    def spring_face(self):
        """(S,) int32 face of each spring point: internal face id, or −1 −
        boundary face id for a support."""
        return self.face_ref[self.spring_slot]

    @property
    def spring_normal(self):
        """(S, 3) unit normal of each spring point at rest (world): the
        first column of its frame.  Computed, not held (the kernels turn
        each face's frame once)."""
        return _frame_normals(self.spring_frame0)

    spring_n0 = spring_normal

    @property
    def spring_point(self):
        """(S, 3) rest position [m] of each spring point: body a's centroid
        plus its arm (the ground's frame is the world's).  Computed, not
        held (48 B per spring point with spring_normal; issue 15)."""
        a = self.spring_bodies[:, 0]
        return self.body_pos0[a] + np.einsum("sij,sj->si", quat_matrix_np(self.body_quat0[a]),
                                             self.spring_arm_a)

    @property
    def n_springs(self):
        return self.spring_bodies.shape[0]

    @property
    def ground(self):
        return self.n_bodies

    @property
    def is_support(self):
        return self.spring_bodies[:, 1] == self.n_bodies

    def stable_dt(self):
        """Stable step 2/ω_max from a bound on ω_max² = λ_max(M⁻¹K): Gershgorin
        row sums of the mass-scaled small-strain stiffness M^-½ K M^-½, with
        the rotations of each body in its principal axes so that M is
        exactly diagonal (m, m, m, I1, I2, I3).  A similarity transform, so
        the bound is safe; it includes the shear-lever coupling of every
        spring (DESIGN.md §5) and is within a factor 2 of the true step on
        blocks, Voronoi and sliver meshes (tests/test_linear_modal.py,
        tests/test_stability.py); refined by omega_max_bound's sweeps."""
        lam = omega_max_bound(self)
        return np.inf if lam <= 0 else 2.0 / np.sqrt(lam)


@dataclass
class State:
    """What changes each step.  Rows 0..N-1 are bodies, row N the ground.

    body_pos (N+1, 3) [m]; body_quat (N+1, 4); body_vel (N+1, 3) [m/s] at
    the half step; body_angmom (N+1, 3) [kg m²/s] world, half step;
    body_rot (N+1, 3, 3), body_dq (N+1, 4) derived from body_quat;
    body_wrench (N+1, 6) [N, N m]: sum of the spring forces and moments
    (about the body's centre) on each body, body_support (N+1, 3) [N]: the
    part of the force from support springs (both written by the spring
    kernels); spring_force (S, 3) [N]: force on body a, written only when a
    kernel is asked to (output steps); body_work, body_damp (N,) [J] accumulated;
    body_reaction (N, 3) [N]; step (int), dt [s].
    Inelastic springs (length S when Model.inelastic, else 0):
    spring_state (S,) int8; spring_dp (S, 3) [m] plastic gap or slip;
    spring_kappa (S,) [m] largest opening (strain law: last equivalent
    strain, physics/inelastic.py); spring_dmg (S,) damage;
    spring_wp, spring_wf (S,) [J] plastic and fracture dissipation.
    Poisson correction scratch (length 0 unless Model.poisson_on; not
    saved by checkpoints): aux_g (n_slots, 3) [1/m], aux_p (7, N)
    (physics/poisson.py poisson_pass)."""
    body_pos: np.ndarray
    body_quat: np.ndarray
    body_vel: np.ndarray
    body_angmom: np.ndarray
    body_rot: np.ndarray
    body_dq: np.ndarray
    body_wrench: np.ndarray
    body_support: np.ndarray
    spring_force: np.ndarray
    body_work: np.ndarray
    body_damp: np.ndarray
    body_reaction: np.ndarray
    spring_state: np.ndarray = None
    spring_dp: np.ndarray = None
    spring_kappa: np.ndarray = None
    spring_dmg: np.ndarray = None
    spring_wp: np.ndarray = None
    spring_wf: np.ndarray = None
    aux_g: np.ndarray = None
    aux_p: np.ndarray = None
    contact: object = None        # contact_model.ContactState when Model.contact
    step: int = 0
    dt: float = 0.0

    @property
    def time(self):
        return self.step * self.dt


def new_state(model):
    n, s = model.n_bodies, model.n_springs
    st = State(body_pos=model.body_pos0.copy(), body_quat=model.body_quat0.copy(),
               body_vel=np.zeros((n + 1, 3)), body_angmom=np.zeros((n + 1, 3)),
               body_rot=np.zeros((n + 1, 3, 3)), body_dq=np.zeros((n + 1, 4)),
               body_wrench=np.zeros((n + 1, 6)), body_support=np.zeros((n + 1, 3)),
               spring_force=np.zeros((s, 3)),
               body_work=np.zeros(n), body_damp=np.zeros(n), body_reaction=np.zeros((n, 3)))
    si = s if model.inelastic else 0
    st.spring_state = model.spring_state0.copy() if si else np.zeros(0, dtype=np.int8)
    st.spring_dp = np.zeros((si, 3))
    st.spring_kappa = np.zeros(si)
    st.spring_dmg = np.zeros(si)
    st.spring_wp = np.zeros(si)
    st.spring_wf = np.zeros(si)
    on = model.poisson_on
    st.aux_g = np.zeros((len(model.poisson.slot_cell) if on else 0, 3))
    st.aux_p = np.zeros((7, n if on else 0))
    refresh_all_rotations(n + 1, st.body_quat, model.body_quat0, st.body_rot, st.body_dq)
    if model.contact is not None:
        from .contact import new_contact_state
        st.contact = new_contact_state(model)
    return st


# --------------------------------------------------------------------------
# building


def build_mesh(case):
    """Cells of the scene (DESIGN.md §6).  One part (the ``domain`` +
    ``mesh`` shorthand): its mesh (part_mesh).  Several parts: each part's
    mesh, merged (mesh/merge.py), and the overlaps of touching parts'
    boundary faces (mesh/interface.py) added as internal faces that carry
    the index of their interface (Mesh.face_interface); parts that touch
    with no interface in the case are an error unless the case's
    ``contact`` covers them (then they share no face: contact alone acts)."""
    from ..case import scene_parts
    parts = scene_parts(case)
    if not case.parts:
        return part_mesh(case, parts[0])
    from ..mesh.interface import face_overlaps
    from ..mesh.merge import add_interface_faces, merge_meshes
    mesh = merge_meshes([part_mesh(case, p) for p in parts], [p.name for p in parts])
    diag = float(np.linalg.norm(mesh.box[1] - mesh.box[0]))
    try:
        ov = face_overlaps(mesh.bface_vertex_ptr, mesh.bface_vertex_xyz, mesh.bface_normal,
                           mesh.bface_cell, mesh.cell_part, length_tol=1e-9 * diag)
    except ValueError as exc:
        raise case.error(("interfaces",), str(exc)) from None
    names = list(case.parts)
    pair_of = {}
    for i, it in enumerate(case.interfaces):
        pa, pb = (names.index(x) for x in it.parts)
        pair_of[(min(pa, pb), max(pa, pb))] = i
    pa = mesh.cell_part[ov.cells[:, 0]]
    pb = mesh.cell_part[ov.cells[:, 1]]
    lo, hi = np.minimum(pa, pb), np.maximum(pa, pb)
    iface = np.full(len(lo), -1, dtype=np.int64)
    for (p0, p1), i in pair_of.items():
        iface[(lo == p0) & (hi == p1)] = i
    # touching parts without an interface: left to the case's contact
    # between cells (physics/collide.py) when it covers them, else an error
    covered = np.zeros(len(lo), dtype=bool)
    if case.contact is not None:
        if case.contact.between == "all":
            covered[:] = True
        else:
            for na, nb_ in case.contact.between:
                p0, p1 = sorted((names.index(na), names.index(nb_)))
                covered |= (lo == p0) & (hi == p1)
    if np.any((iface < 0) & ~covered):
        k = int(np.argmax((iface < 0) & ~covered))
        p0, p1 = names[lo[k]], names[hi[k]]
        area = float(ov.area[(lo == lo[k]) & (hi == hi[k])].sum())
        raise case.error(("interfaces",), f"parts {p0} and {p1} touch ({area:.4g} m² of "
                         f"shared faces): say how they are joined, e.g. interfaces: "
                         f"[{{parts: [{p0}, {p1}], law: bonded}}] or law: contact, or "
                         f"leave them to contact: {{between: [{p0}, {p1}]}}")
    keep = iface >= 0
    if not np.any(keep):
        return mesh
    rows = np.repeat(keep, np.diff(ov.vertex_ptr))
    ptr = np.concatenate(([0], np.cumsum(np.diff(ov.vertex_ptr)[keep])))
    return add_interface_faces(mesh, ov.cells[keep], ptr, ov.vertex_xyz[rows],
                               ov.normal[keep], iface[keep])


def part_mesh(case, part):
    """Cells of one part: a box cut directly (blocks, Voronoi clipped by
    mirrors), any other geometry by clipping the cells of a box around it
    to the solid (mesh/clip.py): Voronoi cells of the seeds inside the
    solid, or blocks over its bounds; a rigid part is one cell bounded by
    its solid's triangles (mesh/merge.py rigid_mesh)."""
    from ..case import part_solid
    m = part.mesh
    if m.kind == "rigid":
        from ..mesh.merge import rigid_mesh
        solid = part_solid(case, part)
        return rigid_mesh(solid.vertices, solid.triangles, solid.tri_surface,
                          solid.surface_names)
    if part.geometry.kind() == "box":
        box = np.asarray(part.geometry.box, dtype=float)
        if m.kind == "blocks":
            return block_mesh(box, tuple(m.divisions))
        return voronoi_mesh(box, m.size, seed=m.seed, min_spacing=m.min_spacing)
    from ..mesh.clip import clip_to_solid
    solid = part_solid(case, part)
    lo, hi = solid.bounds
    if m.kind == "blocks":
        cells = block_mesh(np.array([lo, hi]), tuple(m.divisions))
    else:
        # a margin of half a cell: no side of the box on the solid's surface
        box = np.array([lo - 0.5 * m.size, hi + 0.5 * m.size])
        seeds = voronoi_seeds(box, m.size, seed=m.seed, min_spacing=m.min_spacing)
        seeds = seeds[solid.contains(seeds)]
        if len(seeds) == 0:
            raise case.error(part.mesh_path + ("size",), "no cell seed falls inside the "
                             "solid: make the cells smaller than the solid")
        from ..mesh.voronoi import voronoi_cells
        cells = voronoi_cells(seeds, m.size, box)
    try:
        return clip_to_solid(cells, solid.vertices, solid.triangles, solid.tri_surface,
                             solid.surface_names, box=np.array([lo, hi]),
                             contains=solid.contains)
    except ValueError as exc:
        raise case.error(part.mesh_path, str(exc)) from None


@nb.njit(cache=True)
def _arms(rot, pos0, sb, point, arm_a, arm_b):
    """Arms of the spring points in their bodies' principal frames:
    arm = Rᵀ (point − centroid), for body a and body b (the ground's R is
    the identity); a loop, no (S, 3, 3) gather."""
    for s in range(sb.shape[0]):
        for side in range(2):
            i = sb[s, side]
            d0 = point[s, 0] - pos0[i, 0]
            d1 = point[s, 1] - pos0[i, 1]
            d2 = point[s, 2] - pos0[i, 2]
            out = arm_a if side == 0 else arm_b
            for c in range(3):
                out[s, c] = rot[i, 0, c] * d0 + rot[i, 1, c] * d1 + rot[i, 2, c] * d2


def _frames_from_normals(normal):
    """Quaternions of right-handed frames (n, s, t) for unit normals (S, 3)."""
    out = np.empty((len(normal), 4))
    frames_from_normals(np.ascontiguousarray(normal, dtype=float), out)
    return out


def _frame_normals(frame):
    """First column n of the rotation of each frame quaternion (S, 4) -> (S, 3)."""
    w, x, y, z = frame.T
    return np.ascontiguousarray(np.stack([1.0 - 2.0 * (y * y + z * z), 2.0 * (x * y + w * z),
                                          2.0 * (x * z - w * y)], axis=1))


def _spring_points_by_rule(ptr, xyz, normal, rule):
    """spring_points over polygons with a rule each (rule (F,) str): one
    call per distinct rule, points ordered by polygon."""
    from ..mesh._core import _gather
    from ..mesh.spring_points import SpringPoints
    rules = np.unique(rule)
    if len(rules) <= 1:
        return spring_points(ptr, xyz, normal, rules[0] if len(rules) else "moment")
    out = []
    for r in rules:
        sel = np.nonzero(rule == r)[0]
        p2, vid = _gather(ptr, np.arange(len(xyz)), sel)
        sp = spring_points(p2, xyz[vid], normal[sel], r)
        out.append(SpringPoints(sp.point, sp.weight, sel[sp.face]))
    face = np.concatenate([o.face for o in out])
    order = np.argsort(face, kind="stable")
    return SpringPoints(np.concatenate([o.point for o in out])[order],
                        np.concatenate([o.weight for o in out])[order], face[order])


def elastic_law_row():
    """law_params row of a purely elastic spring that never breaks (supports)."""
    row = np.zeros(N_PARAMS)
    row[P_TENSION] = np.inf
    row[P_MU] = CONTACT_OFF
    return row


def material_law_row(mat, mesh_kind="voronoi", cell_size=None):
    """law_params row of a case material (physics/laws/__init__.py columns).
    A broken face is a contact with Coulomb friction `friction` (default 0).
    Material fracture values are mapped to spring values by the mesh kind's
    fracture calibration (fracture_calibration.py) unless `rupture.values:
    spring`; the mixed-mode law's shear strength defaults to 2 f_t and its
    mode-II energy to G_f (docs/case_file.md)."""
    row = elastic_law_row()
    y = mat.yield_
    if y is not None:
        row[P_CRIT] = CRITERIA[y.criterion]
        if y.criterion == "mohr_coulomb":
            row[P_COH] = y.cohesion
            row[P_TANPHI] = np.tan(np.radians(y.friction_angle))
            row[P_TENSION] = np.inf if y.tension is None else y.tension
        else:
            row[P_SY] = y.stress
    r = mat.rupture
    if r is not None:
        if r.strain is not None:
            row[P_RUPT] = RUPTURE_KINDS["strain"]
            row[P_EPSCR] = r.strain
        else:
            f_t, g_f = 1.0, 1.0
            if r.values == "material":
                f_t, g_f = fracture_ratios(mesh_kind, mat.young, r.fracture_energy,
                                           r.tensile_strength, cell_size)
            row[P_RUPT] = RUPTURE_KINDS[r.law or "mixed_mode"]
            row[P_FT] = r.tensile_strength / f_t
            row[P_GF] = r.fracture_energy / g_f
            ratio = 2.0 if r.shear_strength is None else r.shear_strength / r.tensile_strength
            row[P_RS] = ratio
            g_s = r.fracture_energy if r.shear_fracture_energy is None \
                else r.shear_fracture_energy
            row[P_GS] = g_s / g_f
    row[P_MU] = mat.friction or 0.0
    return row


def unbreakable(row):
    """The law row without rupture (supports and symmetry planes that do not
    break unless the case says `breakable: true`; yield stays)."""
    row = row.copy()
    row[P_RUPT] = 0
    return row


def strength_of(rows):
    """A scalar strength per law row [Pa] to pick the weaker of two
    materials: yield stress, cohesion, tensile strength, else infinite."""
    rows = np.atleast_2d(rows)
    out = np.full(len(rows), np.inf)
    for col in (P_FT, P_COH, P_SY):
        v = rows[:, col]
        out = np.where(v > 0, np.minimum(out, v), out)
    return out


def _select(case, name, centroids):
    if name == "all":
        return np.arange(len(centroids), dtype=IDX)
    box = np.asarray(case.groups[name].box, dtype=float)
    tol = 1e-9 * np.max(np.abs(centroids)) if len(centroids) else 0.0
    inside = np.all((centroids >= box[0] - tol) & (centroids <= box[1] + tol), axis=1)
    return np.nonzero(inside)[0].astype(IDX)


def surface_ids(case, mesh, name):
    """Indices into mesh.surface_names of a named surface (case.py
    surface_indices: a box's xmin ... zmax, a geometry's naming rules, or
    <part>.<surface> in a scene of parts)."""
    from ..case import surface_indices
    try:
        return surface_indices(case, name)
    except ValueError as exc:
        raise case.error(("boundary",), str(exc)) from None


def surface_load(case, mesh, item, path):
    """Dead load of a surface-load item on its boundary faces: (cells (B,),
    forces (B, 3) [N], moments about the cell centroids (B, 3) [N m]), one
    row per face.  Pressure p: F = −p n A (n the outward normal, p > 0
    pushes into the solid); traction t: F = t A; A the face's true area,
    applied at its area centroid x_f: M = (x_f − x_c) × F (DESIGN.md §6)."""
    faces = np.nonzero(np.isin(mesh.bface_side, surface_ids(case, mesh, item.surface)))[0]
    if len(faces) == 0:
        raise case.error(path + ("surface",), f"surface {item.surface!r} has no boundary "
                         "face in the mesh")
    cells = mesh.bface_cell[faces]
    area = mesh.bface_area[faces][:, None]
    if item.pressure is not None:
        f = -item.pressure * mesh.bface_normal[faces] * area
    else:
        f = np.asarray(item.traction, float)[None, :] * area
    arm = mesh.bface_centroid[faces] - mesh.cell_centroid[cells]
    return cells.astype(IDX), f, np.cross(arm, f)


def build_model(case, mesh=None):
    """Model of a validated Case (mesh built here unless given).

    Raises CaseError (via case.error) for what the schema cannot see: a group
    that selects no body, an unreachable ν, a body under two loads with
    different histories."""
    if mesh is None:
        mesh = build_mesh(case)
    n = mesh.n_cells
    cen = mesh.cell_centroid

    # groups and materials: each part is a group of its bodies
    from ..case import scene_parts
    parts = scene_parts(case)
    body_part = (np.zeros(n, dtype=np.int64) if mesh.cell_part is None
                 else np.asarray(mesh.cell_part, dtype=np.int64))
    groups = {"all": np.arange(n, dtype=IDX)}
    for k, part in enumerate(parts if case.parts else []):
        groups[part.name] = np.nonzero(body_part == k)[0].astype(IDX)
    for name in (case.groups or {}):
        ids = _select(case, name, cen)
        if len(ids) == 0:
            raise case.error(("groups", name, "box"), "selects no body (no cell centroid inside)")
        groups[name] = ids
    mat_names = list(case.materials)
    body_material = np.zeros(n, dtype=IDX)
    for k, part in enumerate(parts):
        if part.material is not None:
            body_material[body_part == k] = mat_names.index(part.material)
    for name, g in (case.groups or {}).items():
        if getattr(g, "material", None):
            body_material[groups[name]] = mat_names.index(g.material)
    rigid_part = np.array([p.mesh.kind == "rigid" for p in parts])
    body_rigid = rigid_part[body_part]
    # law slots: one per (material, part) pair in use; stiffness and
    # fracture calibration depend on the part's mesh kind and cell size
    n_parts = len(parts)
    slots, body_slot = np.unique(body_material.astype(np.int64) * n_parts + body_part,
                                 return_inverse=True)
    body_slot = body_slot.reshape(-1)
    deformable = [p for p in parts if p.mesh.kind != "rigid"]
    materials = [None] * len(mat_names)
    law_rows = [elastic_law_row()]
    slot_e0, slot_alpha, slot_lam = [], [], []
    for key in slots:
        j, part = int(key // n_parts), parts[int(key % n_parts)]
        name, mat = mat_names[j], case.materials[mat_names[j]]
        # a rigid part's own springs (none) need no calibration; its law
        # row serves a bonded interface, calibrated as the other part's mesh
        ref = part if part.mesh.kind != "rigid" else (deformable[0] if deformable else part)
        kind = ref.mesh.kind if ref.mesh.kind != "rigid" else "blocks"
        from ..case import part_cell_size
        try:
            e0, alpha, lam_aux = stiffness_rule(mat.stiffness, kind, mat.young, mat.poisson)
        except ValueError as exc:
            raise case.error(("materials", name, "poisson"), str(exc)) from None
        if materials[j] is None:
            materials[j] = dict(name=name, density=mat.density, young=mat.young,
                                poisson=mat.poisson, stiffness=mat.stiffness, e0=e0,
                                alpha=alpha, lambda_aux=lam_aux)
        if part.mesh.kind == "rigid":
            e0, alpha, lam_aux = np.inf, 1.0, 0.0
        slot_e0.append(e0)
        slot_alpha.append(alpha)
        slot_lam.append(lam_aux)
        law_rows.append(material_law_row(mat, kind, part_cell_size(case, ref)))
    for j, name in enumerate(mat_names):
        if materials[j] is None:        # a material no body uses
            mat = case.materials[name]
            materials[j] = dict(name=name, density=mat.density, young=mat.young,
                                poisson=mat.poisson, stiffness=mat.stiffness)
    n_slots = len(slots)
    # rows 1 + n_slots + k: slot k at unbreakable supports (yield, no rupture)
    for row in law_rows[1:1 + n_slots]:
        law_rows.append(unbreakable(row))
    # rows of the interfaces: bonded with a material of its own, or contact
    iface_row = []
    for it in case.interfaces:
        if it.law == "contact":
            row = elastic_law_row()
            row[P_MU] = it.friction or 0.0
        elif it.material is not None:
            ref = next(p for p in parts if p.name in it.parts and p.mesh.kind != "rigid")
            from ..case import part_cell_size
            row = material_law_row(case.materials[it.material], ref.mesh.kind,
                                   part_cell_size(case, ref))
        else:
            row = None                   # the weaker of the two cells' laws
        iface_row.append(-1 if row is None else len(law_rows))
        if row is not None:
            law_rows.append(row)
    law_params = np.array(law_rows, dtype=float)
    dens = np.array([m["density"] for m in materials])[body_material]
    e0 = np.array(slot_e0)[body_slot]
    alpha = np.array(slot_alpha)[body_slot]

    # bodies: mass, principal inertia and axes
    mass = dens * mesh.cell_volume
    inertia, rot0 = principal_axes(dens[:, None, None] * mesh.cell_inertia)
    quat0 = np.empty((n + 1, 4))
    quat0[:n] = matrix_to_quat(rot0)
    quat0[n] = (1.0, 0.0, 0.0, 0.0)
    pos0 = np.vstack([cen, np.zeros((1, 3))])

    # internal springs (each face with the spring-point rule of its part;
    # an interface face, of its deformable side's part)
    part_rule = np.array([p.mesh.spring_points for p in parts])
    fa, fb = mesh.face_cells[:, 0], mesh.face_cells[:, 1]
    sp = _spring_points_by_rule(mesh.face_vertex_ptr, mesh.face_vertex_xyz, mesh.face_normal,
                                part_rule[np.where(body_rigid[fa], body_part[fb], body_part[fa])])
    f = sp.face
    a = mesh.face_cells[f, 0].astype(IDX)
    b = mesh.face_cells[f, 1].astype(IDX)
    nrm = mesh.face_normal[f]
    fc = mesh.face_centroid[f]
    h_a = np.einsum("ij,ij->i", fc - cen[a], nrm)
    h_b = np.einsum("ij,ij->i", cen[b] - fc, nrm)
    # A cell clipped around a notch tip or a hole may be non-convex, its
    # centroid behind one of its faces (h ≤ 0: a negative spring).  Such a
    # face takes the distance's magnitude, at least a twentieth of the cell's
    # size V^(1/3) (convex cells always have h > 0; only slivers thinner
    # than that are touched)
    h_min = 0.05 * np.cbrt(mesh.cell_volume)
    h_a = np.maximum(np.abs(h_a), h_min[a])
    h_b = np.maximum(np.abs(h_b), h_min[b])
    # a rigid body's side of a spring has no length (and no compliance)
    h_a = np.where(body_rigid[a], 0.0, h_a)
    h_b = np.where(body_rigid[b], 0.0, h_b)
    # half-lengths in series (Kawai 1978: h = h1 + h2)
    kn = 1.0 / (h_a / e0[a] + h_b / e0[b])
    ks = 1.0 / (h_a / (alpha[a] * e0[a]) + h_b / (alpha[b] * e0[b]))
    if mesh.face_interface is not None:
        # a bonded interface's layer of thickness t of its own material:
        # one more compliance in series, t/E' (normal) and t/(α E') (shear),
        # with the material's E', α of the mesh kind (calibration.py)
        fi = mesh.face_interface[f]
        for i, it in enumerate(case.interfaces):
            if it.thickness is None:
                continue
            on = fi == i
            ref = next(p for p in parts if p.name in it.parts and p.mesh.kind != "rigid")
            mat = case.materials[it.material]
            e0m, alpham, _ = stiffness_rule(mat.stiffness, ref.mesh.kind, mat.young, mat.poisson)
            kn[on] = 1.0 / (h_a[on] / e0[a[on]] + h_b[on] / e0[b[on]] + it.thickness / e0m)
            ka, kb = alpha[a[on]] * e0[a[on]], alpha[b[on]] * e0[b[on]]
            ks[on] = 1.0 / (h_a[on] / ka + h_b[on] / kb + it.thickness / (alpham * e0m))
    keep = np.ones(len(f), dtype=bool)
    for j, cut in enumerate(case.cuts or []):
        p = np.asarray(cut.point, float)
        nn = np.asarray(cut.normal, float)
        box = np.asarray(cut.within, float)
        sa = (cen[a] - p) @ nn
        sb = (cen[b] - p) @ nn
        inside = np.all((sp.point >= box[0]) & (sp.point <= box[1]), axis=1)
        keep &= ~((sa * sb < 0) & inside)
    n_cut = int((~keep).sum())
    # law of each internal spring: the weaker of its two cells' slots (row 1 + slot);
    # on an interface, the interface's row (bonded with a material, contact)
    sa_, sb_ = body_slot[a], body_slot[b]
    slot_strength = strength_of(law_params[1:1 + n_slots])
    weaker = np.where(slot_strength[sa_] <= slot_strength[sb_], sa_, sb_)
    weaker = np.where(body_rigid[a], sb_, np.where(body_rigid[b], sa_, weaker))
    law = (1 + weaker).astype(IDX)
    state0 = np.where(keep, ELASTIC, BROKEN).astype(np.int8)
    if mesh.face_interface is not None:
        fi = mesh.face_interface[f]
        for i, it in enumerate(case.interfaces):
            on = fi == i
            if iface_row[i] >= 0:
                law[on] = iface_row[i]
            if it.law == "contact":
                state0[on] = BROKEN
    internal = dict(a=a, b=b, point=sp.point, area=sp.weight, h=h_a + h_b,
                    kpa=np.stack([kn, ks, ks], axis=1),
                    frame=_frames_from_normals(nrm), face=f.astype(IDX), law=law, state0=state0)
    del a, b, f, sp, nrm, fc, h_a, h_b, kn, ks, law, state0, weaker, sa_, sb_

    # support springs on domain faces (DESIGN.md §1: h = centroid-to-face distance)
    sup = []
    seen = set()
    for j, item in enumerate(case.boundary or []):
        if not hasattr(item, "face"):         # supports only
            continue
        key = "face" if item.face is not None else "surface"
        name = item.face if item.face is not None else item.surface
        ids = surface_ids(case, mesh, name)
        if seen & set(ids):
            raise case.error(("boundary", j, key), f"{key} {name} is supported twice")
        seen |= set(ids)
        fix = ("x", "y", "z") if item.fix == "all" else tuple(item.fix)
        sel = np.nonzero(np.isin(mesh.bface_side, ids))[0]
        if len(sel) == 0:
            continue
        from ..mesh._core import _gather
        ptr, vid = _gather(mesh.bface_vertex_ptr, np.arange(len(mesh.bface_vertex_xyz)), sel)
        xyz = mesh.bface_vertex_xyz[vid]
        bsp = spring_points(ptr, xyz, mesh.bface_normal[sel],
                            parts[body_part[mesh.bface_cell[sel[0]]]].mesh.spring_points)
        bf = sel[bsp.face]
        cell = mesh.bface_cell[bf]
        nrm_b = mesh.bface_normal[bf]
        h = np.einsum("ij,ij->i", mesh.bface_centroid[bf] - cen[cell], nrm_b)
        h = np.maximum(np.abs(h), 0.05 * np.cbrt(mesh.cell_volume[cell]))   # as above
        kk = e0[cell] / h
        axis_of = np.argmax(np.abs(nrm_b), axis=1)
        aligned = np.abs(nrm_b[np.arange(len(bf)), axis_of]) > 1.0 - 1e-12
        k = np.stack([kk, alpha[cell] * kk, alpha[cell] * kk], axis=1)
        if np.all(aligned) and len(np.unique(axis_of)) == 1:
            # frame (n, s, t) = (±e_k, e_k+1, n × s): local components are world axes
            axis = int(axis_of[0])
            e_s = np.zeros(3)
            e_s[(axis + 1) % 3] = 1.0
            frames = np.empty((len(bf), 4))
            for sgn in (-1.0, 1.0):
                nvec = np.zeros(3)
                nvec[axis] = sgn
                on = np.sign(nrm_b[:, axis]) == sgn
                frames[on] = matrix_to_quat(np.stack([nvec, e_s, np.cross(nvec, e_s)], axis=1))
            comp = [axis, (axis + 1) % 3, (axis + 2) % 3]
            for c in range(3):
                if "xyz"[comp[c]] not in fix:
                    k[:, c] = 0.0
        else:
            # a curved or slanted surface: the springs' frame is the face's
            # own (n, s, t); only a full support is defined there
            if set(fix) != {"x", "y", "z"}:
                raise case.error(("boundary", j, "fix"), f"surface {name} is not normal to "
                                 "one axis: only fix: all is possible on it")
            frames = _frames_from_normals(nrm_b)
        sup.append(dict(a=cell.astype(IDX), b=np.full(len(cell), n, dtype=IDX),
                        point=bsp.point, area=bsp.weight, h=h, kpa=k,
                        frame=frames, face=(-1 - bf).astype(IDX),
                        law=(1 + body_slot[cell]
                             + (0 if item.breakable else n_slots)).astype(IDX),
                        state0=np.zeros(len(cell), dtype=np.int8)))

    pieces = [internal] + sup
    del internal, sup
    # (the build's peak memory: one array's copy at a time, each piece's
    # array freed as soon as it is joined)
    cat = {key: np.concatenate([p.pop(key) for p in pieces]) for key in list(pieces[0])}
    del pieces
    # spring order of the thread-safe schedule (partition.py): by group, then (a, b)
    order, group_ptr, phase_ptr = spring_schedule(np.stack([cat["a"], cat["b"]], axis=1), n)
    for key in list(cat):
        cat[key] = cat[key][order]
    del order
    sb = np.stack([cat.pop("a"), cat.pop("b")], axis=1).astype(IDX, copy=False)
    rot_all = np.ascontiguousarray(np.concatenate([rot0, np.eye(3)[None]]))
    arm_a = np.empty((len(sb), 3))
    arm_b = np.empty((len(sb), 3))
    _arms(rot_all, pos0, sb, np.ascontiguousarray(cat.pop("point")), arm_a, arm_b)

    # constraints and prescribed motion
    hist_t, hist_a, hist_ptr = [], [], [0]

    def add_hist(table):
        table = np.asarray(table, float)
        hist_t.extend(table[:, 0])
        hist_a.extend(table[:, 1])
        hist_ptr.append(len(hist_t))
        return len(hist_ptr) - 2

    dof_kind = np.zeros((n, 6), dtype=np.int8)
    dof_value = np.zeros((n, 6))
    dof_hist = np.full((n, 6), -1, dtype=IDX)
    static = case.solver.mode != "dynamic"
    end_time = getattr(case.solver, "end_time", None) or 1.0
    dof_item = np.full((n, 6), -1)          # the boundary item that set each component
    notes = []
    for i, it in enumerate(case.interfaces):
        if mesh.face_interface is None or not np.any(mesh.face_interface == i):
            notes.append(f"interfaces[{i}]: parts {it.parts[0]} and {it.parts[1]} do not touch "
                         "(no shared faces): nothing joins them")

    def claim(ids, c, j, what):
        """Warn when an earlier item prescribed component c of these bodies
        differently (the later item wins)."""
        prev = dof_item[ids, c]
        clash = prev >= 0
        if clash.any():
            k = int(prev[clash][0])
            notes.append(f"boundary[{j}] ({what}) and boundary[{k}] both prescribe "
                         f"{COMPONENTS[c]} of {int(clash.sum())} bodies; boundary[{j}] wins")
        dof_item[ids, c] = j

    for j, item in enumerate(case.boundary or []):
        if hasattr(item, "face"):             # a support on a face or surface
            continue
        if getattr(item, "surface", None) is not None:
            # the cells with a boundary face on the surface
            on = np.isin(mesh.bface_side, surface_ids(case, mesh, item.surface))
            ids = np.unique(mesh.bface_cell[on]).astype(IDX)
        else:
            ids = groups[item.group]
        if getattr(item, "fix", None) is not None:
            fix = COMPONENTS if item.fix == "all" else tuple(item.fix)
            for c in fix:
                claim(ids, COMPONENTS.index(c), j, "fix")
                dof_kind[ids, COMPONENTS.index(c)] = FIXED
            continue
        if getattr(item, "velocity", None) is not None:
            if static:
                raise case.error(("boundary", j, "velocity"),
                                 "prescribed velocity needs solver.mode: dynamic "
                                 "(use displacement in static mode)")
            kind, vec = VELOCITY, item.velocity
            h = add_hist(item.history) if getattr(item, "history", None) else -1
        else:
            kind, vec = DISPLACEMENT, item.displacement
            table = getattr(item, "history", None) or [[0.0, 0.0], [end_time, 1.0]]
            h = add_hist(table)
        for c in range(3):
            if vec[c] is not None:
                claim(ids, c, j, "velocity" if kind == VELOCITY else "displacement")
                dof_kind[ids, c] = kind
                dof_value[ids, c] = vec[c]
                dof_hist[ids, c] = h

    # loads: a group's total force/moment shared over its bodies by volume;
    # a surface load's force on each boundary face of the surface, at the
    # face's area centroid (surface_load); a follower's in the principal
    # frames.  One amplitude history per body: items on one body must share
    # it (equal tables are one history).
    fext = np.zeros((n, 3))
    mext = np.zeros((n, 3))
    ffol = np.zeros((n, 3))
    mfol = np.zeros((n, 3))
    load_hist = np.full(n, -1, dtype=IDX)
    load_item = np.full(n, -1)              # an item that loads the body
    load_tables = {}
    gravity = np.zeros(3)
    for j, item in enumerate(case.loads or []):
        if getattr(item, "gravity", None) is not None:
            gravity += np.asarray(item.gravity, float)
            continue
        if getattr(item, "surface", None) is not None:
            ids, f, mom = surface_load(case, mesh, item, ("loads", j))
        else:
            ids = groups[item.group]
            w = mesh.cell_volume[ids] / mesh.cell_volume[ids].sum()
            f = w[:, None] * np.asarray(item.force, float)
            mom = w[:, None] * np.asarray(item.moment, float)
        h = -1
        if getattr(item, "history", None):
            key = tuple(map(tuple, item.history))
            if key not in load_tables:
                load_tables[key] = add_hist(item.history)
            h = load_tables[key]
        bodies = np.unique(ids)
        clash = bodies[(load_item[bodies] >= 0) & (load_hist[bodies] != h)]
        if len(clash):
            k = int(load_item[clash[0]])
            raise case.error(("loads", j, "history"),
                             f"{len(clash)} bodies are also loaded by loads[{k}] with another "
                             "history (a body follows one load history: give both items the "
                             "same history, or load disjoint bodies)")
        load_hist[bodies] = h
        load_item[bodies] = j
        if getattr(item, "follower", False):
            # f_b = R0ᵀ f: constant in the rigid cell's frame
            np.add.at(ffol, ids, np.einsum("nki,nk->ni", rot0[ids], f))
            np.add.at(mfol, ids, np.einsum("nki,nk->ni", rot0[ids], mom))
        else:
            np.add.at(fext, ids, f)
            np.add.at(mext, ids, mom)
    if not any(getattr(item, "follower", False) for item in case.loads or []):
        ffol = mfol = np.zeros((0, 3))

    # the face table: what the spring points of one face share (frame,
    # stiffness per area, length, law) is held once per face; springs point
    # to their face's row (spring_slot).  The points of a face follow each
    # other in the schedule (same a, b: one group, sorted stably)
    face = cat["face"]
    first = np.ones(len(face), dtype=bool)
    first[1:] = face[1:] != face[:-1]
    slot = (np.cumsum(first) - 1).astype(IDX)
    table = {key: np.ascontiguousarray(cat.pop(key)[first]) for key in ("frame", "kpa", "h", "law")}

    lam_aux = np.array(slot_lam)[body_slot]
    # the strain fit links cells of one material across intact faces (physics/poisson.py)
    poisson = (build_poisson(mesh.face_cells, mesh.face_area, cen, mesh.cell_volume, lam_aux,
                             rot0, cat["face"], np.where(body_rigid, 0.0, 0.5 * alpha * e0),
                             np.where(body_rigid, len(mat_names) + np.arange(n), body_material),
                             cat["state0"])
               if np.any(lam_aux > 0) else empty_poisson(n))
    model = Model(
        poisson=poisson, warnings=tuple(notes),
        n_bodies=n, body_mass=mass, body_inertia=inertia, body_volume=mesh.cell_volume.copy(),
        body_material=body_material, body_pos0=pos0, body_quat0=quat0,
        spring_bodies=sb, spring_arm_a=np.ascontiguousarray(arm_a),
        spring_arm_b=np.ascontiguousarray(arm_b), spring_slot=slot, spring_area=cat["area"],
        face_frame0=table["frame"], face_k=table["kpa"], face_h=table["h"],
        face_law=table["law"].astype(IDX, copy=False),
        face_ref=np.ascontiguousarray(face[first]).astype(IDX, copy=False),
        group_ptr=group_ptr, phase_ptr=phase_ptr,
        dof_kind=dof_kind, dof_value=dof_value, dof_hist=dof_hist,
        body_fext=fext, body_mext=mext, body_ffol=ffol, body_mfol=mfol,
        body_load_hist=load_hist, gravity=gravity,
        hist_ptr=np.asarray(hist_ptr, dtype=IDX), hist_t=np.asarray(hist_t, float),
        hist_a=np.asarray(hist_a, float), groups=groups, materials=materials, mesh=mesh,
        n_cut=n_cut, law_params=law_params,
        spring_state0=cat["state0"].astype(np.int8, copy=False),
        inelastic=bool(n_cut > 0 or np.any(cat["state0"] >= BROKEN)
                       or np.any(law_params[:, [P_CRIT, P_RUPT]] > 0)))
    from .contact import build_contact, contact_setting
    setting = contact_setting(case, model)
    if setting is None:
        return model
    cm = build_contact(case, model, setting)
    if cm.n_hull:
        notes.append(f"contact: {cm.n_hull} non-convex cell(s) meet others by their convex "
                     "hulls")
    return dataclasses.replace(model, contact=cm, warnings=tuple(notes))


def apply_initial(case, model, state):
    """Initial velocities and angular velocities (case.initial), in the
    order of the items (a later item overrides an earlier one on the
    bodies they share).  ``{velocity, angular_velocity}``: each cell of the
    group translates at v and spins at ω about its own centroid.
    ``{velocity, rigid: {angular_velocity, center}}``: the group as one
    rigid body, each cell at v + ω × (x_c − center) and spinning at ω
    (center default: the group's centre of mass Σ m_c x_c / Σ m_c)."""
    R = state.body_rot
    for item in case.initial or []:
        ids = model.groups[getattr(item, "group", None) or "all"]
        rigid = getattr(item, "rigid", None)
        v0 = getattr(item, "velocity", None)
        w = getattr(item, "angular_velocity", None)
        if rigid is not None:
            w = np.asarray(rigid.angular_velocity, float)
            x = state.body_pos[ids]
            if rigid.center is not None:
                c = np.asarray(rigid.center, float)
            else:
                m = model.body_mass[ids]
                c = (m[:, None] * x).sum(axis=0) / m.sum()
            v = np.asarray(v0 if v0 is not None else (0.0, 0.0, 0.0), float)
            state.body_vel[ids] = v + np.cross(w, x - c)
        elif v0 is not None:
            state.body_vel[ids] = np.asarray(v0, float)
        if w is not None:
            w = np.asarray(w, float)
            # L = R I Rᵀ ω (world)
            wb = np.einsum("nki,k->ni", R[ids], w)
            state.body_angmom[ids] = np.einsum("nik,nk->ni", R[ids], model.body_inertia[ids] * wb)


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
                     body_mass, body_inertia, x, out):
    """(P x)_i = Σ_j P_ij x_j with P_ij = Σ_s |K_s,ij| / √(M_i M_j) per body DOF
    (rotations in principal axes; x = 1 gives the Gershgorin row sums):
    K_s = Bᵀ C B with C = F diag(k) Fᵀ and, for end e of the spring,
    B_e = ±[I, −R_e [r_e]×] (r_e the arm in the principal frame; Kawai 1978,
    eq. 8b)."""
    n = body_mass.shape[0]
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
        for e in range(2):
            body = spring_bodies[s, e]
            if body >= n:
                for j in range(6):
                    scale[6 * e + j] = 0.0
                    for r in range(3):
                        B[r, 6 * e + j] = 0.0
                continue
            sign = -1.0 if e == 0 else 1.0
            arm = spring_arm_a[s] if e == 0 else spring_arm_b[s]
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
                scale[6 * e + j] = 1.0 / np.sqrt(m)
                scale[6 * e + 3 + j] = 1.0 / np.sqrt(body_inertia[body, j])
        for r in range(3):
            for j in range(12):
                CB[r, j] = C[r, 0] * B[0, j] + C[r, 1] * B[1, j] + C[r, 2] * B[2, j]
        for e in range(2):
            body = spring_bodies[s, e]
            if body >= n:
                continue
            for r in range(6):
                i = 6 * e + r
                acc = 0.0
                for j in range(12):
                    if scale[j] == 0.0:
                        continue
                    kij = B[0, i] * CB[0, j] + B[1, i] * CB[1, j] + B[2, i] * CB[2, j]
                    acc += abs(kij) * scale[j] * x[spring_bodies[s, j // 6], j % 6]
                out[body, r] += acc * scale[i]


def scaled_row_sums(model, x=None):
    """P x (N, 6) [1/s²] for the entrywise |M^-½ K M^-½| bound P (see
    Model.stable_dt); x = 1 (default): the Gershgorin row sums.  The
    auxiliary stress of the Poisson correction adds its bound
    |B|ᵀ diag(λV) |B| (physics/poisson.py) on the translations."""
    from ..physics.rotation import quat_matrix_np
    n = model.n_bodies
    out = np.zeros((n, 6))
    xx = np.ones((n + 1, 6))
    if x is not None:
        xx[:n] = x
    _scaled_row_sums(model.spring_bodies, model.spring_arm_a, model.spring_arm_b,
                     quat_matrix_np(model.body_quat0), quat_matrix_np(model.spring_frame0),
                     model.spring_k, model.body_mass, model.body_inertia, xx, out)
    if model.poisson_on:
        s = np.zeros((n, 6))
        s[:, :3] = 1.0 / np.sqrt(model.body_mass)[:, None]
        out += s * poisson_abs_product(model.poisson, n, s * xx[:n])
    return out


STABLE_DT_SWEEPS = 2   # Collatz–Wielandt refinements (one pass over the springs each)


def omega_max_bound(model, sweeps=STABLE_DT_SWEEPS):
    """Upper bound on ω_max² = λ_max(M^-½ K M^-½) [1/s²].

    P = Σ_s |M^-½ K_s M^-½| (entrywise) is nonnegative with λ_max ≤ ρ(P),
    and for any positive x, ρ(P) ≤ max_i (P x)_i / x_i (Collatz–Wielandt;
    Horn & Johnson, Matrix Analysis, 8.1.26).  x = 1 is Gershgorin; a few
    power sweeps x ← P x tighten the bound on irregular meshes, where one
    row stands out, and it stays safe for any x > 0."""
    px = scaled_row_sums(model)
    bound = float(px.max(initial=0.0))
    if bound <= 0.0:
        return 0.0
    x = np.ones_like(px)
    for _ in range(sweeps):
        # keep x strictly positive (a DOF with no springs has (P x)_i = 0)
        x = px / bound + 1e-3
        px = scaled_row_sums(model, x)
        bound = min(bound, float((px / x).max()))
    return bound
