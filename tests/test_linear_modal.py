"""Kawai's stiffness method (solver.mode: linear and modal) against beam and
bar theory, against dynamic relaxation, and the explicit stable step
against the true highest frequency.  ν = 0 throughout, so the lattice
reproduces uniform strain exactly (VERIFICATION, General).

As in test_statics.py the load of a group acts at its cells' centroids, so
a static reference beam ends at the loaded layer's mean centroid x_c.
"""
import numpy as np
import pytest

from rbsm_dyn.case import CaseError, load_case_text
from rbsm_dyn.model import build_model
from rbsm_dyn.solvers import linear, modal
from rbsm_dyn.stiffness import solve_linear

from test_statics import RHO, E, beam_case, cantilever_reference, tip_centroid_x


def as_mode(text, mode):
    """The static beam case text in another solver mode."""
    import re
    return re.sub(r"solver: \{mode: static[^}]*\}", f"solver: {{{mode}}}", text)


def model_of(text):
    import textwrap
    return build_model(load_case_text(textwrap.dedent(text)))


# ------------------------------------------------------------ linear statics

def tangent_of_relaxation(run_case, static_text, P):
    """First-order part of the dynamic-relaxation displacement field at
    load P, by Richardson extrapolation over ±P and ±2P.

    Dynamic relaxation is geometrically nonlinear (finite rotations): at
    P = 10 kN the A2 beam's ends shorten by 2e-6 m (∫ w′²/2, 1e-3 of the
    deflection, even in P) and the deflection carries a θ² term (3e-6,
    odd), both of which the linear solve rightly lacks.  With
    o(P) = (u(P) − u(−P))/2 = aP + cP³ + O(P⁵), the linear part is
    aP = (8 o(P) − o(2P))/6, to O(θ⁴) ~ 1e-11 here.  The relaxation cannot
    be run at a tiny load instead: its residual floor (round-off of
    positions ~1 m) is ~1e-9 of a 10 kN load."""
    def u(load):
        h = run_case(static_text.replace("FORCE", repr(load)))
        return h.position[-1] - h.position[0]
    odd1 = 0.5 * (u(P) - u(-P))
    odd2 = 0.5 * (u(2 * P) - u(-2 * P))
    return (8 * odd1 - odd2) / 6, odd1


def test_linear_equals_relaxation_A2(run_case):
    """VERIFICATION A2 geometry (20 × 1 × 2 blocks): the direct solve of
    K U = F and dynamic relaxation (residual ratio 1e-9) give the same
    displacement field to 1e-6 relative (first-order part of the relaxation,
    tangent_of_relaxation)."""
    static = beam_case(20, 2, force="[0, 0, FORCE]", tol=1e-9)
    u_dr, odd = tangent_of_relaxation(run_case, static, 1.0e4)
    h_lin = run_case(as_mode(static.replace("FORCE", "1.0e4"), "mode: linear"))
    u_lin = h_lin.position[-1] - h_lin.position[0]
    scale = np.abs(u_lin).max()
    assert np.abs(u_lin - u_dr).max() <= 1e-6 * scale
    # without the extrapolation the θ² term shows (≈ 4e-6 of the deflection)
    assert np.abs(u_lin - odd).max() > 1e-6 * scale


def test_linear_equals_relaxation_voronoi(run_case):
    """A Voronoi block cantilever (calibrated springs, ν = 0, ~60 cells):
    linear solve and dynamic relaxation (residual ratio 1e-9) agree to 1e-6
    relative (first-order part of the relaxation)."""
    mesh = "{kind: voronoi, size: 0.035, seed: 5}"
    static = beam_case(8, 2, L=0.4, force="[0, 0, FORCE]", mesh=mesh, tol=1e-9)
    u_dr, _ = tangent_of_relaxation(run_case, static, 1.0e4)
    h_lin = run_case(as_mode(static.replace("FORCE", "1.0e4"), "mode: linear"))
    assert 40 <= h_lin.position.shape[1] <= 200
    u_lin = h_lin.position[-1] - h_lin.position[0]
    assert np.abs(u_lin - u_dr).max() <= 1e-6 * np.abs(u_lin).max()


