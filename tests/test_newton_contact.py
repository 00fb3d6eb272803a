"""Newton through frictional contact (issue 30 item 2): a notched beam of
blocks resting on a rigid pin and a rigid roller and loaded by a rigid
platen, every part joined to the beam by a contact interface (compression
only, Coulomb μ = 0.2), followed by `solver.method: newton` under CMOD
control through its peak onto the softening branch."""
import textwrap

import numpy as np
import pytest

import rbsm_dyn
from rbsm_dyn.__main__ import main

FT, GF = 3.0e6, 100.0
B, W, S = 0.01, 0.05, 0.18          # thickness, depth, span [m]

BEAM = f"""
name: tpb_newton
parts:
  beam:
    geometry: {{box: [[0, 0, 0], [0.2, {W}, {B}]]}}
    mesh: {{kind: blocks, divisions: [40, 10, 1]}}
    material: concrete
  pin:
    geometry: {{box: [[0.005, -0.01, 0], [0.015, 0, {B}]]}}
    mesh: {{kind: rigid}}
    material: steel
  roller:
    geometry: {{box: [[0.185, -0.01, 0], [0.195, 0, {B}]]}}
    mesh: {{kind: rigid}}
    material: steel
  platen:
    geometry: {{box: [[0.095, {W}, 0], [0.105, {W + 0.01}, {B}]]}}
    mesh: {{kind: rigid}}
    material: steel
interfaces:
  - {{parts: [beam, pin], law: contact, friction: 0.2}}
  - {{parts: [beam, roller], law: contact, friction: 0.2}}
  - {{parts: [beam, platen], law: contact, friction: 0.2}}
materials:
  concrete:
    density: 2400
    young: 30.0e9
    poisson: 0.2
    rupture: {{fracture_energy: {GF}, tensile_strength: {FT}}}
  steel: {{density: 7800, young: 2.0e11, poisson: 0.3}}
cuts:
  - {{point: [0.1, 0, 0], normal: [1, 0, 0], within: [[0.09, -0.01, -0.01], [0.11, {W / 2}, 0.02]]}}
boundary:
  - {{group: pin, fix: [x, y, z, rx, ry]}}
  - {{group: roller, fix: [y, z, rx, ry]}}
  - {{group: platen, fix: [x, z, rx, ry, rz]}}
  - {{group: platen, displacement: [null, -1.0e-3, null]}}
  - {{group: beam, fix: [z, rx, ry]}}
solver:
  mode: static
  method: newton
  tolerance: 1.0e-5
  control: {{probe: cmod, increment: 4.0e-6, end: 4.0e-4, stop_fraction: 0.5}}
output:
  probes:
    P: {{group: platen, quantity: reaction, component: y, reduce: sum}}
    R_pin: {{group: pin, quantity: reaction, component: y, reduce: sum}}
    R_roller: {{group: roller, quantity: reaction, component: y, reduce: sum}}
    cmod: {{quantity: relative_displacement, points: [[0.0975, 0.001, 0.005], [0.1025, 0.001, 0.005]],
           component: x}}
"""


@pytest.fixture(scope="module")
def implicit_beam(tmp_path_factory):
    """The beam's history under the default (implicit) damage update."""
    return _run(BEAM, tmp_path_factory.mktemp("implicit"))


def _run(text, where):
    case = where / "beam.yaml"
    case.write_text(textwrap.dedent(text), encoding="utf-8")
    out = where / "beam.h5"
    assert main([str(case), "--out", str(out), "--quiet"]) == 0
    return rbsm_dyn.open_history(out)


