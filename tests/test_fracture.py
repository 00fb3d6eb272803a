"""Dynamic fracture: the crack of cases/dynamic_crack.yaml runs below the
Rayleigh speed (VERIFICATION E2), its energy balance closes with the
fracture and friction dissipation, Griffith's scaling of the failure stress
with the crack length (E1), and a shattering run stays finite and stable."""
from pathlib import Path

import numpy as np
import pytest

CASES = Path(__file__).parent.parent / "cases"


def rayleigh_ratio(nu):
    """c_R/c_S: the root in (0, 1) of the Rayleigh equation
    (2 − ξ²)² = 4 √(1 − ξ²) √(1 − ξ² c_S²/c_P²) (e.g. Graff, Wave Motion in
    Elastic Solids, eq. 6.3.8)."""
    k2 = (1 - 2 * nu) / (2 * (1 - nu))                 # (c_S/c_P)²
    f = lambda x: (2 - x * x) ** 2 - 4 * np.sqrt(1 - x * x) * np.sqrt(1 - x * x * k2)
    lo, hi = 0.5, 0.999999
    for _ in range(200):
        mid = 0.5 * (lo + hi)
        lo, hi = (mid, hi) if f(lo) * f(mid) > 0 else (lo, mid)
    return 0.5 * (lo + hi)


def test_rayleigh_ratio_matches_verification():
    assert rayleigh_ratio(0.0) == pytest.approx(0.87403, abs=1e-5)   # VERIFICATION D1
    assert rayleigh_ratio(0.3) == pytest.approx(0.92741, abs=1e-5)


def crack_tip(h, plane_z=0.03, band=0.01):
    """x of the farthest broken spring near the crack plane, per frame (the
    notch's pre-cut springs excluded)."""
    state = h["springs/state"]
    pos = h.static["springs/position"]
    near = np.abs(pos[:, 2] - plane_z) < band
    cut = state[0] >= 2
    tips = []
    for s in state:
        b = (s >= 2) & ~cut & near
        tips.append(pos[b, 0].max() if b.any() else np.nan)
    return np.array(tips)


@pytest.fixture(scope="module")
def crack_run(tmp_path_factory):
    from rbsm_dyn.__main__ import main
    import rbsm_dyn
    out = tmp_path_factory.mktemp("crack") / "crack.h5"
    assert main([str(CASES / "dynamic_crack.yaml"), "--out", str(out), "--quiet"]) == 0
    return rbsm_dyn.open_history(out)


def test_E2_crack_runs_below_the_rayleigh_speed(crack_run):
    """VERIFICATION E2: the tip never outruns c_R (speeds fitted over 5 µs
    windows, longer than the time to cross a few cells); brittle cracks run
    at ≈ 0.5–0.65 c_R, so the mean speed lies in a band around that."""
    h = crack_run
    E, rho, nu = 60.0e9, 2500.0, 0.2                  # the case's material
    c_r = rayleigh_ratio(nu) * np.sqrt(E / (2 * (1 + nu) * rho))
    tip = crack_tip(h)
    t = h.time
    ran = ~np.isnan(tip) & (tip < 0.059)
    assert ran.sum() >= 20                            # the crack ran across the plate
    t, tip = t[ran], tip[ran]
    window = 5.0e-6
    speeds = []
    for k in range(len(t)):
        w = (t >= t[k]) & (t <= t[k] + window)
        if t[w][-1] - t[k] >= 0.9 * window:
            speeds.append(np.polyfit(t[w], tip[w], 1)[0])
    assert len(speeds) >= 5
    assert max(speeds) < c_r
    mean = (tip[-1] - tip[0]) / (t[-1] - t[0])
    assert 0.3 * c_r < mean < 0.8 * c_r


