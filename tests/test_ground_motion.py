"""Ground motion (`ground_motion` in a case, model/loads.py, records.py;
issue 28 item 3): the `{group, fix}` supports move with an acceleration
record integrated to the ground's velocity.

Facts checked:
* the record's integral is exact for the record linear between samples
  (its velocity and displacement against the closed forms of a constant
  and of a linear acceleration), and the linear baseline correction
  brings the ground back to rest where it started;
* a block on a shear spring (one degree of freedom: ω² = k/m, k = G A/h
  of the blocks' calibrated shear spring with ν = 0, m = ρ V) under a
  record: its peak displacement relative to the base against the exact
  integration of the same oscillator under the same record (the response
  spectrum at its period, ζ = 0, tests/test_spectrum.py) within 1 %; the
  base follows the ground's displacement to 1e-4 of its largest; the
  energy balance, the base motion's work counted as input, within 1 %;
* a probe `relative_to: ground` reads the mass's displacement less the
  ground's (the top less the base, within 1e-3) and the base's velocity
  less the ground's (nil but for the leapfrog's half step);
* supports by springs to the ground ({face, fix}) move with it: one cell
  on its bottom face's support springs (shear k = G' A/h, h = L/2 the
  centroid-to-face distance, the blocks' calibrated G' = E with ν = 0),
  its peak displacement relative to the ground against the exact
  integration of that oscillator within 1 %, energy within 1 %;
* the contact ground moves with it: a rigid block resting on the contact
  `ground` with friction μ starts to slide when the ground's acceleration
  passes μ g (within 2 %), energy within 1 %;
* a static run with a ground motion is refused, naming the key.
"""
import numpy as np
import pytest

from rbsm_dyn.case import CaseError, load_case_text
from rbsm_dyn.records import integrate, read_record

E, RHO, L = 1.0e4, 1000.0, 0.1          # a soft block: T = 2π L/√(E/ρ) = 0.199 s
SCALE = 0.01                            # small motions: δ/L ≈ 3e-3, linear


def write_record(path):
    """A synthetic record: Gaussian white noise, σ = 3 m/s², seed 1, step
    0.01 s, 10 s, under the envelope exp(−((t − 5)/3)²)."""
    dt, n = 0.01, 1000
    t = dt * np.arange(n)
    a = 3.0 * np.random.default_rng(1).standard_normal(n) * np.exp(-((t - 5.0) / 3.0) ** 2)
    np.savetxt(path, np.column_stack([t, a]), delimiter=",", header="t [s], a [m/s2]")
    return t, a


def sdof_case(extra="", boundary="[{group: base, fix: all}, {group: mass, fix: [y, z, rx, ry, rz]}]",
              solver="{mode: dynamic, end_time: 10.0, dt: 2.0e-4}"):
    return f"""
name: sdof
domain: {{box: [[0, 0, 0], [{L}, {L}, {2 * L}]]}}
mesh: {{kind: blocks, divisions: [1, 1, 2]}}
materials: {{m: {{density: {RHO}, young: {E}, poisson: 0.0}}}}
groups:
  base: {{box: [[-1, -1, -1], [1, 1, {L}]]}}
  mass: {{box: [[-1, -1, {L}], [1, 1, 1]]}}
boundary: {boundary}
ground_motion: {{file: record.csv, scale: {SCALE}, direction: [1, 0, 0]}}
solver: {solver}
output:
  interval: 0.002
  fields: [position, orientation, velocity]
  probes:
    base: {{group: base, quantity: displacement, component: x, reduce: mean}}
    top: {{group: mass, quantity: displacement, component: x, reduce: mean}}
    rel: {{group: mass, quantity: displacement, component: x, reduce: mean,
          relative_to: ground}}
    vrel: {{group: base, quantity: velocity, component: x, reduce: mean,
           relative_to: ground}}
{extra}"""


def assert_slides_at_mu_g(h, mu, g_e, t0, c):
    """The block's lag behind the ground (probe `lag`, relative to it)
    under the ground's acceleration c (t − t0): no slip (lag ≤ 1e-5 m, a
    hundred times the stick's elastic shear) before 0.8 of μ g, then
    Coulomb sliding, the lag c (t − t_s)³/6; t_s from that cubic gives the
    ground's acceleration at the start of sliding, c (t_s − t0) = μ g
    within 2 %; the energy balance within 1 % of the work."""
    t = np.asarray(h.time)
    lag = -np.asarray(h.observables["lag"])
    sliding = lag > 1e-5
    assert sliding.sum() > 20 and not sliding[t < t0 + 0.8 * mu * g_e / c].any()
    ts = np.median(t[sliding] - (6.0 * lag[sliding] / c) ** (1.0 / 3.0))
    assert c * (ts - t0) == pytest.approx(mu * g_e, rel=0.02)
    e = h.energy_balance()
    assert np.abs(e["error"]).max() <= 1e-2 * np.abs(e["supplied"]).max()


