"""Static mode by Newton iterations: path following for softening.

Kawai's incremental equilibrium (Kawai 1978; the seed's eq. 21,
(K + K0 + KG) d* = F* − Fr) solved per increment by Newton iterations on
the exact residual.  The residual r = f_springs(x) + λ F (F the loads at
full amplitude, f_springs the wrenches the spring kernels give at the
present positions and rotations, from the spring history of the last
converged increment: a trial, path-independent within the increment) is
driven to zero on the free DOFs.  The iteration matrix is the secant
stiffness Σ B_sᵀ C_s B_s (stiffness.py) in the present configuration,
plus the geometric stiffness of the spring forces once rotations are
finite (solvers/assembly.py): each
spring's (k_n, k_s, k_t) times (1 − d) for a damaged spring (the
consistent tangent while its damage grows), the consistent tangent of the
return mapping for a yielding one (perfect plasticity: a zero modulus,
floored at OPEN_FRACTION), a closed
or touching contact at full stiffness (its tangential springs too when it
has friction, at the consistent tangent of its Coulomb return while it
slips; the contact faces' active set of an increment's first step
settled by a primal-dual active set while some face touches at zero gap,
_increment), an open crack at 10⁻⁶ of it (Rots & Invernizzi
2004's secant "sequentially linear" stiffness is always positive, so the
solve never meets a negative pivot on a softening branch; the rate of
convergence is linear there, quadratic on elastic parts).  Linear
solves (solvers/newton_linear.py _LowRank): while no body has turned by
more than GEOMETRIC_ANGLE, one SuperLU factorisation (scipy;
nested-dissection order by METIS) of
the first iteration's matrix K0 (made symmetric: an unsymmetric spring by
its diagonal) serves the whole run, the springs whose
stiffness has changed since (the fracture process zone) entering by
Woodbury's identity on the DOFs of their bodies: on the 2 866-cell
notched beam of benchmarks/quasi_static.py one factorisation instead of
one or more per iteration (7-17 s per increment before, 1-2 s now).
Past GEOMETRIC_ANGLE (_Full): the whole matrix with the geometric
stiffness, conjugate gradients or GMRES preconditioned by the factors of
an earlier one; an increment that fails on it is made again on the
low-rank one, and the reverse (_increment_or_retry).

Control:
* load / displacement control: λ runs 1/n, 2/n, ... 1 (``load_steps``),
  loads and prescribed displacements scaled by λ;
* indirect displacement control (``solver.control: {probe, increment,
  end}``): λ is an unknown and each increment prescribes the value of a
  relative-displacement probe (a CMOD), τ_k = τ_(k−1) + Δτ; per iteration
  δU = δU_r + δλ δU_F with K δU_r = r and K δU_F = F (the reference load,
  prescribed displacements at full amplitude), δλ from the linearised
  constraint c·(U + δU) = τ (de Borst 1987, "Computation of post-bifurcation
  and post-failure behavior of strain-softening solids"; Crisfield,
  Non-linear Finite Element Analysis of Solids and Structures, vol. 1,
  §9.6).  λ may fall: a snap-back in load against displacement is
  followed as long as the probe grows.
* plain displacement control switches to the opening of the first crack
  once cracking starts (_auto_control); that control's first increment
  starts on the branch of the displacement increment that started it
  (_branch_predictor).
A correction that translates a body by more than STEP_LIMIT times the
increment's own displacements is shortened (a trust-region step bound),
and an increment that converges with a part loose and moved far
(_flown_part: nothing touches it, so it balances trivially) is cut: a
specimen on rigid pin and roller parts is a mechanism at λ = 0.
IMPL-EX (``solver.damage_update: implex``; Oliver, Huespe & Cante 2008,
"An implicit/explicit integration scheme to increase computability of
non-linear material and contact/friction problems", CMAME 197, 1865):
for a diffuse process zone (a Brazilian disc), where the implicit update
switches thousands of springs per iteration and stalls, each increment
holds the damage of the softening laws at its linear extrapolation from
the last two converged increments (_extrapolated_damage), so the
increment is a damaged elastic problem whose secant is its tangent; its
matrix adds the geometric stiffness of the spring forces (_WithGeometric,
GMRES on the low-rank factors: under the disc's strip pressures its
neglect alone stalled the iteration), and an increment that fails is made
again on the low-rank matrix alone, or the reverse, and that matrix stays
(_increment_or_retry; past GEOMETRIC_ANGLE the implicit path's _Full
likewise); after HOLD_AFTER iterations the normal status of the
damaged springs and contact faces is held too (Newton.hold_status), and
with contact faces among them checked at convergence: if the springs at
their own gaps do not balance, the status is held anew (HOLD_ROUNDS
times).  After convergence the implicit law
commits the damage and books its energy; the equilibrium's reactions are
recorded.  (A step control on the difference of the implicit and the
held tractions, 5 % of the strength, halved nearly every increment of the
disc, whose process zone keeps starting new springs: not kept.)  The
damage lags by one increment: a peak may pass the strength by what one
increment adds (tests/test_auto_control.py), and the energy balance
errs by O(increment) (the disc: 1.9 % of the work at increments of 10⁻⁶
m of opening, 0.6 % at 5·10⁻⁷).
Under ``damage_update: auto`` (the default) the implicit update runs until
an increment fails all its halvings (IMPL-EX from there on) or it crawls
(DIVE_CUTS: the run goes back to its last undamaged state, the history's
later frames dropped, and on by IMPL-EX).
An increment that does not converge in NEWTON_MAX_IT iterations is cut in
half (from the last converged state) up to MAX_CUTS times; an increment
that converges lets the next one grow by √(DESIRED_IT/iterations), between
1 and 1.5 (Crisfield vol. 1, §9.5's rule; 1.5 at ≤ DESIRED_IT/2.25) (to
the given increment at most).  Every converged increment is a frame
(`time` = λ, `step` = the total iteration count).

Here: the increment loop (run), an increment's Newton iterations
(_increment, with the active set and the step bound inline) and its retry
on the other matrix (_increment_or_retry).  Elsewhere: the iteration
object Newton in newton_system.py, the springs' local tangents in
newton_tangent.py, the contact faces in newton_contact.py, the control in
newton_control.py, IMPL-EX's damage in implex.py, the saved states in
newton_state.py (none of them imports this module).
"""
import time as _time

