"""The springs of a build: spring points of the internal faces (with their
lengths, stiffness, cuts and laws) and of the supports, their arms in the
bodies' principal frames, and the face table (Model docstring)."""
import numba as nb
import numpy as np

from ..calibration import stiffness_rule
from ..mesh import spring_points
from ..physics.laws import BROKEN, ELASTIC
from ..physics.rotation import frames_from_normals, matrix_to_quat
from ..threads import build_threads, on_threads
from .core import IDX
from .laws import strength_of
from .loads import surface_ids


@nb.njit(cache=True, nogil=True)
def _arms(rot, pos0, sb, point, arm_a, arm_b, s0, s1):
    """Arms of the spring points s0 … s1 − 1 in their bodies' principal
    frames: arm = Rᵀ (point − centroid), for body a and body b (the ground's
    R is the identity); a loop, no (S, 3, 3) gather."""
    for s in range(s0, s1):
        for side in range(2):
            i = sb[s, side]
            d0 = point[s, 0] - pos0[i, 0]
            d1 = point[s, 1] - pos0[i, 1]
            d2 = point[s, 2] - pos0[i, 2]
            out = arm_a if side == 0 else arm_b
            for c in range(3):
                out[s, c] = rot[i, 0, c] * d0 + rot[i, 1, c] * d1 + rot[i, 2, c] * d2


def plane_frames(normal):
    """Quaternions of the frames (n, e_z × n, e_z) of in-plane unit normals
    (S, 3): a plane model's springs shear along the edge's tangent in the
    plane (s) and across the slab (t), the convention the plane passes
    (physics/plane.py) keep their history in."""
    n = np.asarray(normal, dtype=float).copy()
    n[:, 2] = 0.0
    n /= np.linalg.norm(n, axis=1)[:, None]
    tau = np.stack([-n[:, 1], n[:, 0], np.zeros(len(n))], axis=1)
    ez = np.broadcast_to([0.0, 0.0, 1.0], n.shape)
    return np.ascontiguousarray(matrix_to_quat(np.stack([n, tau, ez], axis=2)))


def _frames_from_normals(normal):
    """Quaternions of right-handed frames (n, s, t) for unit normals (S, 3)."""
    out = np.empty((len(normal), 4))
    frames_from_normals(np.ascontiguousarray(normal, dtype=float), out)
    return out


def points_rule(case):
    """The spring-point function of a case: on the faces (3D), or on the
    faces' traces in the mid-plane (plane mode, mesh/spring_points.py)."""
    if case.plane is None:
        return spring_points
    from ..mesh.spring_points import edge_spring_points
    return edge_spring_points


def _spring_points_by_rule(ptr, xyz, normal, rule, spring_points=spring_points):
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


def internal_springs(case, mesh, parts, body_part, body_rigid, laws):
    """The internal springs (a piece of the spring table) and how many cuts broke."""
    # internal springs (each face with the spring-point rule of its part;
    # an interface face, of its deformable side's part)
    part_rule = np.array([p.mesh.spring_points for p in parts])
    fa, fb = mesh.face_cells[:, 0], mesh.face_cells[:, 1]
    sp = _spring_points_by_rule(mesh.face_vertex_ptr, mesh.face_vertex_xyz, mesh.face_normal,
                                part_rule[np.where(body_rigid[fa], body_part[fb], body_part[fa])],
                                points_rule(case))
    f = sp.face
    # (the per-face columns in IDX first, then gathered: one array per
    # spring point each, not two)
    a = mesh.face_cells[:, 0].astype(IDX)[f]
    b = mesh.face_cells[:, 1].astype(IDX)[f]
    # what a face's spring points share is computed per face (a face has
    # about five) and taken by f
    fa, fb = mesh.face_cells[:, 0], mesh.face_cells[:, 1]
    h_a, h_b = _face_half_lengths(mesh, body_rigid)
    e0, alpha = laws.e0, laws.alpha
    # half-lengths in series (Kawai 1978: h = h1 + h2)
    kn = 1.0 / (h_a / e0[fa] + h_b / e0[fb])
    ks = 1.0 / (h_a / (alpha[fa] * e0[fa]) + h_b / (alpha[fb] * e0[fb]))
    if mesh.face_interface is not None:
        _interface_layers(case, parts, mesh.face_interface, fa, fb, h_a, h_b, laws, kn, ks)
    keep = _uncut(case, mesh.cell_centroid, a, b, sp.point)
    n_cut = int((~keep).sum())
    law, contact = _face_laws(case, mesh, fa, fb, body_rigid, laws)
    state0 = np.where(keep & ~contact[f], np.int8(ELASTIC), np.int8(BROKEN))
    nrm = mesh.face_normal
    frame = _frames_from_normals(nrm) if case.plane is None else plane_frames(nrm)
    # FACE_KEYS per face (rows), the rest per spring point (row: its face)
    internal = dict(a=a, b=b, point=sp.point, area=sp.weight, face=f.astype(IDX),
                    state0=state0, row=f.astype(np.int64, copy=False))
    rows = dict(h=h_a + h_b, kpa=np.stack([kn, ks, ks], axis=1), frame=frame, law=law)
    return internal, rows, n_cut


