"""The compressive cap (`rupture: {cap: {stress, hardening, transition}}`,
physics/laws/rupture.py cap_stress): LDPM's compressive boundary on a
spring's normal traction (Cusatis, Pelessone & Mencarelli 2011, eq. 28).

A cube under hydrostatic pressure p: every face's traction is −p n, so
every spring holds σ_n = −p and the cap is met at p = σ_c0 whatever the
mesh.  On a block lattice the faces' normal strain is the cube's strain ε
(the cubic lattice is affine under a pressure), so p(ε) is the boundary
itself, σ_bc(E ε): elastic to σ_c0, the hardening slope H_c0 = h E to
k_c0 σ_c0/E, exponential beyond.  On Voronoi cells the elastic bulk
modulus is the material's, K = E/(3(1 − 2ν)) (the calibrated stiffness),
and the slope after the cap falls to about h of it (every face on the
boundary, whose slope is h times its own).
"""
from __future__ import annotations

import math

import numpy as np
import pytest

from rbsm_dyn.__main__ import main

SC0, HC, KC0 = 60.0e6, 0.4, 4.0
E, NU = 30.0e9, 0.2
P_END, T_END = 300.0e6, 1.0e-3


def cube_text(mesh, cap="cap: {stress: 60.0e6}", frames=100, method=None):
    """A 20 mm cube under a pressure on its six sides ramped to 300 MPa over
    1 ms (about 170 wave transits: quasi-static)."""
    loads = "\n".join(f"  - {{surface: {s}, pressure: {P_END!r}, history: "
                      f"[[0, 0], [{T_END!r}, 1]]}}"
                      for s in ("xmin", "xmax", "ymin", "ymax", "zmin", "zmax"))
    return f"""
name: hydrostatic_cap
domain: {{box: [[0, 0, 0], [0.02, 0.02, 0.02]]}}
mesh: {mesh}
materials:
  concrete:
    density: 2400
    young: {E!r}
    poisson: {NU!r}
    rupture: {{fracture_energy: 100.0, tensile_strength: 3.0e6, {cap}}}
loads:
{loads}
solver: {{mode: dynamic, end_time: {T_END!r}}}
output:
  interval: {T_END / frames!r}
  fields: [position, spring_state]
"""


def boundary(x):
    """σ_bc [Pa] at −ε E0 = x (Cusatis et al. 2011, eq. 28, written out)."""
    if x <= SC0:
        return SC0
    x1 = KC0 * SC0
    if x <= x1:
        return SC0 + HC * (x - SC0)
    s1 = SC0 + HC * (x1 - SC0)
    return s1 * math.exp((x - x1) * HC / s1)


def mean_strain(h):
    """−(tr F − 3)/3 of the cells' least-squares affine motion, per frame."""
    x = h.position
    x0 = x[0] - x[0].mean(axis=0)
    out = []
    for k in range(len(h.time)):
        F = np.linalg.lstsq(x0, x[k] - x[k].mean(axis=0), rcond=None)[0].T
        out.append(-(np.trace(F) - 3.0) / 3.0)
    return np.array(out)


def balance_error(h):
    ob = h.observables
    parts = ob["strain"] + ob["kinetic"] + ob["plastic"] + ob["fracture"] + ob["damping"]
    return np.abs(parts - ob["external_work"]).max() / ob["external_work"].max()


def test_cap_on_a_block_lattice_is_the_boundary(run_case):
    """Blocks (4 × 4 × 4): p against σ_bc(E ε) within 2 % of σ_c0 at every
    frame, elastic, hardening and densifying (the run reaches E ε = 2.1
    k_c0 σ_c0); energy balance within 1 % of the work, the plastic work
    the area between loading and elastic unloading."""
    h = run_case(cube_text("{kind: blocks, divisions: [4, 4, 4]}"))
    eps = mean_strain(h)
    p = P_END * h.time / T_END
    ref = np.array([min(E * e, boundary(E * e)) for e in eps])
    assert np.abs(p - ref).max() <= 0.02 * SC0, np.abs(p - ref).max() / SC0
    assert E * eps[-1] > 1.5 * KC0 * SC0          # the densifying branch is reached
    assert balance_error(h) <= 0.01
    assert h.observables["plastic"][-1] > 0.0
    assert np.all(h.spring_state[-1] == 1)          # every spring on the cap (yielded)


