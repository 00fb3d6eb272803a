"""Poisson correction: auxiliary volumetric stress per cell (physics/poisson.py).

Facts checked:
* the least-squares cell dilatation θ_c is exact for an affine
  displacement (every cell, surface cells too) and zero for a rigid motion
  of any size;
* the forces are −∂U_aux/∂x: the assembled K_aux is the tangent of the
  kernel, and a finite-difference of U_aux gives the kernel's forces;
* the kernel's forces and torques conserve linear and angular momentum to
  round-off, and a short dynamic run with the correction on keeps the
  energy balance and the momenta, with the same result on 1 and 2 threads;
* the calibrated default reaches ν = 0.3 and 0.45 on Voronoi meshes
  (issue 11): measured E within 3 % and ν within 0.02 at 0.2 and 0.3 on a
  mesh the tables were not made on; a ν = 0 scene has no Poisson arrays;
* a broken face switches its cells' auxiliary stress off (χ_c = 0).
"""
import dataclasses
import os
import subprocess
import sys
import textwrap

import numpy as np
import pytest

from rbsm_dyn.calibration import NU_MAX, NU_TABLE_MAX, stiffness_rule
from rbsm_dyn.case import load_case_text
from rbsm_dyn.model import build_mesh, build_model, new_state
from rbsm_dyn.physics.integrate import refresh_all_rotations
from rbsm_dyn.physics.poisson import (RCOND, cell_dilatation, poisson_energy, poisson_pass,
                                      poisson_slots, poisson_stiffness)
from rbsm_dyn.physics.rotation import quat_mul_np
from rbsm_dyn.solvers.passes import body_state
from rbsm_dyn.stiffness import stiffness_matrix, uniaxial_moduli

E = 200.0e9


def case_text(mesh, poisson, stiffness="calibrated", extra="", box="[1.0, 1.0, 1.0]",
              solver="{mode: static}"):
    return f"""
name: poisson
domain: {{box: [[0, 0, 0], {box}]}}
mesh: {mesh}
materials:
  m: {{density: 8000, young: {E}, poisson: {poisson}, stiffness: {stiffness}{extra}}}
solver: {solver}
"""


def make(mesh, poisson, **kw):
    return build_model(load_case_text(case_text(mesh, poisson, **kw), "t.yaml"))


SMALL = "{kind: voronoi, size: 0.25, seed: 3}"           # about 64 cells


@pytest.fixture(scope="module")
def small():
    return make(SMALL, 0.3)


def posed(model, u, theta):
    """Positions, rotations, increments of the bodies displaced by u (N, 3)
    and turned by the world rotation vectors theta (N, 3)."""
    n = model.n_bodies
    pos = model.body_pos0.copy()
    pos[:n] += u
    ang = np.linalg.norm(theta, axis=1)
    axis = theta / np.where(ang > 0, ang, 1.0)[:, None]
    qi = np.column_stack([np.cos(ang / 2), np.sin(ang / 2)[:, None] * axis])
    quat = model.body_quat0.copy()
    quat[:n] = quat_mul_np(qi, model.body_quat0[:n])
    rot = np.zeros((n + 1, 3, 3))
    dq = np.zeros((n + 1, 4))
    refresh_all_rotations(n + 1, quat, model.body_quat0, rot, dq)
    return pos, rot


def slot_projectors(model):
    """P_c = Σ_j g_j Δx_jᵀ (N, 3, 3) from the Poisson arrays: the fit's
    response to an affine field u = ε x is θ_c = tr(P_c ε)."""
    a = model.poisson
    n = model.n_bodies
    c = np.repeat(np.arange(n), np.diff(a.cell_slot_ptr))
    dx = model.body_pos0[a.slot_cell] - model.body_pos0[c]
    P = np.zeros((n, 3, 3))
    np.add.at(P, c, a.slot_gw[:, :, None] * dx[:, None, :])
    return P


def aux_wrench(model, pos, rot):
    n = model.n_bodies
    st = new_state(model)
    out = np.zeros((n + 1, 6))
    st.body_pos, st.body_rot, st.body_wrench = pos, rot, out
    poisson_pass(poisson_slots(model.poisson, st.aux_g, st.aux_p), body_state(st), None, None)
    return out[:n]