def _min_half_length(volume, area):
    """The floor of a spring's half-length in a cell of `volume` across a
    face of `area`: a twentieth of the smaller of the cell's size V^(1/3)
    and its thickness across the face, V/A.  A box of any aspect keeps its
    exact t/2 (V/A = t); with V^(1/3) alone, blocks thinner than 1/40 of
    their width were caught and made too soft (a bar of 1.25 mm × 100 mm
    blocks 27 % low in its axial frequency, tests/test_linear_modal.py,
    until 2026-11-29).  No spring of the shipped cases was at either floor
    (cases/*.yaml: the same half-lengths before and after)."""
    return 0.05 * np.minimum(np.cbrt(volume), volume / np.maximum(area, 1e-300))


def _face_half_lengths(mesh, body_rigid):
    """Half-lengths h_a, h_b of each internal face's springs: centroid to
    face along n."""
    cen = mesh.cell_centroid
    fc = mesh.face_centroid
    a, b = mesh.face_cells[:, 0], mesh.face_cells[:, 1]
    nrm = mesh.face_normal
    h_a = np.einsum("ij,ij->i", fc - cen[a], nrm)
    h_b = np.einsum("ij,ij->i", cen[b] - fc, nrm)
    # A cell clipped around a notch tip or a hole may be non-convex, its
    # centroid behind one of its faces (h ≤ 0: a negative spring).  Such a
    # face takes the distance's magnitude, at least a twentieth of the
    # cell's size across the face (convex cells always have h > 0; only
    # slivers thinner than that are touched; _min_half_length)
    h_min_a = _min_half_length(mesh.cell_volume[a], mesh.face_area)
    h_min_b = _min_half_length(mesh.cell_volume[b], mesh.face_area)
    h_a = np.maximum(np.abs(h_a), h_min_a)
    h_b = np.maximum(np.abs(h_b), h_min_b)
    # a rigid body's side of a spring has no length (and no compliance)
    h_a = np.where(body_rigid[a], 0.0, h_a)
    h_b = np.where(body_rigid[b], 0.0, h_b)
    return h_a, h_b


def _interface_layers(case, parts, fi, a, b, h_a, h_b, laws, kn, ks):
    """Bonded interfaces with a thickness: their layer's compliance in kn, ks (in place)."""
    e0, alpha = laws.e0, laws.alpha
    # a bonded interface's layer of thickness t of its own material:
    # one more compliance in series, t/E' (normal) and t/(α E') (shear),
    # with the material's E', α of the mesh kind (calibration.py)
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


def _uncut(case, cen, a, b, point):
    """(S,) bool: the internal springs no cut of the case crosses."""
    keep = np.ones(len(a), dtype=bool)
    for j, cut in enumerate(case.cuts or []):
        p = np.asarray(cut.point, float)
        nn = np.asarray(cut.normal, float)
        box = np.asarray(cut.within, float)
        sa = (cen[a] - p) @ nn
        sb = (cen[b] - p) @ nn
        inside = np.all((point >= box[0]) & (point <= box[1]), axis=1)
        keep &= ~((sa * sb < 0) & inside)
    return keep


