"""Spring laws: the law_params row of a material (physics/laws/ columns),
and the law table of a build (law slots: one per (material, part) pair in
use, their rows without rupture, the interfaces' rows; Model docstring)."""
from dataclasses import dataclass

import numpy as np

from ..calibration import plane_stiffness_rule, stiffness_rule
from ..compression_calibration import (DEFAULT_RATIO, TABLE_BRITTLENESS, TABLE_TENSION_RATIO,
                                       shear_ratio)
from ..fracture_calibration import fracture_ratios, voronoi_tension_ratio
from ..physics.laws import (CONTACT_OFF, CRITERIA, N_PARAMS, P_CAP, P_CAPH, P_CAPK, P_COH,
                            P_CRIT, P_EPSCR, P_FT,
                            P_GF, P_GS, P_MODEL, P_MU, P_RATE, P_RS, P_RUPT, P_SLOW, P_SY,
                            P_TANPHI, P_TENSION, RUPTURE_KINDS)
from ..physics.laws.rupture import RATE_LAWS
from ..physics.laws.plastic import MODELS
from .core import IDX


def yield_model(y):
    """`interface` or `continuum` (physics/laws/plastic.py) of a yield key:
    its `model`, by default interface."""
    if y.model is not None:
        return y.model
    return "interface"


def elastic_law_row():
    """law_params row of a purely elastic spring that never breaks (supports)."""
    row = np.zeros(N_PARAMS)
    row[P_TENSION] = np.inf
    row[P_MU] = CONTACT_OFF
    return row


def _spring_ratio(mat, mesh_kind):
    """(α = k_s/k_n, ν if the Poisson correction is on else None) of a
    material's 3D Voronoi springs, which the tensile strength's calibration
    depends on; (None, None) for other meshes or a ν no rule reaches
    (refused elsewhere)."""
    if mesh_kind != "voronoi":
        return None, None
    try:
        _, alpha, lam_aux = stiffness_rule(mat.stiffness, mesh_kind, mat.young, mat.poisson)
    except ValueError:
        return None, None
    return alpha, (mat.poisson if lam_aux > 0.0 else None)


def _table_tension_ratio(mat, mesh_kind):
    """The material's (F_T at the compression table's brittleness, its
    springs' α or None with the Poisson correction, its ν with the Poisson
    correction or None): compression_calibration.shear_ratio's
    `tension_ratio`, `alpha` and `aux_poisson`."""
    alpha, aux_nu = _spring_ratio(mat, mesh_kind)
    if alpha is None:
        return TABLE_TENSION_RATIO, None, None
    return (voronoi_tension_ratio(TABLE_BRITTLENESS, alpha, aux_nu),
            alpha if aux_nu is None else None, aux_nu)


def material_law_row(mat, mesh_kind="voronoi", cell_size=None):
    """law_params row of a case material (physics/laws/__init__.py columns).
    A broken face is a contact with Coulomb friction `friction` (default 0).
    Material fracture values are mapped to spring values by the mesh kind's
    fracture calibration (fracture_calibration.py) unless `rupture.values:
    spring`; the mixed-mode law's shear strength defaults to 2 f_t, or is
    the one whose lattice fails at `compressive_strength`
    (compression_calibration.py), and its mode-II energy to G_f
    (docs/case_file.md)."""
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
        row[P_MODEL] = MODELS[yield_model(y)]
    r = mat.rupture
    if r is not None:
        if r.strain is not None:
            row[P_RUPT] = RUPTURE_KINDS["strain"]
            row[P_EPSCR] = r.strain
        else:
            f_t, g_f = 1.0, 1.0
            if r.values == "material":
                alpha, aux_nu = _spring_ratio(mat, mesh_kind)
                f_t, g_f = fracture_ratios(mesh_kind, mat.young, r.fracture_energy,
                                           r.tensile_strength, cell_size, alpha, aux_nu)
            row[P_RUPT] = RUPTURE_KINDS[r.law or "mixed_mode"]
            row[P_FT] = r.tensile_strength / f_t
            row[P_GF] = r.fracture_energy / g_f
            ratio = DEFAULT_RATIO
            if r.shear_strength is not None:
                ratio = r.shear_strength / r.tensile_strength
            elif r.compressive_strength is not None:
                # the ratio whose lattice fails at f_c (compression_calibration.py)
                ratio, _ = shear_ratio(mesh_kind, r.compressive_strength, r.tensile_strength,
                                       *_table_tension_ratio(mat, mesh_kind))
            row[P_RS] = ratio
            g_s = r.fracture_energy if r.shear_fracture_energy is None \
                else r.shear_fracture_energy
            row[P_GS] = g_s / g_f
            if r.rate is not None:
                row[P_RATE] = RATE_LAWS[r.rate]
                row[P_SLOW] = np.sqrt(mat.density / mat.young)
            if r.cap is not None:
                # the face's own normal traction and strain: no calibration
                # (in hydrostatic compression every face holds σ_n = −p)
                row[P_CAP] = r.cap.stress
                row[P_CAPH] = r.cap.hardening
                row[P_CAPK] = r.cap.transition
    row[P_MU] = mat.friction or 0.0
    return row


