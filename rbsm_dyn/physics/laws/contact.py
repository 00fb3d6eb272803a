"""Contact on a broken face (Kawai 1978, eq. 15 form): compression only,
Coulomb friction |τ| ≤ μ|σn| with slip memory.

The normal spring acts only when the gap closes (δn < 0): σn = kn δn.  The
tangential springs act on the gap minus the accumulated slip u_slip:
τ* = ks (δτ − u_slip); if |τ*| > μ|σn| the traction is returned radially to
the cone and the slip grows by the excess (Cundall & Strack 1979).  An open
face carries nothing and its slip follows the gap, so a crack that closes
again starts from zero tangential force.
"""
import math

import numba as nb

JIT = dict(cache=True, nogil=True, fastmath=False, error_model="numpy")

CONTACT_OFF = -1.0   # μ < 0 in law_params: broken faces carry nothing


@nb.njit(inline="always", **JIT)
def contact_traction(mu, kn, ks, kt, dn, ds, dt, slip_s, slip_t):
    """Traction (σn, τs, τt) [Pa] of a broken face with gap (δn, δs, δt) and
    slip (slip_s, slip_t) [m], with the intact spring's stiffnesses (a
    support held in some directions only has k = 0 in the free ones);
    returns the traction, the new slip and whether the face is closed (1)
    or open (0)."""
    if mu < 0.0 or dn >= 0.0:
        return 0.0, 0.0, 0.0, ds, dt, 0
    sn = kn * dn
    ts = ks * (ds - slip_s)
    tt = kt * (dt - slip_t)
    tmax = -mu * sn
    t = math.sqrt(ts * ts + tt * tt)
    if t > tmax:
        r = tmax / t
        # slip takes the excess of the trial traction
        if ks > 0.0:
            slip_s += (ts - ts * r) / ks
        if kt > 0.0:
            slip_t += (tt - tt * r) / kt
        ts *= r
        tt *= r
    return sn, ts, tt, slip_s, slip_t, 1
