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
* what does not move yet is refused, naming the key: supports by springs
  to the ground, the contact ground, a static run.
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
  probes:
    base: {{group: base, quantity: displacement, component: x, reduce: mean}}
    top: {{group: mass, quantity: displacement, component: x, reduce: mean}}
{extra}"""


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
    e = h.energy_balance()
    assert np.abs(e["error"]).max() <= 1e-2 * np.abs(e["supplied"]).max()


@pytest.mark.parametrize("change, where", [
    ({"boundary": "[{face: zmin, fix: all}, {group: mass, fix: [y, z, rx, ry, rz]}]"},
     "boundary"),
    ({"solver": "{mode: static, method: relaxation}"}, "ground_motion"),
    ({"extra": "contact: {ground: {point: [0, 0, 0], normal: [0, 0, 1]}}"}, "contact"),
])
def test_what_does_not_move_yet_is_refused(tmp_path, change, where):
    from rbsm_dyn.model import build_model
    write_record(tmp_path / "record.csv")
    text = sdof_case(**change).replace("file: record.csv", f"file: {tmp_path / 'record.csv'}")
    if "static" in text:
        text = text.replace("  interval: 0.002\n", "")
    with pytest.raises(CaseError) as err:
        build_model(load_case_text(text))
    assert err.value.path.startswith(where), err.value.path
