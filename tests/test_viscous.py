"""Viscous springs (`materials.NAME.viscoelastic`, `solver.damping.beta`
and `rayleigh`; physics/viscous.py; issue 28 items 1 and 2).

The specimen: two blocks of side L stacked in z, the lower one held; the
spring between them has k = E A/L along z (blocks, ν = 0, Kawai's
stiffness: the normal spring of a face is E/h per area, h = L the
centroids' distance), mass m = ρ L³ on the upper one.

Facts checked:
* relaxation (the upper block pulled to δ0 along a ramp of time t_r, then
  held): the force against the convolution of the ramp with the
  relaxation modulus, F(t) = k δ0/t_r ∫ E(s)/E ds over [t − t_r, t], for a
  Maxwell material (E(t) = E e^(−t/τ)), the standard linear solid and a
  three-term Prony series, within 1 % of k δ0 (Simo & Hughes 1998, §10.3);
* creep of a Kelvin solid under a dead load F: the displacement against
  the exact overdamped oscillator m ẍ + τ k ẋ + k x = F, and against
  Kelvin's creep F/k (1 − e^(−t/τ)) once the inertial transient is gone,
  within 1 %;
* the standard solid under a harmonic displacement δ0 sin ωt: the energy
  dissipated per cycle against π k δ0² g ωτ/(1 + ω²τ²) (the loss modulus
  E'' = g E ωτ/(1 + ω²τ²); Lakes, Viscoelastic Materials, 2009, §2.7)
  within 2 %;
* Rayleigh damping α M + β K from ζ = 5 % at the two natural frequencies of
  a two-storey shear column: the free decay of each mode gives ζ within
  5 % of 5 % (Chopra, Dynamics of Structures, §11.4);
* a static run in time (solver.time, solvers/creep.py): relaxation of the
  Maxwell bar and creep of the Kelvin bar against the same closed forms
  within 1 % (both exact for histories linear over each increment: the
  instants include the ramp's end); the creep beam (cases/creep_beam.yaml)
  against the correspondence principle, w(t)/w(0) = E0 J(t) within 1 %
  (Flügge, Viscoelasticity, §4.2), its w(0) against Timoshenko's within
  2 %;
* the energy balance within 1 % (the viscous observable counted as
  dissipated); a restart bitwise; 1 and 2 threads bitwise; inputs that
  cannot work refused, naming the key.
"""
import numpy as np
import pytest

from rbsm_dyn.case import CaseError, load_case_text

E, RHO, L = 1.0e6, 1000.0, 0.1
K = E * L * L / L                     # N/m, the normal spring of the face
M = RHO * L ** 3                      # kg
D0 = 1.0e-4                           # m


def bar(visco, boundary, solver, extra=""):
    return f"""
name: visco
domain: {{box: [[0, 0, 0], [{L}, {L}, {2 * L}]]}}
mesh: {{kind: blocks, divisions: [1, 1, 2]}}
materials: {{m: {{density: {RHO}, young: {E}, poisson: 0.0, viscoelastic: {visco}}}}}
groups:
  base: {{box: [[-1, -1, -1], [1, 1, {L}]]}}
  top: {{box: [[-1, -1, {L}], [1, 1, 1]]}}
boundary: {boundary}
solver: {solver}
{extra}"""


def pulled(visco, t_ramp, end, dt):
    """The bar pulled to D0 over t_ramp and held; probe f: the reaction."""
    return bar(visco, f"""
  - {{group: base, fix: all}}
  - {{group: top, fix: [x, y, rx, ry, rz]}}
  - {{group: top, displacement: [null, null, {D0}],
     history: [[0, 0], [{t_ramp}, 1], [{10 * end}, 1]]}}""",
               f"{{mode: dynamic, end_time: {end}, dt: {dt}}}",
               f"""output:
  interval: {end / 60}
  probes:
    f: {{group: top, quantity: reaction, component: z, reduce: sum}}""")


def ramp_response(t, t_ramp, g, tau):
    """F(t)/(k δ0) of a ramp to δ0 over t_ramp: (1/t_r) ∫ E(s)/E ds over
    [max(t − t_r, 0), t], E(s)/E = 1 − Σ g_i (1 − e^(−s/τ_i))."""
    def integral(s):
        out = (1.0 - sum(g)) * s
        for gi, ti in zip(g, tau):
            out -= gi * ti * np.exp(-s / ti)
        return out
    return (integral(t) - integral(np.maximum(t - t_ramp, 0.0))) / t_ramp


