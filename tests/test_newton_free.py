"""Static Newton on a model no support holds (solvers/newton_system.py
_hold_rigid_motion): a body between self-balancing loads (a Brazilian
disc) is held at one body that carries no force, and a resultant left over
is balanced by inertia relief, the quasi-static response of the free body
accelerating under it."""
import numpy as np
import pytest

E, SIGMA, L, H = 3.0e10, 1.0e6, 1.0, 0.1

FREE_BAR = f"""
name: free_bar
domain: {{box: [[0, 0, 0], [{L}, {H}, {H}]]}}
mesh: {{kind: blocks, divisions: [10, 1, 1]}}
materials:
  c: {{density: 2400, young: {E}, poisson: 0.0}}
groups:
  first: {{box: [[-1, -1, -1], [{H}, 1, 1]]}}
  last: {{box: [[{L - H}, -1, -1], [2, 1, 1]]}}
loads:
  - {{surface: xmax, traction: [{SIGMA}, 0, 0]}}
{{extra}}
solver: {{mode: static, load_steps: 2}}
output:
  probes:
    stretch: {{quantity: relative_displacement, groups: [first, last], component: x}}
"""


@pytest.mark.parametrize("balanced", [True, False])
def test_free_bar_under_newton(run_case, balanced):
    """balanced: tractions ±σ on the ends of a free bar of ten blocks
    (ν = 0: each face's normal spring is E A/h); the end cells' centres,
    0.9 m apart, part by σ/E × 0.9 m (Hooke), within 1e-6 of it (the body
    held carries no force; where the bar sits is that body's place).
    Unbalanced: σ on the far end only.  The free bar accelerates at
    a = F/m; in its frame the d'Alembert forces load it, so the axial
    force at face k (x = k h) is F k/10 (the mass to its left) and the
    stretch is Σ_k F k h/(10 E A) = σ/E × 0.45 m, within 1e-6.  Both: the
    energy balance closes to 1e-3 (the work of the load and the
    d'Alembert forces on the deformation is the strain energy)."""
    extra = "  - {surface: xmin, traction: [%g, 0, 0]}" % -SIGMA if balanced else ""
    h = run_case(FREE_BAR.replace("{extra}", extra))
    stretch = h.observables["stretch"][-1]
    expect = SIGMA / E * (0.9 if balanced else 0.45)
    assert stretch == pytest.approx(expect, rel=1e-6)
    work = h.observables["external_work"][-1]
    assert h.observables["strain"][-1] == pytest.approx(work, rel=1e-3)


def test_free_plane_bar_is_held_in_its_plane(run_case):
    """The balanced bar as a plane-stress model (three DOFs a cell, the
    others held by the plane): the free motions (u, v, θ) are held at a
    body's in-plane components; the stretch is σ/E × 0.9 m within 1e-6."""
    h = run_case(f"""
name: free_plane_bar
plane: {{kind: stress, thickness: {H}}}
domain: {{box: [[0, 0], [{L}, {H}]]}}
mesh: {{kind: blocks, divisions: [10, 1]}}
materials:
  c: {{density: 2400, young: {E}, poisson: 0.0}}
groups:
  first: {{box: [[-1, -1], [{H}, 1]]}}
  last: {{box: [[{L - H}, -1], [2, 1]]}}
loads:
  - {{surface: xmax, traction: [{SIGMA}, 0]}}
  - {{surface: xmin, traction: [{-SIGMA}, 0]}}
solver: {{mode: static, load_steps: 2}}
output:
  probes:
    stretch: {{quantity: relative_displacement, groups: [first, last], component: x}}
""")
    assert h.observables["stretch"][-1] == pytest.approx(SIGMA / E * 0.9, rel=1e-6)
