"""The springs' local tangents of the static Newton iteration (compiled):
every spring's 3 × 3 stiffness at its trial state (_local_tangents: the
damaged secant or the consistent tangent of a growing damage, the
compressive cap, a contact face's normal spring and Coulomb friction, an
open crack at OPEN_FRACTION), and the consistent tangent of a yielding
spring's return mapping by central differences (_plastic_tangent,
_plastic_forces).  Newton.local (solvers/newton_system.py) calls them;
nothing here imports the other Newton modules but newton_linear.py's
OPEN_FRACTION.
"""
import math

import numba as nb
import numpy as np

from ..physics.laws import (BROKEN, P_CAP, P_CAPH, P_CAPK, P_COH, P_CRIT, P_MODEL, P_FT, P_GF, P_GS,
                            P_MU, P_RS, P_RUPT, P_SY, P_TANPHI, P_TENSION)
from ..physics.laws.plastic import CONTINUUM, MOHR_COULOMB, plastic_return
from ..physics.laws.rupture import (MIXED, SOFTENING, cap_stress, mixed_mode_damage,
                                    softening_damage)
from .newton_linear import OPEN_FRACTION


@nb.njit(cache=True)
def _local_tangents(laws, trial, committed, gap, cgap, open_fraction, slip_floor, tangent, out):
    """Local stiffness (3 × 3, [N/m]) of every spring at its trial state
    (rupture.py's laws): intact: diag(kn, ks, kt) times (1 − D) (a closed
    face's normal spring whole); a spring whose damage grows in this
    increment (D > the committed D0) gets the consistent tangent
    ∂f/∂e = (1 − D) K − K e ⊗ ∂D/∂e (∂D/∂e by central differences of the
    damage function; not symmetric); broken: contact at full normal
    stiffness when the faces overlap or touch at the gaps `cgap` (the
    present gaps `gap`, or the active set newton._increment settles: δn ≤ 0), its
    friction at the elastic stiffness while it sticks and at the
    consistent tangent of the Coulomb return while it slips, along the slip
    regularised to `slip_floor` of the return's secant (the consistent
    tangent has none there: a body held by slipping faces only, a roller
    free along x, made the matrix singular); else `open_fraction` of it.
    `tangent` False: the secant (1 − D) K for all.
    Returns True when some spring got a tangent.  laws: (spring_k,
    spring_area, spring_h, spring_law, law_params) per spring point; trial:
    (state, dmg) the trial history; committed: (dmg0, kappa0, dp)."""
    spring_k, spring_area, spring_h, spring_law, law_params = laws
    state, dmg = trial
    dmg0, kappa0, dp = committed
    any_soft = False
    g = np.zeros(3)
    for s in range(spring_k.shape[0]):
        kn, ks, kt = spring_k[s, 0], spring_k[s, 1], spring_k[s, 2]
        P = law_params[spring_law[s]]
        if state[s] >= BROKEN:
            f = open_fraction
            mu = P[P_MU] if kappa0[s] != np.inf else -1.0     # parted: no contact
            # touching counts as closed (the active set of a semi-smooth
            # Newton: a face at zero gap takes its normal stiffness, and one
            # in tension opens at the next iteration, the residual being
            # exact; at an increment's first step newton._increment decides the
            # touching faces by their predicted gaps, cgap)
            # (a capped spring's compaction, dp_n < 0, is its contact's zero)
            g0 = cgap[s, 0] - min(dp[s, 0], 0.0)
            if g0 <= 1e-12 * spring_h[s] and mu >= 0.0:
                out[s, 0, 0] = kn
                # Coulomb friction (laws/contact.py) from the committed slip:
                # stick, the elastic springs; slip, the consistent tangent of
                # the radial return τ = μ|σn| m, m = τ*/|τ*| (Wriggers,
                # Computational Contact Mechanics, 2006, §6.4 / Simo & Taylor
                # 1985): ∂τ/∂δτ = (μ|σn|/|τ*|)(K − m mᵀ K), ∂τ/∂δn = −μ kn m,
                # not symmetric; along m `slip_floor` of the secant
                # μ|σn|/|τ*| K (so (K − (1 − slip_floor) m mᵀ K)), floored
                # at `open_fraction` of K
                ts = ks * (cgap[s, 1] - dp[s, 1])
                tt = kt * (cgap[s, 2] - dp[s, 2])
                t = math.sqrt(ts * ts + tt * tt)
                tmax = -mu * kn * g0
                if mu > 0.0 and tmax > 0.0 and t <= tmax:
                    out[s, 1, 1] = ks
                    out[s, 2, 2] = kt
                elif mu > 0.0 and tmax > 0.0:                # t > tmax > 0
                    # (a face touching at a gap of +0 holds no friction:
                    # the floor below)
                    r = tmax / t
                    ms = ts / t
                    mt = tt / t
                    c = 1.0 - slip_floor
                    out[s, 1, 1] = max(r * ks * (1.0 - c * ms * ms), f * ks)
                    out[s, 1, 2] = -r * c * ms * mt * kt
                    out[s, 2, 1] = -r * c * mt * ms * ks
                    out[s, 2, 2] = max(r * kt * (1.0 - c * mt * mt), f * kt)
                    out[s, 1, 0] = -mu * kn * ms
                    out[s, 2, 0] = -mu * kn * mt
                    any_soft = True
                else:
                    out[s, 1, 1] = f * ks
                    out[s, 2, 2] = f * kt
            else:
                out[s, 0, 0] = f * kn
                out[s, 1, 1] = f * ks
                out[s, 2, 2] = f * kt
            continue
        D = dmg[s]
        en = gap[s, 0] - dp[s, 0]
        es = gap[s, 1] - dp[s, 1]
        et = gap[s, 2] - dp[s, 2]
        out[s, 0, 0] = kn * (1.0 - D) if en > 0.0 else kn
        out[s, 1, 1] = ks * (1.0 - D)
        out[s, 2, 2] = kt * (1.0 - D)
        if P[P_CAP] > 0.0 and en < 0.0:
            # on the compressive cap: the traction follows the boundary of
            # the total gap, ∂σn/∂δn = kn σ_bc'(−δn kn) (rupture.cap_stress),
            # floored as a yielding spring's
            kna = kn / spring_area[s]
            sbc, slope = cap_stress(gap[s, 0], kna, P[P_CAP], P[P_CAPH], P[P_CAPK])
            if kna * en < -sbc:
                out[s, 0, 0] = kn * max(slope, open_fraction)
        if P[P_CRIT] > 0 and P[P_MODEL] != CONTINUUM and D == 0.0:
            # yielding: the consistent tangent of the return mapping
            # (Simo & Hughes 1998, §3.3: ∂σ/∂ε of the closest-point
            # projection), by central differences of plastic.py's return
            if _plastic_tangent(P, kn, ks, kt, spring_area[s], en, es, et, out[s]):
                any_soft |= P[P_CRIT] == MOHR_COULOMB     # non-associated: unsymmetric
            continue
        if not tangent or D <= dmg0[s] or D >= 1.0 or P[P_CRIT] > 0:
            continue
        area = spring_area[s]
        rupt = P[P_RUPT]
        g[:] = 0.0
        if rupt == SOFTENING:
            if en <= kappa0[s]:
                continue
            h = 1e-6 * abs(en) + 1e-300
            g[0] = (softening_damage(en + h, kn / area, P[P_FT], P[P_GF])
                    - softening_damage(en - h, kn / area, P[P_FT], P[P_GF])) / (2.0 * h)
        elif rupt == MIXED:
            e = np.array([en, es, et])
            scale = 1e-6 * math.sqrt(en * en + es * es + et * et) + 1e-300
            for c in range(3):
                ep = e.copy()
                em = e.copy()
                ep[c] += scale
                em[c] -= scale
                dp_, _ = mixed_mode_damage(ep[0], ep[1], ep[2], kn / area, ks / area,
                                           kt / area, P[P_FT], P[P_GF], P[P_RS], P[P_GS])
                dm_, _ = mixed_mode_damage(em[0], em[1], em[2], kn / area, ks / area,
                                           kt / area, P[P_FT], P[P_GF], P[P_RS], P[P_GS])
                g[c] = (dp_ - dm_) / (2.0 * scale)
        else:
            continue
        fvec = (kn * en if en > 0.0 else 0.0, ks * es, kt * et)
        for i in range(3):
            for j in range(3):
                out[s, i, j] -= fvec[i] * g[j]
        any_soft = True
    return any_soft


