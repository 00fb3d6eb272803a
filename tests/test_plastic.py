"""Plastic collapse and impulsive plastic dynamics of beams (VERIFICATION B1,
C1, C2) with elastic–perfectly-plastic springs.

On a block lattice uniaxial stress loads only the normal springs, so the
calibrated uniaxial yield stress of the mesh is σy itself (VERIFICATION,
General: limit loads are compared with the calibrated value)."""
import textwrap

import numpy as np
import pytest

E, RHO, SY = 200.0e9, 8000.0, 250.0e6      # VERIFICATION default material


def b1_case(ends, displacement, nx=41, nz=4):
    """Beam L = 2, b = h = 0.1 under a prescribed central deflection."""
    support = {"pinned": "[{face: xmin, fix: [z]}, {face: xmax, fix: [z]}, {group: mid, fix: [x]}]",
               "clamped": "[{face: xmin, fix: all}, {face: xmax, fix: all}]"}[ends]
    return f"""
    name: b1
    domain: {{box: [[0, 0, 0], [2.0, 0.1, 0.1]]}}
    mesh: {{kind: blocks, divisions: [{nx}, 1, {nz}]}}
    materials:
      steel: {{density: {RHO}, young: {E}, poisson: 0.0, yield: {{criterion: normal, stress: {SY}}}}}
    groups:
      mid: {{box: [[0.99, -1, -1], [1.01, 1, 1]]}}
    boundary: {support[:-1]}, {{group: mid, displacement: [null, null, {-displacement}]}}, {{group: all, fix: [y]}}]
    solver: {{mode: static, load_steps: 6, tolerance: 1.0e-4}}
    output:
      probes:
        load: {{group: mid, quantity: reaction, component: z, reduce: sum}}
        deflection: {{group: mid, quantity: displacement, component: z, reduce: mean}}
    """


@pytest.mark.parametrize("ends, factor", [("pinned", 4.0), ("clamped", 8.0)])
def test_B1_plastic_collapse_load(run_case, ends, factor):
    """VERIFICATION B1: Mp = σy b h²/4 = 62.5 kN·m; collapse load 4Mp/L =
    125 kN simply supported, 8Mp/L = 250 kN clamped (L = 2), within 5 %,
    reached on a plateau of the load–deflection path (displacement control)."""
    Mp = SY * 0.1 * 0.1 ** 2 / 4
    assert Mp == pytest.approx(62.5e3)
    P_lim = factor * Mp / 2.0
    # about 2.5x the deflection at first yield; clamped ends also restrain
    # the axis, so a larger deflection would add membrane force
    h = run_case(b1_case(ends, 0.03 if ends == "pinned" else 0.012))
    load = -h.observables["load"]         # the constraint pushes the cells down: −reaction = load
    assert load[-1] == pytest.approx(P_lim, rel=5e-2)
    assert load[-2] == pytest.approx(load[-1], rel=2e-2)       # a plateau
    assert h.observables["plastic"][-1] > 0
