"""Assembled small-strain stiffness (rbsm_dyn/stiffness.py, Kawai 1978 eq. 8b).

Facts checked: K is symmetric; a free model has exactly the six rigid-body
modes as null space; K is the tangent of the Numba spring kernel
(K u = −kernel force for a tiny displacement); one spring between two
bodies matches the hand formula; the mass matrix holds the cells' mass
and world inertia; the linear solve reproduces δ = PL/(EA) (VERIFICATION A1
form) under force and displacement control, and refuses a free model."""
import dataclasses

import numpy as np
import pytest

from rbsm_dyn.case import load_case_text
from rbsm_dyn.model import build_model, new_state
from rbsm_dyn.physics.integrate import refresh_all_rotations
from rbsm_dyn.physics.rotation import quat_matrix_np
from rbsm_dyn.physics.springs import elastic_spring_pass
from rbsm_dyn.solvers.passes import body_state, model_arrays
from rbsm_dyn.stiffness import (mass_matrix, rigid_modes, solve_linear, spring_forces,
                                stiffness_matrix)

E = 200.0e9
RHO = 8000.0


def make_model(mesh, boundary="", poisson=0.0, stiffness="calibrated", box="[1.0, 1.0, 1.0]",
               extra=""):
    text = f"""
name: t
domain: {{box: [[0, 0, 0], {box}]}}
mesh: {mesh}
materials:
  m: {{density: {RHO}, young: {E}, poisson: {poisson}, stiffness: {stiffness}}}
{boundary}
{extra}
solver: {{mode: static}}
"""
    return build_model(load_case_text(text, "t.yaml"))


VORONOI = "{kind: voronoi, size: 0.34, seed: 3}"        # about 25 cells
BLOCKS = "{kind: blocks, divisions: [3, 2, 2]}"
SUPPORTS = "boundary: [{face: xmin, fix: all}, {face: zmax, fix: [y]}]"


@pytest.fixture(scope="module", params=["voronoi", "blocks"])
def free_model(request):
    mesh = VORONOI if request.param == "voronoi" else BLOCKS
    # ν = 0.1 (α < 1, E0 ≠ E): k_n ≠ k_s, so the shear terms are exercised
    return make_model(mesh, poisson=0.1)


@pytest.fixture(scope="module", params=["voronoi", "blocks"])
def supported_model(request):
    mesh = VORONOI if request.param == "voronoi" else BLOCKS
    return make_model(mesh, SUPPORTS, poisson=0.1)


def test_stiffness_is_symmetric(supported_model):
    K = stiffness_matrix(supported_model)
    n = 6 * supported_model.n_bodies
    assert K.shape == (n, n)
    assert abs(K - K.T).max() <= 1e-14 * abs(K).max()


def test_free_model_null_space_is_the_six_rigid_modes(free_model):
    K = stiffness_matrix(free_model)
    phi = rigid_modes(free_model)
    # rigid motion strains no spring: K φ = 0 to round-off
    scale = abs(K).sum(axis=1).max()
    assert np.linalg.norm(K @ phi, axis=0).max() <= 1e-10 * scale * np.linalg.norm(phi, axis=0).min()
    # and nothing else: the 7th smallest eigenvalue is well away from zero
    lam = np.linalg.eigvalsh(K.toarray())
    assert np.all(np.abs(lam[:6]) <= 1e-12 * lam[-1])
    assert lam[6] >= 1e-6 * lam[-1]


