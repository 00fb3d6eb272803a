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
