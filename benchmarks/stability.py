"""Stability stress tests of the explicit integrator (issue 5).

    NUMBA_NUM_THREADS=1 python benchmarks/stability.py            # full, ~5-15 min
    NUMBA_NUM_THREADS=1 python benchmarks/stability.py --quick    # 10^4-step drift runs
    python benchmarks/stability.py --only sweep,cli --out -       # print, write nothing

Four parts, one table each, written to benchmarks/results/stability.md
(machine, date, git revision and command at the top):

sweep   The true stability limit of the central-difference integrator,
        found by bisection on dt (to 1 %), on supported steel beams cut
        into blocks, Voronoi cells, Voronoi cells without a minimum seed
        spacing (slivers) and 4:1 elongated blocks.  A trial dt runs
        `--trial-steps` steps from a random small velocity and spin field
        (every mode excited), no damping, and is unstable when the energy
        (kinetic at synchronized velocities + strain) exceeds 10× its
        initial value or is not finite.  Compared with the estimate
        Model.stable_dt() (the solver's dt is dt_safety × that, choose_dt)
        and with 2/ω_max from Lanczos (solvers/modal.py).
        Requirement: estimate < limit and estimate > limit / 2.
drift   Elastic runs of `--drift-steps` (10^6) steps of a 32-body
        cantilever at the case's default dt_safety, no damping, from three
        initial velocity fields: the first bending mode, a uniform velocity
        of the tip cells, and a random field.  Reported: max and end of
        |E(t) − E0|/E0 with E = kinetic + strain (what the history records),
        the window-averaged drift, and the leapfrog's conserved modified
        energy Ẽ = E − (dt²/8) fᵀM⁻¹f (its drift is the true secular
        drift).  Requirement: drift ≤ 1e-4.
contact Whether contact on a broken face can be stiffer than the intact
        springs the step estimate was computed from (tangent stiffness of
        each contact state, Lanczos ω_max), and a rupture run (a Voronoi
        glass block thrown onto a breakable support) at the estimated step
        itself (dt_safety 1) and at the default 0.8: finite, energy bounded.
cli     A run with dt far above the limit through the command line: the
        case key solver.dt above the estimate is refused (exit 2); with the
        refusal bypassed (explicit.choose_dt replaced in a subprocess, the
        only way past it), the run stops with exit 1 naming step and time
        and leaves a readable history with status "failed".
"""
import argparse
import dataclasses
import datetime
import os
import platform
import re
import subprocess
import sys
import tempfile
import textwrap
import time
from pathlib import Path

os.environ.setdefault("NUMBA_NUM_THREADS", "1")

import numpy as np  # noqa: E402

HERE = Path(__file__).resolve().parent
ROOT = HERE.parent

from rbsm_dyn.case import DT_SAFETY_MAX, load_case_text  # noqa: E402
from rbsm_dyn.model import apply_initial, build_model, new_state  # noqa: E402
from rbsm_dyn.physics.laws import BROKEN, CONTACT  # noqa: E402
from rbsm_dyn.physics.springs import spring_local_gap  # noqa: E402
from rbsm_dyn.solvers.passes import body_state, model_arrays  # noqa: E402
from rbsm_dyn.solvers.output import strain_energy_of  # noqa: E402
from rbsm_dyn.solvers import modal  # noqa: E402
from rbsm_dyn.solvers.explicit import advance, choose_dt, start_half_step, synchronize  # noqa: E402

STEEL = "{density: 7850, young: 200.0e9, poisson: 0.2}"
BEAM = "[[0, 0, 0], [0.4, 0.1, 0.1]]"
SWEEP_MESHES = {
    "blocks 8×2×2": (BEAM, "{kind: blocks, divisions: [8, 2, 2]}"),
    "voronoi": (BEAM, "{kind: voronoi, size: 0.035, seed: 3}"),
    "voronoi slivers (min_spacing 0)": (BEAM, "{kind: voronoi, size: 0.035, seed: 3, "
                                              "min_spacing: 0.0}"),
    "elongated blocks 40×1×4 (4:1)": ("[[0, 0, 0], [1.0, 0.1, 0.1]]",
                                      "{kind: blocks, divisions: [40, 1, 4]}"),
}
GROWTH = 10.0          # unstable: energy > GROWTH × initial (or not finite)


def beam_case(box, mesh, *, material=STEEL, extra=""):
    return textwrap.dedent(f"""\
        name: stability
        domain: {{box: {box}}}
        mesh: {mesh}
        materials:
          steel: {material}
        groups:
          tip: {{box: [[0.35, -1, -1], [1, 1, 1]]}}
        boundary: [{{face: xmin, fix: all}}]
        solver: {{mode: dynamic, end_time: 1.0}}
        """) + extra


def build(text):
    case = load_case_text(text)
    return case, build_model(case)


# ------------------------------------------------------------------ energies

def strain_energy(m, st):
    return strain_energy_of(m, st)


def energies(m, st):
    """(E, Ẽ): E = kinetic at synchronized v_n, L_n + strain at x_n (as the
    history records it); Ẽ = ½ v_{n−½}·M v_{n+½} + strain, the leapfrog's
    modified energy, exactly conserved for a linear system (= E −
    (dt²/8) fᵀM⁻¹f; e.g. Hairer, Lubich & Wanner, Geometric Numerical
    Integration, §I.4 and §IX.8).  v_{n+½} = 2 v_n − v_{n−½} (no damping,
    no constrained DOF); rotations in the body frame at t_n."""
    vel, ang = synchronize(m, st)
    R = st.body_rot[:-1]
    lb = np.einsum("nki,nk->ni", R, ang)
    lb_m = np.einsum("nki,nk->ni", R, st.body_angmom[:-1])
    lb_p = 2.0 * lb - lb_m
    v_m = st.body_vel[:-1]
    v_p = 2.0 * vel - v_m
    u = strain_energy(m, st)
    mass = m.body_mass[:, None]
    ek = 0.5 * np.sum(mass * vel * vel) + 0.5 * np.sum(lb * lb / m.body_inertia)
    ek_mod = 0.5 * np.sum(mass * v_m * v_p) + 0.5 * np.sum(lb_m * lb_p / m.body_inertia)
    return float(ek + u), float(ek_mod + u), float(u)


