"""Rupture of a spring point (a crack across that part of the face).

* strain (Kawai 1978, Fig. 7): the spring breaks when its equivalent
  strain reaches ε_cr.  Equivalent strain of the gap δ over the length h,
  of von Mises form on (ε, γ): ε_eq = √(⟨δn⟩² + (δs² + δt²)/3) / h
  (⟨x⟩ = max(x, 0): closing never breaks a spring).  The elastic energy
  the spring held is released as fracture energy; in an explicit step that
  crosses ε_cr, the energy it held at the crossing (physics/inelastic.py
  _crossing_share), so that the fracture energy does not grow with dt.
* softening (crack band; Bažant & Oh, Mater. Struct. 16, 155, 1983): linear
  tension softening on the normal opening with secant unloading (scalar
  damage D on both normal and shear springs).  Peak at δ0 = f_t/k_n, full
  break at δu = 2 G_f/f_t, so the energy dissipated per unit face area is
  ½ f_t δu = G_f whatever the cell size: the law is written in the opening
  δ, so h enters only through k_n = E0/h (the regularisation).  For
  δ0 ≤ κ ≤ δu: D(κ) = δu (κ − δ0) / (κ (δu − δ0)), κ the largest opening.
  If δu ≤ δ0 (cells too large for G_f) the spring breaks at the peak.
  Dissipation rate Y·Ḋ, Y = ½ (kn ⟨δn⟩² + ks |δτ|²) (damage mechanics).
  Case file: `rupture: {law: tension, ...}`.
* mixed_mode (`rupture: {law: mixed_mode, ...}`, the default of
  `{fracture_energy, tensile_strength}`): tension, shear and compression
  on one damage variable: the equivalent-strain form and strength envelope
  of Cusatis's CSL/LDPM facet law (a parabolic Mohr–Coulomb envelope with a
  tension cap) with linear crack-band softening whose energy is G_t in
  pure tension and G_s in pure shear (mixed_mode_damage below).
* loading rate (`rupture: {rate: fib2010}`, mixed_mode only): the strength
  envelope raised by the fib Model Code 2010 dynamic increase factor of
  the tensile strength (fib2010_tension_dif) at the spring's smoothed rate
  of equivalent strain up to its peak (smoothed_rate), going over to that
  of the compressive strength (fib2010_compression_dif) in the directions
  under compression (mixed_mode_damage's cfac); the fracture energies are
  kept.
* compressive cap (`rupture: {cap: {stress, hardening, transition}}`):
  the normal traction is bounded in compression by the compressive
  boundary of LDPM (Cusatis, Pelessone & Mencarelli 2011, Cem. Concr.
  Compos. 33, 881, eq. 28, with β = 0 and the hardening modulus H_c0:
  cap_stress below), on the spring's own normal strain: pore collapse at
  σ_c0, linear hardening to k_c0 ε_c0, exponential densification beyond;
  unloading is elastic, the plastic normal gap kept.
"""
import math

import numba as nb
import numpy as np

JIT = dict(cache=True, nogil=True, fastmath=False, error_model="numpy")

NONE, STRAIN, SOFTENING, MIXED = 0, 1, 2, 3
RUPTURE_KINDS = {"strain": STRAIN, "tension": SOFTENING, "mixed_mode": MIXED}
RATE_LAWS = {"fib2010": 1}

# fib Model Code 2010, §5.1.11.1 (strength under high loading rates, the
# tensile strength's pair of relations): tensile strength under a strain
# rate ε̇ against its quasi-static value, ε̇0 = 1e-6 /s
DIF_RATE0 = 1.0e-6             # [1/s]
DIF_KNEE = 10.0                # [1/s] where the exponent changes from 0.018 to 1/3
# the compressive strength's pair (same clause): ε̇_c0 = 30e-6 /s, knee 30 /s
DIF_C_RATE0 = 30.0e-6          # [1/s]
DIF_C_KNEE = 30.0              # [1/s] where the exponent changes from 0.014 to 1/3


@nb.njit(inline="always", **JIT)
def _model_code_dif(rate, rate0, knee, power, coeff):
    """The Model Code's two-branch factor (§5.1.11.1): (ε̇/ε̇0)^power up to
    `knee`, coeff (ε̇/ε̇0)^(1/3) above, 1 at and below ε̇0 = rate0."""
    if rate <= rate0:
        return 1.0
    x = rate / rate0
    if rate <= knee:
        return x ** power
    return coeff * x ** (1.0 / 3.0)


