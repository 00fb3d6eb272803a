"""Quasi-static explicit runs (issue 13, item 2): Cundall's local
non-viscous damping (`solver.damping.local`, physics/integrate.py) damps
the transients of a slowly loaded model without dragging its steady motion,
so the supports carry the load and nothing else; the run records the
kinetic-to-strain energy ratio and warns when it was not slow enough."""
import textwrap

import numpy as np
import pytest

from rbsm_dyn.__main__ import main

E, RHO, L, A, N = 200.0e9, 8000.0, 1.0, 0.01, 20      # steel bar, 20 blocks


def bar(damping, ramp, end, speed=0.05):
    """A bar L × 0.1 × 0.1 m fixed on its face xmin, its last cell driven
    along x at `speed` [m/s] (ramped over `ramp` s, then held) until `end`;
    reactions of the first and the last cell, displacement of the last."""
    return f"""
    name: qs-bar
    domain: {{box: [[0, 0, 0], [{L}, 0.1, 0.1]]}}
    mesh: {{kind: blocks, divisions: [{N}, 1, 1]}}
    materials:
      steel: {{density: {RHO}, young: {E}, poisson: 0.0}}
    groups:
      left: {{box: [[-1, -1, -1], [0.05, 1, 1]]}}
      right: {{box: [[0.95, -1, -1], [2, 1, 1]]}}
    boundary:
      - {{face: xmin, fix: all}}
      - {{group: right, velocity: [{speed}, 0, 0], history: [[0, 0], [{ramp}, 1], [{end}, 1]]}}
    solver: {{mode: dynamic, end_time: {end}, damping: {damping}}}
    output:
      interval: 1.0e-4
      probes:
        R_left: {{group: left, quantity: reaction, component: x, reduce: sum}}
        R_right: {{group: right, quantity: reaction, component: x, reduce: sum}}
        u: {{group: right, quantity: displacement, component: x, reduce: mean}}
    """


def balance_error(h):
    ob = h.observables
    bal = ob["kinetic"] + ob["strain"] + ob["damping"] - ob["external_work"]
    return np.abs(bal).max() / ob["external_work"].max()


def test_local_damping_does_not_load_the_supports(run_case):
    """Driven at 0.05 m/s for 40 wave transits (c0 = 5 000 m/s), the bar's
    two ends carry the same force, EA u/(L − Δ/2) (the driven cell's
    centroid lies half a cell inside the end), within 0.5 %; the ratio of
    kinetic to strain energy ends below 1e-3; the balance closes within
    1e-3 of the work.  Mass-proportional damping α = ω1 (the bar's first
    mode, π c0/(2L)) drags every free cell by α m v instead: the fixed end
    carries Σ α m_i v_i (≈ α M v/2, v linear along the bar) less than the
    driven one, within 1 %."""
    h = run_case(bar("{local: 0.7}", 0.002, 0.008))
    ob = h.observables
    k = E * A / (L - 0.5 * L / N)
    assert -ob["R_left"][-1] == pytest.approx(k * ob["u"][-1], rel=5e-3)
    assert ob["R_right"][-1] == pytest.approx(k * ob["u"][-1], rel=5e-3)
    assert ob["kinetic_ratio"][-1] < 1e-3
    assert ob["damping"][-1] > 0
    assert balance_error(h) < 1e-3

    omega1 = np.pi * np.sqrt(E / RHO) / (2 * L)
    h = run_case(bar(f"{{alpha: {omega1}}}", 0.002, 0.008))
    ob = h.observables
    # the free cells i = 0..N-2 (centroids x_i = (i + ½)Δ) move at v x_i/(L − Δ/2)
    d = L / N
    x = (np.arange(N - 1) + 0.5) * d
    drag = omega1 * RHO * A * d * np.sum(0.05 * x / (L - 0.5 * d))
    assert drag == pytest.approx(omega1 * RHO * A * L * 0.05 / 2, rel=0.1)   # ≈ α M v/2
    assert ob["R_right"][-1] + ob["R_left"][-1] == pytest.approx(drag, rel=1e-2)
    assert "kinetic_ratio" not in ob


def test_a_fast_run_is_told_it_is_not_quasi_static(tmp_path, capsys):
    """Driven in 0.1 ms (half a wave transit) at 1 m/s, the kinetic energy
    of the bar's oscillation stays above 5 % of its strain energy: the run
    completes with a warning naming the ratio; driven over 2 ms at 0.05 m/s,
    no warning."""
    for text, warned in ((bar("{local: 0.3}", 1e-4, 0.002, speed=1.0), True),
                         (bar("{local: 0.7}", 0.002, 0.008), False)):
        case = tmp_path / "bar.yaml"
        case.write_text(textwrap.dedent(text))
        assert main([str(case), "--out", str(tmp_path / "bar.h5"), "--quiet"]) == 0
        err = capsys.readouterr().err
        assert ("not quasi-static: the kinetic energy reached" in err) == warned, err