def test_energy_balance_with_fracture(crack_run):
    """kinetic + strain + fracture + friction = work of the loads, within 1 %
    of the work, while fracture takes a visible part of it."""
    ob = crack_run.observables
    W = ob["external_work"]
    balance = ob["kinetic"] + ob["strain"] + ob["plastic"] + ob["fracture"] + ob["damping"] - W
    assert ob["fracture"][-1] > 0.01 * W[-1]
    assert np.abs(balance).max() <= 1e-2 * W.max()
    assert ob["crack_area"][-1] > ob["crack_area"][0]


def griffith_case(a_cells, n=80, W=0.1, s_max=60.0e6, ramp=4.0e-4, end=1.2e-4,
                  rupture="{strain: 1.0e-3}"):
    """A square plate (blocks n × 1 × n, ν = 0, ε_cr = 1e-3) with a central
    crack of half-length a = a_cells·Δ cut along z = W/2, pulled on its top
    and bottom rows by a traction ramped slowly (a ramp of 20 wave transits)."""
    d = W / n
    a = a_cells * d
    F = s_max * W * d
    return f"""
    name: griffith
    domain: {{box: [[0, 0, 0], [{W}, {d}, {W}]]}}
    mesh: {{kind: blocks, divisions: [{n}, 1, {n}]}}
    materials:
      glass: {{density: 2500, young: 60.0e9, poisson: 0.0, rupture: {rupture}}}
    groups:
      top: {{box: [[-1, -1, {W - d / 2}], [1, 1, 1]]}}
      bottom: {{box: [[-1, -1, -1], [1, 1, {d / 2}]]}}
    cuts: [{{point: [0, 0, {W / 2}], normal: [0, 0, 1],
             within: [[{W / 2 - a}, -1, {W / 2 - d / 4}], [{W / 2 + a}, 1, {W / 2 + d / 4}]]}}]
    loads:
      - {{group: top, force: [0, 0, {F}], history: [[0, 0], [{ramp}, 1]]}}
      - {{group: bottom, force: [0, 0, {-F}], history: [[0, 0], [{ramp}, 1]]}}
    solver: {{mode: dynamic, end_time: {end}}}
    output: {{interval: 5.0e-7, fields: [position]}}
    """, s_max / ramp


def test_E1_griffith_scaling(run_case):
    """VERIFICATION E1: σc = √(E′Gc/(πa)), so doubling the crack length
    divides the failure stress by √2 (within 10 %; the finite-width factor
    √sec(πa/W) of a centre crack (Feddersen) makes the expected ratio
    √2 · 1.0254/1.0062 = 1.441 at a/W = 0.05 → 0.1).  Failure: the first
    spring to break beyond the cut."""
    sigma = []
    for a_cells in (4, 8):
        text, rate = griffith_case(a_cells)
        h = run_case(text)
        nb = h.observables["n_broken"]
        k = np.argmax(nb > nb[0])
        assert k > 0
        sigma.append(rate * h.time[k])
    ratio = sigma[0] / sigma[1]
    feddersen = np.sqrt(2) * np.sqrt(1 / np.cos(np.pi * 0.1)) / np.sqrt(1 / np.cos(np.pi * 0.05))
    assert feddersen == pytest.approx(1.441, abs=1e-3)
    assert ratio == pytest.approx(np.sqrt(2), rel=0.10)
    assert ratio == pytest.approx(feddersen, rel=0.10)


def lefm_case(a_cells, n=40, W=0.1, ft=20.0e6, beta=2.0, ramp=2.0e-4):
    """A square plate (blocks n × 1 × n, ν = 0) with a central crack of
    half-length a = a_cells·Δ along z = W/2, material f_t and G_f (mixed-mode
    law, `values: material`) with l_ch = E G_f/f_t² = β Δ, pulled on its top
    and bottom rows by a traction ramped to twice the LEFM failure stress
    over `ramp` (40 wave transits of the plate).  Returns the case, the
    stress rate and σ_LEFM = √(E G_f)/√(πa) / √sec(πa/W) (Irwin; Feddersen's
    finite-width factor of a centre crack, Tada, Paris & Irwin)."""
    E = 60.0e9                           # griffith_case's glass
    d = W / n
    a = a_cells * d
    gf = beta * d * ft ** 2 / E
    lefm = np.sqrt(E * gf) / np.sqrt(np.pi * a) / np.sqrt(1 / np.cos(np.pi * a / W))
    text, rate = griffith_case(a_cells, n, W, 2 * lefm, ramp, 0.7 * ramp,
                               f"{{fracture_energy: {gf}, tensile_strength: {ft}}}")
    return text, rate, lefm