@nb.njit(inline="always", **JIT)
def fib2010_tension_dif(rate):
    """f_ct,imp/f_ctm at the strain rate `rate` [1/s] (fib Model Code 2010,
    §5.1.11.1): (ε̇/ε̇0)^0.018 up to 10 /s, 0.0062 (ε̇/ε̇0)^(1/3)
    above (the two meet at 10 /s within 0.1 %), ε̇0 = 1e-6 /s; 1 at and
    below ε̇0 (the strength the user gives is the quasi-static one)."""
    return _model_code_dif(rate, DIF_RATE0, DIF_KNEE, 0.018, 0.0062)


@nb.njit(inline="always", **JIT)
def fib2010_compression_dif(rate):
    """f_c,imp/f_cm at the strain rate `rate` [1/s] (fib Model Code 2010,
    §5.1.11.1): (ε̇/ε̇_c0)^0.014 up to 30 /s, 0.012 (ε̇/ε̇_c0)^(1/3)
    above (they meet at 30 /s within 1.2 %), ε̇_c0 = 30e-6 /s; 1 at and
    below ε̇_c0."""
    return _model_code_dif(rate, DIF_C_RATE0, DIF_C_KNEE, 0.014, 0.012)


@nb.njit(inline="always", **JIT)
def smoothed_rate(old, w_prev, w, step, h, slowness):
    """The spring point's smoothed rate of equivalent strain [1/s] after an
    explicit step of `step` [s] in which its equivalent opening went from
    w_prev to w [m] (spring length h [m]): the instantaneous rate
    (w − w_prev)/(step h), closing counted as zero, relaxed into `old` by
    first-order smoothing over τ = h √(ρ/E) (slowness √(ρ/E) [s/m]), the
    time a bar wave takes to cross the spring: exact for a rate held over a
    step (old + (1 − e^(−step/τ)) (rate − old)), so that a wave's ringing at
    the step's period does not chatter the strength, while a load rising
    over a few wave transits is followed.  The caller holds the rate once
    the spring has started to soften: the crack's own opening rate, (w −
    w_prev)/(step h) across a localised crack, is no strain rate of the
    material and would harden the softening branch (a bar pulled at 1 /s
    rose to 1.37 f_t where the factor is 1.28)."""
    rate = (w - w_prev) / (step * h)
    if rate < 0.0:
        rate = 0.0
    return old + (1.0 - math.exp(-step / (h * slowness))) * (rate - old)


@nb.njit(inline="always", **JIT)
def cap_stress(dn, kn, sc0, hc, kc0):
    """Compressive boundary σ_bc [Pa] (> 0, a pressure) of the normal
    traction at the total normal gap dn [m] (< 0 closing), per-area
    stiffness kn = E0/h [Pa/m], and its slope dσ_bc/d(−ε E0): LDPM's
    σ_bc(ε_V) (Cusatis et al. 2011, eq. 28; the Chrono LDPM material's
    CompressBC) with the spring's normal strain ε = dn/h for the
    volumetric one (β = 0; in hydrostatic compression the two are one
    strain): σ_c0 up to ε_c0 = σ_c0/E0 (slope 0), σ_c0 + H_c0 (−ε − ε_c0)
    up to ε_c1 = k_c0 ε_c0 (slope h), then σ_c1 exp((−ε − ε_c1) H_c0/σ_c1)
    (densification, slope h σ_bc/σ_c1).  In gaps: ε E0 = dn kn, H_c0 =
    hc E0.  Returns (σ_bc, slope)."""
    x = -dn * kn                  # −ε E0 [Pa]
    if x <= sc0:
        return sc0, 0.0
    x1 = kc0 * sc0
    if x <= x1:
        return sc0 + hc * (x - sc0), hc
    s1 = sc0 + hc * (x1 - sc0)
    e = math.exp((x - x1) * hc / s1)
    return s1 * e, hc * e


@nb.njit(inline="always", **JIT)
def equivalent_strain(dn, ds, dt, h):
    """ε_eq of the gap (δn, δs, δt) [m] over the spring length h [m]."""
    p = dn if dn > 0.0 else 0.0
    return math.sqrt(p * p + (ds * ds + dt * dt) / 3.0) / h


@nb.njit(inline="always", **JIT)
def softening_damage(kappa, kn, ft, gf):
    """Damage D(κ) of linear tension softening at the largest opening κ [m]
    for per-area stiffness kn [Pa/m], strength ft [Pa], energy gf [J/m²]."""
    d0 = ft / kn
    du = 2.0 * gf / ft
    if kappa <= d0:
        return 0.0
    if du <= d0 or kappa >= du:
        return 1.0
    return du * (kappa - d0) / (kappa * (du - d0))


