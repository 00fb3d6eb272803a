"""Spring laws, one module per family, registered under the names the case
file uses (STYLE.md 0):

* plastic.py  `yield: {criterion: normal | tresca | von_mises | mohr_coulomb}`
* rupture.py  `rupture: {strain}` (sudden), `{law: tension, fracture_energy, tensile_strength}`
              (tension softening) or `{law: mixed_mode, ...}` (the default: tension,
              shear and compression on one damage variable)
* contact.py  broken springs: compression only, Coulomb friction `friction: μ`

A spring's law is a row of the table `law_params (n_laws, N_PARAMS)`
(columns below), chosen per spring by `spring_law (S,) int32`; the row is
built once per run from the materials of the spring's two bodies
(model/laws.py).  Stresses are per unit area [Pa]; a kernel multiplies by the
spring's area.  Spring states (history `springs/state`): 0 elastic,
1 yielded, 2 broken (open), 3 contact (broken and closed).
"""
__all__ = ["CONTACT_OFF", "contact_traction", "CRITERIA", "plastic_return", "RUPTURE_KINDS",
           "ELASTIC", "YIELDED", "BROKEN", "CONTACT", "N_PARAMS"]

from .contact import CONTACT_OFF, contact_traction  # noqa: F401
from .plastic import CRITERIA, plastic_return  # noqa: F401
from .rupture import RUPTURE_KINDS  # noqa: F401

ELASTIC, YIELDED, BROKEN, CONTACT = 0, 1, 2, 3

# columns of law_params
P_CRIT = 0        # yield criterion id (plastic.CRITERIA), 0: none
P_SY = 1          # yield stress σy [Pa] (normal, tresca, von_mises)
P_COH = 2         # cohesion c [Pa] (mohr_coulomb)
P_TANPHI = 3      # tan φ (mohr_coulomb)
P_TENSION = 4     # tension cut-off [Pa] (mohr_coulomb; inf if none)
P_RUPT = 5        # rupture kind id (rupture.RUPTURE_KINDS), 0: none
P_EPSCR = 6       # rupture strain ε_cr (strain)
P_FT = 7          # tensile strength f_t [Pa] (softening)
P_GF = 8          # fracture energy G_f [J/m²] (softening)
P_MU = 9          # Coulomb friction μ of a broken face
P_RS = 10         # shear-to-tensile strength ratio f_s/f_t (mixed_mode)
P_GS = 11         # mode-II fracture energy G_s [J/m²] (mixed_mode)
P_MODEL = 12      # yield judged on: 0 the spring's traction (interface), 1 the
                  # continuum stress at the face (plastic.CONTINUUM; tresca, von_mises)
P_RATE = 13       # strength raised with the loading rate: 0 no, 1 fib Model Code 2010
                  # (rupture.RATE_LAWS; mixed_mode)
P_SLOW = 14       # √(ρ/E) [s/m] of the material: the rate is smoothed over the time
                  # h √(ρ/E) a bar wave takes to cross the spring (rupture.smoothed_rate)
P_CAP = 15        # compressive yield stress σ_c0 of the cap [Pa], 0: no cap (rupture.cap_stress)
P_CAPH = 16       # the cap's hardening modulus over the normal modulus, H_c0/E0
P_CAPK = 17       # the cap's transitional strain ratio k_c0 (densification beyond k_c0 ε_c0)
N_PARAMS = 18