def test_cap_on_voronoi_cells(run_case):
    """Voronoi cells (4 mm in a 20 mm cube): elastic p/ε = 3K within 5 %;
    half the springs have yielded at p within 5 % of σ_c0 (the faces hold
    σ_n = −p on average; one by one within about ±8 % of it); the slope
    of p against ε from 1.3 to 2.6 σ_c0 is h × 3K within
    15 %; energy balance within 1 % of the work."""
    h = run_case(cube_text("{kind: voronoi, size: 0.004, seed: 3}"))
    eps = mean_strain(h)
    p = P_END * h.time / T_END
    three_k = 3.0 * E / (3.0 * (1.0 - 2.0 * NU))
    elastic = (p > 0.2 * SC0) & (p < 0.8 * SC0)
    assert np.median(p[elastic] / eps[elastic]) == pytest.approx(three_k, rel=0.05)
    share = (h.spring_state == 1).mean(axis=1)
    k = int(np.argmax(share >= 0.5))
    assert share[k] >= 0.5 and p[k - 1] <= 1.05 * SC0 and p[k] >= 0.95 * SC0, (p[k - 1], p[k])
    hard = (p >= 1.3 * SC0) & (p <= 2.6 * SC0)
    slope = np.polyfit(eps[hard], p[hard], 1)[0]
    assert slope == pytest.approx(HC * three_k, rel=0.15), slope / three_k
    assert balance_error(h) <= 0.01


def test_no_cap_no_yield(run_case):
    """Without the cap the same pressure only compresses the blocks: p =
    E ε within 1 % and no spring yields (the mixed-mode envelope is open in
    pure compression)."""
    h = run_case(cube_text("{kind: blocks, divisions: [4, 4, 4]}", cap="", frames=10))
    eps = mean_strain(h)
    p = P_END * h.time / T_END
    assert np.abs(p[1:] - E * eps[1:]).max() <= 0.01 * P_END
    assert not np.any(h.spring_state == 1)


