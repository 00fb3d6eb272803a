"""Response spectra of a ground-motion record or of a probe's history
(issue 28: `python -m rbsm_dyn spectrum`).

The oscillator of period T and damping ratio ζ under a base acceleration
a_g(t) (Chopra, Dynamics of Structures, §6.2):

    ü + 2ζω u̇ + ω² u = −a_g(t),     ω = 2π/T,

u the displacement relative to the base.  Between two samples the record
is taken linear in time and each step is integrated exactly (Nigam &
Jennings, "Calculation of response spectra from strong-motion
earthquake records", Bull. Seismol. Soc. Am. 59 (1969) 909-922): the
step's transition and load matrices are the blocks of one matrix
exponential (Van Loan, "Computing integrals involving the matrix
exponential", IEEE Trans. Autom. Control 23 (1978) 395-404), so the
result is exact to round-off for any step and any period, however short.

The spectrum at each period: the relative displacement Sd = max |u|, the
pseudo-velocity PSV = ω Sd and pseudo-acceleration PSA = ω² Sd (Chopra
§6.6), and the absolute acceleration SA = max |ü + a_g| = max |2ζω u̇ + ω² u|.
Units: those of the record (SI: m/s², m, m/s).
"""
from __future__ import annotations

import math

import numpy as np

from ..records import G, read_record  # noqa: F401  (the command reads records)


def step_matrices(period: float, zeta: float, dt: float):
    """(Φ, Γ0, Γ1) of one step dt for the oscillator of `period` [s] and
    damping ratio `zeta` (0 ≤ ζ < 1): with the state s = (u, u̇) and the
    load p = −a_g linear over the step,
    s(t + dt) = Φ s(t) + Γ0 p(t) + Γ1 (p(t + dt) − p(t)) (Van Loan 1978:
    the exponential of [[F, g, 0], [0, 0, 1/dt], [0, 0, 0]] dt)."""
    from scipy.linalg import expm
    w = 2.0 * math.pi / period
    m = np.zeros((4, 4))
    m[0, 1] = 1.0
    m[1, 0], m[1, 1] = -w * w, -2.0 * zeta * w
    m[1, 2] = 1.0                      # the load enters the acceleration
    m[2, 3] = 1.0 / dt                 # the load's slope over the step
    e = expm(m * dt)
    return e[:2, :2], e[:2, 2], e[:2, 3]


def response(t, ag, periods, zeta):
    """Relative displacement and velocity histories (len(t), P) of the
    oscillators at `periods` [s] (damping ratio `zeta`) under the base
    acceleration `ag` sampled at times `t`, evenly spaced (a record's
    times: one step, within 1e-6 of it), at rest at t[0]."""
    t = np.asarray(t, dtype=float)
    p = -np.asarray(ag, dtype=float)
    periods = np.atleast_1d(np.asarray(periods, dtype=float))
    dt = _even_step(t)
    u = np.empty((len(t), len(periods)))
    v = np.empty_like(u)
    for k, T in enumerate(periods):
        u[:, k], v[:, k] = _filtered(T, zeta, dt, p)
    return u, v


#: samples per period at which a peak is looked for: a sampled sine's
#: largest sample is within 1 − cos(π/n) = 0.12 % of its peak
PER_PERIOD = 64