import math

import numpy as np

from ..model import new_state
from ..physics.integrate import FREE
from ..physics.springs import spring_local_gap
from .explicit import RunFailed
from .implex import _damaging, _extrapolated_damage
from .newton_contact import (_contact_faces, _contact_status, _flown_part, _predicted_gap,
                             _translation)
from .newton_control import (_auto_control, _auto_increment, _branch_predictor, _combine,
                             _cracking, _direction, _load, probe_functional)
from .newton_linear import one_blas_thread
from .newton_state import _restore, _save, _save_motion
from .newton_system import Newton
from .newton_plastic import book_plastic_work, newton_increment
from .passes import body_state, model_arrays
from .statics import apply_increment, record_frame

NEWTON_MAX_IT = 40      # iterations per increment before it is cut
ACTIVE_TOUCHING_ONLY = True   # the active set settled only while some contact face touches at zero gap
ACTIVE_MAX = 6          # linear solves of an increment's first iteration that settle the contact set
MAX_CUTS = 12           # halvings of one increment
DESIRED_IT = 15         # iterations per increment the increment size aims at (11: the plain-displacement beam 129 s, 15: 97 s)
LINE_SEARCH = (0.5, 4.0)   # bounds of the line-search step
TANGENT_BACKTRACK = 2   # halvings of a tangent step that raised the residual before the secant
WILD_ANGLE = 0.5        # rotation [rad] of one body in one correction taken for divergence
# the largest translation of one body in one correction, in multiples of the
# increment's own displacement scale (Newton._step_scale): a longer
# correction is shortened to it (_increment), and an active-set solve of the
# first iteration that moves a body further is refused (10: three-point
# bending's softening corrections met it, 242 -> 289 iterations; 100: the
# 3D beam on rigid parts, c7o, failed its first increment; 30: neither)
STEP_LIMIT = 30.0
DIVERGED_RATIO = 1e2    # residual ratio taken for a diverged iteration (the increment is cut)
# iterations without a better residual after which an increment is cut (8
# before 2026-11-28; 6: three-point bending 29 -> 25 s, the notched beam
# of benchmarks/quasi_static.py under CMOD control 77 -> 72 s, under plain
# displacement 82 -> 86 s, all on the same path)
STALL_IT = 6
# the fall of the best residual STALL_IT iterations must bring: any (0.5,
# a halving, cut increments that were converging slowly: the plain-
# displacement notched beam 164 s against 129 s, three-point bending the same)
STALL_FACTOR = 1.0
# iteration of an IMPL-EX increment from which the damaged springs' normal
# status is held (Newton.hold_status)
HOLD_AFTER = 3
# times an IMPL-EX increment may hold the status anew when the held one
# proves no equilibrium at convergence (_increment); then it is cut
HOLD_ROUNDS = 4
# `damage_update: auto` gives the implicit update up when, once halvings
# have brought the increment below DIVE_FRACTION of the one asked for,
# DIVE_CUTS increments of that dive (before the step grows back above it)
# had to be halved again: a step that keeps being cut after it has fallen
# that far does not converge by getting smaller.  The Brazilian disc: cut
# to 1/130 of its increment and still cut, 30-60 s an increment, at 0.41
# of its load; three-point bending's one dive, to 1/300 at its peak, has
# one halved increment and grows back by the 1.5 rule.  The run then goes
# back to its last undamaged state and on by IMPL-EX from there (_run): the
# disc's implicit crawl had left the path (IMPL-EX from the crawl's state,
# at any increment, broke the disc at 0.41 of its load, where IMPL-EX from
# the start and the explicit ramps split it at 0.82)
DIVE_FRACTION = 1.0 / 16.0
DIVE_CUTS = 3


