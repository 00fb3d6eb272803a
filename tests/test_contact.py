"""Frictional contact on a cut face (VERIFICATION F3): a block on a fixed
base, the face between them pre-broken by `cuts`, Coulomb friction μ.

The weight is applied as a force ramped on over a few milliseconds (many
periods of the contact spring), so the contact is loaded quasi-statically
instead of bouncing on a suddenly applied weight; the block's rotations are
held (a rigid block sliding on a plane does not tip).  Contact is between
the two original neighbours and holds while their gap stays below the
spring length h (physics/inelastic.py), so the cells are 5 m tall (h = 5 m)
for slides of up to 4.25 m."""
import numpy as np
import pytest

G = 9.81
H = 5.0                     # cell height [m]
MASS = 8000 * 0.1 * 0.1 * H  # the top cell [kg]


def block_case(theta_deg, mu, v0=0.0, end_time=1.0, ramp=2.0e-3):
    th = np.radians(theta_deg)
    fx, fz = MASS * G * np.sin(th), -MASS * G * np.cos(th)
    return f"""
    name: slide
    domain: {{box: [[0, 0, 0], [0.1, 0.1, {2 * H}]]}}
    mesh: {{kind: blocks, divisions: [1, 1, 2]}}
    materials:
      steel: {{density: 8000, young: 200.0e9, poisson: 0.0, friction: {mu}}}
    groups:
      base: {{box: [[-1, -1, -1], [1, 1, {H}]]}}
      block: {{box: [[-1, -1, {H}], [1, 1, {3 * H}]]}}
    boundary: [{{group: base, fix: all}}, {{group: block, fix: [rx, ry, rz]}}]
    cuts: [{{point: [0, 0, {H}], normal: [0, 0, 1], within: [[-1, -1, {H - 0.01}], [1, 1, {H + 0.01}]]}}]
    initial: [{{group: block, velocity: [{v0}, 0, 0]}}]
    loads: [{{group: block, force: [{fx}, 0, {fz}], history: [[0, 0], [{ramp}, 1], [100, 1]]}}]
    solver: {{mode: dynamic, end_time: {end_time}}}
    output:
      interval: 1.0e-3
      probes:
        x: {{group: block, quantity: displacement, component: x, reduce: mean}}
        vx: {{group: block, quantity: velocity, component: x, reduce: mean}}
    """


@pytest.fixture
def slide(run_case):
    return lambda *a, **k: run_case(block_case(*a, **k))


def test_F3_incline_acceleration(slide):
    """VERIFICATION F3: θ = 30°, μ = 0.2 → a = g(sin θ − μ cos θ) = 3.2059
    m/s² (tol 1 %, fitted on x(t) after the ramp), 1.6029 m after 1 s."""
    a_ref = G * (np.sin(np.radians(30)) - 0.2 * np.cos(np.radians(30)))
    assert a_ref == pytest.approx(3.2059, abs=1e-4)                    # VERIFICATION F3
    h = slide(30.0, 0.2)
    t, x = h.time, h.observables["x"]
    late = t > 0.05
    a = 2 * np.polyfit(t[late], x[late], 2)[0]
    assert a == pytest.approx(a_ref, rel=1e-2)
    assert x[-1] == pytest.approx(1.6029, rel=1e-2)
    assert h.observables["plastic"][-1] > 0          # friction dissipates


def test_F3_horizontal_slide_stops(slide):
    """VERIFICATION F3: v0 = 5 m/s, μ = 0.3 on a level face: stops after
    v0²/(2μg) = 4.2474 m at v0/(μg) = 1.6989 s (tol 1 %), then stays."""
    h = slide(0.0, 0.3, v0=5.0, end_time=2.0, ramp=5.0e-4)
    t, x, v = h.time, h.observables["x"], h.observables["vx"]
    stop = np.argmax(v <= 1e-3)
    assert t[stop] == pytest.approx(5.0 / (0.3 * G), rel=1e-2)
    assert x[stop] == pytest.approx(25.0 / (2 * 0.3 * G), rel=1e-2)
    assert abs(x[-1] - x[stop]) < 1e-4            # no creep once stopped


def test_F3_no_creep_below_the_friction_angle(slide):
    """tan θ < μ: the block sticks; it moves only by the elastic shear of the
    contact spring (μ|σn| never reached), far below a millimetre."""
    h = slide(10.0, 0.3, end_time=0.2, ramp=0.02)
    t, x = h.time, h.observables["x"]
    kt = 200.0e9 / H * 0.01                       # contact shear stiffness [N/m]
    x_static = MASS * G * np.sin(np.radians(10)) / kt
    assert np.abs(x).max() <= 2.5 * x_static
    # no creep: the elastic oscillation about x_static does not drift
    a, b = (t > 0.05) & (t <= 0.125), t > 0.125
    assert abs(x[b].max() - x[a].max()) < 1e-2 * x_static
    assert abs(x[b].min() - x[a].min()) < 1e-2 * x_static