def test_zero_poisson_pays_nothing():
    m = make(SMALL, 0.0)
    assert not m.poisson_on
    st = new_state(m)
    assert st.aux_g.size == 0 and st.aux_p.size == 0
    # and the α table keeps ν ≤ 0.25 (no correction there)
    assert not make(SMALL, NU_TABLE_MAX).poisson_on


def test_dilatation_exact_for_affine_and_zero_for_rigid_motion(small):
    m = small
    n = m.n_bodies
    x = m.body_pos0[:n]
    rng = np.random.default_rng(1)
    eps = 1e-4 * rng.standard_normal((3, 3))
    eps = 0.5 * (eps + eps.T)
    pos, rot = posed(m, x @ eps.T, np.zeros((n, 3)))
    theta, chi = cell_dilatation(m.poisson, pos, rot)
    # least squares is exact for an affine field on the directions the fit
    # resolves: θ_c = tr(P_c ε), P_c = Σ_j g_j Δx_jᵀ = A⁺A an orthogonal
    # projector, the identity (θ_c = tr ε) in every cell that resolves all
    # three directions, which every interior cell does
    P = slot_projectors(m)
    np.testing.assert_allclose(P, np.transpose(P, (0, 2, 1)), atol=1e-12)
    np.testing.assert_allclose(P @ P, P, atol=1e-12)
    rank = np.trace(P, axis1=1, axis2=2)
    np.testing.assert_allclose(rank, np.round(rank), atol=1e-12)
    full = np.round(rank) == 3
    np.testing.assert_allclose(P[full], np.broadcast_to(np.eye(3), P[full].shape), atol=1e-12)
    surface = np.zeros(n, dtype=bool)
    surface[m.mesh.bface_cell] = True
    assert np.all(full | surface) and full.sum() > 0.8 * n
    np.testing.assert_allclose(theta, np.einsum("cij,ji->c", P, eps), rtol=0,
                               atol=1e-9 * np.abs(eps).max())
    np.testing.assert_allclose(theta[full], np.trace(eps), rtol=0, atol=1e-9 * np.abs(eps).max())
    assert np.all(chi == 1.0)
    # a finite rigid rotation (1 rad) about an arbitrary axis plus a shift
    w = np.array([0.3, -0.8, 0.5])
    w /= np.linalg.norm(w)
    c, s = np.cos(1.0), np.sin(1.0)
    W = np.array([[0, -w[2], w[1]], [w[2], 0, -w[0]], [-w[1], w[0], 0]])
    R = np.eye(3) + s * W + (1 - c) * W @ W                  # Rodrigues
    u = (x - 0.5) @ R.T + 0.5 - x + [0.1, 0.2, -0.3]
    pos, rot = posed(m, u, np.tile(w, (n, 1)))
    theta, _ = cell_dilatation(m.poisson, pos, rot)
    assert np.abs(theta).max() <= 1e-12
    # so no force either: |f| = |p G| with p = λ V θ
    f_scale = m.poisson.cell_lv.max() * np.abs(m.poisson.slot_gw).max()
    assert np.abs(aux_wrench(m, pos, rot)).max() <= 1e-11 * f_scale