@nb.njit(inline="always", **JIT)
def csl_strength(s, c2, alpha, ft, r):
    """Strength t0(ω) [Pa] in the equivalent traction t_eq = √(σn² + τ²/α)
    on the direction ω of the gap (sin ω = s, cos² ω = c2), for tensile
    strength ft and shear-to-tensile strength ratio r = f_s/f_t (Cusatis &
    Cedolin 2007; Cusatis, Pelessone & Mencarelli 2011, Cem. Concr. Compos.
    33, 881, eq. 23): the root of (α c2/r²) t0² + s f_t t0 − f_t² = 0, i.e.
    the parabola τ² = f_s² (1 − σn/f_t) in traction space (a Mohr–Coulomb
    envelope with a tension cap whose friction grows with confinement).
    Pure tension (s = 1) gives f_t, pure shear (s = 0) τ = f_s, pure
    compression (s = −1, c2 = 0) never fails (inf)."""
    c = alpha * c2 / (r * r)
    root = math.sqrt(s * s + 4.0 * c)
    if s >= 0.0:
        return 2.0 * ft / (s + root)          # rationalised: no cancellation near ω = π/2
    if c <= 0.0:
        return np.inf
    return ft * (root - s) / (2.0 * c)


@nb.njit(inline="always", **JIT)
def mixed_mode_damage(en, es, et, kn, ks, kt, ft, gt, r, gs, cfac=1.0):
    """Damage D of the mixed-mode law at the elastic gap (en, es, et) [m]
    (per-area stiffnesses kn, ks, kt [Pa/m]; tensile strength ft [Pa],
    mode-I energy gt, mode-II energy gs [J/m²], r = f_s/f_t; cfac the
    loading rate's compressive over tensile factor, 1 without a rate).

    Equivalent opening w = √(en² + (ks es² + kt et²)/kn), so that the
    stored energy is ½ (1 − D) kn w² in tension and t_eq = (1 − D) kn w
    (CSL, Cusatis et al. 2011, with α = ks/kn); direction tan ω =
    en/√((ks es² + kt et²)/kn).  Linear softening of t_eq in w from the
    strength t0(ω) at w0 = t0/kn to zero at wu = 2 G(ω)/t0 (Bažant & Oh
    1983, crack band: the area under the curve is G(ω)), so a radial path
    dissipates G(ω) per unit area: G = gt in pure tension, gs in pure shear,
    G = gs + (gt − gs) sin²ω between (ω ≥ 0), and under compression (ω < 0)
    G = gs (t0(ω)/t0(0))², i.e. the constant softening slope of pure shear
    (CSL's H0 = H_s for ω < 0).  A support that holds no normal component
    (kn = 0) never breaks.  The caller keeps D non-decreasing (D = max over
    the history).  Returns (D, w)."""
    if kn <= 0.0:
        return 0.0, 0.0
    shear = (ks * es * es + kt * et * et) / kn
    w2 = en * en + shear
    if w2 <= 0.0:
        return 0.0, 0.0
    kmax = ks if ks > kt else kt
    w = math.sqrt(w2)
    # inside the envelope on every direction (most springs, most steps):
    # t0(ω) = 2 f_t/(s + √(s² + 4c)) (csl_strength, both branches), and
    # with s ≤ 1, c ≤ α/r², √(a + b) ≤ √a + √b and 2√α ≤ 1 + α,
    # s + √(s² + 4c) ≤ 2 + 2√α/r ≤ 2 + (1 + α)/r, so t0 ≥ 2 f_t r/(2r + 1
    # + α): no damage while kn w ≤ that (the rate's compressive factor
    # cfac < 1 lowers t0 under compression: the bound by it); the same
    # (0, w) as below, without its divisions and roots
    if w * (kn * (2.0 * r + 1.0) + kmax) <= 2.0 * ft * r * (cfac if cfac < 1.0 else 1.0):
        return 0.0, w
    alpha = kmax / kn
    s = en / w
    c2 = shear / w2
    t0 = csl_strength(s, c2, alpha, ft, r)
    if s < 0.0:
        # (with `rate`: ft carries the tensile factor; a direction under
        # compression goes over to the compressive one, linearly in sin ω,
        # the compressive factor in pure compression)
        t0 *= 1.0 + (cfac - 1.0) * (-s)
    w0 = t0 / kn
    if w <= w0:
        return 0.0, w
    if s >= 0.0:
        g = gs + (gt - gs) * s * s
    else:
        t00 = csl_strength(0.0, 1.0, alpha, ft, r)
        g = gs * (t0 / t00) * (t0 / t00)
    wu = 2.0 * g / t0
    if wu <= w0 or w >= wu:
        return 1.0, w
    return wu * (w - w0) / (w * (wu - w0)), w