def excite(m, st, amp=1.0e-3, seed=0):
    """Random velocity (σ = amp [m/s]) and spin (σ = amp / cell size [rad/s])
    on every body: every mode gets energy."""
    rng = np.random.default_rng(seed)
    n = m.n_bodies
    size = np.cbrt(m.body_volume)[:, None]
    st.body_vel[:-1] = amp * rng.standard_normal((n, 3))
    wb = amp / size * rng.standard_normal((n, 3))
    # world L = R (I ω_body)
    st.body_angmom[:-1] = np.einsum("nik,nk->ni", st.body_rot[:-1], m.body_inertia * wb)


def trial(m, dt, n_steps, chunk=100, seed=0):
    """(stable, steps run): n_steps from a random field at dt; unstable when
    E > GROWTH × E0 or not finite.  A stable mode keeps its E within
    1/(1 − (ω dt)²/4) of its mean (central difference, single mode; Hairer
    et al. §I.4), and the random field puts only a small share in the top
    modes, while an unstable mode grows by ≥ 1 + 2√ε per step at
    ω dt = 2(1 + ε) (eigenvalues λ + 1/λ = 2 − (ω dt)²): past the limit by
    0.1 % that is ×10⁴ in energy within ~60 steps."""
    st = new_state(m)
    st.dt = dt
    excite(m, st, seed=seed)
    start_half_step(m, st)
    e0 = energies(m, st)[0]
    done = 0
    while done < n_steps:
        k = min(chunk, n_steps - done)
        advance(m, st, k)
        done += k
        with np.errstate(over="ignore", invalid="ignore"):     # a blown-up state
            e = energies(m, st)[0]
        if not np.isfinite(e) or e > GROWTH * e0:
            return False, done
    return True, done


def bisect_limit(m, start, n_steps, rel=0.01):
    """Bracket [lo, hi] of the stability limit (lo stable, hi unstable,
    hi/lo ≤ 1 + rel), starting from [start, 2 start] and widening as needed."""
    lo, hi = start, 2.0 * start
    n_trials = 0
    while not trial(m, lo, n_steps)[0]:
        lo, hi = lo / 2.0, lo
        n_trials += 1
    n_trials += 1
    while trial(m, hi, n_steps)[0]:
        lo, hi = hi, 2.0 * hi
        n_trials += 1
    n_trials += 1
    while hi / lo > 1.0 + rel:
        mid = np.sqrt(lo * hi)
        if trial(m, mid, n_steps)[0]:
            lo = mid
        else:
            hi = mid
        n_trials += 1
    return lo, hi, n_trials


# ------------------------------------------------------------------- parts

def part_sweep(args):
    rows = []
    for name, (box, mesh) in SWEEP_MESHES.items():
        case, m = build(beam_case(box, mesh))
        est = m.stable_dt()
        dt_used, _ = choose_dt(case, m)
        exact = 2.0 / modal.omega_max(m)
        t0 = time.perf_counter()
        lo, hi, n = bisect_limit(m, est, args.trial_steps)
        wall = time.perf_counter() - t0
        vol = m.body_volume
        h = m.spring_h[~m.is_support]
        rows.append(dict(mesh=name, bodies=m.n_bodies, springs=m.n_springs,
                         vol_ratio=vol.min() / vol.mean(), h_ratio=h.min() / h.mean(),
                         est=est, dt=dt_used, lo=lo, hi=hi, exact=exact, trials=n, wall=wall,
                         ok=bool(est < lo and est > hi / 2)))
        print(f"sweep {name}: est {est:.4g}, limit [{lo:.4g}, {hi:.4g}], 2/ω_max {exact:.4g}, "
              f"est/limit {est / hi:.3f}-{est / lo:.3f}, {n} trials, {wall:.1f} s", flush=True)
    lines = [
        f"Trial: {args.trial_steps} steps from a random velocity and spin field, no damping; "
        f"unstable when E > {GROWTH:g} E0 or not finite; bisection to 1 % "
        "(geometric mid-point). Steel E = 200 GPa, ν = 0.2, ρ = 7850, support "
        "springs on face xmin. Times in µs.",
        "",
        "| mesh | bodies | springs | min vol / mean | min h / mean | estimate stable_dt | "
        "choose_dt (× 0.8) | bisected limit [lo, hi] | 2/ω_max (Lanczos) | estimate / limit | "
        "limit / (2/ω_max) | used dt / limit | safe and within 2× |",
        "|---|---|---|---|---|---|---|---|---|---|---|---|---|"]
    for r in rows:
        mid = np.sqrt(r["lo"] * r["hi"])
        lines.append(
            f"| {r['mesh']} | {r['bodies']} | {r['springs']} | {r['vol_ratio']:.3f} | "
            f"{r['h_ratio']:.3f} | {r['est'] * 1e6:.4f} | {r['dt'] * 1e6:.4f} | "
            f"[{r['lo'] * 1e6:.4f}, {r['hi'] * 1e6:.4f}] | {r['exact'] * 1e6:.4f} | "
            f"{r['est'] / r['hi']:.3f}–{r['est'] / r['lo']:.3f} | "
            f"{r['lo'] / r['exact']:.3f}–{r['hi'] / r['exact']:.3f} | "
            f"{r['dt'] / mid:.3f} | {'yes' if r['ok'] else '**NO**'} |")
    scan = sliver_scan()
    lines += ["", "Estimate against 2/ω_max (Lanczos) over more Voronoi meshes of the same beam "
              "(sizes 0.025, 0.035, 0.045 m: 256, 93, 44 cells; seeds 1-5):", "",
              "| ν | min_spacing | meshes | min stable_dt/(2/ω_max) | mean | max | below 0.5 | "
              "worst mesh |", "|---|---|---|---|---|---|---|---|"]
    for r in scan:
        lines.append(f"| {r['nu']} | {r['ms']} | {r['n']} | {r['min']:.3f} | {r['mean']:.3f} | "
                     f"{r['max']:.3f} | {r['below']} | "
                     f"size {r['worst'][0]}, seed {r['worst'][1]} |")
    return rows, "\n".join(lines)


