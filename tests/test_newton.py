"""Static mode by Newton iterations with path following (issue 13;
solvers/newton.py): load and displacement control, and indirect
displacement control on a relative-displacement probe that follows a
softening branch through a snap-back."""
import numpy as np
import pytest

E, FT, GF = 3.0e10, 3.0e6, 30.0

BAR = f"""
name: snap
domain: {{box: [[0, 0, 0], [0.4, 0.1, 0.1]]}}
mesh: {{kind: blocks, divisions: [4, 1, 1]}}
materials:
  c: {{density: 2400, young: {E}, poisson: 0.0}}
  weak:
    density: 2400
    young: {E}
    poisson: 0.0
    rupture: {{law: tension, fracture_energy: {GF}, tensile_strength: {FT}, values: spring}}
groups:
  c0: {{box: [[0, 0, 0], [0.1, 0.1, 0.1]], material: weak}}
  c1: {{box: [[0.1, 0, 0], [0.2, 0.1, 0.1]]}}
  end: {{box: [[0.3, 0, 0], [0.4, 0.1, 0.1]]}}
boundary:
  - {{face: xmin, fix: all}}
  - {{group: all, fix: [y, z, rx, ry, rz]}}
  - {{group: end, displacement: [1.0e-4, null, null]}}
solver:
  mode: static
  method: newton
  tolerance: 1.0e-9
  control: {{probe: w, increment: 1.0e-6, end: 1.9e-5}}
output:
  probes:
    w: {{quantity: relative_displacement, groups: [c0, c1], component: x}}
    P: {{group: end, quantity: reaction, component: x, reduce: sum}}
    u: {{group: end, quantity: displacement, component: x, reduce: mean}}
"""


def test_softening_bar_snaps_back_under_crack_opening_control(run_case):
    """A bar of four blocks (0.1 m, A = 0.01 m²) held at xmin and pulled
    at its last block, the face at x = 0.1 softening linearly in tension
    (f_t = 3 MPa, G_f = 30 J/m²: opening at the peak δ0 = f_t h/E = 10 µm,
    at full break δu = 2 G_f/f_t = 20 µm; physics/laws/rupture.py).
    Controlled by that face's opening w, the load follows the analytic law
    P = (E A/h) w up to δ0, then P = A f_t (δu − w)/(δu − δ0), within 1 %
    of the peak load; the pulled end moves back after the peak (u = 0.25
    P/(E A) + w falls: a snap-back, which load or displacement control
    cannot follow)."""
    h = run_case(BAR)
    w = h.observables["w"]
    P = np.abs(h.observables["P"])
    u = h.observables["u"]
    A, h_ = 0.01, 0.1
    d0, du = FT * h_ / E, 2 * GF / FT
    ref = np.where(w <= d0, E * A / h_ * w, A * FT * (du - w) / (du - d0))
    assert np.max(np.abs(P - ref)) < 1e-2 * A * FT
    assert w[-1] == pytest.approx(1.9e-5, rel=1e-6)
    peak = int(np.argmax(P))
    assert np.all(np.diff(u[peak:]) < 0)                     # the snap-back
    assert u == pytest.approx(0.25 * P / (E * A) + w, rel=1e-6, abs=1e-12)


def test_stop_fraction_ends_the_run_on_the_softening_branch(run_case):
    """`stop_fraction: 0.45` on the snapping bar (loaded by a prescribed
    displacement, so λ is that displacement, not the load): the run ends at
    the first increment whose load (the reaction along the prescribed
    displacement) is below 0.45 of the peak A f_t = 30 kN: by the analytic
    law above P = 0.45 A f_t at w = 15.5 µm, so with 1 µm increments the
    last frame is w = 16 µm (P = 12 kN; 15 kN at 15 µm).  (It stopped on λ
    before, which falls to 0.61 of its peak only, and ran on to `end`.)"""
    h = run_case(BAR.replace("end: 1.9e-5}", "end: 1.9e-5, stop_fraction: 0.45}"))
    w = h.observables["w"]
    P = np.abs(h.observables["P"])
    assert w[-1] == pytest.approx(1.6e-5, rel=1e-6)
    assert P[-1] < 0.45 * P.max() <= P[-2]
    assert P.max() == pytest.approx(0.01 * FT, rel=1e-2)