def _face_laws(case, mesh, a, b, body_rigid, laws):
    """Law row of each internal face's springs, and whether the face starts
    as contact (an interface with law: contact)."""
    body_slot, law_params, n_slots = laws.body_slot, laws.law_params, laws.n_slots
    # law of each internal spring: the weaker of its two cells' slots (row 1 + slot);
    # on an interface, the interface's row (bonded with a material, contact)
    sa_, sb_ = body_slot[a], body_slot[b]
    slot_strength = strength_of(law_params[1:1 + n_slots])
    weaker = np.where(slot_strength[sa_] <= slot_strength[sb_], sa_, sb_)
    weaker = np.where(body_rigid[a], sb_, np.where(body_rigid[b], sa_, weaker))
    law = (1 + weaker).astype(IDX)
    contact = np.zeros(len(a), dtype=bool)
    if mesh.face_interface is not None:
        fi = mesh.face_interface
        for i, it in enumerate(case.interfaces):
            on = fi == i
            if laws.iface_row[i] >= 0:
                law[on] = laws.iface_row[i]
            if it.law == "contact":
                contact[on] = True
    return law, contact


def support_springs(case, mesh, parts, body_part, laws):
    """The support springs: one piece of the spring table per support item."""
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
        sup.append(_support(case, mesh, parts, body_part, laws, j, item, name, fix, sel))
    return sup


def _support(case, mesh, parts, body_part, laws, j, item, name, fix, sel):
    """The support springs of boundary[j] on its boundary faces sel."""
    from ..mesh._core import _gather
    e0, alpha = laws.e0, laws.alpha
    ptr, vid = _gather(mesh.bface_vertex_ptr, np.arange(len(mesh.bface_vertex_xyz)), sel)
    xyz = mesh.bface_vertex_xyz[vid]
    if case.plane is not None and np.max(np.abs(mesh.bface_normal[sel, 2])) > 1e-9:
        raise case.error(("boundary", j), f"surface {name} is a face of the plane (the "
                         "slab's top or bottom): a plane case supports its edges only")
    bsp = points_rule(case)(ptr, xyz, mesh.bface_normal[sel],
                            parts[body_part[mesh.bface_cell[sel[0]]]].mesh.spring_points)
    bf = sel[bsp.face]
    cell = mesh.bface_cell[bf]
    nrm_b = mesh.bface_normal[bf]
    h = np.einsum("ij,ij->i", mesh.bface_centroid[bf] - mesh.cell_centroid[cell], nrm_b)
    h = np.maximum(np.abs(h), _min_half_length(mesh.cell_volume[cell],
                                               mesh.bface_area[bf]))   # as _face_half_lengths
    kk = e0[cell] / h
    axis_of = np.argmax(np.abs(nrm_b), axis=1)
    aligned = np.abs(nrm_b[np.arange(len(bf)), axis_of]) > 1.0 - 1e-12
    k = np.stack([kk, alpha[cell] * kk, alpha[cell] * kk], axis=1)
    if case.plane is not None:
        # the plane frames (n, e_z × n, e_z); on an edge normal to x or y the
        # components not in `fix` are free (k = 0), on a slanted edge only
        # fix: all is defined
        frames = plane_frames(nrm_b)
        if np.all(aligned):
            tau_axis = 1 - axis_of                          # x-normal: τ along y, and back
            k[:, 0] *= np.isin(np.array(list("xyz"))[axis_of], fix)
            k[:, 1] *= np.isin(np.array(list("xyz"))[tau_axis], fix)
        elif not {"x", "y"} <= set(fix):
            raise case.error(("boundary", j, "fix"), f"surface {name} is not normal to "
                             "one axis: only fix: all (or [x, y]) is possible on it")
    elif np.all(aligned) and len(np.unique(axis_of)) == 1:
        frames = _axis_frames(nrm_b, int(axis_of[0]), fix, k)
    else:
        # a curved or slanted surface: the springs' frame is the face's
        # own (n, s, t); only a full support is defined there
        if set(fix) != {"x", "y", "z"}:
            raise case.error(("boundary", j, "fix"), f"surface {name} is not normal to "
                             "one axis: only fix: all is possible on it")
        frames = _frames_from_normals(nrm_b)
    return dict(a=cell.astype(IDX), b=np.full(len(cell), mesh.n_cells, dtype=IDX),
                point=bsp.point, area=bsp.weight, h=h, kpa=k,
                frame=frames, face=(-1 - bf).astype(IDX),
                law=(1 + laws.body_slot[cell]
                     + (0 if item.breakable else laws.n_slots)).astype(IDX),
                state0=np.zeros(len(cell), dtype=np.int8))


