"""Ground-motion records: reading one from a text file and integrating it
to the ground's velocity and displacement (issue 28: `ground_motion` in a
case, `python -m rbsm_dyn spectrum`).  NumPy only (layer 0)."""
from __future__ import annotations

import numpy as np

#: g [m/s²] (the standard gravity, CGPM 1901) for records given in g
G = 9.80665


def read_record(path, *, dt=None, units="m/s2", scale=1.0, columns=(0, 1), skip=0):
    """A ground-motion record from a text file (CSV or whitespace columns,
    `#` comments): (t [s], a_g [m/s²]).  Two columns by default, time and
    acceleration (`columns`: their indices); with `dt` one column of
    accelerations at that step (`columns[1]` picks it).  `units`: m/s2 or g;
    `scale` multiplies the record (after the units); `skip` header lines."""
    text = open(path, encoding="utf-8").read().replace(",", " ").splitlines()[skip:]
    rows = [r.split("#", 1)[0].split() for r in text]
    rows = [r for r in rows if r]
    try:
        data = [[float(x) for x in r] for r in rows]
    except ValueError as exc:
        raise ValueError(f"{path}: a line that is not numbers ({exc}); give skip= "
                         "(--skip N) for header lines") from None
    width = min(len(r) for r in data) if data else 0
    if dt is None:
        if width < 2:
            raise ValueError(f"{path}: one column: give its step (--dt SECONDS)")
        ct, ca = columns
        arr = np.array([[r[ct], r[ca]] for r in data])
        t, a = arr[:, 0], arr[:, 1]
    else:
        if not dt > 0:
            raise ValueError(f"--dt {dt!r}: a positive step [s]")
        a = np.array([r[min(columns[1], len(r) - 1)] if width > 1 else r[0] for r in data])
        t = dt * np.arange(len(a))
    if units not in ("m/s2", "g"):
        raise ValueError(f"units {units!r}: m/s2 or g")
    return t, a * (G if units == "g" else 1.0) * scale


def integrate(t, a, *, baseline="linear", sub=4):
    """The ground's motion from its acceleration record (t, a): times,
    acceleration, velocity and displacement at `sub` points per step of the
    record, exact for the record taken linear between its samples (the
    velocity is then piecewise quadratic, the displacement cubic), from
    rest at t[0].  `baseline`: "linear" subtracts from the record the
    straight line c0 + c1 (t − t0) that brings the velocity and the
    displacement back to zero at the record's end (the ground ends where it
    started, at rest: a record's drift from an offset in its zero line or
    a tilt of the instrument; Boore, "Effect of baseline corrections on
    displacements and response spectra for several recordings of the 1999
    Chi-Chi, Taiwan, earthquake", Bull. Seismol. Soc. Am. 91 (2001)
    1199-1211: the simplest of the corrections discussed there); "none"
    keeps it.  Returns (t, a, v, d) at the finer times and the corrected
    record (t, a) at its own samples."""
    t = np.asarray(t, dtype=float)
    a = np.asarray(a, dtype=float)
    if baseline not in ("none", "linear"):
        raise ValueError(f"baseline {baseline!r}: none or linear")
    if baseline == "linear":
        v_end, d_end = _ends(t, a)
        T = t[-1] - t[0]
        # ∫(c0 + c1 s) = v_end, ∫∫ = d_end over s in [0, T] from rest
        m = np.array([[T, T * T / 2.0], [T * T / 2.0, T ** 3 / 6.0]])
        c0, c1 = np.linalg.solve(m, [v_end, d_end])
        a = a - (c0 + c1 * (t - t[0]))
    s = np.linspace(0.0, 1.0, sub + 1)[:-1]
    h = np.diff(t)
    a0, a1 = a[:-1], a[1:]
    v = np.zeros(len(t))
    d = np.zeros(len(t))
    # over one step, a = a0 + (a1 − a0) τ/h: v = v0 + a0 τ + (a1 − a0) τ²/(2h),
    # d = d0 + v0 τ + a0 τ²/2 + (a1 − a0) τ³/(6h)
    v[1:] = np.cumsum(h * (a0 + a1) / 2.0)
    d[1:] = np.cumsum(v[:-1] * h + h * h * (2.0 * a0 + a1) / 6.0)
    tau = h[:, None] * s[None, :]
    tf = (t[:-1, None] + tau).ravel()
    af = (a0[:, None] + (a1 - a0)[:, None] * s[None, :]).ravel()
    vf = (v[:-1, None] + a0[:, None] * tau + (a1 - a0)[:, None] * tau ** 2
          / (2.0 * h[:, None])).ravel()
    df = (d[:-1, None] + v[:-1, None] * tau + a0[:, None] * tau ** 2 / 2.0
          + (a1 - a0)[:, None] * tau ** 3 / (6.0 * h[:, None])).ravel()
    return ((np.append(tf, t[-1]), np.append(af, a[-1]), np.append(vf, v[-1]),
             np.append(df, d[-1])), (t, a))


def _ends(t, a):
    h = np.diff(t)
    a0, a1 = a[:-1], a[1:]
    v = np.concatenate([[0.0], np.cumsum(h * (a0 + a1) / 2.0)])
    d_end = np.sum(v[:-1] * h + h * h * (2.0 * a0 + a1) / 6.0)
    return v[-1], d_end