def test_integral_of_a_linear_record_is_exact():
    t = np.linspace(0.0, 2.0, 41)
    (tf, af, vf, df), _ = integrate(t, 0.5 + 3.0 * t, baseline="none")
    assert np.allclose(vf, 0.5 * tf + 1.5 * tf ** 2, rtol=0, atol=1e-12)
    assert np.allclose(df, 0.25 * tf ** 2 + 0.5 * tf ** 3, rtol=0, atol=1e-12)
    (tf, af, vf, df), _ = integrate(t, np.sin(7.0 * t) + 0.2, baseline="linear")
    assert abs(vf[-1]) <= 1e-12 and abs(df[-1]) <= 1e-12


def test_block_on_a_spring_under_a_record(run_case, tmp_path):
    from rbsm_dyn.io.spectrum import spectrum
    write_record(tmp_path / "record.csv")
    text = sdof_case()
    # run_case writes the case in its own folder: the record beside it
    h = run_case(text.replace("file: record.csv", f"file: {tmp_path / 'record.csv'}"))
    t = np.asarray(h.time)
    base = np.asarray(h.observables["base"])
    rel = np.asarray(h.observables["top"]) - base
    tr, ar = read_record(tmp_path / "record.csv", scale=SCALE)
    (tf, _, _, dg), (tc, ac) = integrate(tr, ar)          # the corrected record
    assert np.abs(base - np.interp(t, tf, dg)).max() <= 1e-4 * np.abs(dg).max()
    omega = np.sqrt(E / RHO) / L                           # k = E A/L, m = ρ A L
    sd = spectrum(tc, ac, [2.0 * np.pi / omega], 0.0)["Sd"][0]
    assert np.abs(rel).max() == pytest.approx(sd, rel=1e-2)
    # a probe relative to the ground: the mass's displacement less the
    # ground's, as computed here from the base (which follows the ground);
    # the base's velocity relative to the ground: nil but for the leapfrog's
    # half step (a fraction of the ground's largest velocity)
    probe = np.asarray(h.observables["rel"])
    assert np.abs(probe - rel).max() <= 1e-3 * np.abs(rel).max()
    (_, _, vg, _), _ = integrate(tr, ar)
    assert np.abs(np.asarray(h.observables["vrel"])).max() <= 0.05 * np.abs(vg).max()
    # fields relative to the ground (History): the ground's displacement is
    # the base's, the mass's relative displacement the top's less the base's
    assert np.abs(h.ground_displacement[:, 0] - base).max() <= 1e-4 * np.abs(dg).max()
    assert np.abs(h.ground_displacement[:, 1:]).max() == 0.0
    top = int(np.argmax(h.position0[:, 2]))
    assert np.abs(h.displacement_relative_to_ground[:, top, 0] - rel).max() \
        <= 1e-3 * np.abs(rel).max()
    assert np.abs(h.velocity_relative_to_ground[:, 1 - top, 0]).max() <= 0.05 * np.abs(vg).max()
    e = h.energy_balance()
    assert np.abs(e["error"]).max() <= 1e-2 * np.abs(e["supplied"]).max()


def test_static_run_with_a_ground_motion_is_refused(tmp_path):
    from rbsm_dyn.model import build_model
    write_record(tmp_path / "record.csv")
    text = sdof_case(solver="{mode: static, method: relaxation}").replace(
        "file: record.csv", f"file: {tmp_path / 'record.csv'}")
    text = text.replace("  interval: 0.002\n", "")
    with pytest.raises(CaseError) as err:
        build_model(load_case_text(text))
    assert err.value.path.startswith("ground_motion"), err.value.path