def compression_notes(case, parts, body_part, body_material, body_rigid):
    """Notes on the compressive strengths a mesh cannot give (a Voronoi
    lattice's reach, or a block or plane mesh: compression_calibration.py),
    one per material and mesh kind that uses it."""
    notes = []
    for j, (name, mat) in enumerate(case.materials.items()):
        r = mat.rupture
        if r is None or r.compressive_strength is None or r.shear_strength is not None:
            continue
        used = np.unique(body_part[(body_material == j) & ~body_rigid])
        prefix = "" if case.plane is None else "plane_"
        kinds = sorted({prefix + parts[k].mesh.kind for k in used})
        for kind in kinds:
            _, note = shear_ratio(kind, r.compressive_strength, r.tensile_strength,
                                  *_table_tension_ratio(mat, kind))
            if note:
                notes.append(f"materials.{name}.rupture.compressive_strength: {note}")
    return notes


def law_notes(case):
    """What `check` and `info` print of the laws' derived values: the shear
    strength a compressive strength gives on Voronoi cells
    (compression_calibration.py) and the loading-rate factors of `rate:
    fib2010` at a few strain rates, and the compressive cap's branches
    (physics/laws/rupture.py)."""
    from ..case import scene_parts
    from ..physics.laws.rupture import fib2010_compression_dif, fib2010_tension_dif
    notes = []
    names = list(case.materials)
    parts = scene_parts(case)
    for name, mat in case.materials.items():
        r = mat.rupture
        if r is None or r.strain is not None:
            continue
        kinds = {p.mesh.kind for p in parts
                 if (p.material or names[0]) == name or case.groups}
        if r.compressive_strength is not None and r.shear_strength is None \
                and "voronoi" in kinds and case.plane is None:
            ratio, _ = shear_ratio("voronoi", r.compressive_strength, r.tensile_strength,
                                   *_table_tension_ratio(mat, "voronoi"))
            fc = r.compressive_strength
            notes.append(f"materials.{name}: compressive_strength {fc / 1e6:.4g}"
                         f" MPa = {fc / r.tensile_strength:.3g} f_t gives "
                         f"shear_strength {ratio:.3g} f_t = "
                         f"{ratio * r.tensile_strength / 1e6:.4g} MPa on Voronoi cells "
                         "(docs/calibration.md, \"Compression\")")
        if r.rate is not None:
            rates = (1.0, 10.0, 50.0)
            shown = ", ".join(f"{x:g} /s: × {fib2010_tension_dif.py_func(x):.3g} in tension, "
                              f"× {fib2010_compression_dif.py_func(x):.3g} in compression"
                              for x in rates)
            notes.append(f"materials.{name}: rate {r.rate} raises the strength at a strain rate "
                         f"of {shown} (fib Model Code 2010 §5.1.11.1)")
        if r.cap is not None:
            c = r.cap
            # at the case's E: E0 differs by the stiffness calibration (a few %)
            e1 = c.transition * c.stress / mat.young
            notes.append(f"materials.{name}: cap: a spring's normal traction is held at "
                         f"{c.stress / 1e6:.4g} MPa from a closing strain of about "
                         f"{c.stress / mat.young:.3g}, hardens by {c.hardening:g} E0 to "
                         f"{(c.stress + c.hardening * (e1 * mat.young - c.stress)) / 1e6:.4g} "
                         f"MPa at about {e1:.3g}, then densifies (LDPM's compressive "
                         "boundary; a cube under a pressure yields at the first figure)")
    return notes


def viscous_row(mat):
    """(τ_d [s], [(g_i, τ_i [s]), ...]) of a material (physics/viscous.py):
    Kelvin's dashpot time and the Maxwell branches' shares g_i = E_i/E of
    the instantaneous modulus E = young; None for an elastic material."""
    v = getattr(mat, "viscoelastic", None)
    if v is None:
        return None
    if v.kind == "kelvin":
        return (v.tau, [])
    if v.kind == "maxwell":
        return (0.0, [(1.0, v.tau)])
    if v.kind == "standard":
        return (0.0, [((mat.young - v.relaxed) / mat.young, v.tau)])
    return (0.0, [(e / mat.young, tau) for e, tau in v.terms])


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


def body_materials(case, parts, body_part, groups):
    """(N,) int32 material of each body: its part's, then its groups' (in case order)."""
    mat_names = list(case.materials)
    body_material = np.zeros(len(body_part), dtype=IDX)
    for k, part in enumerate(parts):
        if part.material is not None:
            body_material[body_part == k] = mat_names.index(part.material)
    for name, g in (case.groups or {}).items():
        if getattr(g, "material", None):
            body_material[groups[name]] = mat_names.index(g.material)
    return body_material


