"""The contact faces of the static Newton iteration: which broken springs
can touch (_contact_faces), their status at given gaps, open, slipping or
sticking (_contact_status), the gaps a step would give (_predicted_gap:
the primal-dual active set of an increment's first iteration, in
solvers/newton.py _increment, with ACTIVE_MAX and ACTIVE_TOUCHING_ONLY),
a correction's largest translation (_translation: the trust-region step
bound STEP_LIMIT of _increment, with Newton._step_scale), and a part that
flew, loose, in a converged increment (_flown_part).  The slip secant
(Newton.slip_secant) and the held status of IMPL-EX's contact faces
(Newton.hold_status) are the iteration object's (solvers/newton_system.py).
Nothing here imports newton.py.
"""
import numpy as np

from ..physics.laws import BROKEN, P_MU
from ..physics.springs import spring_local_gap
from .newton_state import _restore, _save_motion
from .passes import body_state, model_arrays
from .statics import apply_increment


#: a part carrying less than this share of the largest force met, moved by
#: more than FLOWN_MOTION times the increment's prescribed translation, has
#: flown (_flown_part)
FLOWN_FORCE = 1e-9
FLOWN_MOTION = 10.0


def _flown_part(nt, state, saved, dlam, parts):
    """A message naming the part that flew in the increment just converged,
    or "": a part (not wholly prescribed) on which no spring between it and
    the rest acts (its faces all open, or touching at zero force) and which
    moved by more than FLOWN_MOTION times the increment's prescribed
    translation.  Such a state balances trivially -- nothing touches,
    nothing is loaded -- but its position is arbitrary (the part's rigid
    motion has no stiffness), so it is no equilibrium of the path: a beam on
    rigid pin and roller parts converged so, the beam slid by 1.5 mm and the
    roller by 3.7 mm under a platen pushed by 30 µm, every reaction 0.
    (Unilateral contact has a solution only while the loads are
    compatible with it, Fichera's condition: Kikuchi & Oden, Contact
    Problems in Elasticity, 1988, §6.)  Only with prescribed
    displacements; loads on a free part cannot balance."""
    scale = nt._step_scale(dlam)
    if not parts or scale <= 0.0:
        return ""
    m = nt.m
    n = nt.n
    moved = np.linalg.norm(state.body_pos[:n] - saved["body_pos"][:n], axis=1)
    sb = m.spring_bodies
    fmag = np.linalg.norm(state.spring_force, axis=1)
    free = nt.free.reshape(n, 6)
    limit = FLOWN_FORCE * max(nt.ref_max, 1e-300)
    for name, ids in parts:
        if ids.size == 0 or not np.any(free[ids]) or moved[ids].max() <= FLOWN_MOTION * scale:
            continue
        inside = np.zeros(n + 1, dtype=bool)
        inside[ids] = True
        cross = inside[sb[:, 0]] != inside[sb[:, 1]]
        if fmag[cross].sum() <= limit:
            return (f"part {name!r} lost all contact and moved by {moved[ids].max():.3g} m "
                    f"(the prescribed displacements moved by {scale:.3g} m): nothing holds it, "
                    f"and a static solution has no position for it; hold it (boundary fix) or "
                    f"let the parts touch")
    return ""


def _translation(nt, dU):
    """The largest translation [m] of one body in the correction dU."""
    if not nt.n:
        return 0.0
    return float(np.max(np.linalg.norm(dU.reshape(nt.n, 6)[:, :3], axis=1)))


def _contact_faces(nt, state, tri):
    """Indices of the broken springs that can touch (their trial state
    broken, not parted, a law with contact)."""
    m = nt.m
    sstate = tri[0]
    if sstate is None:
        return np.zeros(0, dtype=np.int64)
    mu = m.law_params[m.spring_law, P_MU]
    return np.flatnonzero((sstate >= BROKEN) & (mu >= 0.0) & (state.spring_kappa != np.inf))


def _contact_status(nt, state, cgap, faces):
    """Status of the contact faces `faces` at the gaps cgap (S, 3; None:
    the present gaps), as _local_tangents reads it: 0 open, 1 closed and
    slipping (or touching, with no friction to hold), 2 closed and sticking."""
    m = nt.m
    if cgap is None:
        cgap = np.empty((m.n_springs, 3))
        spring_local_gap(model_arrays(m)[1], body_state(state), cgap)
    g = cgap[faces]
    k = m.spring_k[faces]
    dp = state.spring_dp[faces]
    mu = m.law_params[m.spring_law[faces], P_MU]
    gn = g[:, 0] - np.minimum(dp[:, 0], 0.0)       # less a capped spring's compaction
    closed = gn <= 1e-12 * m.spring_h[faces]
    t = np.hypot(k[:, 1] * (g[:, 1] - dp[:, 1]), k[:, 2] * (g[:, 2] - dp[:, 2]))
    tmax = -mu * k[:, 0] * gn
    stick = closed & (mu > 0.0) & (tmax > 0.0) & (t <= tmax)
    return closed.astype(np.int8) + stick


def _predicted_gap(nt, state, dU, lam_new, lam):
    """The spring gaps (S, 3) after the step dU (λ → lam_new); the state is
    left as it was."""
    m = nt.m
    saved = _save_motion(state)
    apply_increment(m, state, dU.reshape(nt.n, 6))
    nt.set_prescribed(state, lam_new)
    gap = np.empty((m.n_springs, 3))
    spring_local_gap(model_arrays(m)[1], body_state(state), gap)
    _restore(state, saved)
    nt.set_prescribed(state, lam)
    return gap
