"""cases/spall_bar.yaml: a concrete bar spalls under a compressive pulse,
and the loading rate raises the spall strength (issue 31 item 4).

The reference is 1D elastic wave theory (Kolsky, Stress Waves in Solids,
1953; Rinehart, Stress Transients in Solids, 1975; the spall test of
Klepaczko & Brara 2001 and Schuler, Mayrhofer & Thoma, Int J Impact Eng
32, 2006): a pressure p(t) on the end x = 0 of a free bar of length L sends
a compressive pulse that the free end x = L sends back as tension, and by
d'Alembert's superposition the net axial stress at a distance ξ from the
free end is

    σ(ξ, t) = p(t − (L + ξ)/c0) − p(t − (L − ξ)/c0),   c0 = √(E/ρ),

tension positive, until the reflected wave reaches the loaded end (2L/c0).
p(t) is the case's pressure times its piecewise-linear `history`, so σ is
linear in t between the history's times shifted by (L ± ξ)/c0, and the
first time it reaches a strength σ_s at each ξ is found exactly
(``first_crossing``); the bar first cracks at the earliest of those
(``exact_first``).  This is numpy on the known pulse, not the simulator's
output:

* without `rate`: σ_s = f_t (a uniaxial stress loads the blocks' faces
  uniformly: no fracture calibration, as in tests/test_rate.py);
* with `rate: fib2010`: σ_s = f_t × the fib Model Code 2010 tensile factor
  (§5.1.11.1, written out in ``model_code_factor``) at the strain rate of
  the net stress there, (dσ/dt)/E.

The pulse rises over 10 µs, is held 10 µs and decays linearly over T =
50 µs, so behind the reflected front the tension at ξ keeps rising at σ0/T
(ε̇ = σ0/(E T) = 4 /s); the case's header says why it is held (behind a
triangle's reflected front the tension stops rising, and the rate law then
gives the strength back).

A face cracks when its traction reaches its strength and it starts to
soften (`spring_damage` > 0): that is the event the closed form predicts.
(A face breaks through at an opening of 2 G_f/f_t = 67 µm, which this pulse
does not give any face by the end of the run.)

The case file runs twice, as written and with `rate: fib2010` taken out,
about 1 s each on one thread.
"""
import io
from pathlib import Path

import numpy as np
import pytest
from ruamel.yaml import YAML

import rbsm_dyn
from rbsm_dyn.__main__ import main

CASE = Path(__file__).resolve().parent.parent / "cases" / "spall_bar.yaml"
RATE_KEY = ", rate: fib2010"


def model_code_factor(rate):
    """fib Model Code 2010 §5.1.11.1, tensile strength (written out here)."""
    if rate <= 1e-6:
        return 1.0
    if rate <= 10.0:
        return (rate / 1e-6) ** 0.018
    return 0.0062 * (rate / 1e-6) ** (1.0 / 3.0)


def read_bar(text):
    c = YAML(typ="safe").load(io.StringIO(text))
    (x0, _, _), (x1, _, _) = c["domain"]["box"]
    (mat,) = c["materials"].values()
    (load,) = c["loads"]
    hist = np.array(load["history"], dtype=float)
    b = dict(L=x1 - x0, h=(x1 - x0) / c["mesh"]["divisions"][0], E=mat["young"],
             rho=mat["density"], ft=mat["rupture"]["tensile_strength"], p0=load["pressure"],
             t_hist=hist[:, 0], a_hist=hist[:, 1], end=c["solver"]["end_time"])
    b["c0"] = np.sqrt(b["E"] / b["rho"])                       # VERIFICATION D1
    # the pulse: rise to its peak, hold T1, linear decay to 0 over T
    top = np.nonzero(b["a_hist"] == b["a_hist"].max())[0]
    assert b["a_hist"].max() == 1.0 and b["a_hist"][-1] == 0.0
    b["T1"] = b["t_hist"][top[-1]] - b["t_hist"][top[0]]
    b["T"] = b["t_hist"][-1] - b["t_hist"][top[-1]]
    assert top[-1] == len(b["t_hist"]) - 2                     # one linear segment to 0
    return b