def test_notched_beam_on_contact_supports_by_newton(implicit_beam):
    """The run goes through the peak to half of it (before this, Newton
    stalled on the rocking supports); at every frame the supports carry
    the platen's load (static equilibrium, ΣR = P to 1e-3 of the peak) in
    compression only, half each (the specimen is symmetric; the roller's
    friction can move the split by a little: 5 %); the work of the platen
    balances stored energy, fracture and friction to 1 % of it (the
    energy balance of a static run, trapezoidal work over the increments);
    the fracture energy booked is below G_f × the ligament area (the crack
    has not run through at half the peak)."""
    h = implicit_beam
    ob = h.observables
    P = -np.asarray(ob["P"])
    Rp, Rr = np.asarray(ob["R_pin"]), np.asarray(ob["R_roller"])
    peak = P.max()
    assert peak > 0 and P[-1] < 0.5 * peak and int(np.argmax(P)) < len(P) - 3
    assert np.abs(Rp + Rr - P).max() <= 1e-3 * peak
    assert Rp.min() >= -1e-3 * peak and Rr.min() >= -1e-3 * peak
    i = int(np.argmax(P))
    assert abs(Rp[i] - 0.5 * P[i]) <= 0.05 * P[i]
    eb = h.energy_balance()
    work = np.asarray(ob["external_work"])
    assert np.abs(np.asarray(eb["error"])).max() <= 1e-2 * work[-1]
    assert 0 < ob["fracture"][-1] < GF * B * W / 2


def test_implex_on_contact_supports_follows_the_implicit_path(implicit_beam, tmp_path):
    """The same beam with `damage_update: implex` (solvers/newton.py): the
    supports' contact faces held open or closed after the third iterate
    must still balance at each converged increment (the held status is
    checked and renewed; held from the third iterate alone, the first
    increment of three-point bending ended off equilibrium, with twice the
    strain energy and 18 times the friction of the implicit increment),
    and an increment that fails on the small-rotation
    matrix is made again with the geometric stiffness (or the reverse: with
    it from the start, this beam's first increment failed 12 halvings).
    At every frame the supports carry the platen's load in compression
    only; the peak lies within 3 % of the implicit path's (the issue's
    bound between two solutions of one specimen); the energy balance
    within 2 % of the work.  IMPL-EX's damage lags one increment, so its
    energy error is O(increment): here 3.7 % at the implicit run's CMOD
    increments (4 µm, 6 % of the crack's critical opening 2 G_f/f_t),
    1.2 % at half of them, which this run takes (the Brazilian disc:
    1.9 % and 0.6 %, docs/case_file.md)."""
    h = _run(BEAM.replace("tolerance: 1.0e-5", "tolerance: 1.0e-5\n  damage_update: implex")
             .replace("increment: 4.0e-6", "increment: 2.0e-6"), tmp_path)
    ob = h.observables
    P = -np.asarray(ob["P"])
    Rp, Rr = np.asarray(ob["R_pin"]), np.asarray(ob["R_roller"])
    peak = P.max()
    assert P[-1] < 0.5 * peak and int(np.argmax(P)) < len(P) - 3
    assert np.abs(Rp + Rr - P).max() <= 1e-3 * peak
    assert Rp.min() >= -1e-3 * peak and Rr.min() >= -1e-3 * peak
    ref = -np.asarray(implicit_beam.observables["P"]).min()
    assert peak == pytest.approx(ref, rel=0.03)
    work = np.asarray(ob["external_work"])
    assert np.abs(np.asarray(h.energy_balance()["error"])).max() <= 2e-2 * work[-1]


def test_the_whole_matrix_falls_back_to_the_low_rank_one(implicit_beam, tmp_path, monkeypatch):
    """The implicit path with the whole present matrix (solvers/newton_linear.py
    _Full, with the geometric stiffness, which a run takes once a body has
    turned past GEOMETRIC_ANGLE), here from the first iteration: on this
    beam its first increment failed 12 halvings, the contact faces cycling
    where the low-rank modified Newton (exact residual, the matrix of an
    earlier state) converges.  An increment that fails on it is made again
    on the low-rank one (_increment_or_retry).  The geometric term is
    negligible at these loads, so the path is the small-rotation one: its
    peak within 1 % of it, equilibrium at every frame, the energy balance
    within the issue's 1 % of the work."""
    from rbsm_dyn.solvers import newton_system
    monkeypatch.setattr(newton_system, "GEOMETRIC_ANGLE", -1.0)
    h = _run(BEAM, tmp_path)
    ob = h.observables
    P = -np.asarray(ob["P"])
    peak = P.max()
    assert P[-1] < 0.5 * peak
    assert np.abs(np.asarray(ob["R_pin"]) + np.asarray(ob["R_roller"]) - P).max() <= 1e-3 * peak
    ref = -np.asarray(implicit_beam.observables["P"]).min()
    assert peak == pytest.approx(ref, rel=0.01)
    work = np.asarray(ob["external_work"])
    assert np.abs(np.asarray(h.energy_balance()["error"])).max() <= 1e-2 * work[-1]