def balance(h):
    eb = h.energy_balance()
    return float(np.max(np.abs(eb["error"])) / np.max(np.abs(eb["supplied"])))


RELAXATION = {
    "maxwell": ("{kind: maxwell, tau: 0.05}", [1.0], [0.05]),
    "standard": ("{kind: standard, relaxed: 4.0e5, tau: 0.05}", [0.6], [0.05]),
    "prony": ("{kind: prony, terms: [[3.0e5, 0.01], [2.0e5, 0.05], [1.0e5, 0.2]]}",
              [0.3, 0.2, 0.1], [0.01, 0.05, 0.2]),
}


@pytest.mark.parametrize("kind", list(RELAXATION))
def test_relaxation_against_the_relaxation_modulus(run_case, kind):
    visco, g, tau = RELAXATION[kind]
    t_ramp, end = 0.01, 0.5
    h = run_case(pulled(visco, t_ramp, end, 5.0e-5))
    t = np.asarray(h.time)
    f = np.asarray(h.observables["f"])
    want = K * D0 * ramp_response(t, t_ramp, g, tau)
    assert np.max(np.abs(f - want)) <= 0.01 * K * D0
    # relaxed: the force has fallen to E∞/E of the glassy one (maxwell: 0)
    assert f[-1] <= K * D0 * (1.0 - sum(g) + 0.5 * max(np.exp(-end / max(tau)), 1e-3))
    assert balance(h) <= 0.01


def test_kelvin_creep_under_a_dead_load(run_case):
    """ζ = τ ω/2 = 10: overdamped, the creep curve within 1/(4ζ²) of
    Kelvin's law after the inertial transient (a time 1/(2ζω))."""
    omega = np.sqrt(K / M)
    tau = 20.0 / omega
    force = 5.0
    h = run_case(bar(f"{{kind: kelvin, tau: {tau}}}", """
  - {group: base, fix: all}
  - {group: top, fix: [x, y, rx, ry, rz]}""", f"{{mode: dynamic, end_time: {5 * tau}}}",
                     f"""loads: [{{group: top, force: [0, 0, {force}]}}]
output:
  interval: {tau / 20}
  probes:
    u: {{group: top, quantity: displacement, component: z, reduce: mean}}"""))
    t = np.asarray(h.time)
    u = np.asarray(h.observables["u"])
    c = tau * K
    disc = np.sqrt(c * c - 4.0 * M * K)
    r1, r2 = (-c + disc) / (2.0 * M), (-c - disc) / (2.0 * M)
    exact = force / K * (1.0 + (r2 * np.exp(r1 * t) - r1 * np.exp(r2 * t)) / (r1 - r2))
    assert np.max(np.abs(u - exact)) <= 0.01 * force / K
    late = t > 0.2 * tau
    creep = force / K * (1.0 - np.exp(-t / tau))
    assert np.max(np.abs(u - creep)[late]) <= 0.01 * force / K
    assert balance(h) <= 0.01


def test_standard_solid_loss_per_cycle(run_case):
    """ωτ = 1 (the largest loss); the cycle from 3 to 4 periods, when the
    start's transient (e^(−t/τ)) has died out; the displacement table has
    128 points a period."""
    g, period = 0.6, 0.1
    omega = 2.0 * np.pi / period
    tau = 1.0 / omega
    ts = np.linspace(0.0, 5 * period, 5 * 128 + 1)
    table = ", ".join(f"[{a:.8g}, {b:.10g}]" for a, b in zip(ts, np.sin(omega * ts)))
    text = bar(f"{{kind: standard, relaxed: {(1 - g) * E}, tau: {tau}}}", f"""
  - {{group: base, fix: all}}
  - {{group: top, fix: [x, y, rx, ry, rz]}}
  - {{group: top, displacement: [null, null, {D0}], history: [{table}]}}""", f"{{mode: dynamic, end_time: {4 * period}, dt: 2.5e-5}}",
               f"output: {{interval: {period / 8}}}")
    h = run_case(text)
    t = np.asarray(h.time)
    wv = np.asarray(h.observables["viscous"])
    i3, i4 = (int(np.argmin(np.abs(t - n * period))) for n in (3, 4))
    assert abs(t[i3] - 3 * period) < 1e-6 and abs(t[i4] - 4 * period) < 1e-6
    want = np.pi * K * D0 ** 2 * g * omega * tau / (1.0 + (omega * tau) ** 2)
    assert abs((wv[i4] - wv[i3]) / want - 1.0) <= 0.02


