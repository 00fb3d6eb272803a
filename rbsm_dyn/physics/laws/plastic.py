"""Elastic–perfectly-plastic spring tractions: return mapping onto the yield
surface of the spring traction (σn, τs, τt), exact for perfect plasticity
(closest point in the energy norm of the spring stiffness = backward Euler
with associated flow; Simo & Hughes, Computational Inelasticity, §1.4 and
§3.3).  σn > 0 is tension, τ = √(τs² + τt²).

Criteria (ids as stored in law_params):
  normal        |σn| ≤ σy, shear elastic (the bending-only assumption of
                beam theory: layered springs give Mp = σy b h²/4)
  tresca        √(σn² + 4τ²) ≤ σy
  von_mises     √(σn² + 3τ²) ≤ σy
  mohr_coulomb  τ ≤ c − σn tan φ and σn ≤ T (tension cut-off), slip with
                zero dilatancy (non-associated: the normal part is returned
                only by the cut-off), as in DEM bond models (Cundall &
                Strack 1979; Potyondy & Cundall 2004).

These are interface criteria (`model: interface`): the traction alone
decides, so a pressure σn = −σy yields a spring whatever the stress beside
it, and a block lattice's strength depends on direction.  `model:
continuum` (tresca, von_mises) judges yield as Kawai's programs did, on the
stress of the continuum (Kawai 1978, "New discrete models and their
application to seismic response analysis of structures", Nucl. Eng. Des.
48; Kawai & Toi 1977): each cell's stress σ_c, the Love–Weber average of
its springs' forces, is returned to J2's cylinder √J2 ≤ k (k = σy/2 for
tresca, σy/√3 for von_mises: in plane strain, where the out-of-plane stress
is the mean of the in-plane ones in plastic flow, the two are one
criterion, Hill 1950, ch. VI) by the radial return of J2 plasticity (Simo
& Hughes 1998, §3.3.1); the cell's plastic strain increment, deviatoric,
moves the plastic gaps of its springs by h ε_p n (half from each of a
face's two cells), physics/inelastic.py finish_cell_stress and
plastic_offset.  Pressure is free, the plastic flow isochoric, the
strength the same in every direction of the mesh.  A face-wise return on
the face's traction and its cells' in-plane stress (tried first, issue 27)
is also pressure-free, but each face flows on its own multiplier: the
plastic flow then changes volume and the mean stress drifts (a 2D block
square in pure shear: σxx + σyy from 0 to 2.5 k at 10 yield strains), and
Prandtl's punch came at 0.79 of (2 + π)k.
"""
import math

import numba as nb

JIT = dict(cache=True, nogil=True, fastmath=False, error_model="numpy")

NONE, NORMAL, TRESCA, VON_MISES, MOHR_COULOMB = 0, 1, 2, 3, 4
INTERFACE, CONTINUUM = 0, 1          # law_params[P_MODEL]
MODELS = {"interface": INTERFACE, "continuum": CONTINUUM}
CRITERIA = {"normal": NORMAL, "tresca": TRESCA, "von_mises": VON_MISES,
            "mohr_coulomb": MOHR_COULOMB}


@nb.njit(inline="always", **JIT)
def _ellipse_return(sn, ss, st, kn, ks, c, sy):
    """Closest point of the trial traction on √(σn² + c τ²) = σy in the
    norm of the compliance diag(1/kn, 1/ks): σn = σn*/(1 + λ kn),
    τ = τ*/(1 + λ c ks), λ ≥ 0 the root of f(λ) = σn² + c τ² − σy² = 0,
    found by Newton from λ = 0 (f is convex and decreasing in λ, so the
    iterates increase monotonically to the root)."""
    t2 = ss * ss + st * st
    lam = 0.0
    tol = 1e-13 * sy * sy    # |f| at round-off of the traction (a 1e-15 step
    for _ in range(60):      # tolerance never triggered: 32 iterations on average)
        an = 1.0 / (1.0 + lam * kn)
        at = 1.0 / (1.0 + lam * c * ks)
        f = sn * sn * an * an + c * t2 * at * at - sy * sy
        if abs(f) <= tol:
            break
        df = -2.0 * (sn * sn * kn * an * an * an + c * c * ks * t2 * at * at * at)
        if df == 0.0:
            break
        step = f / df
        lam -= step
        if abs(step) <= 1e-13 * abs(lam):
            break
    an = 1.0 / (1.0 + lam * kn)
    at = 1.0 / (1.0 + lam * c * ks)
    return sn * an, ss * at, st * at


@nb.njit(inline="always", **JIT)
def plastic_return(crit, sy, coh, tanphi, tension, kn, ks, sn, ss, st):
    """Admissible traction (σn, τs, τt) [Pa] for the trial traction of the
    same name, the per-area stiffnesses kn, ks [Pa/m]; returns the new
    traction and whether the spring yielded (1) or not (0)."""
    if crit == NORMAL:
        if sn > sy:
            return sy, ss, st, 1
        if sn < -sy:
            return -sy, ss, st, 1
        return sn, ss, st, 0
    if crit == TRESCA or crit == VON_MISES:
        c = 4.0 if crit == TRESCA else 3.0
        if sn * sn + c * (ss * ss + st * st) <= sy * sy:
            return sn, ss, st, 0
        a, b, d = _ellipse_return(sn, ss, st, kn, ks, c, sy)
        return a, b, d, 1
    if crit == MOHR_COULOMB:
        yielded = 0
        if sn > tension:
            sn = tension
            yielded = 1
        tmax = coh - sn * tanphi
        if tmax < 0.0:
            tmax = 0.0
        t = math.sqrt(ss * ss + st * st)
        if t > tmax:
            r = tmax / t
            ss *= r
            st *= r
            yielded = 1
        return sn, ss, st, yielded
    return sn, ss, st, 0