def run(case, model, recorder, *, max_steps=None, progress=None):
    """Solve the static case by Newton iterations (module docstring), BLAS
    on one thread: the dense capacitance solves (_LowRank._capacitance)
    round differently on two threads, and the path near a peak depends on
    it (three-point bending: 283 iterations on two BLAS threads, 268 on
    one), so a run's answer would depend on the machine's cores; one
    thread is also faster at these sizes (31 s against 25 s)."""
    with one_blas_thread():
        return _run(case, model, recorder, max_steps=max_steps, progress=progress)


def _run(case, model, recorder, *, max_steps=None, progress=None):
    sol = case.solver
    m = model
    try:
        it_ = Newton(m)
    except ValueError as exc:
        raise case.error(("boundary",), str(exc)) from None
    state = new_state(m)
    state.dt = 1.0
    t_wall = _time.perf_counter()
    record_frame(recorder, m, state, 0, 0.0, 0.0)
    frames = [1]

    def frame(lam, ratio):
        # the work of the loads Newton balances (inertia relief included)
        load = None if it_.relief is None else lam * it_.F.reshape(m.n_bodies, 6)
        record_frame(recorder, m, state, total, lam, ratio, load=load)
        frames[0] += 1
    control = getattr(sol, "control", None)
    plan = None
    if control is not None:
        from .output import probe_plan
        plan = probe_plan(m, {control.probe: case.output.probes[control.probe]}, case)[
            control.probe]
        if plan[0] == "error":
            raise plan[1]
        tau0, _ = probe_functional(m, state, plan)
        target_end = control.end
        d_max = control.increment
    else:
        target_end = 1.0
        d_max = 1.0 / sol.load_steps
    if progress:
        progress.start(100, 1.0)
    lam = 0.0
    pos = 0.0 if control is None else tau0       # the path parameter: λ or τ
    d = d_max
    total = 0
    iterations = []
    peak = 0.0
    sign = 1.0 if target_end >= pos else -1.0
    controlled = control is not None
    # plain displacement control switches to the opening of the crack by
    # itself once cracking starts (_auto_control)
    auto = not controlled and bool(np.any(it_.disp)) and state.spring_dmg is not None \
        and len(state.spring_dmg) > 0
    name = None if control is None else control.probe
    # IMPL-EX (module docstring) when the case asks for it; under `auto` (the
    # default) from the first increment the implicit update cannot converge
    update = getattr(sol, "damage_update", "auto")
    implex = update == "implex" and _damaging(m)
    fallback = update == "auto" and _damaging(m)
    dmg_last, step_last = state.spring_dmg.copy(), d
    implicit_next = False
    dive_cuts = 0           # halved increments of the present dive (DIVE_FRACTION)
    # the last undamaged state, to go back to when the implicit update crawls
    # (DIVE_CUTS; not once plain displacement control has switched itself)
    undamaged = None
    if fallback and not auto:
        undamaged = (_save(state), lam, pos, 0, frames[0],
                     getattr(recorder, "_path_work", None), peak)
    branch = None
    notes = [it_.note] if it_.note else []
    # the parts (model groups) whose flight _flown_part looks for
    parts = [(p, np.asarray(m.groups[p])) for p in (getattr(case, "parts", None) or {})
             if p in m.groups]
    while (auto and controlled and np.isinf(target_end)) or \
            sign * (target_end - pos) > 1e-12 * max(abs(target_end), d_max):
        step = min(d, sign * (target_end - pos))
        saved = _save(state)
        f_start = state.spring_force.copy() if it_.continuum else None
        flown_note = ""
        lam_saved = lam
        for cut in range(MAX_CUTS + 1):
            goal = pos + sign * step
            if implex and not implicit_next:
                it_.hold_damage(_extrapolated_damage(m, saved, dmg_last, step / step_last))
            start, lam_start = saved, lam
            if branch is not None:
                # the first increment of the switched control starts on the
                # branch of the displacement increment that started cracking
                # (_branch_predictor)
                start, lam_start = _branch_predictor(it_, state, saved, lam_saved, branch,
                                                     pos, goal)
            if it_.continuum:
                ok, lam, its, ratio = newton_increment(
                    _increment_or_retry, it_, state, lam_start, goal, plan, sol.tolerance,
                    controlled, start)
            else:
                ok, lam, its, ratio = _increment_or_retry(it_, state, lam_start, goal, plan,
                                                          sol.tolerance, controlled, start)
            if ok and branch is not None and (lam - lam_saved) * branch[1] < 0.0:
                # λ moved against the loading of the increment that started
                # cracking: the spurious branch (_branch_predictor); halve
                ok = False
            held = it_.implex
            if ok and held is not None:
                # the reactions of the equilibrium found (the damage held),
                # not of the implicit law's forces committed below, which it
                # does not balance: the loads' work is that of equilibrium
                _set_reactions(it_, state, lam)
            it_.hold_damage(None)
            total += its
            if controlled and auto and ok and lam > 1.0:
                # past the displacement the case asks for: the last stretch
                # under displacement control again, to λ = 1 exactly
                _restore(state, saved)
                ok, lam, its2, ratio = _increment(it_, state, lam_saved, 1.0, None,
                                                  sol.tolerance, False)
                total += its2
                its += its2
                if ok:
                    goal, target_end = pos, pos
                    break
            if ok:
                flown = _flown_part(it_, state, saved, lam - lam_saved, parts)
                if flown:
                    # (an equilibrium with no force in it: not the path's)
                    ok, ratio = False, np.inf
                    flown_note = flown
            if ok:
                break
            _restore(state, saved)
            lam = lam_saved
            step *= 0.5
            if max_steps is not None and total >= max_steps:
                break
        if not ok:
            what = (f"{name} = {goal:.4g}" if controlled else f"λ = {goal:.4g}")
            if fallback and not implex and not flown_note and \
                    (max_steps is None or total < max_steps):
                # the implicit damage update cycles (a diffuse process zone,
                # a crack through cells that crack under the supports): the
                # increment again, and the rest of the run, by IMPL-EX (Oliver,
                # Huespe & Cante 2008), which converges where it does not
                implex, implicit_next = True, False
                notes.append(f"increment {len(iterations) + 1} ({what}) did not converge "
                             f"under the implicit damage update (residual ratio {ratio:.3g} "
                             f"after {MAX_CUTS} halvings): IMPL-EX from there on "
                             "(solver.damage_update: implex; its error is of the order of "
                             "its increment, docs/case_file.md); give damage_update: "
                             "implicit to stop there instead")
                continue
            msg = (f"increment {len(iterations) + 1} ({what}) did not converge in "
                   f"{NEWTON_MAX_IT} Newton iterations after {MAX_CUTS} halvings: residual "
                   f"ratio {ratio:.3g} > tolerance {sol.tolerance:g}")
            if flown_note:
                msg += "; " + flown_note
            elif update == "implicit" and _damaging(m) and np.any(_cracking(m, state)):
                # a diffuse process zone (a splitting disc) makes the
                # implicit update cycle; IMPL-EX does not (Oliver et al. 2008)
                msg += ("; springs are softening in it: with many of them (a diffuse "
                        "process zone, a splitting disc) give solver.damage_update: implex "
                        "and a small control increment (docs/case_file.md)")
            frame(lam, ratio)
            recorder.fail(msg)
            raise RunFailed(msg)
        it_.trial(state, commit=True)
        if it_.continuum:
            book_plastic_work(it_, state, f_start, saved["spring_dp"])
        if auto and not controlled and np.any(_cracking(m, state)):
            # cracking has started in this increment: it is made again from
            # the last converged state with the opening of the crack it
            # started as the path parameter (_auto_control; a whole
            # increment of displacement can jump past the peak onto the
            # far side of a snap-back, where more than the crack has broken)
            plan = _auto_control(it_, state)
            if plan is not None:
                tau_t, _ = probe_functional(m, state, plan)
                trial_state, lam_t = _save_motion(state), lam
                _restore(state, saved)
                lam = lam_saved
                tau, _ = probe_functional(m, state, plan)
                pos, d_max = tau, _auto_increment(it_, state, plan, len(iterations))
                d = d_max
                name = "the crack opening"
                controlled, sign, target_end = True, 1.0, np.inf
                # (IMPL-EX: no rate of damage in the new path parameter yet,
                # and an extrapolation from none would hold the damage of
                # the state before cracking over a whole increment of
                # opening, an elastic overshoot recorded as a false peak
                # (1.7 × the implicit one on a notched plane beam): the
                # first increment of the new control is implicit)
                dmg_last, step_last = state.spring_dmg.copy(), d
                implicit_next = True
                branch = (trial_state, lam_t - lam_saved, tau_t - tau) \
                    if tau_t > tau else None
                continue
        branch = None
        pos = goal
        implicit_next = False
        iterations.append(its)
        dmg_last, step_last = saved["spring_dmg"], step
        d = min(d_max, step * min(max(math.sqrt(DESIRED_IT / max(its, 1)), 1.0), 1.5))
        if not implex:
            _set_reactions(it_, state, lam)
        if undamaged is not None and not implex:
            if step >= DIVE_FRACTION * d_max:
                dive_cuts = 0
            elif cut > 0:
                dive_cuts += 1
            if dive_cuts >= DIVE_CUTS:
                # the implicit update crawls (DIVE_CUTS): back to the last
                # undamaged state, its frames kept and the later ones
                # dropped, and on by IMPL-EX from there at the increment
                # asked for
                saved0, lam, pos, n_it, n_frames, work0, peak = undamaged
                what = (f"{name} = {goal:.4g}" if controlled else f"λ = {goal:.4g}")
                crawling = len(iterations)
                _restore(state, saved0)
                _set_reactions(it_, state, lam)
                del iterations[n_it:]
                recorder.rewind(n_frames, work0)
                frames[0] = n_frames
                it_.hold, it_.low_rank = None, None
                implex, implicit_next = True, False
                d = d_max
                dmg_last, step_last = state.spring_dmg.copy(), d
                undamaged = None
                notes.append(
                    f"increment {crawling} ({what}): the implicit damage update "
                    f"had to halve {DIVE_CUTS} increments that were already below "
                    f"{DIVE_FRACTION:g} of the increment asked for: back to the last state "
                    f"without damage ({'λ' if not controlled else name} = {pos:.4g}, frame "
                    f"{n_frames - 1}, the frames after it replaced) and on by IMPL-EX "
                    "(solver.damage_update: implex; its error is of the order of its "
                    "increment, docs/case_file.md); give damage_update: implicit to keep "
                    "the implicit update")
                if progress:
                    progress.note(f"increment {crawling}: the implicit damage update crawls; "
                                  f"back to frame {n_frames - 1} and on by IMPL-EX (warning "
                                  "at the end)", restart=True)
                continue
        frame(lam, ratio)
        load = abs(_load(it_, state, lam))
        peak = max(peak, load)
        if undamaged is not None and not implex and not np.any(state.spring_dmg):
            undamaged = (_save(state), lam, pos, len(iterations), frames[0],
                         recorder._path_work, peak)
        if progress:
            if control is None:
                frac = min(abs(lam), 1.0)        # (λ also under the crack-opening control)
            else:
                frac = 1.0 - abs(target_end - pos) / max(abs(target_end - tau0), 1e-300)
            progress.update(100 * frac, lam, ratio, label="residual")
        if control is not None and control.stop_fraction and peak > 0 \
                and load < control.stop_fraction * peak:
            break
        if auto and controlled and max_steps is None and len(iterations) > AUTO_MAX_INCREMENTS:
            msg = (f"the crack-opening control of plain displacement control took "
                   f"{AUTO_MAX_INCREMENTS} increments without reaching the displacement the "
                   f"case asks for (λ = {lam:.4g}); give solver.control (a CMOD probe)")
            recorder.fail(msg)
            raise RunFailed(msg)
        if max_steps is not None and total >= max_steps:
            return dict(iterations=iterations, wall_time=_time.perf_counter() - t_wall,
                        state=state, converged=False, warnings=notes)
    return dict(iterations=iterations, wall_time=_time.perf_counter() - t_wall, state=state,
                converged=True, warnings=notes)


