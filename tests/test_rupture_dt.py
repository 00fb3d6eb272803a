"""Issue 14 item 12: the fracture energy of the strain rupture law
(`rupture: {strain: ε_cr}`, Kawai 1978) converges with the time step.

A spring whose equivalent strain crosses ε_cr inside a step used to break
with the elastic energy it held at the end of that step; in fast fracture
it had overshot the threshold by the step's opening (v dt ≫ ε_cr h), so
the fracture energy grew with dt² (a 300 m/s explosion: 8-16× from dt/4 to
dt) and, as the motion had not given that energy up, the balance was off
by as much.  Now a spring that crosses the threshold inside an explicit
step releases the energy it held at the crossing and keeps the share of
its force that takes exactly that energy from the motion
(physics/inelastic.py _crossing_share).  A single call of the spring pass
(no time step: tests/test_laws.py) breaks as before."""
import textwrap

import numpy as np
import pytest

E, RHO, EPS = 60.0e9, 2500.0, 1.0e-3


def explosion(safety, mesh="{kind: voronoi, size: 0.007, seed: 3}", n=4, L=0.05, V=300.0):
    """A glass cube blown apart: the cells in each of n³ boxes get the
    velocity V (x − c)/R of the box centre x (R: the corner boxes' distance
    from the centre c, so the corners fly out at V = 300 m/s)."""
    h = L / n
    c = L / 2
    R = np.sqrt(3) * (c - h / 2)
    groups, initial = [], []
    for i in range(n):
        for j in range(n):
            for k in range(n):
                idx = np.array([i, j, k])
                x = idx * h + h / 2
                v = V * (x - c) / R
                lo = x - h / 2 - (idx == 0) * h          # outer boxes reach past the domain
                hi = x + h / 2 + (idx == n - 1) * h
                name = f"b{i}{j}{k}"
                groups.append(f"  {name}: {{box: [{lo.tolist()}, {hi.tolist()}]}}")
                initial.append(f"  - {{group: {name}, velocity: {v.tolist()}}}")
    return "\n".join([
        "name: explosion",
        f"domain: {{box: [[0, 0, 0], [{L}, {L}, {L}]]}}",
        f"mesh: {mesh}",
        "materials:",
        f"  glass: {{density: {RHO}, young: {E}, poisson: 0.2, rupture: {{strain: {EPS}}}, "
        "friction: 0.3}",
        "groups:", *groups,
        "initial:", *initial,
        f"solver: {{mode: dynamic, end_time: 2.0e-5, dt_safety: {safety}}}",
        "output: {interval: 5.0e-7}",
    ]) + "\n"


def _balance(h):
    eb = h.energy_balance()
    return np.abs(eb["error"]).max() / np.abs(eb["supplied"]).max()


def test_explosion_fracture_energy_converges_with_dt(run_case):
    """A Voronoi glass cube (≈ 360 cells, 11 000 spring points) blown apart
    at 300 m/s: two thirds of its springs break, most in the first steps
    (the faces open by v dt ≈ 12 ε_cr h in a step at dt_safety 0.8).  The
    fracture energy at dt and dt/4 agrees within 10 % (measured: 9.486 and
    9.492 J; 171 and 20.8 J before), the energy balance closes within 1 %
    of the supplied energy at every frame (measured: 2e-6; 2.2 % before,
    the whole overshoot), and the state stays finite."""
    runs = {s: run_case(explosion(s)) for s in (0.8, 0.2)}
    wf = {s: h.observables["fracture"][-1] for s, h in runs.items()}
    for s, h in runs.items():
        o = h.observables
        assert h.status == "completed"
        assert o["n_broken"][-1] > 0.5 * len(h.static["springs/area"])
        assert np.all(np.isfinite(o["kinetic"])) and np.all(np.isfinite(o["fracture"]))
        assert _balance(h) <= 1e-2, (s, _balance(h))
    assert wf[0.8] == pytest.approx(wf[0.2], rel=0.10)
    # the same springs break at both steps
    n_broken = {s: h.observables["n_broken"][-1] for s, h in runs.items()}
    assert n_broken[0.8] == pytest.approx(n_broken[0.2], rel=1e-2)


PAIR = """
name: pair
domain: {box: [[0, 0, 0], [0.02, 0.01, 0.01]]}
mesh: {kind: blocks, divisions: [2, 1, 1]}
materials:
  glass: {density: 2500, young: 60.0e9, poisson: 0.0, rupture: {strain: 1.0e-3}}
groups:
  left: {box: [[0, -1, -1], [0.01, 1, 1]]}
  right: {box: [[0.01, -1, -1], [1, 1, 1]]}
initial: [{group: left, velocity: [-V, 0, 0]}, {group: right, velocity: [V, 0, 0]}]
solver: {mode: dynamic, end_time: 4.0e-6, dt_safety: SAFETY}
output: {interval: 1.0e-7}
"""


@pytest.mark.parametrize("speed, worst", [(50.0, 2e-3), (5.0, 0.15)])
def test_a_face_torn_apart_releases_its_threshold_energy(run_case, speed, worst):
    """Two glass blocks (1 cm cubes, ν = 0) pulled apart at ±V: their face
    opens straight and breaks at δn = ε_cr h, where it holds ½ (E/h) A
    (ε_cr h)² = ½ E ε_cr² A h = 0.03 J.  At 2 × 50 m/s the face opens by
    ≈ 60 ε_cr h in a step (it broke with up to 200× that energy before, a
    balance error of 100 % that was taken for divergence); at 2 × 5 m/s the
    face nearly stops the blocks (at 1.4 ε_cr h) and breaks over a few
    steps.  At dt_safety 0.85, 0.3 and 0.1 the energy balance closes to
    round-off once the face has broken (K + U + W_f = K0 within 1e-9; it
    is the trapezoidal work of the forces, booked exactly), and the
    fracture energy is the threshold energy within `worst` (measured:
    0.12 % at 50 m/s; 12 % at 5 m/s and dt_safety 0.85, where the step is
    ω dt ≈ 0.95 of the pair's own vibration) and within 1 % at dt_safety
    0.1 (measured: 0.12 %, 0.18 %)."""
    h_cell, area = 0.01, 1.0e-4
    threshold = 0.5 * E * EPS ** 2 * area * h_cell
    for safety in (0.85, 0.3, 0.1):
        text = PAIR.replace("V,", f"{speed},").replace("-V", f"-{speed}") \
            .replace("SAFETY", str(safety))
        h = run_case(textwrap.dedent(text))
        o = h.observables
        assert h.status == "completed"
        assert o["n_broken"][-1] == len(h.static["springs/area"])
        k0 = o["kinetic"][0]
        total = o["kinetic"] + o["strain"] + o["fracture"]
        assert abs(total[-1] - k0) <= 1e-9 * k0
        # (at a frame while the face is loaded, the synchronized velocity's
        # own O((ω dt)²) term, stability.md (b): 1.4 % of K0 at 5 m/s and
        # dt_safety 0.85; and the share's work still to come)
        assert np.abs(total - k0).max() <= 2e-2 * k0
        assert o["fracture"][-1] == pytest.approx(threshold, rel=worst if safety > 0.1 else 1e-2)