def test_rayleigh_damping_of_two_modes(run_case):
    """Three blocks stacked in z, the lowest held, the upper two free to
    slide in x alone: a two-storey shear column, K = k_s [[2, −1], [−1, 1]],
    M = m I, ω² = (3 ∓ √5)/2 k_s/m, k_s the faces' shear spring.  The upper
    block starts at 0.01 m/s; the modal coordinates q_i = φ_i·x/|φ_i|²
    decay as e^(−ζ ω_i t)."""
    from rbsm_dyn.case import load_case_text as load
    from rbsm_dyn.model import build_model
    case_text = lambda solver: f"""
name: column
domain: {{box: [[0, 0, 0], [{L}, {L}, {3 * L}]]}}
mesh: {{kind: blocks, divisions: [1, 1, 3]}}
materials: {{m: {{density: {RHO}, young: {E}, poisson: 0.0}}}}
groups:
  base: {{box: [[-1, -1, -1], [1, 1, {L}]]}}
  one: {{box: [[-1, -1, {L}], [1, 1, {2 * L}]]}}
  two: {{box: [[-1, -1, {2 * L}], [1, 1, 1]]}}
boundary: [{{group: base, fix: all}}, {{group: one, fix: [y, z, rx, ry, rz]}},
           {{group: two, fix: [y, z, rx, ry, rz]}}]
initial: [{{group: two, velocity: [0.01, 0, 0]}}]
solver: {solver}
output:
  interval: 0.002
  probes:
    x1: {{group: one, quantity: displacement, component: x, reduce: mean}}
    x2: {{group: two, quantity: displacement, component: x, reduce: mean}}
"""
    model = build_model(load(case_text("{mode: dynamic, end_time: 1.0}")))
    # the shear spring of a face: the sum over its spring points [N/m]
    pair = np.sort(model.spring_bodies, axis=1)
    ks = float(model.spring_k[(pair[:, 0] == 0) & (pair[:, 1] == 1), 1].sum())
    assert np.allclose(model.spring_k[:, 1:], model.spring_k[:1, 1:])
    lam = np.array([(3 - np.sqrt(5)) / 2, (3 + np.sqrt(5)) / 2]) * ks / M
    omega = np.sqrt(lam)
    phi = np.array([[1.0, ks / (ks - M * w2) * 1.0] for w2 in lam])  # x2/x1 from row 2
    f1, f2 = omega / (2 * np.pi)
    zeta = 0.05
    end = 12.0 / f1 * 1.0
    h = run_case(case_text(f"{{mode: dynamic, end_time: {end:.6g}, dt: 2.0e-4, damping: "
                           f"{{rayleigh: {{ratio: {zeta}, frequencies: [{f1:.10g}, {f2:.10g}]}}}}}}"))
    t = np.asarray(h.time)
    x = np.stack([np.asarray(h.observables["x1"]), np.asarray(h.observables["x2"])])
    from scipy.optimize import curve_fit
    for i in range(2):
        q = phi[i] @ x / (phi[i] @ phi[i])
        wd = omega[i] * np.sqrt(1 - zeta ** 2)

        def decay(tt, a, b, s):
            return np.exp(-s * tt) * (a * np.cos(wd * tt) + b * np.sin(wd * tt))
        p, _ = curve_fit(decay, t, q, p0=(0.0, q.max(), zeta * omega[i]))
        assert abs(p[2] / omega[i] / zeta - 1.0) <= 0.05, (i, p[2] / omega[i])
    assert balance(h) <= 0.01