def test_support_springs_move_with_the_ground(run_case, tmp_path):
    """One cube of side L on the support springs of its bottom face
    ({face: zmin, fix: all}), held but in x: a shear spring k = E A/(L/2)
    (the blocks' calibrated shear stiffness per area E/h with ν = 0, h =
    L/2 from the centroid to the face; the two-block oscillator above has
    E A/L) under the record: the peak displacement relative to the ground
    against the exact integration of the same oscillator (ω² = 2E/(ρ L²),
    ζ = 0) within 1 %; energy within 1 %, the ground's work through the
    springs counted as input."""
    from rbsm_dyn.io.spectrum import spectrum
    write_record(tmp_path / "record.csv")
    text = f"""
name: sdof-on-springs
domain: {{box: [[0, 0, 0], [{L}, {L}, {L}]]}}
mesh: {{kind: blocks, divisions: [1, 1, 1]}}
materials: {{m: {{density: {RHO}, young: {E}, poisson: 0.0}}}}
groups:
  mass: {{box: [[-1, -1, -1], [1, 1, 1]]}}
boundary: [{{face: zmin, fix: all}}, {{group: mass, fix: [y, z, rx, ry, rz]}}]
ground_motion: {{file: {tmp_path / 'record.csv'}, scale: {SCALE}, direction: [1, 0, 0]}}
solver: {{mode: dynamic, end_time: 10.0, dt: 1.0e-4}}
output:
  interval: 0.002
  probes:
    rel: {{group: mass, quantity: displacement, component: x, reduce: mean,
          relative_to: ground}}
"""
    h = run_case(text)
    rel = np.asarray(h.observables["rel"])
    tr, ar = read_record(tmp_path / "record.csv", scale=SCALE)
    _, (tc, ac) = integrate(tr, ar)
    omega = np.sqrt(2.0 * E / RHO) / L
    sd = spectrum(tc, ac, [2.0 * np.pi / omega], 0.0)["Sd"][0]
    assert np.abs(rel).max() == pytest.approx(sd, rel=1e-2)
    e = h.energy_balance()
    assert np.abs(e["error"]).max() <= 1e-2 * np.abs(e["supplied"]).max()


def test_a_large_model_on_moving_support_springs_balances(run_case, tmp_path):
    """The threaded passes (above SERIAL_SPRINGS spring points): a slab of
    12 × 6 × 6 blocks on the support springs of its bottom face, shaken
    along x and z: the slab follows the ground (its mean displacement
    reaches half the ground's; the history's ground displacement is the
    record's integral within 1e-3 of its largest), and the energy balance
    closes within 1 %, the ground's work through the springs counted as
    input."""
    tr = np.linspace(0.0, 0.05, 51)
    np.savetxt(tmp_path / "shake.csv", np.column_stack([tr, 20.0 * np.sin(200.0 * tr)]),
               delimiter=",")
    h = run_case(f"""
name: slab-on-springs
domain: {{box: [[0, 0, 0], [1.0, 0.5, 0.5]]}}
mesh: {{kind: blocks, divisions: [12, 6, 6]}}
materials: {{m: {{density: 1000, young: 1.0e7, poisson: 0.2}}}}
boundary: [{{face: zmin, fix: all}}]
ground_motion: {{file: {tmp_path / 'shake.csv'}, baseline: none, direction: [1, 0, 1]}}
solver: {{mode: dynamic, end_time: 0.05}}
output:
  interval: 0.001
  probes:
    ux: {{group: all, quantity: displacement, component: x, reduce: mean}}
""")
    from rbsm_dyn.physics.springs import SERIAL_SPRINGS
    assert h.n_springs > SERIAL_SPRINGS
    tr, ar = read_record(tmp_path / "shake.csv")
    (tf, _, _, dg), _ = integrate(tr, ar, baseline="none")
    g = h.ground_displacement
    want = np.interp(h.time, tf, dg)[:, None] * np.array([1.0, 0.0, 1.0]) / np.sqrt(2.0)
    assert np.abs(g - want).max() <= 1e-3 * np.abs(want).max()
    assert np.abs(h.observables["ux"]).max() >= 0.5 * np.abs(want[:, 0]).max()
    e = h.energy_balance()
    assert np.abs(e["supplied"]).max() > 0.0
    assert np.abs(e["error"]).max() <= 1e-2 * np.abs(e["supplied"]).max()


def test_block_on_a_moving_contact_ground_slides_at_mu_g(run_case, tmp_path):
    """A rigid block (0.2 × 0.1 × 0.05 m) resting on the contact `ground`
    (friction μ = 0.4, a critically damped normal dashpot), which moves
    with the ground's acceleration rising linearly, a = c (t − t0): it
    sticks while m a ≤ μ W and then slides (Coulomb), as on the table of
    blocks below; the ground's acceleration at the start of sliding is
    μ g within 2 %; energy within 1 %, the moving ground's work through
    the contact (its friction and its dashpot) counted as input."""
    mu, g_e, t0, span = 0.4, 9.81, 0.05, 0.2
    c = 2.0 * mu * g_e / span
    tr = np.arange(0.0, t0 + span + 5e-4, 1e-3)
    np.savetxt(tmp_path / "ramp.csv", np.column_stack([tr, c * np.maximum(tr - t0, 0.0)]),
               delimiter=",")
    rho = 2000.0
    weight = rho * 0.2 * 0.1 * 0.05 * g_e
    h = run_case(f"""
name: block-on-moving-ground
parts:
  block:
    geometry: {{box: [[0.1, 0.05, 0.0], [0.3, 0.15, 0.05]]}}
    mesh: {{kind: rigid}}
    material: stone
materials: {{stone: {{density: {rho}, young: 1.0e9, poisson: 0.0}}}}
loads: [{{group: block, force: [0, 0, {-weight!r}], history: [[0, 0], [{t0}, 1], [10, 1]]}}]
contact: {{friction: {mu}, damping: 1.0, ground: {{point: [0, 0, 0], normal: [0, 0, 1]}}}}
ground_motion: {{file: {tmp_path / 'ramp.csv'}, baseline: none, direction: [1, 0, 0]}}
solver: {{mode: dynamic, end_time: {t0 + span}}}
output:
  interval: 5.0e-4
  probes:
    lag: {{group: block, quantity: displacement, component: x, reduce: mean,
          relative_to: ground}}
""")
    assert_slides_at_mu_g(h, mu, g_e, t0, c)