def kernel_body_forces(model, U):
    """Generalised spring forces (N, 6) of the Numba kernel at the
    displacement U (N, 6): positions x0 + u, rotations exp(θ) R0."""
    n = model.n_bodies
    pos = model.body_pos0.copy()
    pos[:n] += U[:, :3]
    quat = model.body_quat0.copy()
    th = U[:, 3:]
    ang = np.linalg.norm(th, axis=1)
    axis = th / np.where(ang > 0, ang, 1.0)[:, None]
    qi = np.column_stack([np.cos(ang / 2), np.sin(ang / 2)[:, None] * axis])
    q0 = model.body_quat0[:n]
    # Hamilton product qi ⊗ q0 (world-frame increment on the left)
    w1, x1, y1, z1 = qi.T
    w2, x2, y2, z2 = q0.T
    quat[:n] = np.column_stack([w1 * w2 - x1 * x2 - y1 * y2 - z1 * z2,
                                w1 * x2 + x1 * w2 + y1 * z2 - z1 * y2,
                                w1 * y2 - x1 * z2 + y1 * w2 + z1 * x2,
                                w1 * z2 + x1 * y2 - y1 * x2 + z1 * w2])
    rot = np.zeros((n + 1, 3, 3))
    dq = np.zeros((n + 1, 4))
    refresh_all_rotations(n + 1, quat, model.body_quat0, rot, dq)
    S = model.n_springs
    f = np.zeros((S, 3))
    out = np.zeros((n + 1, 6))
    st = new_state(model)
    st.body_pos, st.body_rot, st.body_dq, st.body_wrench, st.spring_force = pos, rot, dq, out, f
    elastic_spring_pass(model_arrays(model)[1], body_state(st), True, None)
    return out[:n], f


def test_stiffness_is_the_tangent_of_the_spring_kernel(supported_model):
    model = supported_model
    n = model.n_bodies
    rng = np.random.default_rng(5)
    eps = 1e-7                                   # m and rad, on a 1 m specimen
    U = eps * rng.standard_normal((n, 6))
    K = stiffness_matrix(model)
    Ku = (K @ U.ravel()).reshape(n, 6)
    # central difference: the second-order terms cancel
    (gp, fp), (gm, fm) = kernel_body_forces(model, U), kernel_body_forces(model, -U)
    fd = 0.5 * (gp - gm)
    assert np.linalg.norm(Ku + fd) <= 1e-6 * np.linalg.norm(Ku)
    # spring_forces is the same linearisation, per spring (force on body a)
    np.testing.assert_allclose(spring_forces(model, U), 0.5 * (fp - fm),
                               rtol=0, atol=1e-6 * np.abs(fp).max())


def test_one_spring_between_two_blocks_matches_the_hand_formula():
    # two unit cubes along x, Kawai stiffness at ν = 0: E' = E, G = E/2
    model = make_model("{kind: blocks, divisions: [2, 1, 1], spring_points: centroid}",
                       stiffness="kawai", box="[2.0, 1.0, 1.0]")
    s = int(np.argmax(model.spring_point[:, 1]))            # any one internal spring point
    assert model.spring_bodies[s].tolist() == [0, 1]
    f = model.spring_slot[s]
    one = dataclasses.replace(model, spring_slot=np.zeros(1, dtype=np.int32), **{
        k: getattr(model, k)[s:s + 1] for k in
        ("spring_bodies", "spring_arm_a", "spring_arm_b", "spring_area")}, **{
        k: getattr(model, k)[f:f + 1] for k in
        ("face_frame0", "face_k", "face_h", "face_law", "face_ref")})
    A = model.spring_area[s]
    h = 1.0                                                  # centroid distance
    kn, ks = E * A / h, 0.5 * E * A / h                      # Kawai 1978 eq. 13 × area
    np.testing.assert_allclose(one.spring_k[0], [kn, ks, ks], rtol=1e-12)
    p = model.spring_point[s]
    ra = p - np.array([0.5, 0.5, 0.5])
    rb = p - np.array([1.5, 0.5, 0.5])
    # strain energy ½ dᵀ C d, C = diag(kn, ks, ks) (normal along x), with
    # d = (u_b + θ_b × r_b) − (u_a + θ_a × r_a):  K_ij = (∂d/∂q_i)ᵀ C (∂d/∂q_j)
    cols = []
    for sign, r in ((-1.0, ra), (1.0, rb)):
        for j in range(3):
            cols.append(sign * np.eye(3)[j])
        for j in range(3):
            cols.append(sign * np.cross(np.eye(3)[j], r))
    D = np.array(cols).T
    K_hand = D.T @ np.diag([kn, ks, ks]) @ D
    K = stiffness_matrix(one).toarray()
    np.testing.assert_allclose(K, K_hand, rtol=0, atol=1e-12 * kn)
    # a few entries written out
    assert K[0, 0] == pytest.approx(kn) and K[0, 6] == pytest.approx(-kn)
    assert K[1, 1] == pytest.approx(ks)
    assert K[11, 11] == pytest.approx(kn * rb[1] ** 2 + ks * rb[0] ** 2)   # θz_b
    assert K[3, 3] == pytest.approx(ks * (ra[1] ** 2 + ra[2] ** 2))        # θx_a
    assert K[0, 10] == pytest.approx(-kn * rb[2])                          # ux_a, θy_b


