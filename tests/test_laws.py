"""Spring laws on a single face (two blocks, the left one held): the
perfect-plastic path, the yield surface, rupture at ε_cr, fracture energy
G_f per crack area independent of the cell size, contact and friction."""
import textwrap

import numpy as np
import pytest

from rbsm_dyn.case import load_case_text
from rbsm_dyn.model import build_model, new_state
from rbsm_dyn.physics.laws import BROKEN, CONTACT, ELASTIC, YIELDED
from rbsm_dyn.physics.arrays import SpringHistory, of
from rbsm_dyn.physics.inelastic import inelastic_spring_pass
from rbsm_dyn.solvers.passes import body_state, model_arrays

E, RHO = 200.0e9, 8000.0
SY = 250.0e6          # VERIFICATION default σy
A = 0.1 * 0.1         # face area [m²]


def pair(material, size=0.1):
    text = f"""
    name: pair
    domain: {{box: [[0, 0, 0], [{2 * size}, 0.1, 0.1]]}}
    mesh: {{kind: blocks, divisions: [2, 1, 1], spring_points: centroid}}
    materials:
      m: {{density: {RHO}, young: {E}, poisson: 0.0, {material}}}
    solver: {{mode: dynamic, end_time: 1.0}}
    """
    m = build_model(load_case_text(textwrap.dedent(text)))
    assert m.inelastic
    return m, new_state(m)


def step(m, st, u):
    """Move body 1 by u (world) relative to its rest place, run the spring
    pass once (committing the history); return the face traction (σx, τy,
    τz) [Pa]: the force on body 0 over the area (DESIGN.md §1: tension pulls
    body 0 toward body 1, σ > 0)."""
    st.body_pos[1] = m.body_pos0[1] + u
    inelastic_spring_pass(model_arrays(m)[1], body_state(st), of(SpringHistory, st), True, 0.0,
                          None)
    return st.spring_force.sum(axis=0) / A


def test_normal_yield_follows_the_perfect_plastic_path():
    """Loading past yield holds σ = σy; unloading is elastic with the initial
    slope k = E/h; reversed loading yields at −σy; the plastic work is
    σy × (plastic stretch) × area."""
    m, st = pair("yield: {criterion: normal, stress: %g}" % SY)
    k = E / 0.1                                   # per-area stiffness [Pa/m], h = 0.1
    uy = SY / k
    path = np.concatenate([np.linspace(0, 3 * uy, 31), np.linspace(3 * uy, -3 * uy, 61)[1:]])
    sig = np.array([step(m, st, [u, 0, 0])[0] for u in path])
    up = 0.0                                      # exact 1D perfect plasticity
    ref = []
    for u in path:
        trial = k * (u - up)
        s = np.clip(trial, -SY, SY)
        up += (trial - s) / k
        ref.append(s)
    assert np.allclose(sig, ref, rtol=0, atol=1e-9 * SY)
    assert np.abs(sig).max() <= SY * (1 + 1e-12)
    assert set(st.spring_state) == {YIELDED}
    # plastic work: forward 2 uy, back 4 uy at |σ| = σy
    assert st.spring_wp.sum() == pytest.approx(SY * A * 6 * uy, rel=1e-9)


@pytest.mark.parametrize("criterion, c", [("von_mises", 3.0), ("tresca", 4.0)])
def test_yield_surface_is_never_exceeded(criterion, c):
    """Combined tension and shear along a random path: √(σn² + c τ²) ≤ σy
    always (c = 3 von Mises, 4 Tresca), and the spring does yield."""
    m, st = pair("yield: {criterion: %s, stress: %g}" % (criterion, SY))
    rng = np.random.default_rng(1)
    u = np.zeros(3)
    uy = SY / (E / 0.1)
    for _ in range(300):
        u += rng.normal(scale=0.4 * uy, size=3)
        t = step(m, st, u)
        f = np.sqrt(t[0] ** 2 + c * (t[1] ** 2 + t[2] ** 2))
        assert f <= SY * (1 + 1e-10)
    assert np.all(st.spring_state == YIELDED)
    assert st.spring_wp.sum() > 0