CANTILEVER = """
name: cantilever
domain: {box: [[0, 0, 0], [1.0, 0.1, 0.05]]}
mesh: {kind: voronoi, size: 0.04, seed: 2}
materials:
  c: {density: 2400, young: 3.0e10, poisson: 0.2}
groups:
  tip: {box: [[0.95, 0, 0], [1.0, 0.1, 0.05]]}
boundary:
  - {face: xmin, fix: all}
loads:
  - {group: tip, force: [0, -5.0, 0]}
SOLVER
output:
  probes:
    d: {group: tip, quantity: displacement, component: y, reduce: mean}
    R: {group: all, quantity: reaction, component: y, reduce: sum}
"""


def test_elastic_cantilever_in_one_newton_step_equals_the_linear_solve(run_case):
    """VERIFICATION A2 on a Voronoi cantilever under a 5 N tip load (tip
    deflection 1e-5 m = 1e-5 L: the finite-rotation terms, measured
    2.6e-3 δ/L relative, stay below 1e-7, and the round-off of the gaps,
    1e-16 m against spring gaps of 1e-9 m, too; tolerance 1e-7): one Newton
    load step gives the linear solve's tip deflection to 1e-8 and reactions
    that balance the load (1e-8)."""
    lin = run_case(CANTILEVER.replace("SOLVER", "solver: {mode: linear}"))
    new = run_case(CANTILEVER.replace(
        "SOLVER", "solver: {mode: static, method: newton, load_steps: 1, tolerance: 1.0e-7}"))
    assert new.observables["d"][-1] == pytest.approx(lin.observables["d"][-1], rel=1e-8)
    assert new.observables["R"][-1] == pytest.approx(5.0, rel=1e-8)


E2, B, H = 1.0e9, 0.02, 0.02
I2 = B * H ** 3 / 12
LT = 0.995          # the tip cell's centroid: where the load acts


def strip(load):
    return f"""
name: strip
domain: {{box: [[0, 0, 0], [1.0, {B}, {H}]]}}
mesh: {{kind: blocks, divisions: [100, 1, 2]}}
materials:
  m: {{density: 1000, young: {E2}, poisson: 0.0}}
groups:
  tip: {{box: [[0.99, 0, 0], [1.0, {B}, {H}]]}}
boundary:
  - {{face: xmin, fix: all}}
loads:
  - {{group: tip, {load}}}
solver: {{mode: static, method: newton, load_steps: 20, tolerance: 1.0e-6}}
output:
  probes:
    w: {{group: tip, quantity: displacement, component: z, reduce: mean}}
    u: {{group: tip, quantity: displacement, component: x, reduce: mean}}
"""


def test_elastica_under_a_dead_tip_load(run_case):
    """Large rotations: a cantilever strip (100 × 1 × 2 blocks) under a
    dead tip load P with P L²/(EI) = 10 (L to the tip cell's centroid)
    bends to the elastica: tip deflection v/L = 0.81061, (L − x)/L =
    0.55500 (Bisshopp & Drucker 1945; Mattiasson 1981, table 1), each
    within 0.5 %, in 20 load increments (the geometric stiffness of
    solvers/assembly.py makes Newton converge)."""
    P = 10 * E2 * I2 / LT ** 2
    h = run_case(strip(f"force: [0, 0, {-P}]"))
    assert len(h.observables["w"]) == 21
    assert -h.observables["w"][-1] / LT == pytest.approx(0.81061, rel=5e-3)
    assert -h.observables["u"][-1] / LT == pytest.approx(0.55500, rel=5e-3)