@dataclass
class LawSlots:
    """The law table of a build (law_slots).  law_params (n_laws, N_PARAMS)
    (Model.law_params); n_slots K; body_slot (N,) the slot of each body;
    iface_row: the law_params row of each interface (−1: the weaker of its
    two cells' laws); visc_rows: each law row's viscous_row (None:
    elastic); materials: Model.materials; e0, alpha, lam_aux (N,)
    each body's stiffness rule (calibration.py; a rigid part's e0 is
    infinite)."""
    law_params: np.ndarray
    visc_rows: list
    n_slots: int
    body_slot: np.ndarray
    iface_row: list
    materials: list
    e0: np.ndarray
    alpha: np.ndarray
    lam_aux: np.ndarray


def viscous_laws(case, visc_rows):
    """(law_dashpot (L,) [s], law_branch_g (L, M), law_branch_tau (L, M) [s])
    of the law rows (physics/viscous.py): Kelvin's dashpot time plus the
    solver's Rayleigh β (mode dynamic) on every row; empty arrays (the
    viscous pass off) when no row has either."""
    beta = 0.0
    if case.solver.mode == "dynamic":
        beta = case.solver.damping.coefficients()[1]
    if beta == 0.0 and all(r is None for r in visc_rows):
        return np.zeros(0), np.zeros((0, 0)), np.zeros((0, 0))
    n = len(visc_rows)
    m = max((len(r[1]) for r in visc_rows if r is not None), default=0)
    dashpot = np.full(n, beta)
    g = np.zeros((n, m))
    tau = np.ones((n, m))
    for i, r in enumerate(visc_rows):
        if r is None:
            continue
        dashpot[i] += r[0]
        for j, (gi, ti) in enumerate(r[1]):
            g[i, j], tau[i, j] = gi, ti
    return dashpot, g, tau


def law_slots(case, parts, body_part, body_material):
    """The law table: elastic row, slot rows, slot rows without rupture, interface rows."""
    # law slots: one per (material, part) pair in use; stiffness and
    # fracture calibration depend on the part's mesh kind and cell size
    n_parts = len(parts)
    slots, body_slot = np.unique(body_material.astype(np.int64) * n_parts + body_part,
                                 return_inverse=True)
    body_slot = body_slot.reshape(-1)
    law_rows = [elastic_law_row()]
    visc_rows = [None]
    materials, slot_e0, slot_alpha, slot_lam = _slot_laws(case, parts, slots, law_rows,
                                                          visc_rows)
    n_slots = len(slots)
    # rows 1 + n_slots + k: slot k at unbreakable supports (yield, no rupture)
    for row in law_rows[1:1 + n_slots]:
        law_rows.append(unbreakable(row))
    visc_rows += visc_rows[1:1 + n_slots]
    iface_row = _interface_laws(case, parts, law_rows, visc_rows)
    law_params = np.array(law_rows, dtype=float)
    return LawSlots(law_params=law_params, visc_rows=visc_rows, n_slots=n_slots, body_slot=body_slot,
                    iface_row=iface_row, materials=materials,
                    e0=np.array(slot_e0)[body_slot], alpha=np.array(slot_alpha)[body_slot],
                    lam_aux=np.array(slot_lam)[body_slot])


def _slot_laws(case, parts, slots, law_rows, visc_rows):
    """Law rows (appended to law_rows) and stiffness rules of the law slots; Model.materials."""
    n_parts = len(parts)
    mat_names = list(case.materials)
    deformable = [p for p in parts if p.mesh.kind != "rigid"]
    materials = [None] * len(mat_names)
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
            if case.plane is None:
                e0, alpha, lam_aux = stiffness_rule(mat.stiffness, kind, mat.young, mat.poisson)
            else:
                e0, alpha, lam_aux = plane_stiffness_rule(mat.stiffness, kind, mat.young,
                                                          mat.poisson, case.plane.kind)
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
        law_rows.append(material_law_row(mat, kind if case.plane is None else "plane_" + kind,
                                         part_cell_size(case, ref)))
        visc_rows.append(viscous_row(mat))
    for j, name in enumerate(mat_names):
        if materials[j] is None:        # a material no body uses
            mat = case.materials[name]
            materials[j] = dict(name=name, density=mat.density, young=mat.young,
                                poisson=mat.poisson, stiffness=mat.stiffness)
    return materials, slot_e0, slot_alpha, slot_lam


def _interface_laws(case, parts, law_rows, visc_rows):
    """Law rows of the interfaces (appended to law_rows); each interface's row or −1."""
    # rows of the interfaces: bonded with a material of its own, or contact
    iface_row = []
    for it in case.interfaces:
        if it.law == "contact":
            row = elastic_law_row()
            row[P_MU] = it.friction or 0.0
        elif it.material is not None:
            ref = next(p for p in parts if p.name in it.parts and p.mesh.kind != "rigid")
            from ..case import part_cell_size
            kind = ref.mesh.kind if case.plane is None else "plane_" + ref.mesh.kind
            row = material_law_row(case.materials[it.material], kind, part_cell_size(case, ref))
        else:
            row = None                   # the weaker of the two cells' laws
        iface_row.append(-1 if row is None else len(law_rows))
        if row is not None:
            law_rows.append(row)
            visc_rows.append(viscous_row(case.materials[it.material])
                             if it.law != "contact" and it.material is not None else None)
    return iface_row