@nb.njit(cache=True)
def _plastic_forces(P, kn, ks, kt, area, en, es, et):
    """Spring forces [N] of the trial elastic gap (en, es, et) [m] after
    the return mapping (physics/inelastic.py's call of plastic_return)."""
    gn, gs, gt, y = plastic_return(int(P[P_CRIT]), P[P_SY] * area, P[P_COH] * area,
                                   P[P_TANPHI], P[P_TENSION] * area, kn, ks,
                                   kn * en, ks * es, kt * et)
    return gn, gs, gt, y


@nb.njit(cache=True)
def _plastic_tangent(P, kn, ks, kt, area, en, es, et, out):
    """out (3 × 3) = ∂(returned forces)/∂(gap) of a spring that yields at
    its trial gap, floored at OPEN_FRACTION of the elastic stiffness on the
    diagonal (perfect plasticity has a zero modulus: the floor keeps a
    collapse mechanism under displacement control solvable); False when the
    spring does not yield."""
    y = _plastic_forces(P, kn, ks, kt, area, en, es, et)[3]
    if y == 0:
        return False
    e = np.array([en, es, et])
    h = 1e-7 * (math.sqrt(en * en + es * es + et * et) + 1e-30)
    for c in range(3):
        ep = e.copy()
        em = e.copy()
        ep[c] += h
        em[c] -= h
        pn, ps, pt, _ = _plastic_forces(P, kn, ks, kt, area, ep[0], ep[1], ep[2])
        mn, ms, mt, _ = _plastic_forces(P, kn, ks, kt, area, em[0], em[1], em[2])
        out[0, c] = (pn - mn) / (2.0 * h)
        out[1, c] = (ps - ms) / (2.0 * h)
        out[2, c] = (pt - mt) / (2.0 * h)
    k = (kn, ks, kt)
    for r in range(3):
        if out[r, r] < OPEN_FRACTION * k[r]:
            out[r, r] = OPEN_FRACTION * k[r]
    return True