def test_A2_cantilever_linear(run_case):
    """VERIFICATION A2 by the linear solve: δ = Px³/(3EI) + Px/(κGA) and tip
    rotation Px²/(2EI) at x = x_c, 40 × 1 × 6 blocks (≥ 6 through the
    depth, ≥ 20 along), clamp as a support on the face (tol 2 %).  The
    reaction probe carries the load; the external work along the
    proportional path, ½ (F + R)ᵀU, equals the strain energy ½ UᵀKU
    (Clapeyron's theorem; 1e-9)."""
    P = 1.0e4
    h = run_case(as_mode(beam_case(40, 6, force=f"[0, 0, {-P}]"), "mode: linear"))
    assert h.frames == 2 and h.status == "completed"
    d, rot = cantilever_reference(P, tip_centroid_x(h))
    assert -h.observables["tip_z"][-1] == pytest.approx(d, rel=2e-2)
    assert h.observables["tip_ry"][-1] == pytest.approx(rot, rel=2e-2)
    assert h.observables["reaction_z"][-1] == pytest.approx(P, rel=1e-9)
    assert h.observables["external_work"][-1] == pytest.approx(h.observables["strain"][-1],
                                                               rel=1e-9)
    assert h.observables["residual"][-1] < 1e-9


def test_A3_simply_supported_linear(run_case):
    """VERIFICATION A3 by the linear solve: δ = PL³/(48EI) + PL/(4κGA),
    L = 2, b = h = 0.1, P = 10 kN -> 1.006e-3 m (tol 2 %).  Supports and
    constraints as in test_statics.py."""
    P = 1.0e4
    text = f"""
    name: a3
    domain: {{box: [[0, 0, 0], [2.0, 0.1, 0.1]]}}
    mesh: {{kind: blocks, divisions: [41, 1, 6]}}
    materials:
      steel: {{density: {RHO}, young: {E}, poisson: 0.0}}
    groups:
      mid: {{box: [[0.99, -1, -1], [1.01, 1, 1]]}}
    boundary:
      - {{face: xmin, fix: [z]}}
      - {{face: xmax, fix: [z]}}
      - {{group: mid, fix: [x]}}
      - {{group: all, fix: [y]}}
    loads: [{{group: mid, force: [0, 0, {-P}]}}]
    solver: {{mode: linear}}
    output:
      probes:
        mid_z: {{group: mid, quantity: displacement, component: z, reduce: mean}}
        support_z: {{group: all, quantity: reaction, component: z, reduce: sum}}
    """
    h = run_case(text)
    I = 0.1 ** 4 / 12
    ref = P * 2.0 ** 3 / (48 * E * I) + P * 2.0 / (4 * 5 / 6 * (E / 2) * 0.01)
    assert ref == pytest.approx(1.006e-3, rel=1e-3)      # VERIFICATION A3
    assert -h.observables["mid_z"][-1] == pytest.approx(ref, rel=2e-2)
    assert h.observables["support_z"][-1] == pytest.approx(P, rel=1e-9)


def test_conjugate_gradients_equal_direct_solve():
    """CG with the 6 × 6 block-Jacobi preconditioner reaches the direct
    solution (Voronoi cantilever, relative residual 1e-12)."""
    m = model_of(beam_case(8, 2, L=0.4, force="[0, 0, -1.0e4]",
                           mesh="{kind: voronoi, size: 0.04, seed: 2}"))
    d = linear.solve(m, method="direct")
    c = linear.solve(m, method="cg", rtol=1e-12)
    assert c.iterations > 0
    assert np.abs(c.U - d.U).max() <= 1e-8 * np.abs(d.U).max()
    U, R = solve_linear(m)                       # stiffness.py's spsolve
    assert np.abs(U - d.U).max() <= 1e-10 * np.abs(d.U).max()


def test_prescribed_displacement_and_rotation_output():
    """A prescribed end displacement (full amplitude) is met exactly, the
    constraint force does the work 2 × strain energy, and the written
    orientation is the exact rotation by θ (rotation_quat round trip)."""
    text = beam_case(10, 2, force="[0, 0, 0]").replace(
        "boundary: [{face: xmin, fix: all}]",
        "boundary: [{face: xmin, fix: all}, {group: tip, displacement: [null, null, -1.0e-3]}]")
    m = model_of(as_mode(text, "mode: linear"))
    sol = linear.solve(m)
    tip = m.groups["tip"]
    assert np.allclose(sol.U[tip, 2], -1e-3, rtol=0, atol=1e-15)
    Uf = sol.U.reshape(-1)
    strain = 0.5 * Uf @ (sol.K @ Uf)
    work = (sol.load.reshape(-1) + sol.reaction.reshape(-1)) @ Uf
    assert work == pytest.approx(2 * strain, rel=1e-9)
    st = linear.displaced_state(m, sol.U)
    from rbsm_dyn.solvers.output import rotation_vectors
    assert np.allclose(rotation_vectors(m, st.body_quat), sol.U[:, 3:], rtol=0, atol=1e-15)