def test_E1_griffith_failure_stress_against_lefm(run_case):
    """VERIFICATION E1 with the material's G_f and f_t (mixed-mode law):
    the stress at which the centre crack runs (it has grown by a cell at
    each tip, and it runs through the plate by the end) lies within ±20 % of
    LEFM's σc = √(E G_f/(πa)) with the finite-width correction, at a = 4
    and 8 cells, and the ratio of the two within ±10 % of LEFM's (√2 times
    the ratio of the width factors).  The energy balance closes within
    1 % of the work."""
    sigma, lefm = [], []
    for a_cells in (4, 8):
        text, rate, s_lefm = lefm_case(a_cells)
        h = run_case(text)
        ob = h.observables
        grown = ob["n_broken"] - ob["n_broken"][0]
        k = np.argmax(grown >= 2 * 4 * 2)        # two faces (4 points each) at each tip
        assert k > 0 and grown[-1] >= 4 * (40 - 2 * a_cells)   # ... and ran through
        sigma.append(rate * h.time[k])
        lefm.append(s_lefm)
        balance = (ob["kinetic"] + ob["strain"] + ob["plastic"] + ob["fracture"]
                   + ob["damping"] - ob["external_work"])
        assert np.abs(balance).max() <= 1e-2 * ob["external_work"].max()
    for s, ref in zip(sigma, lefm):
        assert s == pytest.approx(ref, rel=0.20)
    assert sigma[0] / sigma[1] == pytest.approx(lefm[0] / lefm[1], rel=0.10)


def smooth_ramp(ramp, rise, end, k=16):
    """Load history (times, fractions of the full load) ramped at the rate
    1/`ramp`, the rate itself raised over `rise` as a half cosine (16
    segments): f' = (1 − cos(πt/rise))/(2 ramp) for t < rise, then
    f = (t − rise/2)/ramp.  A rate switched on at once rings the lowest
    mode (period T) with an amplitude rate·T/2π; raised over `rise` it rings
    |cos(π rise/T)|/((2 rise/T)² − 1) of that (the Fourier transform of the
    half-sine jerk)."""
    t = np.linspace(0.0, rise, k + 1)
    f = (t / 2 - rise / (2 * np.pi) * np.sin(np.pi * t / rise)) / ramp
    return np.append(t, end), np.append(f, (end - rise / 2) / ramp)