def sliver_scan():
    out = []
    for nu in (0.0, 0.2):
        for ms in (0.0, 0.5):
            mat = f"{{density: 7850, young: 200.0e9, poisson: {nu}}}"
            ratios = {}
            for size in (0.025, 0.035, 0.045):
                for seed in range(1, 6):
                    mesh = f"{{kind: voronoi, size: {size}, seed: {seed}, min_spacing: {ms}}}"
                    _, m = build(beam_case(BEAM, mesh, material=mat))
                    ratios[(size, seed)] = m.stable_dt() * modal.omega_max(m) / 2.0
            r = np.array(list(ratios.values()))
            out.append(dict(nu=nu, ms=ms, n=len(r), min=r.min(), mean=r.mean(), max=r.max(),
                            below=int(np.sum(r < 0.5)), worst=min(ratios, key=ratios.get)))
            print(f"scan ν {nu} min_spacing {ms}: min {r.min():.3f}", flush=True)
    return out


DRIFT_FIELDS = ("first bending mode", "tip cells uniform", "random")


def drift_run(field, n_steps, samples):
    case, m = build(beam_case(BEAM, "{kind: blocks, divisions: [8, 2, 2]}"))
    dt, est = choose_dt(case, m)
    st = new_state(m)
    st.dt = dt
    amp = 1.0e-3           # [m/s]: strains ~ amp / c0 ~ 2e-7, the linear range
    if field == "first bending mode":
        res = modal.natural_modes(m, 1)
        shape = res.shape[0]                 # (N, 6), world ux..θz, largest translation 1
        omega1 = res.omega[0]
        st.body_vel[:-1] = amp * shape[:, :3]
        wb = np.einsum("nki,nk->ni", st.body_rot[:-1], amp * shape[:, 3:])
        st.body_angmom[:-1] = np.einsum("nik,nk->ni", st.body_rot[:-1], m.body_inertia * wb)
    elif field == "tip cells uniform":
        omega1 = None
        st.body_vel[m.groups["tip"], 2] = -amp
    else:
        omega1 = None
        excite(m, st, amp=amp, seed=1)
    start_half_step(m, st)
    w_max = modal.omega_max(m)
    every = max(1, n_steps // samples)
    E, Et, U, steps = [], [], [], []
    t0 = time.perf_counter()
    while True:
        e, et, u = energies(m, st)
        E.append(e)
        Et.append(et)
        U.append(u)
        steps.append(st.step)
        if st.step >= n_steps:
            break
        advance(m, st, min(every, n_steps - st.step))
    wall = time.perf_counter() - t0
    E, Et, U = map(np.asarray, (E, Et, U))
    e0, et0 = E[0], Et[0]
    dev = np.abs(E - e0) / e0
    w = max(1, len(E) // 10)
    # the E − Ẽ bound: (dt²/8) fᵀM⁻¹f ≤ (dt² ω_max²/4) U, since fᵀM⁻¹f =
    # xᵀK M⁻¹K x ≤ ω_max² xᵀK x (Rayleigh quotient of M⁻¹K)
    h = w_max * dt
    live = U > 1e-3 * U.max()          # not at U ≈ 0 (round-off over round-off)
    gap_ratio = np.max(np.abs(E - Et)[live] / (h * h / 4 * U[live]))
    return dict(field=field, omega1=omega1, bodies=m.n_bodies, springs=m.n_springs, dt=dt, est=est,
                h=h, steps=st.step, samples=len(E), wall=wall, dev_max=dev.max(),
                dev_end=dev[-1], window=abs(E[-w:].mean() - E[:w].mean()) / e0,
                mod_max=np.max(np.abs(Et - et0)) / et0, mod_end=abs(Et[-1] - et0) / et0,
                gap_ratio=gap_ratio, finite=bool(np.all(np.isfinite(E))))


def part_drift(args):
    rows = []
    for field in DRIFT_FIELDS:
        r = drift_run(field, args.drift_steps, args.drift_samples)
        rows.append(r)
        print(f"drift {field}: max {r['dev_max']:.3g}, end {r['dev_end']:.3g}, window "
              f"{r['window']:.3g}, modified max {r['mod_max']:.3g}, {r['wall']:.1f} s", flush=True)
    r0 = rows[0]
    lines = [
        f"Cantilever 0.4 × 0.1 × 0.1 m, blocks 8 × 2 × 2 ({r0['bodies']} bodies, "
        f"{r0['springs']} spring points), support springs on xmin, no damping, "
        f"dt = 0.8 × stable_dt = {r0['dt']:.4g} s (ω_max dt = {r0['h']:.3f}), "
        f"{r0['steps']} steps, energy sampled every {r0['steps'] // (r0['samples'] - 1)} "
        "steps. Initial speed scale 1e-3 m/s (strain ~ 1e-7: linear range).",
        "",
        "| initial field | max \\|E−E0\\|/E0 | end \\|E−E0\\|/E0 | drift of 10 %-window means | "
        "max \\|Ẽ−Ẽ0\\|/Ẽ0 (modified energy) | end \\|Ẽ−Ẽ0\\|/Ẽ0 | "
        "max \\|E−Ẽ\\| / ((ω_max dt)²/4 · U) "
        "| wall [s] |",
        "|---|---|---|---|---|---|---|---|"]
    for r in rows:
        lines.append(f"| {r['field']} | {r['dev_max']:.2e} | {r['dev_end']:.2e} | "
                     f"{r['window']:.2e} | {r['mod_max']:.2e} | {r['mod_end']:.2e} | "
                     f"{r['gap_ratio']:.3f} | {r['wall']:.0f} |")
    h1 = r0["omega1"] * r0["dt"]
    lines += [
        "",
        f"* First bending mode: ω₁ dt = {h1:.4g}; a single mode's E oscillates by "
        f"(ω₁dt)²/4 / (1 − (ω₁dt)²/4) = {h1 * h1 / 4 / (1 - h1 * h1 / 4):.3e} of E0 "
        "(central difference; Hairer, Lubich & Wanner §I.4): the measured max is that "
        "oscillation, not drift.",
        "* The other fields put energy in the top modes: E then differs from the conserved "
        "Ẽ by (dt²/8) fᵀM⁻¹f ≤ ((ω_max dt)²/4)·U (column 7 ≤ 1 checks it at every sample "
        "with U > 1e-3 max U), an oscillation of a few % that is no drift either: the "
        "window means and Ẽ move by orders of magnitude less. The history's energy "
        "columns are E, so a user comparing frames sees that oscillation.",
        f"* Ẽ moves by at most {max(r['mod_max'] for r in rows):.2e} over "
        f"{r0['steps']} steps. The amplitude scan below (random field, 10^5 steps each) "
        "shows no systematic drift: at 1e-4-1e-3 m/s it creeps by ~1e-6 per 10^5 steps "
        "with a sign that changes with the amplitude (round-off: displacements ~1e-9 m "
        "on positions ~0.2 m), at 0.1-1 m/s (strain up to 2e-4) it wanders by up to "
        "~5e-5 without a trend (Ẽ is exact only for the linear system; the finite "
        "rotations are not)."]
    k = args.scan_steps // 10
    lines += ["", f"| speed scale [m/s] | Ẽ/Ẽ0 − 1 after 2, 4, 6, 8, 10 × {k} steps |",
              "|---|---|"]
    for amp, series in amplitude_scan(args.scan_steps):
        lines.append(f"| {amp:g} | " + ", ".join(f"{x:+.2e}" for x in series[1::2]) + " |")
    return rows, "\n".join(lines)


def amplitude_scan(n_steps, amps=(1e-4, 1e-3, 1e-1, 1.0)):
    """Ẽ/Ẽ0 − 1 every n_steps/10 steps from a random field at each speed scale."""
    case, m = build(beam_case(BEAM, "{kind: blocks, divisions: [8, 2, 2]}"))
    dt, _ = choose_dt(case, m)
    out = []
    for amp in amps:
        st = new_state(m)
        st.dt = dt
        excite(m, st, amp=amp, seed=1)
        start_half_step(m, st)
        et0 = energies(m, st)[1]
        series = []
        for _ in range(10):
            advance(m, st, n_steps // 10)
            series.append(energies(m, st)[1] / et0 - 1.0)
        out.append((amp, series))
        print(f"scan amp {amp}: {series[-1]:+.2e}", flush=True)
    return out


RUPTURE_MATERIAL = ("{density: 2500, young: 60.0e9, poisson: 0.2, "
                    "rupture: {strain: 1.0e-3}, friction: 0.5}")


def rupture_case(dt_safety, mesh="{kind: voronoi, size: 0.02, seed: 4}"):
    return textwrap.dedent(f"""\
        name: rupture
        domain: {{box: [[0, 0, 0], [0.1, 0.1, 0.1]]}}
        mesh: {mesh}
        materials:
          glass: {RUPTURE_MATERIAL}
        boundary: [{{face: zmin, fix: all, breakable: true}}]
        initial: [{{velocity: [20.0, 0, -300.0]}}]
        solver: {{mode: dynamic, end_time: 1.0, dt_safety: {min(dt_safety, DT_SAFETY_MAX)}}}
        """)


def contact_states(m):
    """ω_max of the tangent stiffness with every internal spring in one
    state: intact (k_n, k_s, k_t), closed contact sticking (contact.py uses
    the spring's own k_n and k_s: identical), closed contact sliding (k_n
    only: the tangential traction is on the friction cone, no tangent
    stiffness), and a support on face xmin holding x and y only (a roller in
    z) after rupture: contact.py applies k_s to both tangential gaps, so the
    released z direction gets stiffness k_s."""
    out = {}
    internal = m.face_ref >= 0          # (per face: the points of a face share k)
    k = m.face_k
    stick = k.copy()
    stick[internal, 1:] = k[internal, 1][:, None]
    slide = k.copy()
    slide[internal, 1:] = 0.0
    for name, kk in (("intact", k), ("all internal springs closed contact, sticking", stick),
                     ("all internal springs closed contact, sliding", slide)):
        mm = dataclasses.replace(m, face_k=kk)
        out[name] = (modal.omega_max(mm), mm.stable_dt())
    return out


def roller_support_rows():
    text = beam_case(BEAM, "{kind: blocks, divisions: [8, 2, 2]}",
                     material=RUPTURE_MATERIAL).replace("fix: all", "fix: [x, y]")
    _, m = build(text)
    sup = m.face_ref < 0
    kk = m.face_k.copy()
    kk[sup, 2] = kk[sup, 1]          # contact.py: τt = k_s (δt − slip_t)
    rows = {}
    for name, k in (("roller support (xmin, fix [x, y]) intact", m.face_k),
                    ("same support broken, closed, sticking (contact uses k_s for t)", kk)):
        mm = dataclasses.replace(m, face_k=k)
        rows[name] = (modal.omega_max(mm), m.stable_dt())
    # the force it makes: the support of one cell pressed in x and moved along
    # z (a DOF the support leaves free)
    from rbsm_dyn.solvers.explicit import spring_pass
    _, one = build(textwrap.dedent(f"""\
        name: roller
        domain: {{box: [[0, 0, 0], [0.1, 0.1, 0.1]]}}
        mesh: {{kind: blocks, divisions: [1, 1, 1]}}
        materials:
          glass: {RUPTURE_MATERIAL}
        boundary: [{{face: xmin, fix: [x, y]}}]
        solver: {{mode: dynamic, end_time: 1.0}}
        """))
    forces = {}
    for state in (0, BROKEN):
        mm = dataclasses.replace(one, spring_state0=np.full(one.n_springs, state, np.int8))
        st = new_state(mm)
        st.body_pos[0] += [-1.0e-6, 0.0, 1.0e-7]
        spring_pass(mm, st)
        forces["broken" if state else "intact"] = st.spring_force.sum(axis=0)
    return rows, forces, float(one.spring_k[:, 1].sum())


def rupture_run(dt_safety, n_steps, samples):
    case, m = build(rupture_case(dt_safety))
    _, est = choose_dt(case, m)
    dt = dt_safety * est          # beyond case.DT_SAFETY_MAX too: the kernel's own limit
    st = new_state(m)
    st.dt = dt
    apply_initial(case, m, st)
    start_half_step(m, st)
    every = max(1, n_steps // samples)
    e0 = energies(m, st)[0]
    rec = []
    contact_max = 0
    t0 = time.perf_counter()
    while True:
        e, em, _ = energies(m, st)
        wp, wf = float(st.spring_wp.sum()), float(st.spring_wf.sum())
        n_contact = int(np.count_nonzero(st.spring_state == CONTACT))
        contact_max = max(contact_max, n_contact)
        rec.append((e, e + wp + wf, int(np.count_nonzero(st.spring_state >= BROKEN)), n_contact,
                    em, st.step))
        if st.step >= n_steps or not np.isfinite(e):
            break
        # every 2 steps through the impact (the first 400), then `every`
        advance(m, st, min(2 if st.step < 400 else every, n_steps - st.step))
    wall = time.perf_counter() - t0
    rec = np.array(rec)
    internal = ~m.is_support
    ever_contact = int(np.count_nonzero(rec[:, 3] > 0))
    return dict(dt_safety=dt_safety, dt=dt, est=est, bodies=m.n_bodies, springs=m.n_springs,
                steps=st.step, finite=bool(np.all(np.isfinite(rec))),
                mech_max=rec[:, 0].max() / e0, mod_max=rec[:, 4].max() / e0,
                bal_impact=((rec[:, 1] - e0)[rec[:, 5] <= 400] / e0).min(),
                bal_impact_max=((rec[:, 1] - e0)[rec[:, 5] <= 400] / e0).max(),
                bal_max=(rec[:, 1] - e0).max() / e0, bal_end=(rec[-1, 1] - e0) / e0,
                broken=int(rec[-1, 2]), broken_frac=rec[-1, 2] / m.n_springs,
                contact_max=contact_max, contact_end=int(rec[-1, 3]),
                internal=int(internal.sum()), frames_with_contact=ever_contact,
                samples=len(rec), wall=wall, dissipated=(rec[-1, 1] - rec[-1, 0]) / e0)


def flip_diagnosis(n_steps=1300, jump=5e-3):
    """Replays the dt_safety 0.8 rupture run step by step: the first step
    where E + W rises by more than `jump` E0, the spring whose friction
    work jumps most there, its local gap before and after, its length h and
    the relative rotation of its two cells; and the tangential elastic
    energy of closed contacts dropped when they open (contact.py resets the
    slip to the gap) during the first 120 steps, against the balance then."""
    from rbsm_dyn.physics.rotation import quat_matrix_np
    case, m = build(rupture_case(0.8))
    dt, _ = choose_dt(case, m)
    st = new_state(m)
    st.dt = dt
    apply_initial(case, m, st)
    start_half_step(m, st)
    e0 = energies(m, st)[0]
    d = np.zeros((m.n_springs, 3))

    def local_gap():
        spring_local_gap(model_arrays(m)[1], body_state(st), d)
        return d.copy()

    def rel_rotation(a, b):
        Ra = quat_matrix_np(st.body_quat[a]) @ quat_matrix_np(m.body_quat0[a]).T
        Rb = quat_matrix_np(st.body_quat[b]) @ quat_matrix_np(m.body_quat0[b]).T
        return float(np.degrees(np.arccos(np.clip((np.trace(Ra.T @ Rb) - 1) / 2, -1, 1))))

    ks = m.spring_k
    dropped = 0.0
    bal_prev = 0.0
    out = dict(e0=e0)
    g_prev, dq_prev = local_gap(), st.body_dq.copy()
    for _ in range(n_steps):
        g0 = local_gap()
        closed = st.spring_state == CONTACT
        e_t = 0.5 * (ks[:, 1] * (g0[:, 1] - st.spring_dp[:, 1]) ** 2
                     + ks[:, 2] * (g0[:, 2] - st.spring_dp[:, 2]) ** 2)
        wp0 = st.spring_wp.copy()
        dq0 = st.body_dq.copy()
        state0 = st.spring_state.copy()
        advance(m, st, 1)
        opened = closed & (st.spring_state == BROKEN)
        if st.step <= 120:
            dropped += float(e_t[opened].sum())
            if st.step == 120:
                e, em, _ = energies(m, st)
                w = st.spring_wp.sum() + st.spring_wf.sum()
                out["balance_120"] = (e + w - e0) / e0
                out["modified_balance_120"] = (em + w - e0) / e0
                out["dropped_120"] = dropped / e0
        if st.step > 120:
            e = energies(m, st)[0]
            bal = (e + st.spring_wp.sum() + st.spring_wf.sum() - e0) / e0
            if bal - bal_prev > jump:
                s = int(np.argmax(st.spring_wp - wp0))
                a, b = m.spring_bodies[s]
                out.update(step=st.step, jump=bal - bal_prev, spring=s, bodies=(int(a), int(b)),
                           gap_before=g_prev[s], gap_after=g0[s], h=m.spring_h[s],
                           state=(int(state0[s]), int(st.spring_state[s])),
                           dwp=(st.spring_wp[s] - wp0[s]) / e0, rot=rel_rotation(a, b),
                           dqdot=(float(dq_prev[a] @ dq_prev[b]), float(dq0[a] @ dq0[b])))
                return out
            bal_prev = bal
        g_prev, dq_prev = g0, dq0
    return out


def part_contact(args):
    _, m = build(rupture_case(1.0))
    states = contact_states(m)
    roller, forces, ks_sum = roller_support_rows()
    est = m.stable_dt()
    lines = [
        "Contact law (physics/laws/contact.py, called from physics/inelastic.py): a "
        "broken, closed face uses the intact spring's own k_n (normal) and k_s "
        "(both tangential directions, up to the Coulomb cap). For an internal "
        "spring k = (k_n, k_s, k_s), so the contact's tangent stiffness is the "
        "intact one (sticking) or less (sliding: k_n only; open: 0). Each spring "
        "matrix then only loses a positive semi-definite part, K_contact ≤ K_intact, "
        "so ω_max can only fall (Courant–Fischer) and the step estimated from the "
        "intact springs stays safe without a re-check.",
        "",
        f"Rupture model (Voronoi glass block, {m.n_bodies} bodies, {m.n_springs} springs), "
        f"stable_dt = {est * 1e6:.4f} µs:",
        "",
        "| springs in state | ω_max [rad/s] (Lanczos) | 2/ω_max [µs] | stable_dt / (2/ω_max) | "
        "Gershgorin stable_dt of that state [µs] |",
        "|---|---|---|---|---|"]
    for name, (w, g) in states.items():
        lines.append(f"| {name} | {w:.5g} | {2 / w * 1e6:.4f} | {est * w / 2:.3f} | "
                     f"{g * 1e6:.4f} |")
    lines += ["",
              "The exception: a support spring on a face that holds only some components "
              "has k = 0 in the free ones (model.py), but after rupture contact.py gives "
              "both tangential directions k_s (it never reads k_t = spring_k[:, 2]). A "
              "roller support on xmin holding x and y (k = (k_n, k_s, 0)) breaks into a "
              "contact that resists z with k_s and friction:",
              "",
              "| model (beam 8×2×2, glass) | ω_max [rad/s] | 2/ω_max [µs] | stable_dt [µs] | "
              "stable_dt / (2/ω_max) |",
              "|---|---|---|---|---|"]
    for name, (w, g) in roller.items():
        lines.append(f"| {name} | {w:.5g} | {2 / w * 1e6:.4f} | {g * 1e6:.4f} | {g * w / 2:.3f} |")
    fi, fb = forces["intact"], forces["broken"]
    (w0, _), (w1, g1) = roller.values()
    lines += ["",
              "One cell on that support, pressed 1 µm into it (x) and moved 0.1 µm along z "
              f"(the free direction): force on the cell intact ({fi[0]:.4g}, {fi[1]:.4g}, "
              f"{fi[2]:.4g}) N, broken ({fb[0]:.4g}, {fb[1]:.4g}, {fb[2]:.4g}) N; "
              f"−Σk_s · 0.1 µm = {-ks_sum * 1e-7:.4g} N. The step stays safe here (ω_max "
              f"rises by {w1 / w0 - 1:.1%}; the estimate, not recomputed, is "
              f"{g1 * w1 / 2:.3f} of the new 2/ω_max), but a released direction of a support "
              "gains stiffness and friction once the support breaks: a law bug to fix in "
              "contact.py (use k_t = spring_k[:, 2] for the t direction), not a stability "
              "one.", ""]
    rows = []
    for safety in (1.0, 0.8):
        r = rupture_run(safety, args.rupture_steps, 200)
        rows.append(r)
        print(f"rupture dt_safety {safety}: broken {r['broken']}, contact max "
              f"{r['contact_max']}, E max {r['mech_max']:.4f}, balance max {r['bal_max']:+.3g}, "
              f"{r['wall']:.1f} s", flush=True)
    r = rows[0]
    lines += [
        f"Rupture run: Voronoi glass block 0.1 m ({r['bodies']} bodies, {r['springs']} spring "
        "points), E = 60 GPa, ν = 0.2, ρ = 2500, rupture at equivalent strain 1e-3, "
        "friction 0.5, support springs on zmin (breakable, same material), initial "
        f"velocity (20, 0, −300) m/s, {r['steps']} steps, energies at {r['samples']} "
        "samples (every 2 steps through the impact, the first 400 steps). "
        "E = kinetic + strain, W = friction + fracture dissipation; "
        "E0 = initial kinetic energy, no external work (supports are springs).",
        "",
        "| dt_safety | dt [µs] | broken at end (fraction) | most springs in closed contact at "
        "a sample | in contact at end | max E/E0 | max Ẽ/E0 | (E + W − E0)/E0 in the "
        "impact (steps ≤ 400), min / max | max (E + W − E0)/E0, whole run | at end | "
        "dissipated W/E0 at end | finite | wall [s] |",
        "|---|---|---|---|---|---|---|---|---|---|---|---|---|"]
    for r in rows:
        lines.append(f"| {r['dt_safety']} | {r['dt'] * 1e6:.4f} | {r['broken']} "
                     f"({r['broken_frac']:.2f}) | {r['contact_max']} | {r['contact_end']} | "
                     f"{r['mech_max']:.4f} | {r['mod_max']:.4f} | {r['bal_impact']:+.4f} / "
                     f"{r['bal_impact_max']:+.4f} | {r['bal_max']:+.4f} | {r['bal_end']:+.4f} | "
                     f"{r['dissipated']:.3f} | {'yes' if r['finite'] else '**NO**'} | "
                     f"{r['wall']:.0f} |")
    lines += ["",
              "E exceeds E0 by a fraction of a percent during the impact: the synchronized "
              "energy's own oscillation (E − Ẽ = (dt²/8) fᵀM⁻¹f ≥ 0); the modified energy "
              f"Ẽ stays within {max(r['mod_max'] for r in rows) - 1:.2%} of E0. Nothing "
              "grows: the runs are stable at the estimated step and at 0.8 of it, through "
              "thousands of springs in closed contact."]
    f = flip_diagnosis()
    print(f"flip: {f}", flush=True)
    if "step" in f:
        gb, ga = f["gap_before"] * 1e3, f["gap_after"] * 1e3
        lines += [
            "",
            "Energy balance: E + W − E0 is not zero. Two contact effects, neither a "
            "step-size one (replay of the dt_safety 0.8 run step by step):",
            "",
            f"* **Energy created when two cells have turned half a turn relative to each "
            f"other.** Step {f['step']}: E + W jumps by {f['jump']:.4f} E0 in one step. "
            f"Spring {f['spring']} (cells {f['bodies'][0]}, {f['bodies'][1]}) turns from "
            f"state {f['state'][0]} to {f['state'][1]} (open → closed contact); relative "
            f"rotation of the cells {f['rot']:.1f}°. One step earlier Δq_a·Δq_b went "
            f"{f['dqdot'][0]:+.4f} → {f['dqdot'][1]:+.4f} and, while the world gap moved "
            "by less than 0.1 mm, its local components (δn, δs, δt) jumped from "
            f"({gb[0]:.2f}, {gb[1]:.2f}, {gb[2]:.2f}) mm "
            f"to ({ga[0]:.2f}, {ga[1]:.2f}, {ga[2]:.2f}) mm: the mid rotation "
            "normalize(Δq_a ± Δq_b) (physics/springs.py) switches sign branch when the "
            "relative rotation crosses 180°, so the spring frame flips and an open face "
            f"reads as a penetration of {-ga[0]:.2f} mm ({-ga[0] / (f['h'] * 1e3):.0%} of "
            f"h = {f['h'] * 1e3:.1f} mm). Its gap |δ| < h, so physics/inelastic.py still "
            "treats the pair as neighbours in contact; the contact fires with that "
            f"penetration and the friction return books {f['dwp']:.4f} E0 of friction work "
            "in that step. Suggested fix (not made here): part a broken pair once its "
            "relative rotation is large (e.g. when the two faces' normals carried by each "
            "cell differ by more than 90°), not only when |δ| > h.",
            f"* **Energy lost when a closed face opens.** contact.py sets the slip to the gap "
            "when a face opens, so the tangential elastic energy ½ k_s (δτ − slip)² of a "
            "closed contact vanishes without being booked as friction or fracture work. "
            f"During the first 120 steps (the impact) that drop sums to "
            f"{f['dropped_120']:.4f} E0 (from the state one step before each opening), "
            f"against a balance of {f['balance_120']:+.4f} E0 at step 120 "
            f"({f['modified_balance_120']:+.4f} E0 with the modified kinetic energy "
            "½ v_{n−½}·M v_{n+½}); the rest of the loss is not traced here.",
            ""]
    return dict(states=states, roller=roller, forces=forces, runs=rows, flip=f), \
        "\n".join(lines)


CLI_CASE = textwrap.dedent("""\
    name: blowup
    domain: {box: [[0, 0, 0], [0.4, 0.1, 0.1]]}
    mesh: {kind: blocks, divisions: [8, 2, 2]}
    materials:
      steel: {density: 7850, young: 200.0e9, poisson: 0.2}
    groups:
      tip: {box: [[0.35, -1, -1], [1, 1, 1]]}
    boundary: [{face: xmin, fix: all}]
    initial: [{group: tip, velocity: [0, 0, -1.0]}]
    solver: {mode: dynamic, end_time: END, dt: DT}
    output: {interval: INTERVAL}
    """)

# runs the command line with explicit.choose_dt replaced by one that takes
# solver.dt as given (the real one refuses solver.dt above the estimate)
BYPASS = ("import sys; import rbsm_dyn.solvers.explicit as ex; "
          "ex.choose_dt = lambda case, model: (case.solver.dt, model.stable_dt()); "
          "from rbsm_dyn.__main__ import main; sys.exit(main(sys.argv[1:]))")


def first_unstable_step(dt, n_steps):
    """Replay of the CLI case in-process: first step at which E > GROWTH E0."""
    case, m = build(CLI_CASE.replace("END", "1.0").replace("DT", "1.0").replace(
        "INTERVAL", "1.0"))
    st = new_state(m)
    st.dt = dt
    apply_initial(case, m, st)
    start_half_step(m, st)
    e0 = energies(m, st)[0]
    for _ in range(n_steps):
        advance(m, st, 1)
        with np.errstate(over="ignore", invalid="ignore"):
            e = energies(m, st)[0]
        if not np.isfinite(e) or e > GROWTH * e0:
            return st.step
    return None


def part_cli(args, limit):
    import rbsm_dyn
    rows = []
    env = dict(os.environ, NUMBA_NUM_THREADS="1")
    with tempfile.TemporaryDirectory() as tmp:
        tmp = Path(tmp)
        for factor, n_end in ((5.0, 2000), (1.02, 2000)):
            dt = factor * limit
            text = (CLI_CASE.replace("END", f"{n_end * dt:.6e}").replace("DT", f"{dt:.6e}")
                    .replace("INTERVAL", f"{20 * dt:.6e}"))
            path = tmp / f"blowup{factor}.yaml"
            path.write_text(text, encoding="utf-8")
            out = tmp / f"blowup{factor}.h5"
            plain = subprocess.run([sys.executable, "-m", "rbsm_dyn", str(path), "--out",
                                    str(out), "--quiet"], capture_output=True, text=True, env=env)
            by = subprocess.run([sys.executable, "-c", BYPASS, str(path), "--out", str(out),
                                 "--quiet"], capture_output=True, text=True, env=env)
            h = rbsm_dyn.open_history(out)
            pos = h.position
            first = first_unstable_step(dt, n_end)
            rows.append(dict(factor=factor, dt=dt, plain_code=plain.returncode,
                             plain_err=plain.stderr.strip(), code=by.returncode,
                             err=by.stderr.strip(), status=h.status, frames=h.frames,
                             last_step=int(h.step[-1]), finite=bool(np.all(np.isfinite(pos))),
                             stop=(re.findall(r"diverged at step (\d+)", by.stderr) or ["?"])[0],
                             first=first, late=int(np.sum(np.asarray(h.step) >= (first or 0)))))
            print(f"cli ×{factor}: plain exit {plain.returncode}, bypass exit {by.returncode}: "
                  f"{by.stderr.strip()[:200]}", flush=True)
    lines = [
        "Case: the test_cli cantilever (blocks 8×2×2, steel, tip cells at −1 m/s), "
        "`solver.dt` = factor × the bisected limit of the sweep's blocks mesh, "
        "output every 20 steps, 2000 steps. Run as `python -m rbsm_dyn CASE --out F.h5 --quiet` "
        "(NUMBA_NUM_THREADS=1).",
        ""]
    for r in rows:
        lines += [
            f"**dt = {r['factor']} × limit = {r['dt']:.4g} s.**",
            "",
            f"* plain CLI: exit {r['plain_code']}: `{r['plain_err']}`",
            f"* choose_dt bypassed: exit {r['code']}: `{r['err']}`",
            f"* history: status `{r['status']}`, {r['frames']} frame(s) (last at step "
            f"{r['last_step']}), all written positions finite: {r['finite']}; first step "
            f"with E > {GROWTH:g} E0 (in-process replay): {r['first']}",
            ""]
    r = rows[-1]
    lines += [
        "The message names the step and time and the history stays readable with status "
        "failed, as DESIGN §4 asks. The guard (solvers/explicit.py) looks at the state only "
        "at output steps and chunk ends, and only for non-finite values or a body faster "
        "than 10 c0: just past the limit (×1.02) the energy passed 10 E0 at step "
        f"{r['first']} but the run stopped at step {r['stop']}, and the "
        f"{r['late']} frames written in between hold a growing, finite, meaningless "
        "oscillation. An energy test at output steps (E > k·(E0 + W_ext), as in this "
        "sweep) would stop it within one output interval (suggestion, not made). "
        "solver.dt above the estimate is refused with exit 2 (case.error on solver.dt), "
        "and dt_safety ≤ 1 is enforced by the schema, so through the case file a run "
        "cannot exceed the estimate; this part replaces explicit.choose_dt in a "
        "subprocess (`BYPASS` in the script) to get past that refusal.", ""]
    return rows, "\n".join(lines)


# ------------------------------------------------------------------- report

def machine():
    try:
        out = subprocess.run(["lscpu"], capture_output=True, text=True).stdout
    except OSError:
        return platform.processor()
    keep = ("Model name", "CPU(s)", "Thread(s) per core", "L2 cache", "L3 cache")
    lines = [ln.strip() for ln in out.splitlines() if ln.split(":")[0].strip() in keep]
    return "; ".join(" ".join(ln.split()) for ln in lines)


def git_rev():
    try:
        rev = subprocess.run(["git", "rev-parse", "--short", "HEAD"], cwd=ROOT,
                             capture_output=True, text=True).stdout.strip()
        # changes to the code measured (the package and this script) only
        dirty = subprocess.run(["git", "status", "--porcelain", "--untracked-files=no", "--",
                                "rbsm_dyn", "benchmarks/stability.py"],
                               cwd=ROOT, capture_output=True, text=True).stdout.strip()
        return rev + (" (+ uncommitted changes to rbsm_dyn/ or this script)" if dirty else "")
    except OSError:
        return "unknown"


def main(argv=None):
    p = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    p.add_argument("--only", default="sweep,drift,contact,cli",
                   help="comma-separated parts: sweep, drift, contact, cli")
    p.add_argument("--trial-steps", type=int, default=2000, help="steps per bisection trial")
    p.add_argument("--drift-steps", type=float, default=1e6)
    p.add_argument("--drift-samples", type=int, default=1000)
    p.add_argument("--scan-steps", type=int, default=100000,
                   help="steps of each run of the amplitude scan (drift part)")
    p.add_argument("--rupture-steps", type=int, default=40000)
    p.add_argument("--quick", action="store_true", help="10^4-step drift runs")
    p.add_argument("--out", default=str(HERE / "results" / "stability.md"),
                   help="markdown report ('-': print only)")
    args = p.parse_args(argv)
    args.drift_steps = int(1e4 if args.quick else args.drift_steps)
    if args.quick:
        args.scan_steps = 10000
    parts = args.only.split(",")
    t_start = time.perf_counter()
    import numba
    sections = []
    limit = None
    if "sweep" in parts:
        rows, md = part_sweep(args)
        sections.append(("(a) Stability limit: estimate against a dt sweep", md))
        limit = rows[0]["lo"]
    if "drift" in parts:
        _, md = part_drift(args)
        sections.append((f"(b) Energy drift over {args.drift_steps:.0e} elastic steps", md))
    if "contact" in parts:
        _, md = part_contact(args)
        sections.append(("(c) Contact after rupture and the stable step", md))
    if "cli" in parts:
        if limit is None:
            _, m = build(beam_case(BEAM, "{kind: blocks, divisions: [8, 2, 2]}"))
            limit = bisect_limit(m, m.stable_dt(), args.trial_steps)[0]
        _, md = part_cli(args, limit)
        sections.append(("(d) A run that blows up, through the command line", md))
    wall = time.perf_counter() - t_start
    cmd = "NUMBA_NUM_THREADS=1 python benchmarks/stability.py " + " ".join(
        argv if argv is not None else sys.argv[1:])
    load = os.getloadavg() if hasattr(os, "getloadavg") else ("?",) * 3
    head = [
        "# Stability stress tests (benchmarks/stability.py)",
        "",
        f"* Date: {datetime.datetime.now().isoformat(timespec='seconds')}",
        f"* Git revision: {git_rev()}",
        f"* Command: `{cmd.strip()}`",
        f"* Machine: {machine()}; load average at the end {load[0]:.2f}, {load[1]:.2f}, "
        f"{load[2]:.2f} (shared)",
        f"* Python {platform.python_version()}, Numba {numba.__version__}, NumPy "
        f"{np.__version__}, {numba.get_num_threads()} Numba thread(s); total wall time "
        f"{wall:.0f} s",
        ""]
    text = "\n".join(head + [f"## {t}\n\n{md}\n" for t, md in sections])
    if args.out == "-":
        print(text)
    else:
        Path(args.out).write_text(text, encoding="utf-8")
        print(f"wrote {args.out} ({wall:.0f} s)")
    return 0


if __name__ == "__main__":
    sys.exit(main())