def spectrum(t, ag, periods, zeta=0.05):
    """The response spectrum of the record (t, ag) at `periods` [s] for the
    damping ratio `zeta`: a dict of arrays over the periods, `period`, `Sd`
    (max |u|), `PSV` (ω Sd), `PSA` (ω² Sd), `SA` (max |ü + a_g|).  The
    maxima are taken at PER_PERIOD points per period at least: a step of
    the record longer than T/64 is divided (exactly: the record is linear
    over it), so that a short period's peak between two samples is not
    missed (it would be by up to 1 − cos(ω dt/2): 29 % at T = 2 dt).
    Each period's recurrence runs as a linear filter (scipy.signal.lfilter):
    its zero-state part, the filter of the load, plus the free vibration
    from the start (closed form)."""
    if not 0.0 <= zeta < 1.0:
        raise ValueError(f"damping {zeta!r}: a ratio in [0, 1) (0.05 is 5 %)")
    periods = np.atleast_1d(np.asarray(periods, dtype=float))
    if np.any(~np.isfinite(periods)) or np.any(periods <= 0.0):
        raise ValueError("periods: each must be a positive number of seconds")
    t = np.asarray(t, dtype=float)
    p = -np.asarray(ag, dtype=float)
    dt = _even_step(t)
    sd = np.empty(len(periods))
    sa = np.empty(len(periods))
    for k, T in enumerate(periods):
        m = max(1, math.ceil(PER_PERIOD * dt / T))
        h = dt / m
        tk = t[0] + h * np.arange((len(t) - 1) * m + 1)
        pk = np.interp(tk, t, p)
        u, v = _filtered(T, zeta, h, pk)
        w = 2.0 * math.pi / T
        sd[k] = np.abs(u).max()
        sa[k] = np.abs(2.0 * zeta * w * v + w * w * u).max()
    w = 2.0 * np.pi / periods
    return {"period": periods, "Sd": sd, "PSV": w * sd, "PSA": w * w * sd, "SA": sa}


def _filtered(period, zeta, dt, p):
    """(u, v) of the oscillator from rest under the load p (= −a_g) at a
    step dt: s_{n+1} = Φ s_n + Γ0 p_n + Γ1 (p_{n+1} − p_n) (step_matrices)
    rewritten for z_n = s_n − Γ1 p_n as z_{n+1} = Φ z_n + B p_n,
    B = Φ Γ1 + Γ0 − Γ1, so s_n = (the filter of p) + Φⁿ z_0 + Γ1 p_n with
    z_0 = −Γ1 p_0; Φⁿ z_0 is the free vibration from z_0 (Chopra §2.2)."""
    from scipy.signal import lfilter, ss2tf
    phi, g0, g1 = step_matrices(period, zeta, dt)
    b = phi @ g1 + g0 - g1
    out = []
    z0 = -g1 * p[0]
    w = 2.0 * math.pi / period
    wd = w * math.sqrt(1.0 - zeta * zeta)
    tn = dt * np.arange(len(p))
    e = np.exp(-zeta * w * tn)
    cs, sn = np.cos(wd * tn), np.sin(wd * tn)
    u0, v0 = z0
    free_u = e * (u0 * cs + (v0 + zeta * w * u0) / wd * sn)
    free_v = e * (v0 * cs - (w * w * u0 + zeta * w * v0) / wd * sn)
    for row, free in ((0, free_u), (1, free_v)):
        c = np.zeros((1, 2))
        c[0, row] = 1.0
        num, den = ss2tf(phi, b.reshape(2, 1), c, np.zeros((1, 1)))
        out.append(lfilter(num[0], den, p) + free + g1[row] * p)
    return out[0], out[1]


def _even_step(t) -> float:
    if t.ndim != 1 or len(t) < 2:
        raise ValueError("the record needs at least two samples")
    d = np.diff(t)
    dt = float(np.median(d))
    if dt <= 0.0 or np.abs(d - dt).max() > 1e-6 * dt:
        raise ValueError("the record's times are not evenly spaced (resample it to one step "
                         f"first; steps from {d.min():.6g} to {d.max():.6g} s)")
    return dt


def probe_acceleration(history, name):
    """(t, a) of a probe of a run: its values differentiated to an
    acceleration by its unit (m: twice, m/s: once; central differences on
    the output times, which must be evenly spaced)."""
    from .history_reader import open_history
    h = open_history(history) if isinstance(history, (str, bytes)) or hasattr(
        history, "__fspath__") else history
    if name not in h.observables:
        raise KeyError(f"probe {name!r}: not in the history (it has "
                       f"{', '.join(sorted(h.observables)) or 'none'})")
    t = np.asarray(h.time, dtype=float)
    x = np.asarray(h.observables[name], dtype=float)
    unit = h.units.get(f"observables/{name}", "1")
    order = {"m": 2, "m s-1": 1, "m s-2": 0}.get(unit)
    if order is None:
        raise ValueError(f"probe {name!r} is in {unit}: a spectrum needs a displacement, "
                         "a velocity or an acceleration")
    _even_step(t)
    for _ in range(order):
        x = np.gradient(x, t)
    return t, x