ROCKERS = """
name: rockers
plane: {kind: stress, thickness: 0.04}
parts:
  beam:
    geometry: {box: [[0, 0], [0.44, 0.1]]}
    mesh: {kind: voronoi, size: 0.005, seed: 1}
    material: concrete
  pin:
    geometry: {box: [[0.015, -0.02], [0.025, 0]]}
    mesh: {kind: rigid}
    material: steel
  roller:
    geometry: {box: [[0.415, -0.02], [0.425, 0]]}
    mesh: {kind: rigid}
    material: steel
  platen:
    geometry: {box: [[0.215, 0.1], [0.225, 0.12]]}
    mesh: {kind: rigid}
    material: steel
interfaces:
  - {parts: [beam, pin], law: contact, friction: 0.2}
  - {parts: [beam, roller], law: contact, friction: 0.2}
  - {parts: [beam, platen], law: contact, friction: 0.2}
materials:
  concrete: {density: 2400, young: 30.0e9, poisson: 0.2}
  steel: {density: 7800, young: 2.0e11, poisson: 0.3}
cuts:
  - {point: [0.22, 0], normal: [1, 0], within: [[0.2, -0.01], [0.24, 0.05]], planar: true}
boundary:
  - {group: pin, fix: [x, y]}
  - {group: roller, fix: [y]}
  - {group: platen, fix: [x, rz]}
  - {group: platen, displacement: [null, -3.0e-5]}
solver: {mode: static}
output:
  probes:
    P: {group: platen, quantity: reaction, component: y, reduce: sum}
    R: {group: pin, quantity: reaction, component: y, reduce: sum}
    cmod: {quantity: relative_displacement, points: [[0.21, 0.001], [0.23, 0.001]], component: x}
"""


@pytest.mark.parametrize("limit", [None, 1e30])
def test_elastic_beam_on_rocking_parts(tmp_path, monkeypatch, limit):
    """An elastic notched beam on a rigid pin (held x, y) and roller (held
    y), both free to turn, under a rigid platen, all contact interfaces,
    plain `solver: {mode: static}`: at λ = 0 every face touches at zero
    force, and the first increment's active set cycled into a mechanism
    (beam and roller sliding 1.2 mm under a 3 µm platen step); the run
    then "converged" with nothing touching, P = 0.  Now its elastic
    compliance CMOD/P is LEFM's for a beam of span S = 4W with a notch
    a = W/2 (Tada, Paris & Irwin, The Stress Analysis of Cracks Handbook;
    Jenq & Shah 1985: CMOD = 4 σ a V1(α)/E, σ = 3PS/(2bW²), V1 = 0.76 −
    2.28α + 3.87α² − 2.04α³ + 0.66/(1 − α)²) within 10 % (the cells are
    5 mm against a 50 mm ligament; the beam held at points under the
    supports instead of parts measured +7 %, this one +5 %), the pin
    carries half of P, and the beam stays in place.
    limit 1e30: with the step bound off, the check of a flown part alone
    (newton_contact._flown_part) cuts the increments that flew, to the same answer."""
    from rbsm_dyn.solvers import newton
    if limit is not None:
        monkeypatch.setattr(newton, "STEP_LIMIT", limit)
    h = _run(ROCKERS, tmp_path)
    ob = h.observables
    P = -np.asarray(ob["P"])
    E, b, W, a, S = 30.0e9, 0.04, 0.1, 0.05, 0.4
    al = a / W
    v1 = 0.76 - 2.28 * al + 3.87 * al ** 2 - 2.04 * al ** 3 + 0.66 / (1 - al) ** 2
    lefm = 4 * (3 * S / (2 * b * W ** 2)) * a * v1 / E        # CMOD per unit P [m/N]
    assert P[-1] > 0.0
    assert np.asarray(ob["cmod"])[-1] / P[-1] == pytest.approx(lefm, rel=0.10)
    assert abs(np.asarray(ob["R"])[-1] - 0.5 * P[-1]) <= 0.05 * P[-1]
    u = np.asarray(h.position[-1]) - np.asarray(h.position0)
    assert np.abs(u[:, 0]).max() < 3e-5