def pressure(b, t):
    return b["p0"] * np.interp(t, b["t_hist"], b["a_hist"])


def net_stress(b, xi, t):
    """σ(ξ, t), tension positive: the reflected pulse minus the incoming one."""
    return pressure(b, t - (b["L"] + xi) / b["c0"]) - pressure(b, t - (b["L"] - xi) / b["c0"])


def first_crossing(b, level, xi):
    """The first time σ(ξ, t) reaches `level` at each ξ (inf if it never
    does): σ is linear in t between the breakpoints t_i + (L ± ξ)/c0, so the
    crossing is the linear interpolation inside the first interval whose end
    reaches the level."""
    xi = np.asarray(xi, dtype=float)[:, None]
    tb = np.sort(np.concatenate([b["t_hist"] + (b["L"] + xi) / b["c0"],
                                 b["t_hist"] + (b["L"] - xi) / b["c0"]], axis=1), axis=1)
    s = net_stress(b, xi, tb)
    above = s >= level
    k = np.argmax(above, axis=1)
    rows = np.arange(len(tb))
    assert np.all(k[above.any(axis=1)] > 0)         # σ = 0 at the first breakpoint
    k0 = np.maximum(k - 1, 0)
    s0, s1, t0, t1 = s[rows, k0], s[rows, k], tb[rows, k0], tb[rows, k]
    t = t0 + (level - s0) / np.where(s1 > s0, s1 - s0, 1.0) * (t1 - t0)
    return np.where(above.any(axis=1), t, np.inf)


def exact_first(b, level):
    """(ξ, t) where the net tension first reaches `level` anywhere in the bar
    (ξ on a grid of h/100)."""
    xi = np.arange(b["h"] / 100, b["L"] / 2, b["h"] / 100)
    t = first_crossing(b, level, xi)
    j = int(np.argmin(t))
    assert t[j] < 2 * b["L"] / b["c0"]              # before the reflection reaches x = 0
    return xi[j], t[j]


def first_crack(h, b):
    """(ξ, t, frame gap) of the face that cracked first: the first frame in
    which a spring point has damage, and of the faces cracked in it the one
    with the most damage (the one longest past its strength)."""
    d = np.asarray(h["springs/damage"])
    face = h.static["springs/face"]
    x = h.static["springs/position"][:, 0]
    ids = np.unique(face)
    assert np.all(ids >= 0)                         # no supports: internal faces only
    dmg = np.stack([d[:, face == f].max(axis=1) for f in ids], axis=1)
    xf = np.array([x[face == f].mean() for f in ids])
    cracked = (dmg > 0).any(axis=1)
    assert cracked.any(), "no face cracked"
    k = int(np.argmax(cracked))
    assert k > 0
    j = int(np.argmax(dmg[k]))
    return b["L"] - xf[j], h.time[k], h.time[k] - h.time[k - 1]


@pytest.fixture(scope="module")
def runs(tmp_path_factory):
    text = CASE.read_text(encoding="utf-8")
    assert RATE_KEY in text
    out = {}
    for name, t in (("rated", text), ("plain", text.replace(RATE_KEY, ""))):
        d = tmp_path_factory.mktemp(f"spall_{name}")
        path = d / "spall_bar.yaml"
        path.write_text(t, encoding="utf-8")
        h5 = d / "spall_bar.h5"
        assert main([str(path), "--out", str(h5), "--quiet"]) == 0
        out[name] = rbsm_dyn.open_history(h5)
    return read_bar(text), out