def test_restart_is_bitwise(tmp_path):
    """A run with Maxwell branches and a dashpot, on a base shaken by a
    ground motion, continued from its checkpoint ends in the
    uninterrupted run's state bit for bit (the ground's row too)."""
    from rbsm_dyn.__main__ import main
    from rbsm_dyn.solvers.checkpoint import ARRAYS, read_checkpoint
    record = tmp_path / "shake.csv"
    tr = np.linspace(0.0, 0.06, 61)
    np.savetxt(record, np.column_stack([tr, 5.0 * np.sin(300.0 * tr)]), delimiter=",")
    text = lambda end: bar("{kind: prony, terms: [[3.0e5, 0.01], [2.0e5, 0.05]]}", """
  - {group: base, fix: all}""", f"{{mode: dynamic, end_time: {end}, damping: {{beta: 1.0e-4}}}}",
                           "initial: [{group: top, velocity: [0.01, 0.02, 0.03]}]\n"
                           f"ground_motion: {{file: {record}, baseline: none, direction: [1, 0, 0]}}\n"
                           "output: {interval: 0.001}")
    ref_case, case = tmp_path / "ref.yaml", tmp_path / "case.yaml"
    ref_case.write_text(text(0.06))
    case.write_text(text(0.03))
    ref, out = tmp_path / "ref.h5", tmp_path / "out.h5"
    assert main([str(ref_case), "--out", str(ref), "--quiet"]) == 0
    assert main([str(case), "--out", str(out), "--quiet"]) == 0
    case.write_text(text(0.06))
    assert main([str(case), "--restart", str(out), "--quiet"]) == 0
    got, _ = read_checkpoint(out)
    want, _ = read_checkpoint(ref)
    assert np.abs(want["spring_q"]).max() > 0.0
    assert abs(want["body_pos"][-1, 0]) > 0.0         # the ground has moved
    for name in ARRAYS + ("step", "dt"):
        assert np.array_equal(got[name], want[name]), name


@pytest.mark.parametrize("visco, key, words", [
    ("{kind: maxwell}", "materials.m.viscoelastic.tau", "required"),
    ("{kind: kelvin, tau: 1.0, relaxed: 1.0}", "materials.m.viscoelastic.relaxed", "not used"),
    ("{kind: standard, tau: 1.0, relaxed: 2.0e6}", "materials.m.viscoelastic.relaxed", "below"),
    ("{kind: prony, terms: [[8.0e5, 1.0], [4.0e5, 2.0]]}", "materials.m.viscoelastic.terms",
     "sum"),
])
def test_bad_viscoelastic_keys_are_refused(visco, key, words):
    with pytest.raises(CaseError) as e:
        load_case_text(bar(visco, "[{group: base, fix: all}]", "{mode: dynamic, end_time: 1}"))
    assert key in str(e.value) and words in str(e.value)


def test_what_does_not_combine_is_refused():
    text = bar("{kind: maxwell, tau: 1.0}", "[{group: base, fix: all}]",
               "{mode: dynamic, end_time: 1}")
    with pytest.raises(CaseError, match=r"viscoelastic\.kind.*rupture"):
        load_case_text(text.replace("poisson: 0.0,", "poisson: 0.0, rupture: {strain: 0.01},"))
    with pytest.raises(CaseError, match=r"materials\.m\.viscoelastic.*solver\.time"):
        load_case_text(text.replace("{mode: dynamic, end_time: 1}", "{mode: static}"))
    with pytest.raises(CaseError, match=r"solver\.method.*newton"):
        load_case_text(text.replace("{mode: dynamic, end_time: 1}",
                                    "{mode: static, method: relaxation, time: [1, 2]}"))
    with pytest.raises(CaseError, match=r"solver\.time\[1\].*increasing"):
        load_case_text(text.replace("{mode: dynamic, end_time: 1}",
                                    "{mode: static, time: [1, 1, 2]}"))
    with pytest.raises(CaseError, match=r"solver\.damping\.alpha.*rayleigh"):
        load_case_text(text.replace("end_time: 1}", "end_time: 1, damping: {alpha: 1.0, "
                                    "rayleigh: {ratio: 0.05, frequencies: [1, 2]}}}"))
    # a Kelvin dashpot does combine with rupture (it acts while the spring is intact)
    load_case_text(text.replace("{kind: maxwell, tau: 1.0}", "{kind: kelvin, tau: 1.0}")
                   .replace("poisson: 0.0,", "poisson: 0.0, rupture: {strain: 0.01},"))