def test_forces_are_minus_gradient_and_K_is_their_tangent(small):
    m = small
    n = m.n_bodies
    rng = np.random.default_rng(2)
    U = 1e-7 * rng.standard_normal((n, 6))
    Kaux = poisson_stiffness(m.poisson, n)
    assert abs(Kaux - Kaux.T).max() <= 1e-14 * abs(Kaux).max()
    Ku = (Kaux @ U.ravel()).reshape(n, 6)
    fp = aux_wrench(m, *posed(m, U[:, :3], U[:, 3:]))
    fm = aux_wrench(m, *posed(m, -U[:, :3], -U[:, 3:]))
    assert np.linalg.norm(Ku + 0.5 * (fp - fm)) <= 1e-6 * np.linalg.norm(Ku)
    # finite strain: force = −∂U_aux/∂x by central differences of the energy
    U = 1e-3 * rng.standard_normal((n, 6))
    pos, rot = posed(m, U[:, :3], U[:, 3:])
    f = aux_wrench(m, pos, rot)
    h = 1e-7
    for i, k in [(0, 0), (n // 2, 1), (n - 1, 2)]:
        pp, pm = pos.copy(), pos.copy()
        pp[i, k] += h
        pm[i, k] -= h
        dU = (poisson_energy(m.poisson, pp, rot) - poisson_energy(m.poisson, pm, rot)) / (2 * h)
        assert f[i, k] == pytest.approx(-dU, rel=1e-5, abs=1e-9 * np.abs(f).max())


def test_forces_conserve_linear_and_angular_momentum(small):
    m = small
    n = m.n_bodies
    rng = np.random.default_rng(3)
    pos, rot = posed(m, 1e-2 * rng.standard_normal((n, 3)), 0.3 * rng.standard_normal((n, 3)))
    w = aux_wrench(m, pos, rot)
    scale = np.abs(w[:, :3]).max()
    assert np.abs(w[:, :3].sum(axis=0)).max() <= 1e-13 * scale * n
    # total moment about the origin: Σ x × f + Σ torque
    L = np.cross(pos[:n], w[:, :3]).sum(axis=0) + w[:, 3:].sum(axis=0)
    assert np.abs(L).max() <= 1e-13 * scale * n


def test_K_includes_the_correction_and_keeps_the_rigid_modes(small):
    K = stiffness_matrix(small)
    K0 = stiffness_matrix(dataclasses.replace(small, poisson=None))
    assert abs(K - K0).max() > 0.1 * abs(K0).max() * 1e-3
    from rbsm_dyn.stiffness import rigid_modes
    phi = rigid_modes(small)
    scale = abs(K).sum(axis=1).max()
    resid = np.linalg.norm(K @ phi, axis=0).max()
    assert resid <= 1e-10 * scale * np.linalg.norm(phi, axis=0).min()


def test_stable_dt_bounds_the_corrected_lattice(small):
    """The auxiliary stiffness enters the frequency bound: stable_dt stays
    below the exact 2/ω_max (and is smaller than without the correction)."""
    from rbsm_dyn.solvers import modal
    est = small.stable_dt()
    exact = 2.0 / modal.omega_max(small)
    assert 0.3 * exact < est < exact
    assert est < dataclasses.replace(small, poisson=None).stable_dt()


VORONOI_CHECK = "{kind: voronoi, size: 0.1111111111111111, seed: 11}"   # 729 cells


@pytest.fixture(scope="module")
def check_mesh():
    return build_mesh(load_case_text(case_text(VORONOI_CHECK, 0.0), "t.yaml"))


def moduli(mesh, nu, stiffness="calibrated"):
    model = build_model(load_case_text(case_text(VORONOI_CHECK, nu, stiffness), "t.yaml"), mesh)
    E_eff, nu_eff = uniaxial_moduli(model)
    return model, E_eff.mean(), nu_eff.mean()


@pytest.mark.parametrize("nu,stiffness", [(0.2, "calibrated"), (0.2, "homogeneous"),
                                          (0.3, "calibrated"), (0.3, "homogeneous")])
def test_corrected_voronoi_reproduces_E_and_nu(check_mesh, nu, stiffness):
    # issue 11: ν within ±0.02 and E within 3 % on a mesh (seed 11) the
    # tables were not measured on (seeds 1, 2, 3)
    model, E_eff, nu_eff = moduli(check_mesh, nu, stiffness)
    assert model.poisson_on == (stiffness == "homogeneous" or nu > NU_TABLE_MAX)
    assert E_eff == pytest.approx(E, rel=0.03)
    assert nu_eff == pytest.approx(nu, abs=0.02)


def test_nu_045_is_reached(check_mesh):
    # issue 11: 0.45 measured and reported (docs/calibration.md); the test
    # asserts the reach with the tolerances of the other targets
    _, E_eff, nu_eff = moduli(check_mesh, NU_MAX)
    print(f"ν = 0.45: E_eff/E = {E_eff / E:.4f}, ν_eff = {nu_eff:.4f}")
    assert E_eff == pytest.approx(E, rel=0.03)
    assert nu_eff == pytest.approx(NU_MAX, abs=0.02)


def test_nu_above_the_reach_names_the_range():
    with pytest.raises(ValueError, match=r"reaches ν in \["):
        stiffness_rule("calibrated", "voronoi", E, 0.49)


def test_homogeneous_blocks_tend_to_the_target():
    """Cubic α = 1 lattice + λ tr ε: the Lamé constants are exact for a
    uniform strain in the interior; the free surface layer (one cell) is
    softer, so E_eff → E as the number of cells n across grows (measured
    1 − E_eff/E = 4.7 %, 1.8 %, 1.4 % at n = 4, 8, 10; docs/calibration.md)."""
    errs = []
    for n in (4, 8):
        m = make(f"{{kind: blocks, divisions: [{n}, {n}, {n}]}}", 0.3, stiffness="homogeneous")
        E_eff, nu_eff = uniaxial_moduli(m)
        errs.append(1 - E_eff.mean() / E)
        assert nu_eff.mean() == pytest.approx(0.3, abs=0.01)
    # a surface effect: it falls as the surface layer's share falls
    assert 0 < errs[1] < 0.5 * errs[0]
    assert errs[1] < 0.02


def test_broken_face_switches_its_cells_off(small):
    m = small
    n = m.n_bodies
    st = np.zeros(m.n_springs, dtype=np.int8)
    dmg = np.zeros(m.n_springs)
    s = int(np.nonzero(m.spring_face >= 0)[0][0])
    a, b = m.spring_bodies[s]
    dmg[s] = 0.25
    pos, rot = posed(m, 1e-4 * np.random.default_rng(4).standard_normal((n, 3)),
                     np.zeros((n, 3)))
    _, chi = cell_dilatation(m.poisson, pos, rot, st, dmg)
    assert chi[a] == chi[b] == 0.75
    assert np.sum(chi < 1) == 2
    st[s] = 2
    _, chi = cell_dilatation(m.poisson, pos, rot, st, dmg)
    assert chi[a] == chi[b] == 0.0
    # less damage never more energy at the same positions
    assert poisson_energy(m.poisson, pos, rot, st, dmg) <= poisson_energy(m.poisson, pos, rot)


def slab(nu, seed=1):
    """A Voronoi slab one cell thick: 40 × 40 × 2 mm, cells of 2 mm (400)."""
    return make(f"{{kind: voronoi, size: 0.002, seed: {seed}}}", nu,
                box="[0.04, 0.04, 0.002]")


@pytest.fixture(scope="module")
def slabs():
    return slab(0.3), slab(0.0)


def test_one_cell_thick_slab_keeps_its_stable_step(slabs):
    """All neighbours of a slab cell lie nearly in its plane: the fit must
    not resolve the thickness direction from small centroid offsets
    (RCOND; before it, this slab's true step fell 10 times at ν = 0.3).

    Bound: the corrected lattice is the α = 1 lattice of E0(ν) plus the
    auxiliary term.  The α = 1 lattice is E0(ν)/E0(0) times the ν = 0
    lattice with its k_s lowered (α(0) ≥ 1), so its ω² is at most
    E0(ν)/E0(0) times ω_0².  The auxiliary stress adds λ to the modulus
    E0(ν) of a longitudinal wave (α = 1: 2μ = E0), and the truncated fit
    amplifies a cell's gains over an isotropic stencil's by at most
    κ = tr(A⁺) μ_max / 3 ≤ (2 + 1/RCOND)/3 (physics/poisson.py; λ not
    condensed, the larger).  So

        ω² ≤ ω_0² E0(ν)/E0(0) (1 + κ λ/E0(ν)),   dt ≥ dt_0 / √(that factor)

    for the true step 2/ω_max, and for the estimate (its row sums are made
    of the same terms).  The estimate must stay below the true step (the
    explicit run is stable)."""
    from rbsm_dyn.solvers import modal
    m, m0 = slabs
    assert m.poisson_on and not m0.poisson_on
    e0_0, alpha_0, _ = stiffness_rule("calibrated", "voronoi", E, 0.0)
    e0, alpha, lam = stiffness_rule("calibrated", "voronoi", E, 0.3)
    assert alpha_0 >= alpha == 1.0
    kappa = (2.0 + 1.0 / RCOND) / 3.0
    factor = 1.0 / np.sqrt(e0 / e0_0 * (1.0 + kappa * lam / e0))
    exact = 2.0 / modal.omega_max(m)
    exact0 = 2.0 / modal.omega_max(m0)
    est, est0 = m.stable_dt(), m0.stable_dt()
    assert est <= exact
    assert exact >= factor * exact0
    assert est >= factor * est0


def in_plane_moduli(model, core=0.25):
    """E and ν of a slab under uniform in-plane uniaxial stress along x and
    y (as stiffness.uniaxial_moduli, the strain fitted in the plane):
    E = σ/ε_kk, ν = −ε_ll/ε_kk, the mean of the two axes."""
    from rbsm_dyn.physics.integrate import FIXED
    from rbsm_dyn.stiffness import solve_linear
    mesh, n = model.mesh, model.n_bodies
    x = model.body_pos0[:n]
    lo, hi = np.asarray(mesh.box, float)
    centre = 0.5 * (lo + hi)
    load = np.zeros((n, 6, 2))
    for k in (0, 1):
        for side, sgn in ((2 * k, -1.0), (2 * k + 1, 1.0)):
            sel = mesh.bface_side == side
            cell = mesh.bface_cell[sel]
            f = np.zeros((sel.sum(), 3))
            f[:, k] = sgn * mesh.bface_area[sel]                 # σ = 1 Pa
            np.add.at(load[:, :3, k], cell, f)
            np.add.at(load[:, 3:, k], cell, np.cross(mesh.bface_centroid[sel] - x[cell], f))
    kind = np.zeros((n, 6), dtype=np.int8)
    kind[np.argmin(np.linalg.norm(x - centre, axis=1))] = FIXED
    U, _ = solve_linear(model, load, kind=kind, value=np.zeros((n, 6)))
    E_k, nu_k = [], []
    for k in (0, 1):
        length = hi[k] - lo[k]
        sel = (x[:, k] >= lo[k] + core * length) & (x[:, k] <= hi[k] - core * length)
        A = np.hstack([np.ones((sel.sum(), 1)), x[sel, :2] - centre[:2]])
        coef, *_ = np.linalg.lstsq(A, U[sel, :2, k], rcond=None)
        eps = 0.5 * (coef[1:].T + coef[1:])
        E_k.append(1.0 / eps[k, k])
        nu_k.append(-eps[1 - k, 1 - k] / eps[k, k])
    return np.mean(E_k), np.mean(nu_k)


def test_one_cell_thick_slab_is_in_plane_stress(slabs):
    """The slab's faces are free: σ_zz = 0, so its in-plane Poisson ratio is
    the material's ν (plane stress), not ν/(1 − ν) (plane strain: the
    thickness direction dropped from the fit without condensing λ) nor the
    bare lattice's ≈ 0 (a fit that lets a spurious ε_zz cancel the in-plane
    dilatation).  The measured ν must lie nearer to ν than to either."""
    nu = 0.3
    _, nu_eff = in_plane_moduli(slabs[0])
    assert 0.5 * nu < nu_eff < 0.5 * (nu + nu / (1 - nu))


SPLIT = textwrap.dedent("""\
    name: poisson-split
    domain: {box: [[0, 0, 0], [1, 1, 1]]}
    mesh: {kind: voronoi, size: 0.25, seed: 3}
    materials:
      a: {density: 8000, young: 2.0e11, poisson: 0.3}
      b: {density: 8000, young: 2.0e5, poisson: 0.3}
    groups:
      right: {box: [[0.5, -1, -1], [2, 2, 2]], material: b}
    solver: {mode: static}
    """)
CUT = SPLIT.replace(", material: b", "") + (
    "cuts: [{point: [0.5, 0, 0], normal: [1, 0, 0], within: [[-1, -1, -1], [2, 2, 2]]}]\n")


@pytest.mark.parametrize("split", ["cut", "material"])
def test_cut_and_material_interface_do_not_link_the_fit(split):
    """A cut through the whole block (or an interface to another material)
    at x = 0.5: moving the right part rigidly (a finite rotation and a
    shift) strains neither part, so θ_c = 0 and no auxiliary force in every
    cell; the cut faces are no links, so χ_c of the cut's flanks stays 1
    (their auxiliary stress stays on) at the initial spring states."""
    text = CUT if split == "cut" else SPLIT
    m = build_model(load_case_text(text, "t.yaml"))
    n = m.n_bodies
    assert m.poisson_on and (m.n_cut > 0) == (split == "cut")
    right = m.body_pos0[:n, 0] > 0.5
    assert 0 < right.sum() < n
    w = np.array([0.2, -0.5, 0.4])
    ang = np.linalg.norm(w)
    W = np.array([[0, -w[2], w[1]], [w[2], 0, -w[0]], [-w[1], w[0], 0]]) / ang
    R = np.eye(3) + np.sin(ang) * W + (1 - np.cos(ang)) * W @ W
    x = m.body_pos0[:n]
    u = np.where(right[:, None], (x - 0.75) @ R.T + 0.75 - x + [0.3, 0.1, -0.2], 0.0)
    pos, rot = posed(m, u, np.where(right[:, None], w, 0.0))
    st = m.spring_state0
    theta, chi = cell_dilatation(m.poisson, pos, rot, st, np.zeros(m.n_springs))
    assert np.abs(theta).max() <= 1e-12
    assert np.all(chi == 1.0)
    f_scale = m.poisson.cell_lv.max() * np.abs(m.poisson.slot_gw).max()
    assert np.abs(aux_wrench(m, pos, rot)).max() <= 1e-11 * f_scale
    # and the separation is no strain only because the fit does not cross:
    # the same motion without the split strains the cells along it
    # (its own mesh: a cut's seeds are mirrored across its plane)
    whole = build_model(load_case_text(case_text(SMALL, 0.3), "t.yaml"))
    xw = whole.body_pos0[:whole.n_bodies]
    rw = xw[:, 0] > 0.5
    uw = np.where(rw[:, None], (xw - 0.75) @ R.T + 0.75 - xw + [0.3, 0.1, -0.2], 0.0)
    theta, _ = cell_dilatation(whole.poisson, *posed(whole, uw, np.where(rw[:, None], w, 0.0)))
    assert np.abs(theta).max() > 1e-3


DYNAMIC = textwrap.dedent("""\
    name: poisson-dynamic
    domain: {box: [[0, 0, 0], [0.4, 0.2, 0.2]]}
    mesh: {kind: voronoi, size: 0.05, seed: 5}
    materials:
      m: {density: 8000, young: 2.0e11, poisson: 0.4}
    initial: [{velocity: [1.0, -0.5, 0.2], angular_velocity: [3.0, -2.0, 5.0]},
              {group: half, velocity: [-2.0, 1.0, 0.5]}]
    groups: {half: {box: [[0, 0, 0], [0.2, 0.2, 0.2]]}}
    solver: {mode: dynamic, end_time: 2.0e-4}
    output: {interval: 2.0e-5, fields: [position, velocity, orientation, angular_velocity]}
    """)


def test_dynamic_run_closes_the_energy_balance(run_case):
    """No damping, no loads: kinetic + strain energy (springs and U_aux)
    stays at its initial value up to the leapfrog's O(dt²) error: within
    1e-3 at dt_safety 0.2, and four times smaller than at 0.4."""
    err = []
    for safety in (0.4, 0.2):
        h = run_case(DYNAMIC.replace("end_time: 2.0e-4", f"end_time: 2.0e-4, dt_safety: {safety}"))
        ob = h.observables
        kin, strain = ob["kinetic"], ob["strain"]
        assert np.all(ob["external_work"] == 0.0)
        assert strain.max() > 0.3 * kin[0]                  # the motion strains the block
        total = kin + strain
        err.append(np.abs(total - total[0]).max() / total[0])
    assert err[1] <= 1e-3
    assert err[0] / err[1] == pytest.approx(4.0, rel=0.25)


def test_dynamic_run_conserves_momentum():
    """Σ m v and Σ (x × m v + L) of a free corrected model stay fixed to
    round-off over 300 steps of random velocities and spins."""
    from rbsm_dyn.solvers.explicit import advance
    m = build_model(load_case_text(DYNAMIC, "t.yaml"))
    assert m.poisson_on
    st = new_state(m)
    st.dt = 0.5 * m.stable_dt()
    rng = np.random.default_rng(0)
    st.body_vel[:-1] = rng.normal(size=(m.n_bodies, 3))
    spin = m.body_inertia.mean(axis=1)[:, None] * 30
    st.body_angmom[:-1] = rng.normal(size=(m.n_bodies, 3)) * spin

    def momenta():
        mv = m.body_mass[:, None] * st.body_vel[:-1]
        x = st.body_pos[:-1]
        return mv.sum(axis=0), (np.cross(x, mv) + st.body_angmom[:-1]).sum(axis=0), \
            np.abs(mv).sum(), np.abs(np.cross(x, mv)).sum() + np.abs(st.body_angmom[:-1]).sum()

    p0, j0, ps, js = momenta()
    advance(m, st, 300)
    p1, j1, _, _ = momenta()
    assert np.abs(p1 - p0).max() <= 1e-12 * ps
    assert np.abs(j1 - j0).max() <= 1e-12 * js


@pytest.mark.parametrize("law", ["", ", rupture: {strain: 1.0e-4}"])
def test_one_and_two_threads_are_bitwise_equal(tmp_path, law):
    """Elastic, and with rupture (the damaged path: χ_c from the springs'
    states and damage, springs breaking during the run)."""
    case = tmp_path / "c.yaml"
    case.write_text(DYNAMIC.replace("end_time: 2.0e-4", "end_time: 5.0e-5")
                    .replace("size: 0.05", "size: 0.02")
                    .replace("poisson: 0.4}", "poisson: 0.4" + law + "}"), encoding="utf-8")
    code = textwrap.dedent(f"""
        import numpy as np, sys
        from rbsm_dyn.case import load_case
        from rbsm_dyn.model import apply_initial, build_model, new_state
        from rbsm_dyn.solvers.explicit import advance, choose_dt, start_half_step
        case = load_case({str(case)!r})
        m = build_model(case)
        assert m.poisson_on and len(m.poisson.slot_cell) > 4096      # the parallel path
        assert m.inelastic == {bool(law)}
        st = new_state(m)
        st.dt, _ = choose_dt(case, m)
        apply_initial(case, m, st)
        start_half_step(m, st)
        advance(m, st, 30)
        if m.inelastic:
            assert np.count_nonzero(st.spring_state >= 2) > 0         # springs broke
        np.save(sys.argv[1], np.concatenate([st.body_pos.ravel(), st.body_angmom.ravel()]))
        """)
    out = {}
    for nt in (1, 2):
        env = dict(os.environ, NUMBA_NUM_THREADS=str(nt))
        path = tmp_path / f"r{nt}.npy"
        subprocess.run([sys.executable, "-c", code, str(path)], env=env, check=True)
        out[nt] = np.load(path)
    assert np.array_equal(out[1], out[2])


STATIC = textwrap.dedent("""\
    name: poisson-static
    domain: {box: [[0, 0, 0], [0.4, 0.1, 0.1]]}
    mesh: {kind: voronoi, size: 0.04, seed: 2}
    materials:
      m: {density: 8000, young: 2.0e11, poisson: 0.35}
    groups: {tip: {box: [[0.36, 0, 0], [0.4, 0.1, 0.1]]}}
    boundary: [{face: xmin, fix: all}]
    loads: [{group: tip, force: [1.0e3, 0, -2.0e2]}]
    solver: {mode: static, predictor: false, tolerance: 1.0e-7}
    output: {fields: [position]}
    """)


def test_relaxation_finds_the_linear_solution(run_case):
    """Dynamic relaxation (its fictitious masses include the auxiliary
    stiffness, or it would diverge) stops at the equilibrium of the
    kernel's forces, which must be the linear solution K U = F of the
    assembled stiffness with K_aux.  The load is small (tip deflection
    2e-6 m) so that the geometric nonlinearity of the kernel (about 3e-3
    of U at 100 times this load, with or without the correction) stays
    below the tolerance."""
    from rbsm_dyn.stiffness import solve_linear
    h = run_case(STATIC)
    m = build_model(load_case_text(STATIC, "t.yaml"))
    assert m.poisson_on
    U, _ = solve_linear(m)
    u = h.position[-1] - m.body_pos0[:-1]
    assert np.abs(u - U[:, :3]).max() <= 2e-4 * np.abs(U[:, :3]).max()


CRACK = textwrap.dedent("""\
    name: poisson-crack
    domain: {box: [[0, 0, 0], [0.03, 0.003, 0.03]]}
    mesh: {kind: voronoi, size: 0.0015, seed: 1}
    materials:
      glass: {density: 2500, young: 60.0e9, poisson: 0.35, rupture: {strain: 1.0e-3},
              friction: 0.5}
    groups:
      top: {box: [[-1, -1, 0.0285], [1, 1, 1]]}
      bottom: {box: [[-1, -1, -1], [1, 1, 0.0015]]}
    cuts:
      - {point: [0, 0, 0.015], normal: [0, 0, 1], within: [[-1, -1, 0.013], [0.006, 1, 0.017]]}
    loads:
      - {group: top, force: [0, 0, 1350.0]}
      - {group: bottom, force: [0, 0, -1350.0]}
    solver: {mode: dynamic, end_time: 1.5e-5}
    output: {interval: 1.0e-6}
    """)


def test_fracture_with_the_correction_creates_no_energy(run_case):
    """A notched plate breaks under a tensile step with the correction on
    (the damaged path of the pass: χ_c = 0 next to broken faces).  Energy
    released by the auxiliary term when a face breaks is dissipated, never
    created: kinetic + strain + plastic + fracture ≤ external work, up to
    the leapfrog's O(dt²) error (VERIFICATION 'General', energy balance)."""
    h = run_case(CRACK)
    ob = h.observables
    assert ob["n_broken"][-1] > ob["n_broken"][0]              # the crack grew
    W = ob["external_work"]
    held = ob["kinetic"] + ob["strain"] + ob["plastic"] + ob["fracture"]
    assert W[-1] > 0
    assert np.all(held - W <= 2e-3 * W.max())


BRITTLE_BAR = """
name: poisson-brittle-bar
domain: {box: [[0, 0, 0], [0.02, 0.01, 0.002]]}
mesh: {kind: voronoi, size: 0.002, seed: 1}
materials:
  steel: {density: 8000, young: 190.0e9, poisson: 0.3,
          rupture: {fracture_energy: 2.213e4, tensile_strength: 2.0e9}}
groups:
  left: {box: [[-1, -1, -1], [0.002, 1, 1]]}
  right: {box: [[0.018, -1, -1], [1, 1, 1]]}
boundary:
  - {group: left, fix: all}
  - {group: right, velocity: [16.5, null, null], history: [[0, 0], [1.0e-6, 1], [1, 1]]}
solver: {mode: dynamic, end_time: 3.0e-5}
output: {interval: 1.0e-6}
"""


def test_damage_books_the_auxiliary_energy_it_releases(tmp_path):
    """A Voronoi bar at ν = 0.3 pulled apart at 16.5 m/s: the energy the
    auxiliary stress loses as χ_c falls is fracture energy, so kinetic +
    strain + fracture − work stays within 1 % of the work (DESIGN.md energy
    balance; unbooked it was −9 % of the work, a quarter of the fracture
    energy: λ = 1.5 μ at ν = 0.3, and the cells next to the crack lose
    their volumetric stress)."""
    from rbsm_dyn.__main__ import main
    import rbsm_dyn
    case = tmp_path / "bar.yaml"
    case.write_text(BRITTLE_BAR, encoding="utf-8")
    out = tmp_path / "bar.h5"
    assert main([str(case), "--out", str(out), "--quiet"]) == 0
    h = rbsm_dyn.open_history(out)
    ob = h.observables
    w = ob["external_work"]
    bal = ob["kinetic"] + ob["strain"] + ob["plastic"] + ob["fracture"] + ob["damping"] - w
    assert ob["n_broken"][-1] > 0
    assert np.abs(bal).max() <= 1e-2 * np.abs(w).max()