def voronoi_lefm_case(a_cells, seed, n=40, W=0.1, ft=20.0e6, beta=2.0, ramp=2.0e-4,
                      rise=1.0e-4):
    """A square Voronoi plate W × Δ × W (cells of size Δ = W/n, a slab one
    cell thick, ν = 0) with a central crack of half-length a = a_cells·Δ cut
    along z = W/2 (the faces whose cells lie either side of the plane, their
    points within |x − W/2| ≤ a), material f_t and G_f (`values: material`,
    mixed-mode law) with l_ch = E G_f/f_t² = β Δ, pulled on the cells within
    Δ of its top and bottom by a traction ramped to twice the LEFM failure
    stress σ_LEFM over `ramp` (10 wave transits W/c0), its rate raised over
    `rise` (smooth_ramp).  Returns the case, the history of the traction
    (times, σ) and σ_LEFM = √(E G_f/(πa))/√sec(πa/W)."""
    E = 60.0e9
    d = W / n
    a = a_cells * d
    gf = beta * d * ft ** 2 / E
    lefm = float(np.sqrt(E * gf / (np.pi * a)) / np.sqrt(1 / np.cos(np.pi * a / W)))
    end = 0.7 * ramp + rise / 2                       # the traction reaches 1.4 σ_LEFM
    t, f = smooth_ramp(ramp, rise, end)
    history = "[" + ", ".join(f"[{x!r}, {y!r}]" for x, y in zip(t.tolist(), f.tolist())) + "]"
    F = 2 * lefm * W * d
    text = f"""
    name: griffith-voronoi
    domain: {{box: [[0, 0, 0], [{W!r}, {d!r}, {W!r}]]}}
    mesh: {{kind: voronoi, size: {d!r}, seed: {seed}}}
    materials:
      glass: {{density: 2500, young: {E!r}, poisson: 0.0,
              rupture: {{fracture_energy: {gf!r}, tensile_strength: {ft!r}}}}}
    groups:
      top: {{box: [[-1, -1, {W - d!r}], [1, 1, 1]]}}
      bottom: {{box: [[-1, -1, -1], [1, 1, {d!r}]]}}
    cuts: [{{point: [0, 0, {W / 2!r}], normal: [0, 0, 1],
             within: [[{W / 2 - a!r}, -1, {W / 2 - d!r}], [{W / 2 + a!r}, 1, {W / 2 + d!r}]]}}]
    loads:
      - {{group: top, force: [0, 0, {F!r}], history: {history}}}
      - {{group: bottom, force: [0, 0, {-F!r}], history: {history}}}
    solver: {{mode: dynamic, end_time: {end!r}}}
    output: {{interval: 1.0e-6, fields: [spring_state]}}
    """
    return text, (t, f * 2 * lefm), lefm


def crack_growth(h, a, d, W=0.1):
    """Projected growth of the right and left tips of a centre crack of
    half-length a on z = W/2, per frame [m]: how far beyond x = W/2 ± a the
    farthest broken spring point (the cut's excluded) within 3Δ of the plane
    lies."""
    state = h["springs/state"]
    pos = h.static["springs/position"]
    near = (np.abs(pos[:, 2] - W / 2) < 3 * d) & (state[0] < 2)
    right, left = near & (pos[:, 0] > W / 2), near & (pos[:, 0] < W / 2)
    grown = np.zeros((len(state), 2))
    for k, s in enumerate(state):
        b = s >= 2
        if (b & right).any():
            grown[k, 0] = pos[b & right, 0].max() - (W / 2 + a)
        if (b & left).any():
            grown[k, 1] = (W / 2 - a) - pos[b & left, 0].min()
    return grown


