"""build_model: the Model of a validated Case, built in steps (each named
for what it builds): parts and groups, laws, bodies, springs and faces,
schedule, constraints, loads, Poisson correction, contact."""
import dataclasses

import numpy as np

from ..partition import spring_schedule
from ..mesh import principal_axes
from ..physics.integrate import FIXED
from ..physics.laws import BROKEN, P_CRIT, P_MODEL, P_RUPT
from ..physics.laws.plastic import CONTINUUM
from ..physics.poisson import build_poisson, empty_poisson
from ..physics.rotation import matrix_to_quat, quat_matrix_np
from ..threads import build_threads, on_threads
from .contact import build_contact, contact_setting
from .core import IDX, Model
from .laws import body_materials, compression_notes, law_slots, viscous_laws
from .loads import Amplitudes, body_groups, body_loads, constraints, interface_notes
from .mesh_build import build_mesh
from .springs import (THREADED_SPRINGS, face_rows, face_table, internal_springs, spring_arms,
                      support_springs)


def build_model(case, mesh=None):
    """Model of a validated Case (mesh built here unless given).

    Raises CaseError (via case.error) for what the schema cannot see: a group
    that selects no body, an unreachable ν, a body under two loads with
    different histories."""
    if mesh is None:
        mesh = build_mesh(case)
    parts, body_part, body_rigid, groups, body_material = _parts_and_groups(case, mesh)
    laws = law_slots(case, parts, body_part, body_material)
    bodies, rot0 = _bodies(mesh, laws, body_material)
    springs, spring_face, n_cut = _springs_and_faces(case, mesh, parts, body_part, body_rigid,
                                                     laws, rot0, bodies["body_pos0"])
    hist = Amplitudes()
    notes = interface_notes(case, mesh) + compression_notes(case, parts, body_part,
                                                            body_material, body_rigid)
    dof_kind, dof_value, dof_hist, ground_hist, ground_dir = constraints(case, mesh, groups,
                                                                         hist, notes)
    _moved_plastic_notes(case, mesh, groups, body_material, notes)
    if case.plane is not None:
        # a plane model moves in x-y and turns about z (physics/plane.py); the
        # 3D solvers that serve it (output, Newton, modal) see z, rx, ry held
        dof_kind[:, 2:5] = FIXED
        dof_value[:, 2:5] = 0.0
    fext, mext, ffol, mfol, load_hist, gravity = body_loads(case, mesh, groups, rot0, hist)
    poisson = _poisson(case, mesh, rot0, body_rigid, body_material, laws, spring_face,
                       springs["spring_state0"])
    dashpot, branch_g, branch_tau = viscous_laws(case, laws.visc_rows)
    model = Model(
        law_dashpot=dashpot, law_branch_g=branch_g, law_branch_tau=branch_tau,
        poisson=poisson, warnings=tuple(notes), **bodies, **springs,
        dof_kind=dof_kind, dof_value=dof_value, dof_hist=dof_hist,
        ground_hist=ground_hist, ground_dir=ground_dir, body_fext=fext, body_mext=mext, body_ffol=ffol, body_mfol=mfol,
        body_load_hist=load_hist, gravity=gravity,
        hist_ptr=np.asarray(hist.ptr, dtype=IDX), hist_t=np.asarray(hist.t, float),
        hist_a=np.asarray(hist.a, float), groups=groups, materials=laws.materials, mesh=mesh,
        n_cut=n_cut, law_params=laws.law_params,
        plane="" if case.plane is None else case.plane.kind,
        inelastic=bool(n_cut > 0 or np.any(springs["spring_state0"] >= BROKEN)
                       or np.any(laws.law_params[:, [P_CRIT, P_RUPT]] > 0)))
    model = _yield_field(model, case)
    return _with_contact(case, model, notes)


def _moved_plastic_notes(case, mesh, groups, body_material, notes):
    """A note for each boundary item that moves a group (velocity or
    displacement) holding cells of a continuum-yield material that do not
    reach the body's surface: the item moves all its cells together in the
    components it gives, so those cells cannot flow, and a band of them is
    a stiff block that raises a limit load (a square in pure shear loaded
    on bands a quarter of its side deep: 1.6 k at ten yield strains, k on
    one-cell bands; benchmarks/results/continuum_yield.md)."""
    cont = [i for i, mat in enumerate(case.materials.values())
            if mat.yield_ is not None and mat.yield_.model == "continuum"]
    if not cont or not case.boundary:
        return
    outer = np.zeros(mesh.n_cells, dtype=bool)
    side = np.ones(len(mesh.bface_cell), dtype=bool)
    if case.plane is not None:
        side = np.abs(mesh.bface_normal[:, 2]) < 0.5     # not the plane's faces
    outer[mesh.bface_cell[side]] = True
    plastic = np.isin(body_material, cont)
    for j, item in enumerate(case.boundary):
        group = getattr(item, "group", None)
        vec = getattr(item, "velocity", None)
        if vec is None:
            vec = getattr(item, "displacement", None)
        if group is None or vec is None or all(v is None for v in vec[:3]):
            continue
        ids = groups[group]
        inner = int(np.count_nonzero(plastic[ids] & ~outer[ids]))
        if inner and len(ids) > 1:
            notes.append(f"boundary[{j}] moves group {group}'s {len(ids)} cells together, "
                         f"{inner} of them inside the body: with continuum yield they cannot "
                         "flow in the components it gives (a stiff block that raises the "
                         "limit load); move one layer of cells at the surface")