def test_cap_run_restarts_bitwise(tmp_path):
    """The plastic closing is in the checkpoint: a run stopped on the cap
    and continued with --restart ends as the uninterrupted run."""
    import rbsm_dyn
    case = tmp_path / "cube.yaml"
    case.write_text(cube_text("{kind: blocks, divisions: [3, 3, 3]}", frames=20),
                    encoding="utf-8")
    full, part = tmp_path / "full.h5", tmp_path / "part.h5"
    assert main([str(case), "--out", str(full), "--quiet"]) == 0
    a = rbsm_dyn.open_history(full)
    stop = int(a.step[len(a.step) // 2])        # past the cap (p = 150 MPa)
    assert main([str(case), "--out", str(part), "--quiet", "--max-steps", str(stop)]) == 0
    assert main([str(case), "--out", str(part), "--quiet", "--restart", str(part)]) == 0
    b = rbsm_dyn.open_history(part)
    assert np.array_equal(a.position, b.position)
    assert np.array_equal(a.observables["plastic"], b.observables["plastic"])


def test_cap_in_a_plane_model(run_case):
    """The plane passes share the spring law: a plane-strain square of 4 ×
    4 blocks under a pressure on its four edges holds σ_n = −p on every
    face, so with E0 = p/ε measured below the cap, p against
    σ_bc(E0 ε) within 5 % of σ_c0 at every frame to 300 MPa (the ramp's
    ringing: ±3 % in this 16-cell square, which no cell damps)."""
    loads = "\n".join(f"  - {{surface: {s}, pressure: {P_END!r}, history: "
                      f"[[0, 0], [{T_END!r}, 1]]}}" for s in ("xmin", "xmax", "ymin", "ymax"))
    h = run_case(f"""
name: plane_cap
plane: {{kind: strain, thickness: 0.005}}
domain: {{box: [[0, 0], [0.02, 0.02]]}}
mesh: {{kind: blocks, divisions: [4, 4]}}
materials:
  concrete:
    density: 2400
    young: {E!r}
    poisson: {NU!r}
    rupture: {{fracture_energy: 100.0, tensile_strength: 3.0e6, cap: {{stress: {SC0!r}}}}}
loads:
{loads}
solver: {{mode: dynamic, end_time: {T_END!r}}}
output:
  interval: {T_END / 50!r}
  fields: [position]
""")
    x = h.position[..., :2]
    x0 = x[0] - x[0].mean(axis=0)
    eps = np.array([-(np.trace(np.linalg.lstsq(x0, x[k] - x[k].mean(axis=0),
                                               rcond=None)[0]) - 2.0) / 2.0
                    for k in range(len(h.time))])
    p = P_END * h.time / T_END
    elastic = (p > 0.2 * SC0) & (p < 0.8 * SC0)
    e0 = float(np.median(p[elastic] / eps[elastic]))
    ref = np.array([min(e0 * e, boundary(e0 * e)) for e in eps])
    assert np.abs(p - ref).max() <= 0.05 * SC0, np.abs(p - ref).max() / SC0
    assert e0 * eps[-1] > KC0 * SC0          # the densifying branch is reached
    assert balance_error(h) <= 0.01


def test_cap_by_newton_is_the_boundary(run_case):
    """The same block cube static, by Newton (the cap's tangent, the
    boundary's slope): p against σ_bc(E ε) within 1 % of σ_c0 at each of
    20 load steps to 300 MPa."""
    text = cube_text("{kind: blocks, divisions: [4, 4, 4]}", frames=20)
    text = text.replace("solver: {mode: dynamic, end_time: 0.001}",
                        "solver: {mode: static, method: newton, load_steps: 20}")
    text = text.replace(", history: [[0, 0], [0.001, 1]]", "").replace(
        "  interval: 5e-05\n", "")
    h = run_case(text)
    eps = mean_strain(h)
    p = P_END * h.time
    ref = np.array([min(E * e, boundary(E * e)) for e in eps])
    assert len(p) == 21 and np.abs(p - ref).max() <= 0.01 * SC0, np.abs(p - ref).max() / SC0


@pytest.mark.parametrize("change, words", [
    (("rupture: {fracture_energy: 100.0, tensile_strength: 3.0e6, cap: {stress: 60.0e6}}",
      "rupture: {strain: 1.0e-3, cap: {stress: 60.0e6}}"), ("cap", "rupture strain")),
    (("cap: {stress: 60.0e6}", "cap: {stress: -60.0e6}"), ("cap", "stress")),
    (("cap: {stress: 60.0e6}", "cap: {stress: 60.0e6, transition: 0.5}"),
     ("cap", "transition"))])
def test_cap_input_errors(tmp_path, capsys, change, words):
    """A cap with the strain law, a negative stress or a transition below 1
    exit 2 naming the key."""
    text = cube_text("{kind: blocks, divisions: [2, 2, 2]}")
    assert change[0] in text
    case = tmp_path / "bad.yaml"
    case.write_text(text.replace(change[0], change[1]), encoding="utf-8")
    assert main([str(case), "--out", str(tmp_path / "bad.h5"), "--quiet"]) == 2
    err = capsys.readouterr().err
    assert all(w in err for w in words), err


def test_check_prints_the_cap(tmp_path, capsys):
    """`check` prints the cap's branches: held at σ_c0 = 60 MPa, hardening
    to σ_c1 = σ_c0 + h (k_c0 − 1) σ_c0 = 132 MPa (eq. 28 at ε_c1)."""
    case = tmp_path / "cap.yaml"
    case.write_text(cube_text("{kind: blocks, divisions: [2, 2, 2]}"), encoding="utf-8")
    assert main(["check", str(case)]) == 0
    out = capsys.readouterr().out
    assert "cap: a spring's normal traction is held at 60 MPa" in out
    assert "hardens by 0.4 E0 to 132 MPa" in out