def test_exact_spall_plane_is_the_closed_form():
    """The exact first crossing (the case's cosine rise) against the closed
    form of a sharp-fronted pulse held T1 and decaying over T: behind the
    reflected front the tension at ξ is (σ0/T)(2ξ/c0 − T1), so it first
    reaches σ_s at ξ_s = c0 T1/2 + σ_s c0 T/(2σ0), as the front passes,
    t = (L + ξ_s)/c0, plus the rise.  The rise (10 µs, half a cosine) moves
    the plane and the time by less than a cell and its h/c0, for f_t and for
    1.3 f_t alike."""
    b = read_bar(CASE.read_text(encoding="utf-8"))
    for level in (b["ft"], 1.3 * b["ft"]):
        xi, t = exact_first(b, level)
        closed = b["c0"] * b["T1"] / 2 + level * b["c0"] * b["T"] / (2 * b["p0"])
        assert xi == pytest.approx(closed, abs=b["h"])
        rise = b["t_hist"][np.argmax(b["a_hist"])]
        assert t == pytest.approx((b["L"] + closed) / b["c0"] + rise, abs=b["h"] / b["c0"])


def test_spall_bar_first_crack_at_the_exact_plane(runs):
    """Without `rate`: the first face to crack lies at the exact spall plane
    within one cell, h (the faces are h apart, so the nearest one is within
    h/2 of the plane, and the lattice resolves a stress to a cell), at the
    exact time within h/c0 + one frame gap (a face a cell away from the
    plane reaches f_t at most h/c0 later: the first-crossing time changes
    with ξ by at most 1/c0, exactly 1/c0 on the side towards the free end
    where the front meets the pulse's decay; and the crack is seen at the
    first frame after it)."""
    b, h = runs
    xi_s, t_s = exact_first(b, b["ft"])
    assert t_s < b["end"]
    xi, t, frame = first_crack(h["plain"], b)
    assert xi == pytest.approx(xi_s, abs=b["h"])
    assert t == pytest.approx(t_s, abs=b["h"] / b["c0"] + frame)


def test_spall_bar_rate_raises_the_spall_strength_by_the_model_code_factor(runs):
    """With `rate: fib2010`: the exact net tension at the first cracked face
    at the time it cracked, over f_t, is the Model Code's tensile factor at
    the exact strain rate there, (dσ/dt)/E as it cracked (σ is linear in t
    between breakpoints: its slope over the last nanosecond), within 10 %
    (a crack a cell off the plane changes the exact tension by its gradient
    2σ0/(c0 T) × h, 2.6 % of the rated strength here; the frame it is seen
    in, by σ0/T × the frame gap, 0.7 %).
    And the rated bar cracks deeper than the plain one by the distance
    between the exact planes of f_t and of f_t × the factor at the rate
    behind the reflected front, σ0/(E T) = 4 /s (factor 1.3147):
    c0 T (1.3147 − 1) f_t/(2σ0) = 13.9 mm, within two cells (each plane
    within one, as in the test above)."""
    b, h = runs
    xi, t, frame = first_crack(h["rated"], b)
    sigma = net_stress(b, xi, t)
    step = 1e-9
    rate = (sigma - net_stress(b, xi, t - step)) / step / b["E"]
    assert rate > 0                                 # the tension was rising as it cracked
    assert sigma / b["ft"] == pytest.approx(model_code_factor(rate), rel=0.10)
    # deeper than without the rate, by the exact planes' distance
    decay = b["p0"] / (b["E"] * b["T"])
    xi0, _, _ = first_crack(h["plain"], b)
    xi_f, _ = exact_first(b, b["ft"])
    xi_r, t_r = exact_first(b, b["ft"] * model_code_factor(decay))
    assert t_r < b["end"]
    assert xi_r - xi_f >= 5 * b["h"]                # the case keeps them cells apart
    assert xi - xi0 == pytest.approx(xi_r - xi_f, abs=2 * b["h"])


@pytest.mark.parametrize("run", ["rated", "plain"])
def test_spall_bar_energy_balance(runs, run):
    """Kinetic + strain + fracture = the work of the pressure, within 1 %
    of it at every frame; fracture has begun."""
    b, h = runs
    eb = h[run].energy_balance()
    work = eb["supplied"].max()
    assert work > 0
    assert h[run].observables["fracture"][-1] > 0
    assert np.max(np.abs(eb["error"])) <= 0.01 * work