#: increments the automatic crack-opening control may take before it gives up
AUTO_MAX_INCREMENTS = 2000


def _increment_or_retry(nt, state, lam, goal, plan, tol, controlled, saved):
    """_increment; an increment that fails on the whole present matrix
    (IMPL-EX's _WithGeometric, or _Full once a body has turned past
    GEOMETRIC_ANGLE) is made once more on the low-rank modified Newton
    (factorised afresh at the increment's start: the failed attempt may
    have renewed the factors at a wild iterate), or the reverse, and that
    matrix stays (Newton.whole).  The Brazilian disc near its peak stalls
    without the geometric stiffness; the notched beam on contact supports
    of tests/test_newton_contact.py fails its first increment on the whole
    matrix (12 halvings, implicit on _Full as under IMPL-EX), not for the
    geometric term, negligible there, but for the present matrix in place
    of the low-rank one's, whose residual is exact too."""
    nt.full_used = False
    ok, lam_new, its, ratio = _increment(nt, state, lam, goal, plan, tol, controlled)
    if ok or (nt.implex is None and nt.whole and not nt.full_used):
        return ok, lam_new, its, ratio
    _restore(state, saved)
    nt.hold = None
    nt.whole = not nt.whole
    nt.low_rank = None
    ok, lam_new, its2, ratio = _increment(nt, state, lam, goal, plan, tol, controlled)
    if not ok:
        nt.whole = not nt.whole
    return ok, lam_new, its + its2, ratio


