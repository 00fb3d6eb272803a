"""Interior Poisson ratio of a uniaxial specimen as a user writes it (issue 30).

A Voronoi unit cube of 1 000 cells (seeds 23, the issue's, and 5) under the default
calibrated stiffness, its bottom face on rollers (support springs holding z),
its top face's cells pressed down by a prescribed z displacement (x, y and
the rotations free), the lateral faces free, one bottom cell held in x, y, rz
against the rigid motion; run by the static solver through the command line.
The strain is the volume-weighted least-squares fit u ≈ u0 + G x of the
centroid displacements of the cells in the middle half of the cube along
every axis (the interior: away from the ends and the free surface); the
stress is the top cells' reaction over the area.

# Tolerance: issue 30 and the calibration's own requirement (issue 11,
# docs/calibration.md): ν within ±0.02 of the target at ν = 0.2 and 0.3,
# E within 3 %.
"""
import textwrap

import numpy as np
import pytest

from rbsm_dyn.case import load_case_text
from rbsm_dyn.model import build_mesh

E = 30.0e9
D = 1.0e-4          # top displacement [m]: a strain of 1e-4 on the unit cube


def case_text(nu, seed, pin):
    lo = [float(v) - 1e-9 for v in pin]
    hi = [float(v) + 1e-9 for v in pin]
    return textwrap.dedent(f"""\
        name: uniaxial-rollers
        domain: {{box: [[0, 0, 0], [1, 1, 1]]}}
        mesh: {{kind: voronoi, size: 0.1, seed: {seed}}}
        materials:
          m: {{density: 2400, young: {E}, poisson: {nu}}}
        groups:
          pin: {{box: [{lo}, {hi}]}}
        boundary:
          - {{face: zmin, fix: [z]}}
          - {{surface: zmax, displacement: [null, null, {-D}]}}
          - {{group: pin, fix: [x, y, rz]}}
        solver: {{mode: static, load_steps: 1}}
        output:
          probes:
            P: {{surface: zmax, quantity: reaction, component: z, reduce: sum}}
        """)


def bottom_centre_cell(seed):
    mesh = build_mesh(load_case_text(case_text(0.2, seed, [0.5, 0.5, 0.0]), "t.yaml"))
    x = mesh.cell_centroid
    return x[np.argmin(np.linalg.norm(x - [0.5, 0.5, 0.0], axis=1))]


# seed 23: the cube; seed 5: the farthest from the target of the
# seeds measured (23, 4, 5) before the fix (benchmarks/poisson_interior.py)
@pytest.mark.parametrize("seed", [23, 5])
@pytest.mark.parametrize("nu", [0.2, 0.3])
def test_interior_nu_of_a_specimen_on_rollers(run_case, nu, seed):
    h = run_case(case_text(nu, seed, bottom_centre_cell(seed)))
    x = h.position0
    u = h.displacement[-1]
    w = h["particles/bodies/volume"]
    assert len(x) == 1000
    core = np.all((x >= 0.25) & (x <= 0.75), axis=1)         # middle half along every axis
    A = np.hstack([np.ones((core.sum(), 1)), x[core]])
    sw = np.sqrt(w[core])[:, None]
    coef, *_ = np.linalg.lstsq(A * sw, u[core] * sw, rcond=None)
    G = coef[1:].T                                            # G[i, j] = ∂u_i/∂x_j
    eps = 0.5 * (G + G.T)
    assert eps[2, 2] == pytest.approx(-D, rel=0.1)            # the load went in
    nu_eff = -(eps[0, 0] + eps[1, 1]) / (2 * eps[2, 2])
    sigma = h.observables["P"][-1] / 1.0                      # reaction / top area (1 m²)
    assert sigma / eps[2, 2] == pytest.approx(E, rel=0.03)
    assert nu_eff == pytest.approx(nu, abs=0.02)