def test_rupture_at_critical_strain():
    """Kawai Fig. 7: the spring breaks when δn/h reaches ε_cr, not before;
    once broken it carries no tension; the elastic energy it held is
    fracture energy."""
    eps = 1.0e-3
    m, st = pair("rupture: {strain: %g}" % eps)
    h = 0.1
    step(m, st, [0.999 * eps * h, 0, 0])
    assert np.all(st.spring_state == ELASTIC)
    t = step(m, st, [1.0001 * eps * h, 0, 0])
    assert np.all(st.spring_state == BROKEN)
    assert np.allclose(t, 0.0)
    assert st.spring_wf.sum() == pytest.approx(0.5 * E / h * A * (1.0001 * eps * h) ** 2, rel=1e-9)
    # closing the crack again: contact in compression, no tension
    t = step(m, st, [-1e-6, 0, 0])
    assert np.all(st.spring_state == CONTACT)
    assert t[0] == pytest.approx(-E / h * 1e-6, rel=1e-9)


@pytest.mark.parametrize("size", [0.1, 0.025])
def test_softening_dissipates_fracture_energy_per_area(size):
    """Crack band (Bažant & Oh 1983): pulled apart to full separation, a
    face dissipates G_f × area whatever the cell size (within 5 %)."""
    gf, ft = 100.0, 3.0e6
    m, st = pair("rupture: {fracture_energy: %g, tensile_strength: %g}" % (gf, ft), size=size)
    du = 2 * gf / ft
    for u in np.linspace(0, 1.2 * du, 2000):
        t = step(m, st, [u, 0, 0])
        assert t[0] <= ft * (1 + 1e-9)
    assert np.all(st.spring_state == BROKEN)
    assert st.spring_wf.sum() == pytest.approx(gf * A, rel=5e-2)


def test_friction_on_a_cut_face():
    """A pre-cut face (cuts) under compression sticks below μ|σn| and slides
    at τ = μ|σn| above it; opening releases it (no tension)."""
    text = f"""
    name: cut
    domain: {{box: [[0, 0, 0], [0.2, 0.1, 0.1]]}}
    mesh: {{kind: blocks, divisions: [2, 1, 1], spring_points: centroid}}
    materials:
      m: {{density: {RHO}, young: {E}, poisson: 0.0, friction: 0.5}}
    cuts: [{{point: [0.1, 0, 0], normal: [1, 0, 0], within: [[0.09, -1, -1], [0.11, 1, 1]]}}]
    solver: {{mode: dynamic, end_time: 1.0}}
    """
    m = build_model(load_case_text(textwrap.dedent(text)))
    st = new_state(m)
    assert m.inelastic and np.all(st.spring_state == BROKEN)
    dn = -1e-6
    small = 0.2e-6                               # τ = ks·small < μ|σn|
    t = step(m, st, [dn, small, 0])              # stick: τ = ks·u (ks = kn at ν = 0, blocks)
    assert np.all(st.spring_state == CONTACT)
    ks = m.spring_k[0, 1] / m.spring_area[0]
    assert abs(t[1]) == pytest.approx(ks * small, rel=1e-9)
    t = step(m, st, [dn, 5e-6, 0])                # slide
    assert abs(t[1]) == pytest.approx(0.5 * abs(t[0]), rel=1e-9)
    assert st.spring_wp.sum() > 0
    t = step(m, st, [1e-6, 5e-6, 0])              # open
    assert np.allclose(t, 0) and np.all(st.spring_state == BROKEN)


MIXED = ("rupture: {fracture_energy: %g, tensile_strength: %g, shear_strength: %g, "
         "shear_fracture_energy: %g}")


@pytest.mark.parametrize("direction, energy", [((1, 0, 0), "gt"), ((0, 1, 0), "gs"),
                                               ((0, 0.6, 0.8), "gs")])
