"""Stability of the explicit integrator (issue 5): the estimated step
against the true limit found by a dt sweep, energy conservation of the
central difference, contact after rupture at the estimated step.  Timings
live in benchmarks/stability.py; here only the facts, on small models.

Energies (as the history records them): E = kinetic at the synchronized
v_n, L_n + strain at x_n.  The leapfrog conserves exactly, for a linear
system, the modified energy Ẽ = ½ v_{n−½}·M v_{n+½} + strain = E −
(dt²/8) fᵀM⁻¹f (Hairer, Lubich & Wanner, Geometric Numerical Integration,
§I.4); E itself oscillates about it, for a single mode of frequency ω by
a relative (ω dt)²/4 / (1 − (ω dt)²/4), and does not drift.
"""
import dataclasses
import functools
import textwrap

import numpy as np
import pytest

from rbsm_dyn.case import load_case_text
from rbsm_dyn.model import apply_initial, build_model, new_state
from rbsm_dyn.physics.integrate import refresh_all_rotations
from rbsm_dyn.physics.laws import BROKEN, CONTACT
from rbsm_dyn.physics.laws.contact import contact_traction
from rbsm_dyn.physics.rotation import axis_angle_quat, quat_matrix_np, quat_mul_np
from rbsm_dyn.solvers import modal
from rbsm_dyn.solvers.explicit import advance, choose_dt, spring_pass, start_half_step, synchronize
from rbsm_dyn.solvers.output import strain_energy_of

STEEL = "{density: 7850, young: 200.0e9, poisson: 0.2}"
GLASS = ("{density: 2500, young: 60.0e9, poisson: 0.2, rupture: {strain: 1.0e-3}, "
         "friction: 0.5}")
BEAM = "[[0, 0, 0], [0.4, 0.1, 0.1]]"
MESHES = {
    "blocks": "{kind: blocks, divisions: [8, 2, 2]}",
    "voronoi": "{kind: voronoi, size: 0.045, seed: 2}",
    # no minimum seed spacing: slivers (smallest cell 0.1 of the mean volume)
    "slivers": "{kind: voronoi, size: 0.045, seed: 1, min_spacing: 0.0}",
}
GROWTH = 10.0
TRIAL_STEPS = 1000


def build(text):
    case = load_case_text(textwrap.dedent(text))
    return case, build_model(case)


def beam(mesh, material=STEEL, box=BEAM, boundary="[{face: xmin, fix: all}]"):
    """A model supported on face xmin (support springs), steel by default;
    the group `tip` (cells beyond x = 0.35) on the 0.4 m beam."""
    tip = "groups: {tip: {box: [[0.35, -1, -1], [1, 1, 1]]}}" if box == BEAM else ""
    return build(f"""
    name: stability
    domain: {{box: {box}}}
    mesh: {mesh}
    materials:
      m: {material}
    {tip}
    boundary: {boundary}
    solver: {{mode: dynamic, end_time: 1.0}}
    """)


def energies(m, st):
    """(E, Ẽ, strain) at the current whole step (module docstring)."""
    vel, ang = synchronize(m, st)
    R = st.body_rot[:-1]
    lb = np.einsum("nki,nk->ni", R, ang)
    lb_m = np.einsum("nki,nk->ni", R, st.body_angmom[:-1])
    v_m = st.body_vel[:-1]
    u = strain_energy_of(m, st)
    mass = m.body_mass[:, None]
    ek = 0.5 * np.sum(mass * vel * vel) + 0.5 * np.sum(lb * lb / m.body_inertia)
    # v_{n+½} = 2 v_n − v_{n−½} (no damping, no constrained DOF)
    ek_mod = 0.5 * np.sum(mass * v_m * (2 * vel - v_m)) + \
        0.5 * np.sum(lb_m * (2 * lb - lb_m) / m.body_inertia)
    return float(ek + u), float(ek_mod + u), float(u)