def _increment(nt, state, lam, goal, plan, tol, controlled):
    """Newton iterations of one increment towards λ = goal (load control) or
    probe = goal (indirect control).  Returns (converged, λ, iterations,
    residual ratio)."""
    m = nt.m
    lam_start = lam
    if not controlled:
        lam = goal
    ratio = np.inf
    # the consistent tangent of damaging springs first (quadratic where it
    # works); the secant, always positive, for the rest of the increment
    # once the residual grows (a softening lattice can send the tangent
    # iteration astray: Rots & Invernizzi 2004)
    nt.use_tangent = True
    nt.slip_secant = False
    back = None
    seen = []
    rounds = 0
    for k in range(1, NEWTON_MAX_IT + 1):
        nt.set_prescribed(state, lam)
        r, tri = nt.residual(state, lam)
        prev = ratio
        ref = nt.reference(r, lam, state.body_support[:nt.n])
        ratio = nt.norm(r) / max(ref, 1e-300)
        if back is not None and not ratio < prev:
            # a step of the consistent tangent raised the residual (it can
            # send a softening lattice far astray, a cell turned by 0.02 rad
            # on the notched beam; or a contact face at a support opens or
            # starts slipping): halved back along the same direction
            # (backtracking, Dennis & Schnabel 1983, §6.3) up to
            # TANGENT_BACKTRACK times; if the residual still has not fallen,
            # undone, and the secant from here on
            motion, lam_b, ratio_b, dU_b, dlam_b, tries = back
            _restore(state, motion)
            if tries < TANGENT_BACKTRACK:
                dU_b, dlam_b = 0.5 * dU_b, 0.5 * dlam_b
                lam = lam_b + dlam_b
                apply_increment(m, state, dU_b.reshape(nt.n, 6))
                back = (motion, lam_b, ratio_b, dU_b, dlam_b, tries + 1)
                ratio = prev
                continue
            lam, ratio = lam_b, ratio_b
            nt.use_tangent = False
            nt.set_prescribed(state, lam)
            r, tri = nt.residual(state, lam)
            ref = nt.reference(r, lam, state.body_support[:nt.n])
        back = None
        if k > 1 and ((nt.raw == 0.0 and abs(lam - lam_start) > abs(lam_start))
                      or ratio > DIVERGED_RATIO):
            # no force left anywhere after λ more than doubled (every spring
            # broken or parted by a wild step, the platen of three-point
            # bending moved by metres: a residual of zero that is not the
            # path's equilibrium; a specimen broken through on the path
            # converges on REF_FLOOR) or an imbalance far above the loads:
            # the iteration has left the path; cut
            return False, lam, k, ratio if nt.raw > 0.0 else np.inf
        if k > 2 and not ratio < prev:
            nt.use_tangent = False
        if k > 1:               # (not the converged residual the increment starts from)
            seen.append(ratio)
        if nt.implex is not None and k == HOLD_AFTER and ratio > tol:
            nt.hold_status(state, tri)
            r, tri = nt.residual(state, lam)
        if len(seen) > STALL_IT and ratio > tol and \
                min(seen[-STALL_IT:]) > STALL_FACTOR * min(seen[:-STALL_IT]):
            # stalled: the best residual of the last STALL_IT iterations is
            # no better than the best before them (a cell of the process
            # zone switching between two states near the peak of
            # three-point bending, where 40 iterations ended no better);
            # cut now
            return False, lam, k, ratio
        if controlled:
            tau, c = probe_functional(m, state, plan)
            gap = goal - tau
        else:
            gap = 0.0
        if ratio <= tol and abs(gap) <= 1e-6 * max(abs(goal), 1e-300) and k > 1:
            if nt.hold is None or nt.hold[2].size == 0:
                return True, lam, k - 1, ratio
            # converged with the contact faces' status held (IMPL-EX): an
            # equilibrium only if the springs and faces, each at its own
            # gap, still balance (an active-set check, Hintermüller, Ito &
            # Kunisch 2002: a face held closed that has opened pulls; the
            # supports of three-point bending, held at the third iterate of
            # the first increment, ended it off equilibrium, with twice the
            # implicit increment's strain energy and 18 times its friction);
            # if not, the status of the present gaps is held and the
            # iteration goes on.  (Not for a model whose held springs are
            # all damaged ones: those that flip sit at a gap near zero,
            # where the two forces differ little, and checking them made
            # 5 increments of the Brazilian disc in the time 44 took
            # without; its faces, the broken springs of the split, are
            # checked)
            nt.hold = None
            r, tri = nt.residual(state, lam)
            ratio = nt.norm(r) / max(nt.reference(r, lam, state.body_support[:nt.n]), 1e-300)
            if ratio <= tol:
                return True, lam, k - 1, ratio
            if rounds == HOLD_ROUNDS:
                return False, lam, k, ratio
            rounds += 1
            nt.hold_status(state, tri)
            r, tri = nt.residual(state, lam)
            ratio = nt.norm(r) / max(nt.reference(r, lam, state.body_support[:nt.n]), 1e-300)
            seen = []
        if not np.isfinite(ratio):
            return False, lam, k, ratio
        lam0 = lam
        free = nt.free
        # the contact faces' active set of an increment's first step (a
        # primal-dual active set, Hintermüller, Ito & Kunisch 2002, "The
        # primal-dual active set strategy as a semismooth Newton method",
        # SIAM J. Optim. 13, on the linearised problem): the step of the
        # present set (a face closed when it overlaps or touches) moves every
        # contact face to a predicted normal gap; a face predicted to close
        # is closed (and sticks if its friction holds its present tangential
        # gap), one predicted to open is open, and the step is solved again
        # until the set repeats (ACTIVE_MAX solves at most).  A face touching
        # at zero gap -- a cut or an interface at the start -- is so decided
        # by the sign of its predicted normal force (tension: the intact
        # spring's answer opens it), not by its gap, which says nothing: the
        # notch of three-point bending, shut to the tangent, put λ 10 times
        # too high at the first step.  Later steps take the set of the
        # present gaps (the semi-smooth Newton iteration itself; a set
        # settled in every step cycled between two sets on the rocking
        # supports of three-point bending)
        nt.active = None
        contact = None
        first = None            # the translation scale of the set's first try
        good = None             # the last set's solution within STEP_LIMIT of it
        for inner in range(ACTIVE_MAX):
            lin = nt.linear(state, tri)
            out = _direction(nt, lin, r, controlled)
            if out is None:
                nt.active = None
                return False, lam, k, ratio
            dU_r, dF = out
            if controlled:
                den = float(c @ dF)
                if abs(den) < 1e-300:
                    nt.active = None
                    return False, lam, k, ratio
                cr = float(c @ dU_r)
            if k > 1:
                break
            if first is not None:
                # a set that leaves a body free to fly (a contact face
                # opened or slipping at zero force: the pin and the roller
                # of a beam on rigid parts, whose set cycled until one left
                # beam and roller sliding together by 1.2 mm under a
                # platen pushed by 3 µm) is no prediction: the last set
                # whose step stays within STEP_LIMIT of the first's is kept
                # (the PDAS converges for a nondegenerate problem only,
                # Hintermüller, Ito & Kunisch 2002, §4)
                d_try = _combine(dU_r, dF, gap, cr, den, 1.0)[0] if controlled else dU_r
                if _translation(nt, d_try) > STEP_LIMIT * first:
                    dU_r, dF, den, cr = good
                    break
            if contact is None:
                contact = _contact_faces(nt, state, tri)
                if contact.size == 0:
                    break
                now = np.empty((m.n_springs, 3))
                spring_local_gap(model_arrays(m)[1], body_state(state), now)
                touch = now[contact, 0] - np.minimum(state.spring_dp[contact, 0], 0.0)
                if ACTIVE_TOUCHING_ONLY and not np.any(
                        np.abs(touch) <= 1e-12 * nt.laws[2][contact]):
                    break
                closed = _contact_status(nt, state, now, contact) > 0
            dU, dlam = _combine(dU_r, dF, gap, cr, den, 1.0) if controlled else (dU_r, 0.0)
            if not np.all(np.isfinite(dU)):
                break
            if first is None:
                first = max(_translation(nt, dU), nt._step_scale(lam + dlam - lam_start))
            good = (dU_r, dF, den if controlled else None, cr if controlled else None)
            cg = now.copy()
            cg[:, 0] = _predicted_gap(nt, state, dU, lam + dlam, lam)[:, 0]
            new = _contact_status(nt, state, cg, contact) > 0
            if np.array_equal(new, closed):
                break
            closed = new
            nt.active = cg
        nt.active = None
        dU = dU_r
        if controlled:
            def step(alpha):
                """α δU_r + δλ(α) δU_F, δλ keeping the linearised constraint."""
                return _combine(dU_r, dF, gap, cr, den, alpha)
            dU, dlam = step(1.0)
            if not np.all(np.isfinite(dU)):
                return False, lam, k, ratio
            if k > 1:
                # line search on the residual part of the step (the secant
                # iteration converges linearly, its error along one softening
                # mode): r(α) is affine in α to first order, least at
                # α* = −r(0)·(r(1) − r(0))/|r(1) − r(0)|² (Crisfield vol. 1,
                # §9.3), the constraint held for any α
                saved = _save_motion(state)
                res = []
                for alpha in (0.0, 1.0):
                    if alpha == 0.0 and abs(gap) <= 1e-9 * abs(goal):
                        # the constraint holds (to 1e-9): α = 0 is the present
                        # state, its residual known
                        res.append(r[free] * nt.w[free])
                        continue
                    d, dl = step(alpha)
                    apply_increment(m, state, d.reshape(nt.n, 6))
                    nt.set_prescribed(state, lam + dl)
                    res.append(nt.residual(state, lam + dl)[0][free] * nt.w[free])
                    _restore(state, saved)
                diff = res[1] - res[0]
                dd = float(diff @ diff)
                if dd > 0.0:
                    alpha = -float(res[0] @ diff) / dd
                    alpha = min(max(alpha, LINE_SEARCH[0]), LINE_SEARCH[1])
                    dU, dlam = step(alpha)
            lam += dlam
        if not np.all(np.isfinite(dU)):
            return False, lam, k, ratio
        tr = _translation(nt, dU)
        if k == 1:
            scale = max(tr, nt._step_scale(lam - lam_start))
        elif tr > STEP_LIMIT * scale > 0.0:
            # a correction that translates a body by more than STEP_LIMIT
            # times the increment's own displacements (the predictor's, the
            # prescribed ones'): the direction of a near-mechanism (a body
            # held by faces slipping at a friction force that does not
            # grow with the slip, or by open faces at OPEN_FRACTION: the
            # beam and roller of a beam on rigid parts, thrown by 1 mm a
            # correction where the platen moved by 3 µm, then at rest with
            # nothing touching, an equilibrium with no force at all) is
            # shortened to that length (a step bound of the trust-region
            # kind, Dennis & Schnabel 1983, §6.4; Crisfield vol. 1, §9.4's
            # limit on the iterative displacement); the residual, exact,
            # decides the next one
            # ... and the slipping faces take their secant from here on:
            # along the slip the consistent tangent of the Coulomb return
            # is nil (SLIP_FLOOR of the secant), so a body held by friction
            # alone (the roller, free along x, its faces slipping all one
            # way at the first iterates) is thrown past the stick cone,
            # 10⁻⁹ m wide, at every correction; the secant lands it inside
            # (the secant for the unilateral and frictional springs: Rots &
            # Invernizzi 2004's always-positive secant, as for damage)
            f = STEP_LIMIT * scale / tr
            dU = f * dU
            lam = lam0 + f * (lam - lam0)
            nt.slip_secant = True
        if k > 1 and nt.n and np.max(np.linalg.norm(dU.reshape(nt.n, 6)[:, 3:], axis=1)) > \
                WILD_ANGLE:
            # a wild iterate: a correction that turns a body by more than
            # WILD_ANGLE, far past where the linearised rotation means
            # anything (a near-singular matrix on a contact set that has just
            # opened: the pin of three-point bending, its faces all open in
            # one iterate, thrown by 2.3 rad where the predictor turned it by
            # 1.5e-4; the iteration went on for five more steps, factorising
            # a matrix with the geometric stiffness at each, 5-12 s, before
            # the residual overflowed): cut now
            return False, lam, k, ratio
        if nt.tangent and nt.use_tangent and k > 1:
            # (only a step of the damage tangent is undone: friction's and
            # plasticity's tangents stay, and undoing their step would
            # repeat it; not an increment's first step, the predictor, which
            # raises the residual of the converged state it starts from by
            # moving the load)
            back = (_save_motion(state), lam0, ratio, dU.copy(), lam - lam0, 0)
        apply_increment(m, state, dU.reshape(nt.n, 6))
    return False, lam, NEWTON_MAX_IT, ratio


def _set_reactions(nt, state, lam):
    """body_reaction: support-spring force plus the constraint force on
    constrained translation components (relax.py's convention)."""
    n = nt.n
    r = state.body_wrench[:n, :3] + lam * nt.F.reshape(n, 6)[:, :3]
    cons = nt.m.dof_kind[:, :3] != FREE
    state.body_reaction[:] = np.where(cons, state.body_support[:n] - r, state.body_support[:n])