def test_elastica_with_the_default_static_settings(run_case):
    """The same elastica written without solver.method (issue 30: dynamic
    relaxation, the old default, failed at load step 2 after 200 000
    iterations): Newton by default, v/L and (L − x)/L within 0.5 % of
    Bisshopp & Drucker's 0.81061 and 0.55500."""
    P = 10 * E2 * I2 / LT ** 2
    h = run_case(strip(f"force: [0, 0, {-P}]").replace("method: newton, ", ""))
    assert -h.observables["w"][-1] / LT == pytest.approx(0.81061, rel=5e-3)
    assert -h.observables["u"][-1] / LT == pytest.approx(0.55500, rel=5e-3)


def test_end_moment_rolls_a_cantilever_into_a_half_circle(run_case):
    """An end moment M = π EI/L bends the strip to a half circle of radius
    L/π (curvature M/EI): the tip comes back over the clamp, x = 0, at
    height 2L/π, each within 0.5 % of L, in 20 increments."""
    import math
    M = math.pi * E2 * I2 / LT
    h = run_case(strip(f"moment: [0, {-M}, 0]"))
    assert abs(LT + h.observables["u"][-1]) < 5e-3 * LT
    assert h.observables["w"][-1] == pytest.approx(2 * LT / math.pi, abs=5e-3 * LT)


def test_geometric_stiffness_is_the_jacobian_of_the_residual():
    """At a state with rotations of 0.3 rad, the secant + geometric
    stiffness of solvers/newton_system.py is the derivative of the spring
    wrenches (central differences, h = 1e-7) to 1e-6 of the largest
    entry, where the material stiffness alone is off by about 1e-2."""
    from rbsm_dyn.case import load_case_text
    from rbsm_dyn.model import build_model, new_state
    from rbsm_dyn.solvers import newton as N
    from rbsm_dyn.solvers.relax import apply_increment
    m = build_model(load_case_text(strip("force: [0, 0, -1.0]").replace(
        "divisions: [100, 1, 2]", "divisions: [10, 1, 2]").replace("0.99, 0, 0", "0.9, 0, 0")))
    nt = N.Newton(m)
    st = new_state(m)
    n = m.n_bodies
    rng = np.random.default_rng(3)
    U = np.zeros((n, 6))
    U[:, 3:] = rng.normal(size=(n, 3)) * 0.3
    U[:, :3] = rng.normal(size=(n, 3)) * 1e-3
    U[m.dof_kind != 0] = 0.0
    apply_increment(m, st, U)
    _, tri = nt.residual(st, 0.0)
    K = nt.stiffness(st, tri).toarray()
    assert not nt.symmetric
    free = np.nonzero(m.dof_kind.reshape(-1) == 0)[0]
    worst = 0.0
    for col in free[::7]:
        J = []
        for sgn in (1.0, -1.0):
            s2 = new_state(m)
            for key in ("body_pos", "body_quat", "body_rot", "body_dq"):
                getattr(s2, key)[...] = getattr(st, key)
            d = np.zeros(6 * n)
            d[col] = sgn * 1e-7
            apply_increment(m, s2, d.reshape(n, 6))
            J.append(nt.residual(s2, 0.0)[0])
        jac = -(J[0] - J[1]) / 2e-7
        worst = max(worst, np.abs(jac[free] - K[free, col]).max() / np.abs(jac).max())
    assert worst < 1e-6


@pytest.mark.parametrize("method", ["relaxation", "newton"])
def test_static_energy_balance_closes(run_case, method):
    """A static run books the work of its loads along the path (trapezoidal
    over the load steps): for the elastic cantilever under 1 kN (tip
    deflection 2e-3 L: a linear response to 1e-5) the external work equals
    the strain energy at every frame (1e-4), so `plot` no longer shows a 50 % balance error
    (issue 13)."""
    h = run_case(CANTILEVER.replace("force: [0, -5.0, 0]", "force: [0, -1000.0, 0]").replace(
        "SOLVER", f"solver: {{mode: static, method: {method}, load_steps: 4, "
                  "tolerance: 1.0e-6}"))
    ob = h.observables
    assert ob["external_work"][-1] > 0
    assert np.abs(ob["external_work"] - ob["strain"]).max() <= 1e-4 * ob["strain"][-1]
    eb = h.energy_balance()
    assert np.abs(eb["error"]).max() <= 1e-4 * ob["strain"][-1]