def test_E1_griffith_on_a_voronoi_plate_against_lefm(run_case):
    """VERIFICATION E1 on a Voronoi mesh (issue 11: +54 % and +75 % above
    LEFM before the fracture calibration), with the material's G_f and f_t
    mapped to spring values by the calibration at β = l_ch/Δ = 2 (within
    VORONOI_FRACTURE), ν = 0 (plane stress and plane strain agree: E′ = E,
    so a slab one cell thick is the plate: the issue's, and the cheapest;
    slabs 2 and 3 cells thick scatter as much, their crack front breaking
    at its weakest cell).  The failure stress is the traction when the
    crack has grown by 4Δ in projection, two cells at each tip on average,
    as the block test's 16 points (after that it runs through the plate).
    Each mesh's failure stress lies within ±20 % of σc = √(E G_f/(πa)) /
    √sec(πa/W) (Irwin; Feddersen's width factor) at a = 4 and 8 cells
    (a/W = 0.1, 0.2); the ratio of the two, averaged over four meshes (seeds 1–4: one
    mesh scatters by about ±6 % with the cells at its tips, and a ratio of
    two by ±9 %), within ±10 % of LEFM's; the energy balance closes within
    1 % of the work.  The rate of the traction is raised over 100 µs, 2.4
    periods of the plate's lowest extensional mode (2W/c0 = 41 µs):
    switched on at once it rings that mode by ±6.5 % of σc and the failure
    stress with it."""
    n, W, seeds = 40, 0.1, (1, 2, 3, 4)
    d = W / n
    sigma, lefm = [], []
    for a_cells in (4, 8):
        a = a_cells * d
        per_mesh = []
        for seed in seeds:
            text, (t, s), s_lefm = voronoi_lefm_case(a_cells, seed, n, W)
            h = run_case(text)
            grown = crack_growth(h, a, d, W)
            k = np.argmax(grown.sum(axis=1) >= 4 * d)
            assert k > 0 and grown[-1].min() >= W / 2 - a - d       # ... and it ran through
            per_mesh.append(np.interp(h.time[k], t, s))
            ob = h.observables
            balance = (ob["kinetic"] + ob["strain"] + ob["plastic"] + ob["fracture"]
                       + ob["damping"] - ob["external_work"])
            assert np.abs(balance).max() <= 1e-2 * ob["external_work"].max()
        assert per_mesh == pytest.approx([s_lefm] * len(seeds), rel=0.20)
        sigma.append(np.mean(per_mesh))
        lefm.append(s_lefm)
    assert sigma[0] / sigma[1] == pytest.approx(lefm[0] / lefm[1], rel=0.10)


def test_shattering_run_stays_finite_and_bounded(run_case):
    """A glass cube (7 × 7 × 7 blocks) thrown at 300 m/s onto a support that
    can break: thousands of springs rupture, cracks open, close, slide and
    part; over 10⁵ steps the state stays finite, the run is not stopped as
    diverged, and the mechanical energy never exceeds what it was given
    (kinetic + strain ≤ 1.01 × initial kinetic energy)."""
    text = """
    name: shatter
    domain: {box: [[0, 0, 0], [0.07, 0.07, 0.07]]}
    mesh: {kind: blocks, divisions: [7, 7, 7]}
    materials:
      glass: {density: 2500, young: 60.0e9, poisson: 0.0, rupture: {strain: 1.0e-3}, friction: 0.3}
    boundary: [{face: zmin, fix: all, breakable: true}]
    initial: [{velocity: [20.0, 0, -300.0]}]
    solver: {mode: dynamic, end_time: 1.0}
    output: {interval: 2.0e-3, fields: [position, spring_state]}
    """
    h = run_case(text, "--max-steps", 100000)
    ob = h.observables
    assert h.step[-1] == 100000
    assert ob["n_broken"][-1] >= 1000
    assert np.all(np.isfinite(h.position))
    k0 = ob["kinetic"][0]
    assert np.all(ob["kinetic"] + ob["strain"] <= 1.01 * k0)
    balance = ob["kinetic"] + ob["strain"] + ob["plastic"] + ob["fracture"] - k0
    assert np.abs(balance).max() <= 2e-2 * k0


def test_crack_faces_can_be_drawn_from_the_history(crack_run):
    """The broken springs of the last frame name internal faces whose
    polygons (springs/faces) are stored: the crack of the notched plate lies
    along its notch plane z = 30 mm (most of its area within a band of a
    few cells), and its area equals the crack_area observable."""
    h = crack_run
    state = h["springs/state"][-1]
    face = h.static["springs/face"]
    area = h.static["springs/area"]
    ptr = h.static["springs/faces/vertex_ptr"]
    xyz = h.static["springs/faces/vertex_xyz"]
    broken = (state >= 2) & (face >= 0)
    assert area[state >= 2].sum() == pytest.approx(h.observables["crack_area"][-1], rel=1e-12)
    faces = np.unique(face[broken])
    z = np.array([xyz[ptr[f]:ptr[f + 1], 2].mean() for f in faces])
    a = np.array([area[broken & (face == f)].sum() for f in faces])
    assert a[np.abs(z - 0.03) < 0.006].sum() > 0.7 * a.sum()