def test_threads_give_the_same_numbers(thread_states, tmp_path):
    """Above SERIAL_SPRINGS the viscous pass runs phase by phase in the
    springs' schedule (no atomics): 1 and 2 threads end bit for bit alike,
    with the face's support springs moving with a ground motion (the
    ground's work booked per body, physics/integrate.py)."""
    from rbsm_dyn.solvers.checkpoint import ARRAYS
    record = tmp_path / "shake.csv"
    tr = np.linspace(0.0, 2.0e-3, 41)
    np.savetxt(record, np.column_stack([tr, 50.0 * np.sin(3000.0 * tr)]), delimiter=",")
    text = f"""
name: threads
domain: {{box: [[0, 0, 0], [1.0, 0.5, 0.5]]}}
mesh: {{kind: blocks, divisions: [12, 6, 6]}}
materials: {{m: {{density: {RHO}, young: {E}, poisson: 0.2,
                 viscoelastic: {{kind: prony, terms: [[3.0e5, 1.0e-3], [2.0e5, 1.0e-2]]}}}}}}
boundary: [{{face: xmin, fix: all}}]
initial: [{{velocity: [0, 0, -0.5], angular_velocity: [0, 0, 1.0]}}]
ground_motion: {{file: {record}, baseline: none, direction: [0, 0, 1]}}
solver: {{mode: dynamic, end_time: 2.0e-3, damping: {{beta: 2.0e-5}}}}
"""
    a, b = thread_states(text)
    assert a["spring_q"].shape[0] >= 4096
    assert np.abs(a["spring_q"]).max() > 0.0
    assert abs(a["body_pos"][-1, 2]) > 0.0           # the ground has moved
    for name in ARRAYS:
        assert np.array_equal(a[name], b[name]), name


def test_rayleigh_damping_of_a_cantilever(run_case):
    """A cantilever of ten blocks (1 × 0.1 × 0.1 m, clamped at xmin, bending
    in x–z): its first two bending modes from the modal solver; Rayleigh
    damping with ζ = 5 % at their frequencies; a uniform start velocity
    along z excites both.  Each mode's modal velocity q̇_i = φ_iᵀ M v /
    φ_iᵀ M φ_i (M the bodies' masses and inertias) decays as e^(−ζ ω_i t):
    ζ fitted within 5 % of 5 %.  This checks β through the springs'
    moment arms and α on the rotations, which the shear column does not."""
    def text(solver, extra=""):
        return f"""
name: cantilever
domain: {{box: [[0, 0, 0], [1.0, 0.1, 0.1]]}}
mesh: {{kind: blocks, divisions: [10, 1, 1]}}
materials: {{m: {{density: {RHO}, young: {E}, poisson: 0.0}}}}
boundary: [{{face: xmin, fix: all}}, {{group: all, fix: [y, rx, rz]}}]
solver: {solver}
{extra}"""
    modal = run_case(text("{mode: modal, modes: 4}"))
    freq = np.asarray(modal["modes/frequency"])
    shape = np.asarray(modal["modes/shape"])              # (M, N, 6)
    bending = [i for i in range(len(freq))
               if np.abs(shape[i, :, 2]).max() > np.abs(shape[i, :, 0]).max()][:2]
    f1, f2 = freq[bending]
    assert 5.0 < f2 / f1 < 7.0                             # 6.27 for Euler–Bernoulli
    zeta = 0.05
    end = 8.0 / f1
    h = run_case(text(f"{{mode: dynamic, end_time: {end:.6g}, damping: {{rayleigh: "
                      f"{{ratio: {zeta}, frequencies: [{f1:.10g}, {f2:.10g}]}}}}}}",
                      f"""initial: [{{group: all, velocity: [0, 0, 0.01]}}]
output: {{interval: {1 / (40 * f2):.6g}, fields: [velocity, angular_velocity]}}"""))
    from rbsm_dyn.case import load_case_text as load
    from rbsm_dyn.model import build_model
    model = build_model(load(text("{mode: modal, modes: 4}")))
    m = model.body_mass
    inertia = model.body_inertia.mean(axis=1)              # cubes: isotropic
    w = np.concatenate([np.repeat(m[:, None], 3, axis=1), np.repeat(inertia[:, None], 3, axis=1)],
                       axis=1)                             # (N, 6)
    t = np.asarray(h.time)
    v = np.concatenate([np.asarray(h.velocity), np.asarray(h.angular_velocity)], axis=2)
    from scipy.optimize import curve_fit
    for i, f in zip(bending, (f1, f2)):
        phi = shape[i]
        q = np.einsum("tnk,nk->t", v, w * phi) / np.sum(w * phi * phi)
        omega = 2 * np.pi * f
        wd = omega * np.sqrt(1 - zeta ** 2)

        def decay(tt, a, b, s):
            return np.exp(-s * tt) * (a * np.cos(wd * tt) + b * np.sin(wd * tt))
        p, _ = curve_fit(decay, t, q, p0=(q[0], 0.0, zeta * omega))
        assert abs(p[2] / omega / zeta - 1.0) <= 0.05, (f, p[2] / omega)
    assert balance(h) <= 0.01