# ------------------------------------------------------------------- modes

def test_cantilever_first_bending_frequency():
    """Cantilever L = 1, b = h = 0.1 (ν = 0), clamp as a support on the
    face: f1 = 1.87510²/(2πL²)·√(EI/(ρA)) = 80.8 Hz (Euler–Bernoulli;
    Timoshenko effects lower it by < 1 % at L/h = 10), tol 3 %.  Modes 1
    and 2 are bending in z and y, equal by symmetry of the section."""
    m = model_of(as_mode(beam_case(40, 4, force="[0, 0, -1]"), "mode: modal, modes: 2"))
    res = modal.natural_modes(m, 2)
    I, A = 0.1 ** 4 / 12, 0.01
    f1 = 1.87510 ** 2 / (2 * np.pi) * np.sqrt(E * I / (RHO * A))
    assert f1 == pytest.approx(80.8, abs=0.05)
    assert res.frequency[0] == pytest.approx(f1, rel=3e-2)
    assert res.frequency[1] == pytest.approx(f1, rel=3e-2)
    assert len(res.rigid_omega) == 0
    # shape: tip moves most, clamp least; the first mode is a bending mode
    s = res.shape[0]
    x = m.body_pos0[:-1, 0]
    bend = np.abs(s[:, :3]).sum(axis=0).argmax()
    assert bend in (1, 2)
    assert np.abs(s[x > 0.95, bend]).mean() > 20 * np.abs(s[x < 0.05, bend]).mean()


def test_axial_fixed_free_bar_D3():
    """VERIFICATION D3: axial fixed–free bar, f = c0/(4L) = 1250 Hz for
    L = 1, c0 = √(E/ρ) = 5000 m/s (tol 1 %).  The axial mode is found
    among the bar's modes by its shape (translation along x dominates); 40
    cells along, the clamp a support spring of h = half a cell."""
    text = beam_case(40, 2, force="[0, 0, -1]")
    m = model_of(as_mode(text, "mode: modal, modes: 10"))
    res = modal.natural_modes(m, 10)
    share = np.array([np.sum(s[:, 0] ** 2) / np.sum(s[:, :3] ** 2) for s in res.shape])
    k = int(np.argmax(share))
    assert share[k] > 0.9
    c0 = np.sqrt(E / RHO)
    assert c0 / 4.0 == pytest.approx(1250.0)               # VERIFICATION D3
    assert res.frequency[k] == pytest.approx(c0 / 4.0, rel=1e-2)


def test_free_model_reports_six_rigid_modes():
    """A model without supports has six rigid-body modes at ω ≈ 0; they are
    reported apart and the elastic modes follow (same frequencies as
    with the rigid modes counted in)."""
    m = model_of("""
    name: free
    domain: {box: [[0, 0, 0], [0.4, 0.1, 0.1]]}
    mesh: {kind: blocks, divisions: [8, 2, 2]}
    materials:
      steel: {density: 8000, young: 200.0e9, poisson: 0.0}
    solver: {mode: modal, modes: 3}
    """)
    res = modal.natural_modes(m, 3)
    assert len(res.rigid_omega) == 6
    assert np.all(res.rigid_omega < 1e-3 * res.omega[0])
    assert np.all(res.omega > 0)
    # free–free bar: first axial mode c0/(2L) lies above the first bending modes
    assert res.frequency[0] < np.sqrt(E / RHO) / (2 * 0.4)


def test_modal_run_writes_modes(run_case):
    """solver.mode: modal through the CLI: one frame per mode, observable
    frequency, and the /modes group (docs/history.md) with ω_max and the
    exact stable step."""
    text = as_mode(beam_case(20, 2, force="[0, 0, -1]"), "mode: modal, modes: 3")
    h = run_case(text)
    assert h.frames == 4 and h.status == "completed"
    f = h["modes/frequency"]
    assert f.shape == (3,) and np.all(np.diff(f) >= 0)
    assert np.allclose(h.observables["frequency"][1:], f)
    assert h["modes/shape"].shape == (3, h.position.shape[1], 6)
    assert np.abs(h["modes/shape"][:, :, :3]).max() == pytest.approx(1.0)
    assert h["modes/stable_dt"] == pytest.approx(2 / h["modes/omega_max"])
    assert h.units["modes/frequency"] == "Hz"
    # the drawn frame k is x0 + amplitude · shape_k
    amp = h["modes/display_amplitude"]
    u = h.position[1] - h.position[0]
    assert np.allclose(u, amp * h["modes/shape"][0, :, :3], rtol=0, atol=1e-12)