#: an axis carries "no springs" below this share of a cell's Σ A n_k²
PLANE_SHARE = 1.0e-9


def _yield_field(model, case):
    """The model with the cell arrays of continuum yield (cell_ivol,
    cell_plane, cell_lever, cell_k, cell_2g; physics/laws/plastic.py) when
    some law has it, else unchanged.  cell_k [Pa] the shear strength k of
    the cell's material (σy/2 tresca, σy/√3 von_mises; 0: no continuum
    yield), cell_2g [Pa] its 2G = E/(1 + ν).

    cell_plane: a world axis k along which no spring of a cell acts (its
    springs' Σ A n_k² below PLANE_SHARE of their Σ A) while the cell's
    translation along k is held (fixed or prescribed): a cell of a
    one-cell-thick slab held in plane strain, or of a plane-strain model
    (Model.plane), whose out-of-plane normal stress no spring carries
    (physics/inelastic.py finish_cell_stress); none in plane stress.
    cell_lever (N+1, 3, 3) [m]: row k, the lever of the reaction of a
    translation held along axis k (other than the plane axis; zero if
    free), for the cell stress of the held cells."""
    P = model.law_params
    if not np.any((P[:, P_MODEL] == CONTINUUM) & (P[:, P_CRIT] > 0)):
        return model
    n = model.n_bodies
    ivol = np.zeros(n + 1)
    ivol[:n] = 1.0 / model.body_volume
    normal = quat_matrix_np(model.face_frame0)[:, :, 0][model.spring_slot]    # (S, 3)
    w = model.spring_area[:, None] * normal * normal
    share = np.zeros((n + 1, 3))
    np.add.at(share, model.spring_bodies[:, 0], w)
    np.add.at(share, model.spring_bodies[:, 1], w)
    share = share[:n]
    total = share.sum(axis=1, keepdims=True)
    held = model.dof_kind[:, :3] != 0
    lacking = (share <= PLANE_SHARE * total) & held
    plane = np.full(n + 1, -1, dtype=np.int8)
    rows = np.flatnonzero(lacking.any(axis=1))
    plane[rows] = np.argmax(lacking[rows], axis=1)
    if model.plane == "stress":
        plane[:] = -1          # plane stress: σzz = 0, what the springs give
    held &= ~lacking
    # a held translation's reaction acts where the cell meets what holds it:
    # its lever along axis k is the centroid of the cell's boundary faces
    # weighted by area × |n_k| (a platen's cells: their loaded face)
    mesh = model.mesh
    lever = np.zeros((n + 1, 3, 3))
    bc = mesh.bface_cell
    if len(bc):
        w = mesh.bface_area[:, None] * np.abs(mesh.bface_normal)          # (B, 3)
        wsum = np.zeros((n, 3))
        np.add.at(wsum, bc, w)
        for k in range(3):
            acc = np.zeros((n, 3))
            np.add.at(acc, bc, w[:, k:k + 1] * mesh.bface_centroid)
            ok = held[:, k] & (wsum[:, k] > 0.0)
            lever[:n][ok, k] = (acc[ok] / wsum[ok, k:k + 1]
                                - model.body_pos0[:n][ok])
    k = np.zeros(n + 1)
    g2 = np.ones(n + 1)
    for i, mat in enumerate(case.materials.values()):
        y = mat.yield_
        if y is None or y.model != "continuum":
            continue
        rows = np.flatnonzero(model.body_material == i)
        k[rows] = y.stress / (2.0 if y.criterion == "tresca" else np.sqrt(3.0))
        g2[rows] = mat.young / (1.0 + mat.poisson)
    return dataclasses.replace(model, cell_ivol=ivol, cell_plane=plane, cell_lever=lever,
                               cell_k=k, cell_2g=g2)


def _parts_and_groups(case, mesh):
    """The parts, each body's part, rigidity and material, and the groups."""
    # groups and materials: each part is a group of its bodies
    from ..case import scene_parts
    n = mesh.n_cells
    parts = scene_parts(case)
    body_part = (np.zeros(n, dtype=np.int64) if mesh.cell_part is None
                 else np.asarray(mesh.cell_part, dtype=np.int64))
    groups = body_groups(case, mesh, parts, body_part)
    body_material = body_materials(case, parts, body_part, groups)
    rigid_part = np.array([p.mesh.kind == "rigid" for p in parts])
    body_rigid = rigid_part[body_part]
    return parts, body_part, body_rigid, groups, body_material