def test_elastica_energy_balance_closes_to_the_step_error(run_case):
    """Large rotations under a dead load: the trapezoidal path work over 20
    increments equals the strain energy to 1 % (the rule's O(Δλ²) error on
    the stiffening path)."""
    P = 10 * E2 * I2 / LT ** 2
    h = run_case(strip(f"force: [0, 0, {-P}]"))
    ob = h.observables
    assert ob["external_work"][-1] == pytest.approx(ob["strain"][-1], rel=1e-2)


LOWRANK_BEAM = """
name: lowrank
domain: {box: [[0, 0, 0], [0.2, 0.05, 0.04]]}
mesh: {kind: voronoi, size: 0.015, seed: 4}
materials:
  c: {density: 2400, young: 3.0e10, poisson: 0.2}
groups:
  end: {box: [[0.18, 0, 0], [0.2, 0.05, 0.04]]}
boundary:
  - {face: xmin, fix: all}
  - {group: end, displacement: [null, -1.0e-4, null]}
solver: {mode: static, method: newton}
"""


@pytest.mark.parametrize("symmetric", [True, False])
def test_low_rank_update_solves_the_changed_matrix(symmetric):
    """The Newton iteration's linear solver factorises the matrix K0 of one
    state and takes the springs changed since by Woodbury's identity
    (solvers/newton_linear.py _LowRank).  With 40 springs then 40 more changed
    (their local stiffness scaled by 10⁻⁶ to 1, an unsymmetric coupling
    added to some: a damaging spring's tangent), its solves equal the
    direct solve of the assembled K0 + ΔK to 1e-8 (relative), and so does
    the pair indirect control solves, K⁻¹ r and K⁻¹ (F − K_fp U_p) (the
    reference load less the prescribed displacement's forces), from a symmetric
    local stiffness and from an unsymmetric one (K0 is symmetric either way:
    an unsymmetric spring enters it by its diagonal, the rest by the
    update)."""
    from rbsm_dyn.case import load_case_text
    from rbsm_dyn.model import build_model, new_state
    from rbsm_dyn.solvers import newton as N
    from rbsm_dyn.solvers import newton_linear as NL
    m = build_model(load_case_text(LOWRANK_BEAM))
    nt = N.Newton(m)
    st = new_state(m)
    _, tri = nt.residual(st, 0.0)
    k, frames, turned = nt.local(st, tri)
    assert not turned
    rng = np.random.default_rng(5)
    if not symmetric:
        some = rng.choice(m.n_springs, 30, replace=False)
        k[some, 0, 1] = 0.2 * k[some, 0, 0]
    lr = NL._LowRank(nt, st, k, frames)
    f = nt.free
    B = rng.normal(size=(int(f.sum()), 2))
    k2 = k.copy()
    for _ in range(2):
        s = rng.choice(m.n_springs, 40, replace=False)
        k2[s] *= 10.0 ** rng.uniform(-6, 0, size=(40, 3, 1))
        k2[s[:10], 0, 2] = 0.3 * k2[s[:10], 0, 0]
        # (limit=False: 40 springs at once can take more columns of K0⁻¹
        # than GROW_MAX_COLUMNS, where Newton.linear would refactorise)
        assert lr.update(k2, limit=False)
        K = nt.pattern.matrix(m, st.body_quat, frames, k2).toarray()
        X = np.linalg.solve(K[f][:, f], B)
        assert np.abs(lr.solve(B) - X).max() < 1e-8 * np.abs(X).max()
        # the pair of indirect control: K⁻¹ r and K⁻¹ (F − K_fp U_p)
        g = nt.F[f] - K[f][:, nt.disp] @ nt.Up[nt.disp]
        Xg = np.linalg.solve(K[f][:, f], np.column_stack([B[:, 0], g]))
        for x, ref in zip(lr.solve_pair(B[:, 0]).T, Xg.T):
            assert np.abs(x - ref).max() < 1e-8 * np.abs(ref).max()
    assert 0 < len(lr.bodies) < m.n_bodies