# --------------------------------------------------------------- stable step

STABLE_DT_MESHES = {
    "blocks": ("[[0, 0, 0], [0.4, 0.1, 0.1]]", "{kind: blocks, divisions: [8, 2, 2]}"),
    "voronoi": ("[[0, 0, 0], [0.4, 0.1, 0.1]]", "{kind: voronoi, size: 0.025, seed: 3}"),
    # elongated blocks (4:1) and Voronoi without a minimum spacing (slivers)
    "elongated": ("[[0, 0, 0], [1.0, 0.1, 0.1]]", "{kind: blocks, divisions: [40, 1, 4]}"),
    "slivers": ("[[0, 0, 0], [0.4, 0.1, 0.1]]",
                "{kind: voronoi, size: 0.025, seed: 3, min_spacing: 0.0}"),
}


def stable_dt_ratio(name):
    box, mesh = STABLE_DT_MESHES[name]
    m = model_of(f"""
    name: dt
    domain: {{box: {box}}}
    mesh: {mesh}
    materials:
      steel: {{density: 8000, young: 200.0e9, poisson: 0.0}}
    boundary: [{{face: xmin, fix: all}}]
    solver: {{mode: modal}}
    """)
    return m.stable_dt() / (2.0 / modal.omega_max(m))


@pytest.mark.parametrize("name", list(STABLE_DT_MESHES))
def test_stable_dt_estimate_is_safe(name):
    """DESIGN §5: the explicit step estimate Model.stable_dt() is below the
    exact central-difference limit 2/ω_max (ω_max by Lanczos on (K, M))."""
    assert stable_dt_ratio(name) < 1.0


@pytest.mark.parametrize("name", list(STABLE_DT_MESHES))
def test_stable_dt_estimate_is_not_wasteful(name):
    """Issue 3: the estimate is above half of 2/ω_max (no more than twice
    the steps needed)."""
    assert stable_dt_ratio(name) > 0.5


# -------------------------------------------------------------- case schema

def test_modes_key_only_in_modal_mode():
    """`solver.modes` belongs to mode modal; static keys are refused in
    modes linear and modal (case file errors name the key)."""
    base = beam_case(4, 1, force="[0, 0, -1]")
    with pytest.raises(CaseError, match="solver.modes: not used in mode static"):
        load_case_text(base.replace("load_steps: 1,", "load_steps: 1, modes: 3,"))
    with pytest.raises(CaseError, match="solver.tolerance: not used in mode linear"):
        load_case_text(as_mode(base, "mode: linear, tolerance: 1.0e-6"))
    with pytest.raises(CaseError, match="solver.modes: not used in mode linear"):
        load_case_text(as_mode(base, "mode: linear, modes: 3"))
    assert load_case_text(as_mode(base, "mode: modal")).solver.modes == 6


def test_linear_refuses_an_unrestrained_model(tmp_path):
    """A free model in mode linear: exit 2 with a message, no traceback."""
    from rbsm_dyn.__main__ import main
    text = beam_case(4, 1, force="[0, 0, -1]").replace("boundary: [{face: xmin, fix: all}]", "")
    p = tmp_path / "free.yaml"
    import textwrap
    p.write_text(textwrap.dedent(as_mode(text, "mode: linear")), encoding="utf-8")
    assert main([str(p), "--out", str(tmp_path / "o.h5"), "--quiet"]) == 2


def test_axial_bar_of_thin_blocks_D3():
    """VERIFICATION D3 on blocks 80 times thinner than wide (800 × 1 × 1
    over 1 × 0.1 × 0.1 m: 1.25 mm along the bar): a box's springs keep
    their exact half-lengths t/2 however thin the box, so the axial
    frequency is still c0/(4L) = 1250 Hz within 1 % (the discretisation
    error of 800 cells is 2e-6).  Until 2026-11-29 a floor of V^(1/3)/20
    on every half-length, meant for slivers of non-convex cells, caught
    such blocks and made the bar 14 % too soft (1 075 Hz)."""
    text = beam_case(800, 1, force="[0, 0, -1]")
    m = model_of(as_mode(text, "mode: modal, modes: 10"))
    res = modal.natural_modes(m, 10)
    share = np.array([np.sum(s[:, 0] ** 2) / np.sum(s[:, :3] ** 2) for s in res.shape])
    k = int(np.argmax(share))
    assert share[k] > 0.9
    assert res.frequency[k] == pytest.approx(np.sqrt(E / RHO) / 4.0, rel=1e-2)