def _bodies(mesh, laws, body_material):
    """The bodies' Model fields (mass, principal inertia and axes), and rot0 (N, 3, 3)."""
    n = mesh.n_cells
    dens = np.array([m["density"] for m in laws.materials])[body_material]
    mass = dens * mesh.cell_volume
    inertia, rot0 = principal_axes(dens[:, None, None] * mesh.cell_inertia)
    quat0 = np.empty((n + 1, 4))
    quat0[:n] = matrix_to_quat(rot0)
    quat0[n] = (1.0, 0.0, 0.0, 0.0)
    pos0 = np.vstack([mesh.cell_centroid, np.zeros((1, 3))])
    return dict(n_bodies=n, body_mass=mass, body_inertia=inertia,
                body_volume=mesh.cell_volume.copy(), body_material=body_material,
                body_pos0=pos0, body_quat0=quat0), rot0


def _springs_and_faces(case, mesh, parts, body_part, body_rigid, laws, rot0, pos0):
    """The springs' and face table's Model fields, each spring's face, the number cut."""
    internal, internal_rows, n_cut = internal_springs(case, mesh, parts, body_part, body_rigid,
                                                      laws)
    pieces = [internal] + support_springs(case, mesh, parts, body_part, laws)
    rows = face_rows(internal_rows, pieces)
    del internal, internal_rows
    cat, group_ptr, phase_ptr = _schedule(pieces, mesh.n_cells)
    del pieces
    sb = np.stack([cat.pop("a"), cat.pop("b")], axis=1).astype(IDX, copy=False)
    arm_a, arm_b = spring_arms(rot0, pos0, sb, cat.pop("point"))
    slot, table, face_ref = face_table(cat, rows)
    fields = dict(
        spring_bodies=sb, spring_arm_a=np.ascontiguousarray(arm_a),
        spring_arm_b=np.ascontiguousarray(arm_b), spring_slot=slot, spring_area=cat["area"],
        face_frame0=table["frame"], face_k=table["kpa"], face_h=table["h"],
        face_law=table["law"].astype(IDX, copy=False), face_ref=face_ref,
        group_ptr=group_ptr, phase_ptr=phase_ptr,
        spring_state0=cat["state0"].astype(np.int8, copy=False))
    return fields, cat["face"], n_cut


def _schedule(pieces, n):
    """The pieces of the spring table joined, in schedule order; group_ptr, phase_ptr."""
    # (the build's peak memory: one array's copy at a time, each piece's
    # array freed as soon as it is joined)
    cat = {key: np.concatenate([p.pop(key) for p in pieces]) for key in list(pieces[0])}
    # spring order of the thread-safe schedule (partition.py): by group, then (a, b)
    order, group_ptr, phase_ptr = spring_schedule(np.stack([cat["a"], cat["b"]], axis=1), n)
    nt = build_threads() if len(order) >= THREADED_SPRINGS else 1
    for key in list(cat):
        cat[key] = _take(cat.pop(key), order, nt)
    return cat, group_ptr, phase_ptr


def _take(x, order, nt):
    """x[order] (rows), ranges of the order on nt threads (np.take releases
    the GIL)."""
    out = np.empty((len(order),) + x.shape[1:], dtype=x.dtype)
    on_threads(lambda i0, i1: np.take(x, order[i0:i1], axis=0, out=out[i0:i1]),
               len(order), nt, lambda i0, i1: (i0, i1))
    return out


def _poisson(case, mesh, rot0, body_rigid, body_material, laws, spring_face, state0):
    """The Poisson correction's arrays (physics/poisson.py); empty without auxiliary λ."""
    n = mesh.n_cells
    lam_aux, alpha, e0 = laws.lam_aux, laws.alpha, laws.e0
    # the strain fit links cells of one material across intact faces (physics/poisson.py)
    return (build_poisson(mesh.face_cells, mesh.face_area, mesh.cell_centroid, mesh.cell_volume,
                          lam_aux, rot0, spring_face, np.where(body_rigid, 0.0, 0.5 * alpha * e0),
                          np.where(body_rigid, len(case.materials) + np.arange(n), body_material),
                          state0)
            if np.any(lam_aux > 0) else empty_poisson(n))


def _with_contact(case, model, notes):
    """The model with its contact (contact.py) when the scene asks for contact."""
    setting = contact_setting(case, model)
    if setting is None:
        return model
    cm = build_contact(case, model, setting)
    if cm.n_hull:
        notes.append(f"contact: {cm.n_hull} non-convex cell(s) meet others by their convex "
                     "hulls")
    return dataclasses.replace(model, contact=cm, warnings=tuple(notes))
