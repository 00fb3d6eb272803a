"""Rupture of a spring point (a crack across that part of the face).

* strain (Kawai 1978, Fig. 7): the spring breaks when its equivalent
  strain reaches ε_cr.  Equivalent strain of the gap δ over the length h,
  of von Mises form on (ε, γ): ε_eq = √(⟨δn⟩² + (δs² + δt²)/3) / h
  (⟨x⟩ = max(x, 0): closing never breaks a spring).  The elastic energy
  the spring held is released as fracture energy.
* softening (crack band; Bažant & Oh, Mater. Struct. 16, 155, 1983): linear
  tension softening on the normal opening with secant unloading (scalar
  damage D on both normal and shear springs).  Peak at δ0 = f_t/k_n, full
  break at δu = 2 G_f/f_t, so the energy dissipated per unit face area is
  ½ f_t δu = G_f whatever the cell size: the law is written in the opening
  δ, so h enters only through k_n = E0/h (the regularisation).  For
  δ0 ≤ κ ≤ δu: D(κ) = δu (κ − δ0) / (κ (δu − δ0)), κ the largest opening.
  If δu ≤ δ0 (cells too large for G_f) the spring breaks at the peak.
  Dissipation rate Y·Ḋ, Y = ½ (kn δn² + ks |δτ|²) (damage mechanics).
"""
import math

import numba as nb

JIT = dict(cache=True, nogil=True, fastmath=False, error_model="numpy")

NONE, STRAIN, SOFTENING = 0, 1, 2
RUPTURE_KINDS = {"strain": STRAIN, "fracture_energy": SOFTENING}


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