def test_block_on_a_shaking_table_slides_at_mu_g(run_case, tmp_path):
    """A rigid block (0.2 × 0.1 × 0.05 m) on a table of blocks held by
    `{group, fix}` (so it moves with the ground), joined by a contact
    interface with friction μ = 0.4; its weight W = m g_e applied as a force
    ramped on over 0.05 s (a settled contact: a weight applied at once sets
    the block bouncing, N swinging between 0 and 2W).  The ground's
    acceleration then rises linearly, a = c (t − t0), c = 2 μ g_e / 0.2 s.
    Coulomb: the block sticks while m a ≤ μ W, then slides with the
    kinetic μ, lagging the ground by c (t − t_s)³/6; t_s from that cubic
    (the lag taken above 1e-5 m, a hundred times the stick's elastic
    shear) gives the ground's acceleration at the start of sliding,
    c (t_s − t0) = μ g_e within 2 %."""
    mu, g_e, t0, span = 0.4, 9.81, 0.05, 0.2
    c = 2.0 * mu * g_e / span
    # sampled every millisecond, as a record is (the supports follow its
    # integral at four points a sample, linear between them)
    tr = np.arange(0.0, t0 + span + 5e-4, 1e-3)
    np.savetxt(tmp_path / "ramp.csv", np.column_stack([tr, c * np.maximum(tr - t0, 0.0)]),
               delimiter=",", header="t, a", comments="")
    rho = 2000.0
    weight = rho * 0.2 * 0.1 * 0.05 * g_e
    h = run_case(f"""
name: sliding-block
parts:
  table:
    geometry: {{box: [[0, 0, 0], [0.4, 0.2, 0.05]]}}
    mesh: {{kind: blocks, divisions: [4, 2, 1]}}
    material: stone
  block:
    geometry: {{box: [[0.1, 0.05, 0.05], [0.3, 0.15, 0.1]]}}
    mesh: {{kind: rigid}}
    material: stone
interfaces: [{{parts: [table, block], law: contact, friction: {mu}}}]
materials: {{stone: {{density: {rho}, young: 1.0e9, poisson: 0.0}}}}
boundary: [{{group: table, fix: all}}]
loads: [{{group: block, force: [0, 0, {-weight!r}], history: [[0, 0], [{t0}, 1], [10, 1]]}}]
ground_motion: {{file: {tmp_path / 'ramp.csv'}, skip: 1, baseline: none, direction: [1, 0, 0]}}
solver: {{mode: dynamic, end_time: {t0 + span}}}
output:
  interval: 5.0e-4
  probes:
    lag: {{group: block, quantity: displacement, component: x, reduce: mean,
          relative_to: ground}}
""")
    assert_slides_at_mu_g(h, mu, g_e, t0, c)


def test_block_on_spring_quake_case(run_case):
    """cases/block_on_spring_quake.yaml itself: its peak displacement
    relative to the ground against the response spectrum's Sd of the same
    (baseline-corrected) record at its period and ζ = 5 % (Rayleigh's β),
    within 1 %; the energy balance within 1 %."""
    from pathlib import Path
    from rbsm_dyn.io.spectrum import spectrum
    root = Path(__file__).resolve().parent.parent / "cases"
    text = (root / "block_on_spring_quake.yaml").read_text()
    h = run_case(text.replace("file: records/", f"file: {root / 'records'}/"))
    u = np.asarray(h.observables["u"])
    tr, ar = read_record(root / "records" / "synthetic_quake.csv", scale=0.01)
    _, (tc, ac) = integrate(tr, ar)
    omega = np.sqrt(2.0e6 / 2000.0) / 1.0                  # √(E/ρ)/L
    sd = spectrum(tc, ac, [2.0 * np.pi / omega], 0.05)["Sd"][0]
    assert np.abs(u).max() == pytest.approx(sd, rel=1e-2)
    e = h.energy_balance()
    assert np.abs(e["error"]).max() <= 1e-2 * np.abs(e["supplied"]).max()