def random_field(m, st, amp=1.0e-3, seed=0):
    """Random velocity (σ = amp) and spin (σ = amp / cell size) on every body."""
    rng = np.random.default_rng(seed)
    n = m.n_bodies
    st.body_vel[:-1] = amp * rng.standard_normal((n, 3))
    wb = amp / np.cbrt(m.body_volume)[:, None] * rng.standard_normal((n, 3))
    st.body_angmom[:-1] = np.einsum("nik,nk->ni", st.body_rot[:-1], m.body_inertia * wb)


def stable(m, dt, n_steps=TRIAL_STEPS, chunk=100):
    """True when n_steps from a random field at dt keep E ≤ GROWTH · E0.  A
    stable mode's E stays within 1/(1 − (ω dt)²/4) of its mean and the random
    field gives the top modes a small share, while past the limit by ε the
    worst mode grows by ≥ 1 + 2√ε per step (λ + 1/λ = 2 − (ω dt)²): ×10⁴ in
    energy within ~60 steps at ε = 0.1 %."""
    st = new_state(m)
    st.dt = dt
    random_field(m, st)
    start_half_step(m, st)
    e0 = energies(m, st)[0]
    for _ in range(n_steps // chunk):
        advance(m, st, chunk)
        e = energies(m, st)[0]
        if not np.isfinite(e) or e > GROWTH * e0:
            return False
    return True


@functools.lru_cache(maxsize=None)
def sweep(name):
    """(model, estimate, lo, hi): the limit bracketed to 3 % by bisection
    from [estimate, 2 × estimate] (lo stable, hi unstable)."""
    _, m = beam(MESHES[name])
    est = m.stable_dt()
    lo, hi = est, 2.0 * est
    assert stable(m, lo), f"{name}: unstable at the estimated step {est:.4g} s"
    assert not stable(m, hi), f"{name}: still stable at twice the estimate"
    while hi / lo > 1.03:
        mid = np.sqrt(lo * hi)
        lo, hi = (mid, hi) if stable(m, mid) else (lo, mid)
    return m, est, lo, hi


@pytest.mark.parametrize("name", list(MESHES))
def test_estimate_is_below_the_swept_limit_and_above_half_of_it(name):
    """Issue 5: Model.stable_dt() is safe (below the limit found by the dt
    sweep) and not wasteful (above half of it)."""
    _, est, lo, hi = sweep(name)
    assert est < lo
    assert est > hi / 2


@pytest.mark.parametrize("name", list(MESHES))
def test_swept_limit_is_two_over_omega_max(name):
    """The sweep finds the central-difference limit 2/ω_max (Belytschko, Liu
    & Moran, Nonlinear FE, §6.3; ω_max by Lanczos): 2/ω_max lies in the
    3 % bracket (widened by 0.5 % for eigsh's tolerance and the rotations'
    nonlinearity at this amplitude)."""
    m, _, lo, hi = sweep(name)
    exact = 2.0 / modal.omega_max(m)
    assert lo / 1.005 <= exact <= hi * 1.005


@pytest.mark.parametrize("name", list(MESHES))
def test_criterion_flags_a_step_just_past_the_limit(name):
    """The criterion can fail: 1.1 × the bracket's unstable end is flagged,
    and so is 1.02 × 2/ω_max (growth ≥ 1 + 2√0.02 = 1.28 per step), while
    0.98 × 2/ω_max is not (E of the top mode stays within 1/(1 − 0.96) of
    its mean, and that mode holds a small share of E0)."""
    m, _, lo, hi = sweep(name)
    exact = 2.0 / modal.omega_max(m)
    assert not stable(m, 1.1 * hi)
    assert not stable(m, 1.02 * exact)
    assert stable(m, 0.98 * exact)


def test_estimate_within_two_on_the_worst_sliver_mesh():
    """The worst sliver mesh of benchmarks/stability.py (ν = 0.2): plain
    Gershgorin gave 0.498 of 2/ω_max; the Collatz–Wielandt sweeps of
    model.omega_max_bound must bring it within the factor 2 (and stay safe)."""
    _, m = beam("{kind: voronoi, size: 0.035, seed: 3, min_spacing: 0.0}")
    exact = 2.0 / modal.omega_max(m)
    assert 0.5 * exact < m.stable_dt() < exact


# ------------------------------------------------------------- energy drift

def bending_start(dt_field):
    """The blocks cantilever at the case's dt (default dt_safety 0.8),
    started at velocity `dt_field` ('mode': first bending mode, largest
    speed 1e-3 m/s; 'tip': the tip cells at 1e-3 m/s, every mode)."""
    case, m = beam(MESHES["blocks"])
    dt, _ = choose_dt(case, m)
    st = new_state(m)
    st.dt = dt
    amp = 1.0e-3               # strain ~ amp/c0 ~ 2e-7: the linear range
    if dt_field == "mode":
        res = modal.natural_modes(m, 1)
        shape = res.shape[0]
        st.body_vel[:-1] = amp * shape[:, :3]
        wb = np.einsum("nki,nk->ni", st.body_rot[:-1], amp * shape[:, 3:])
        st.body_angmom[:-1] = np.einsum("nik,nk->ni", st.body_rot[:-1], m.body_inertia * wb)
        omega = res.omega[0]
    else:
        st.body_vel[m.groups["tip"], 2] = -amp
        omega = modal.omega_max(m)
    start_half_step(m, st)
    return m, st, omega


def energy_series(m, st, n_steps, every):
    out = [energies(m, st)]
    while st.step < n_steps:
        advance(m, st, every)
        out.append(energies(m, st))
    return np.array(out)


def test_energy_of_one_mode_oscillates_by_its_formula_and_does_not_drift():
    """2·10⁴ steps of the first bending mode at the case's step: |E − E0|/E0
    stays within (ω₁dt)²/4 / (1 − (ω₁dt)²/4) ≈ 1.8e-5 (module docstring;
    + 1e-7 for the rotations' nonlinearity at strain ~ 2e-7), and the
    modified energy Ẽ that E oscillates about stays within 1e-7 of its start
    (measured 2e-9: nonlinearity and round-off), so E does not drift."""
    m, st, omega1 = bending_start("mode")
    h2 = (omega1 * st.dt) ** 2 / 4
    assert 1e-6 < h2 < 1e-4                  # a tight bound, and below the 1e-4
    s = energy_series(m, st, 20000, 50)
    E, Et = s[:, 0], s[:, 1]
    assert np.abs(E - E[0]).max() <= (h2 / (1 - h2) + 1e-7) * E[0]
    assert np.abs(E - E[0]).max() >= 0.5 * h2 * E[0]      # the oscillation is there
    assert np.abs(Et - Et[0]).max() <= 1e-7 * Et[0]


def test_modified_energy_is_conserved_when_every_mode_is_excited():
    """The tip cells started at 1e-3 m/s excite every mode: E then moves by
    up to (dt²/8) fᵀM⁻¹f ≤ ((ω_max dt)²/4)·U (Rayleigh quotient of M⁻¹K)
    at every sample, while the leapfrog's modified energy Ẽ stays within
    1e-6 of its start over 2·10⁴ steps (exact for the linear system; the
    rest is the rotations' nonlinearity at strain ~ 2e-7, and round-off)."""
    m, st, omega_max = bending_start("tip")
    s = energy_series(m, st, 20000, 100)
    E, Et, U = s.T
    bound = (omega_max * st.dt) ** 2 / 4 * U
    assert np.all(np.abs(E - Et) <= bound * (1 + 1e-6) + 1e-12 * E[0])
    assert np.abs(E - E[0]).max() > 1e-3 * E[0]          # E does move (high modes) ...
    assert np.abs(Et - Et[0]).max() <= 1e-6 * Et[0]      # ... Ẽ does not


# -------------------------------------------------- contact after rupture

def test_contact_is_never_stiffer_than_the_intact_spring():
    """The estimate is computed from the intact springs; contact.py uses the
    same k_n and k_s, so a closed face's tangent (central differences of
    contact_traction at random closed states, sticking and sliding) is at
    most k_n normal and k_s tangential: K_contact ≤ K_intact and ω_max can
    only fall.  Tolerance 1e-6: the difference quotient's round-off."""
    rng = np.random.default_rng(3)
    kn, ks, mu = 2.0e12, 1.5e12, 0.5
    for _ in range(200):
        dn = -abs(rng.normal()) * 1e-6
        ds, dt = rng.normal(size=2) * 1e-6
        slip = rng.normal(size=2) * 1e-6
        e = 1e-12
        J = np.zeros((3, 3))
        for c in range(3):
            p = np.array([dn, ds, dt])
            q = p.copy()
            p[c] += e
            q[c] -= e
            fp = contact_traction(mu, kn, ks, ks, *p, *slip)[:3]
            fq = contact_traction(mu, kn, ks, ks, *q, *slip)[:3]
            J[:, c] = (np.array(fp) - np.array(fq)) / (2 * e)
        assert J[0, 0] <= kn * (1 + 1e-6)
        assert np.linalg.norm(J[1:, 1:], 2) <= ks * (1 + 1e-6)


def rupture_run(n_steps=300, every=5):
    """A Voronoi glass block (64 cells) thrown at (20, 0, −300) m/s onto a
    breakable support, at dt = Model.stable_dt() itself (beyond the
    largest dt_safety a case may ask for, case.DT_SAFETY_MAX): every spring
    breaks and most are in closed contact during the impact."""
    case, m = build(f"""
    name: rupture
    domain: {{box: [[0, 0, 0], [0.1, 0.1, 0.1]]}}
    mesh: {{kind: voronoi, size: 0.025, seed: 4}}
    materials:
      glass: {GLASS}
    boundary: [{{face: zmin, fix: all, breakable: true}}]
    initial: [{{velocity: [20.0, 0, -300.0]}}]
    solver: {{mode: dynamic, end_time: 1.0}}
    """)
    _, est = choose_dt(case, m)
    dt = est
    st = new_state(m)
    st.dt = dt
    apply_initial(case, m, st)
    start_half_step(m, st)
    rows = []
    while True:
        e, et, _ = energies(m, st)
        w = float(st.spring_wp.sum() + st.spring_wf.sum())
        rows.append((e, et, w, np.count_nonzero(st.spring_state == CONTACT),
                     np.count_nonzero(st.spring_state >= BROKEN)))
        if st.step >= n_steps:
            return m, st, np.array(rows)
        advance(m, st, every)


def test_rupture_into_contact_at_the_estimated_step_is_stable_and_bounded():
    """At dt = stable_dt(): finite; more than half of the springs in closed
    contact at some sample; the modified energy plus friction and fracture
    work never exceeds the initial energy (no external work: supports are
    springs) by more than 1 % of it (contact switching within a step is not
    energy-exact; measured 0.11 %, while an instability grows without bound
    and the 180° frame flip below adds 7 % in one step).  The books lose up
    to 10 % (a closed face that opens drops its tangential elastic energy
    unbooked, contact.py; measured −6.3 %)."""
    m, st, r = rupture_run()
    E, Et, W, n_contact, n_broken = r.T
    e0 = E[0]
    assert np.all(np.isfinite(r)) and np.all(np.isfinite(st.body_pos))
    assert n_broken[-1] == m.n_springs
    assert n_contact.max() > 0.5 * m.n_springs
    assert np.all(Et + W - e0 <= 0.01 * e0)
    assert np.all(Et + W - e0 >= -0.10 * e0)


def test_contact_force_is_continuous_through_half_a_turn():
    """Two cells with a cut face between them; cell b turned about the y axis
    through the face centre by 179.9° and by 180.1° (and pushed 0.1 mm
    toward a).  The mid frame's sign branch switches at 180°, so a pair
    still counted as touching there read a continuous world gap as a sudden
    penetration (benchmarks/stability.py: +0.07 E0 in one step).  A broken
    pair turned by more than 90° is parted (inelastic.py): both forces are
    zero, while the same push without the turn closes the contact."""
    _, m = build(f"""
    name: flip
    domain: {{box: [[0, 0, 0], [0.2, 0.1, 0.1]]}}
    mesh: {{kind: blocks, divisions: [2, 1, 1]}}
    materials:
      glass: {GLASS}
    cuts: [{{point: [0.1, 0, 0], normal: [1, 0, 0], within: [[0.09, -1, -1], [0.11, 1, 1]]}}]
    solver: {{mode: dynamic, end_time: 1.0}}
    """)
    b = int(np.argmax(m.body_pos0[:-1, 0]))
    centre = np.array([0.1, 0.05, 0.05])
    forces = []
    for deg in (0.0, 179.9, 180.1):
        st = new_state(m)
        q = axis_angle_quat([0.0, 1.0, 0.0], np.radians(deg))
        st.body_pos[b] = quat_matrix_np(q) @ (m.body_pos0[b] - centre) + centre + [-1e-4, 0, 0]
        st.body_quat[b] = quat_mul_np(q, m.body_quat0[b])
        refresh_all_rotations(m.n_bodies + 1, st.body_quat, m.body_quat0, st.body_rot, st.body_dq)
        spring_pass(m, st)
        forces.append(st.spring_force.sum(axis=0))
    assert forces[0][0] < 0.0          # pushed in, unturned: closed, pushes a away (−x)
    assert np.all(forces[1] == 0.0) and np.all(forces[2] == 0.0)


def test_broken_roller_support_leaves_its_free_direction_free():
    """A cell on a support at xmin that holds x and y (free in z), support
    broken: pressed 1 µm into it and moved 0.1 µm along z, the z force is
    zero as when it was intact."""
    _, m = beam("{kind: blocks, divisions: [1, 1, 1]}", material=GLASS,
                box="[[0, 0, 0], [0.1, 0.1, 0.1]]",
                boundary="[{face: xmin, fix: [x, y]}]")
    m = dataclasses.replace(m, spring_state0=np.full(m.n_springs, BROKEN, np.int8))
    st = new_state(m)
    st.body_pos[0] += [-1.0e-6, 0.0, 1.0e-7]
    spring_pass(m, st)
    f = st.spring_force.sum(axis=0)
    assert f[0] > 0                       # the contact is closed and pushes back
    assert abs(f[2]) <= 1e-9 * abs(f[0])


# ------------------------------------------------------------- blow-up guard

def test_a_run_just_past_the_limit_stops_at_the_first_output_with_runaway_energy(
        tmp_path, monkeypatch, capsys):
    """dt = 1.05 × 2/ω_max (Lanczos) on the blocks cantilever, tip cells at
    −1 m/s, output every 20 steps: the unstable mode grows by ~1.4× a step
    (|λ| of central differences at ω dt = 2.1), so K + U passes 10 × E0
    long before a body reaches 10 c0.  The run must stop at the first output
    past that (exit 1, 'diverged at step', the energy named) and leave a
    readable history whose frames are all finite."""
    import rbsm_dyn
    from rbsm_dyn.__main__ import main
    from rbsm_dyn.solvers import explicit
    _, m = beam(MESHES["blocks"])
    dt = 1.05 * 2.0 / modal.omega_max(m)
    text = f"""
    name: blowup
    domain: {{box: {BEAM}}}
    mesh: {MESHES["blocks"]}
    materials:
      m: {STEEL}
    groups: {{tip: {{box: [[0.35, -1, -1], [1, 1, 1]]}}}}
    boundary: [{{face: xmin, fix: all}}]
    initial: [{{group: tip, velocity: [0, 0, -1.0]}}]
    solver: {{mode: dynamic, end_time: {2000 * dt:.6e}, dt: {dt:.6e}}}
    output: {{interval: {20 * dt:.6e}}}
    """
    path = tmp_path / "blowup.yaml"
    path.write_text(textwrap.dedent(text), encoding="utf-8")
    out = tmp_path / "blowup.h5"
    # the solver refuses solver.dt above its estimate: take it as given here
    monkeypatch.setattr(explicit, "choose_dt",
                        lambda case, model: (case.solver.dt, model.stable_dt()))
    code = main([str(path), "--out", str(out), "--quiet"])
    err = capsys.readouterr().err
    assert code == 1 and "diverged at step" in err and "energy" in err
    step = int(err.split("diverged at step ")[1].split(",")[0])
    assert step < 500                    # 10^16 growth at ≥ 1.4× a step: ~110 steps
    h = rbsm_dyn.open_history(out)
    assert h.status.startswith("failed")
    assert np.all(np.isfinite(h.position)) and int(h.step[-1]) == step
