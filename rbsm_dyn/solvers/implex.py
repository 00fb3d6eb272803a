"""IMPL-EX for the static Newton solver (``solver.damage_update: implex``;
Oliver, Huespe & Cante 2008, "An implicit/explicit integration scheme to
increase computability of non-linear material and contact/friction
problems", CMAME 197, 1865; solvers/newton.py's docstring): whether a model
has laws to extrapolate (_damaging) and the damage an increment holds, its
linear extrapolation from the last two converged increments
(_extrapolated_damage).  The rest of IMPL-EX is the iteration object's
(solvers/newton_system.py: Newton.hold_damage, the held normal status
Newton.hold_status and its forces Newton._held_wrench) and the increment's
(solvers/newton.py _increment: HOLD_AFTER, HOLD_ROUNDS, the held status
checked at convergence; _increment_or_retry).  Nothing here imports the
Newton modules.
"""
import numpy as np

from ..physics.laws import P_RUPT
from ..physics.laws.rupture import MIXED, SOFTENING


def _damaging(m):
    """True when some spring point has a softening law (rupture.py SOFTENING,
    MIXED): the laws IMPL-EX extrapolates."""
    rupt = m.law_params[m.spring_law, P_RUPT] if m.n_springs else np.zeros(0)
    return bool(np.any(np.isin(rupt, (SOFTENING, MIXED))))


def _extrapolated_damage(m, saved, dmg_last, ratio):
    """IMPL-EX's explicit extrapolation of the damage (Oliver, Huespe &
    Cante 2008, CMAME 197, eq. 37, on D for the internal variable):
    D̃ = D_n + ratio (D_n − D_(n−1)), ratio = Δτ_(n+1)/Δτ_n the increments
    of the path parameter, within [D_n, 1]."""
    dn = saved["spring_dmg"]
    return np.clip(dn + ratio * (dn - dmg_last), dn, 1.0)