STATIC = {
    # kind, the bar's history, the probe, the closed form's kernel ∫ over
    # [t − t_r, t] of the response to a unit rate (t_r = 1 s, τ = 100 s)
    "maxwell": ("{kind: maxwell, tau: 100.0}",
                f"- {{group: top, displacement: [null, null, {D0}], history: [[0, 0], [1.0, 1], "
                "[1.0e9, 1]]}", "{group: top, quantity: reaction, component: z, reduce: sum}",
                lambda x: -100.0 * np.exp(-x / 100.0), K * D0),
    "kelvin": ("{kind: kelvin, tau: 100.0}", "", "{group: top, quantity: displacement, "
               "component: z, reduce: mean}",
               lambda x: x + 100.0 * np.exp(-x / 100.0), 5.0 / K),
}


@pytest.mark.parametrize("kind", list(STATIC))
def test_static_in_time_against_the_closed_forms(run_case, kind):
    """Maxwell: the bar pulled to δ0 over 1 s, then held: F = k δ0 e^(−t/τ)
    convolved with the ramp; Kelvin: 5 N ramped on over 1 s, then held:
    u = (F/k)(1 − e^(−t/τ)) convolved with the ramp.  Seven instants from
    1 s to 1 000 s (= 10 τ)."""
    visco, item, probe, kernel, scale = STATIC[kind]
    loads = "" if kind == "maxwell" else \
        "loads: [{group: top, force: [0, 0, 5.0], history: [[0, 0], [1.0, 1], [1.0e9, 1]]}]"
    h = run_case(bar(visco, f"""
  - {{group: base, fix: all}}
  - {{group: top, fix: [x, y, rx, ry, rz]}}
  {item}""", "{mode: static, time: [1.0, 3, 10, 30, 100, 300, 1000]}", f"""{loads}
output:
  probes:
    p: {probe}"""))
    t = np.asarray(h.time)
    got = np.asarray(h.observables["p"])
    want = scale * (kernel(t) - kernel(np.maximum(t - 1.0, 0.0)))
    assert len(t) == 8 and t[-1] == 1000.0
    assert np.max(np.abs(got - want)) <= 0.01 * np.max(np.abs(want))
    assert balance(h) <= 0.01


def test_creep_beam_case(run_case):
    """cases/creep_beam.yaml itself (its header: the standard solid's
    J(t), τr = 90 days, and Timoshenko's w(0) = 1.146 mm)."""
    from pathlib import Path
    text = (Path(__file__).parent.parent / "cases" / "creep_beam.yaml").read_text()
    h = run_case(text)
    t = np.asarray(h.time)[1:]
    w = -np.asarray(h.observables["mid_z"])[1:]
    e0, e_inf, tau_r = 30.0e9, 10.0e9, 90 * 86400.0
    creep = e0 / e_inf * (1.0 - (1.0 - e_inf / e0) * np.exp(-t / tau_r))      # E0 J(t)
    w0 = w[0] / creep[0]
    assert np.max(np.abs(w / (w0 * creep) - 1.0)) <= 0.01
    assert t[-1] == pytest.approx(8.64e7) and w[-1] / w0 == pytest.approx(3.0, rel=0.01)
    assert w0 == pytest.approx(1.146e-3, rel=0.02)
    assert balance(h) <= 0.01