def _axis_frames(nrm_b, axis, fix, k):
    """Frames of support springs on faces normal to one axis; k of the free components zeroed."""
    # frame (n, s, t) = (±e_k, e_k+1, n × s): local components are world axes
    e_s = np.zeros(3)
    e_s[(axis + 1) % 3] = 1.0
    frames = np.empty((len(nrm_b), 4))
    for sgn in (-1.0, 1.0):
        nvec = np.zeros(3)
        nvec[axis] = sgn
        on = np.sign(nrm_b[:, axis]) == sgn
        frames[on] = matrix_to_quat(np.stack([nvec, e_s, np.cross(nvec, e_s)], axis=1))
    comp = [axis, (axis + 1) % 3, (axis + 2) % 3]
    for c in range(3):
        if "xyz"[comp[c]] not in fix:
            k[:, c] = 0.0
    return frames


#: spring points from which spring_arms runs on threads
THREADED_SPRINGS = 200_000


def spring_arms(rot0, pos0, sb, point):
    """Arms (S, 3) of the spring points in the principal frames of bodies a and b."""
    rot_all = np.ascontiguousarray(np.concatenate([rot0, np.eye(3)[None]]))
    arm_a = np.empty((len(sb), 3))
    arm_b = np.empty((len(sb), 3))
    point = np.ascontiguousarray(point)
    # spring ranges on threads for a large model (threads.py)
    nt = build_threads() if len(sb) >= THREADED_SPRINGS else 1
    on_threads(_arms, len(sb), nt,
               lambda s0, s1: (rot_all, pos0, sb, point, arm_a, arm_b, s0, s1))
    return arm_a, arm_b


#: what the spring points of one face share, held once per face
FACE_KEYS = ("frame", "kpa", "h", "law")


def face_rows(internal_rows, pieces):
    """The rows of what faces share (FACE_KEYS): the internal faces' (per
    face, internal_springs), then each support spring's own, taken out of
    its piece; each piece's springs get their ``row``."""
    F = len(internal_rows["h"])
    rows = {key: [internal_rows[key]] for key in FACE_KEYS}
    start = F
    for p in pieces:
        if "row" in p:
            continue
        n = len(p["a"])
        for key in FACE_KEYS:
            rows[key].append(p.pop(key))
        p["row"] = np.arange(start, start + n, dtype=np.int64)
        start += n
    return {key: np.concatenate(v) for key, v in rows.items()}


def face_table(cat, rows):
    """The face table of the spring table cat (in schedule order), from the
    face rows of face_rows: slot, table, face_ref."""
    # the face table: what the spring points of one face share (frame,
    # stiffness per area, length, law) is held once per face; springs point
    # to their face's row (spring_slot).  The points of a face follow each
    # other in the schedule (same a, b: one group, sorted stably)
    face = cat["face"]
    first = np.ones(len(face), dtype=bool)
    first[1:] = face[1:] != face[:-1]
    slot = (np.cumsum(first) - 1).astype(IDX)
    row = cat.pop("row")[first]
    table = {key: np.ascontiguousarray(rows[key][row]) for key in FACE_KEYS}
    return slot, table, np.ascontiguousarray(face[first]).astype(IDX, copy=False)