def test_mass_matrix_holds_mass_and_world_inertia(free_model):
    model = free_model
    n = model.n_bodies
    M = mass_matrix(model).toarray().reshape(n, 6, n, 6)
    blocks = M[np.arange(n), :, np.arange(n), :]             # (n, 6, 6)
    off = M.copy()
    off[np.arange(n), :, np.arange(n), :] = 0
    assert not off.any()
    vol = model.mesh.cell_volume
    np.testing.assert_allclose(blocks[:, [0, 1, 2], [0, 1, 2]], RHO * vol[:, None] * [1, 1, 1],
                               rtol=1e-13)
    assert not blocks[:, :3, 3:].any()
    # rotational block: ρ ∫(|r|² 1 − r rᵀ) dV of the mesh, in world axes
    np.testing.assert_allclose(blocks[:, 3:, 3:], RHO * model.mesh.cell_inertia,
                               rtol=1e-10, atol=1e-12 * np.abs(RHO * model.mesh.cell_inertia).max())
    R = quat_matrix_np(model.body_quat0[:n])
    assert np.allclose(np.einsum("nij,nik->njk", R, R), np.eye(3))


BAR = dict(mesh="{kind: blocks, divisions: [10, 1, 1]}", box="[1.0, 0.1, 0.1]",
           boundary="boundary: [{face: xmin, fix: all}]")


def test_linear_solve_axial_bar_force_and_displacement_control():
    # Axial bar on a support at xmin (h = half a cell): the chain of springs
    # to the last cell's centroid x_c = 0.95 has compliance x_c/(E A), so
    # δ = P x_c/(E A) (VERIFICATION A1 form, ν = 0, exact for the lattice).
    P = 1.0e5
    area = 0.01
    model = make_model(**BAR, extra="groups: {tip: {box: [[0.9, -1, -1], [2, 1, 1]]}}\n"
                                    "loads: [{group: tip, force: [100000.0, 0, 0]}]")
    U, reac = solve_linear(model)
    tip = model.groups["tip"]
    assert len(tip) == 1
    delta = P * 0.95 / (E * area)
    assert U[tip[0], 0] == pytest.approx(delta, rel=1e-10)
    assert np.abs(U[:, 1:]).max() <= 1e-12 * delta
    assert not reac.any()                                     # no constrained DOF
    # the support springs hold the bar back with −P in total (force on body a)
    f = spring_forces(model, U)
    assert f[model.is_support, 0].sum() == pytest.approx(-P, rel=1e-10)
    # displacement control: prescribe δ at the tip, the reaction there is P
    model = make_model(**BAR, extra="groups: {tip: {box: [[0.9, -1, -1], [2, 1, 1]]}}")
    kind = model.dof_kind.copy()
    value = model.dof_value.copy()
    kind[tip, 0] = 3
    value[tip, 0] = delta
    U2, reac2 = solve_linear(model, kind=kind, value=value)
    assert reac2[tip[0], 0] == pytest.approx(P, rel=1e-10)
    np.testing.assert_allclose(U2[:, 0], U[:, 0], rtol=1e-10)


def test_linear_solve_refuses_unrestrained_and_velocity_dofs():
    model = make_model(BLOCKS)
    with pytest.raises(ValueError, match="rigid-body motion"):
        solve_linear(model, np.zeros((model.n_bodies, 6)))
    # x held on one face leaves y, z and rotation about x free
    model = make_model(BLOCKS, "boundary: [{face: xmin, fix: [x]}]")
    with pytest.raises(ValueError, match="rigid-body motion"):
        solve_linear(model, np.zeros((model.n_bodies, 6)))
    kind = np.zeros((model.n_bodies, 6), np.int8)
    kind[0, 1] = 2
    with pytest.raises(ValueError, match="velocity"):
        solve_linear(model, kind=kind)