def test_mixed_mode_dissipates_the_energy_of_its_mode(direction, energy):
    """Mixed-mode law (CSL form, Cusatis et al. 2011; crack band, Bažant &
    Oh 1983): a face opened in pure tension dissipates G_t × area, slid in
    pure shear (any shear direction) G_s × area, to full separation; the
    peak traction is f_t in tension and f_s in shear."""
    gt, ft, fs, gs = 100.0, 3.0e6, 6.0e6, 500.0
    m, st = pair(MIXED % (gt, ft, fs, gs), size=0.025)
    g, f = (gt, ft) if energy == "gt" else (gs, fs)
    k = E / 0.025                                  # blocks, ν = 0: k_s = k_n
    du = 2 * g / f
    d = np.asarray(direction, float)
    peak = 0.0
    for u in np.linspace(0, 1.2 * du + f / k, 3000):
        t = step(m, st, u * d)
        peak = max(peak, float(np.linalg.norm(t)))
    assert np.all(st.spring_state == BROKEN)
    assert peak == pytest.approx(f, rel=1e-2)
    assert st.spring_wf.sum() == pytest.approx(g * A, rel=1e-2)


@pytest.mark.parametrize("sigma", [-9.0e6, -3.0e6, 1.5e6])
def test_mixed_mode_envelope_is_the_csl_parabola(sigma):
    """Under a held normal traction σ the shear strength is the CSL
    envelope τ = f_s √(1 − σ/f_t) (Cusatis & Cedolin 2007): more under
    compression (friction-like), less under tension."""
    gt, ft, fs, gs = 100.0, 3.0e6, 6.0e6, 600.0
    m, st = pair(MIXED % (gt, ft, fs, gs), size=0.025)
    k = E / 0.025
    un = sigma / k
    tau_max = fs * np.sqrt(1 - sigma / ft)
    # shear grows at fixed normal gap; damage starts when the envelope is met
    peak = 0.0
    for ut in np.linspace(0, 1.5 * tau_max / k, 3000):
        t = step(m, st, [un, ut, 0])
        if st.spring_dmg.max() == 0:
            peak = abs(t[1])
    assert st.spring_dmg.max() > 0
    assert peak == pytest.approx(tau_max, rel=2e-3)


def test_supports_do_not_break_unless_asked():
    """A support on a domain face takes the cell's law without rupture by
    default: pulled far beyond the material's strength it holds (elastic),
    while the internal face next to it breaks; `breakable: true` lets it
    break like the material."""
    text = f"""
    name: sup
    domain: {{box: [[0, 0, 0], [0.2, 0.1, 0.1]]}}
    mesh: {{kind: blocks, divisions: [2, 1, 1], spring_points: centroid}}
    materials:
      m: {{density: {RHO}, young: {E}, poisson: 0.0,
           rupture: {{fracture_energy: 10.0, tensile_strength: 1.0e6}}}}
    boundary: [{{face: xmin, fix: all{{}}}}]
    solver: {{mode: dynamic, end_time: 1.0}}
    """
    for breakable, expect in ((None, ELASTIC), (True, BROKEN)):
        extra = "" if breakable is None else ", breakable: true"
        m = build_model(load_case_text(textwrap.dedent(text).replace("{}", extra)))
        st = new_state(m)
        sup = m.is_support
        assert sup.sum() == (~sup).sum() > 0        # one face each
        # body 0 pulled away from the wall by 1 mm, body 1 by 2 mm: both
        # the support face and the internal face open by 1 mm (f_t/k = 5e-7 m)
        for frac in np.linspace(0, 1, 200):
            st.body_pos[0] = m.body_pos0[0] + [1e-3 * frac, 0, 0]
            st.body_pos[1] = m.body_pos0[1] + [2e-3 * frac, 0, 0]
            step(m, st, st.body_pos[1] - m.body_pos0[1])
        assert np.all(st.spring_state[~sup] == BROKEN)
        assert np.all(st.spring_state[sup] == expect)