def test_low_rank_renews_past_its_size(monkeypatch):
    """Past LOWRANK_MAX DOFs of changed bodies the update refuses and
    Newton.linear refactorises at the present stiffness (a renewal: the
    changed set starts empty again, and the solve is still exact)."""
    from rbsm_dyn.case import load_case_text
    from rbsm_dyn.model import build_model, new_state
    from rbsm_dyn.solvers import newton as N
    from rbsm_dyn.solvers import newton_linear as NL
    m = build_model(load_case_text(LOWRANK_BEAM))
    nt = N.Newton(m)
    st = new_state(m)
    _, tri = nt.residual(st, 0.0)
    k, frames, _ = nt.local(st, tri)
    lr = NL._LowRank(nt, st, k, frames)
    monkeypatch.setattr(NL, "LOWRANK_MAX", 12)              # two bodies
    k2 = k.copy()
    k2[np.random.default_rng(1).choice(m.n_springs, 20, replace=False)] *= 0.5
    assert not lr.update(k2)
    renewed = NL._LowRank(nt, st, k2, frames)
    assert renewed.update(k2) and renewed.A is None and len(renewed.bodies) == 0
    f = nt.free
    B = np.ones((int(f.sum()), 1))
    K = nt.pattern.matrix(m, st.body_quat, frames, k2).toarray()[f][:, f]
    X = np.linalg.solve(K, B)
    assert np.abs(renewed.solve(B) - X).max() < 1e-8 * np.abs(X).max()


@pytest.mark.parametrize("slip", [False, True])
def test_friction_tangent_is_the_jacobian_of_the_contact_traction(slip):
    """A closed broken face (δn < 0) with Coulomb friction μ = 0.5: the
    local tangent Newton takes (solvers/newton_tangent.py _local_tangents) is the
    derivative of the traction of physics/laws/contact.py (central
    differences, h = 1e-6 of the gap, to 1e-6 of kn): the elastic springs
    while it sticks, the consistent tangent of the radial return while it
    slips (issue 30: Newton through contact)."""
    from rbsm_dyn.physics.laws import BROKEN, N_PARAMS, P_MU
    from rbsm_dyn.physics.laws.contact import contact_traction
    from rbsm_dyn.solvers.newton_tangent import _local_tangents
    kn, ks, kt, mu = 3.0e9, 1.2e9, 0.9e9, 0.5
    gap = np.array([[-1.0e-6, 3.0e-6 if slip else 0.1e-6, -1.5e-6 if slip else 0.05e-6]])
    slip0 = np.array([[0.0, 0.1e-6, 0.05e-6]])
    law = np.zeros((1, N_PARAMS))
    law[0, P_MU] = mu
    out = np.zeros((1, 3, 3))
    _local_tangents((np.array([[kn, ks, kt]]), np.ones(1), np.full(1, 0.01),
                     np.zeros(1, np.int64), law),
                    (np.full(1, BROKEN, np.int8), np.zeros(1)),
                    (np.zeros(1), np.zeros(1), slip0), gap, gap, 1e-6, 0.0, True, out)

    def traction(g):
        sn, ts, tt, *_ = contact_traction(mu, kn, ks, kt, g[0], g[1], g[2],
                                          slip0[0, 1], slip0[0, 2])
        return np.array([sn, ts, tt])
    t0 = traction(gap[0])
    assert (np.hypot(t0[1], t0[2]) >= -mu * t0[0] * (1 - 1e-12)) == slip
    h = 1e-12
    fd = np.zeros((3, 3))
    for j in range(3):
        e = np.zeros(3)
        e[j] = h
        fd[:, j] = (traction(gap[0] + e) - traction(gap[0] - e)) / (2 * h)
    assert np.allclose(out[0], fd, atol=1e-6 * kn, rtol=0)
