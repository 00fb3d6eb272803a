"""What run, check and info share: read the case, set the threads, build
the model (or read it from the model cache), check it before anything is
written (preflight), the lines naming its domain, surfaces and groups, and
the observables of each mode."""
import sys
import time

from .notice import compile_notice
from .signals import stop_if_interrupted


def load(path):
    """The case of this file, or the exit status (2) after one line naming
    the problem."""
    from ..case import CaseError, load_case
    stop_if_interrupted()
    try:
        return load_case(path)
    except CaseError as exc:
        print(f"rbsm_dyn: {exc}", file=sys.stderr)
        return 2
    except OSError as exc:
        print(f"rbsm_dyn: {path}: cannot read the case file ({exc.strerror})", file=sys.stderr)
        return 2


class Prepared:
    """The model of a case ready to check, describe or run: model, threads
    (the count in use), step ((dt, stable step estimate) of a dynamic case,
    else None) and notice (the CompileNotice of a run)."""

    def __init__(self, model, threads, step, notice):
        self.model, self.threads, self.step, self.notice = model, threads, step, notice


def prepare(command, case, args):
    """Threads, compile notice, model, preflight and warnings of run, check
    and info: a Prepared, or the exit status (2) after one line naming the
    problem.  The notice (its heartbeat) of check and info ends with the
    build; a run's goes on into the run (run.py ends it)."""
    if args.threads is not None:
        threads = _set_threads(args.threads, "--threads")
    else:
        threads = _set_threads(getattr(case.solver, "threads", None), "solver.threads")
    notice = compile_notice(command, case, args)
    try:
        ready = _prepared(command, case, args, threads, notice)
    except BaseException:
        notice.cancel()             # (no heartbeat after Ctrl-C or a traceback)
        raise
    if not isinstance(ready, Prepared):
        notice.cancel()
    return ready


def _prepared(command, case, args, threads, notice):
    from ..case import CaseError
    try:
        model = _model(command, case, args)
    except CaseError as exc:
        notice.cancel()
        print(f"rbsm_dyn: {exc}", file=sys.stderr)
        return 2
    if command != "run":
        notice.done()               # check, info: the heartbeat ends with the build
    s = case.solver
    if s.mode == "static" and s._method_default:
        # the default static method by the size of the model too (case/solver.py)
        from ..case import default_static_method
        s.method = default_static_method(case, model.n_bodies)
    if args.threads is None and getattr(case.solver, "threads", None) is None:
        # no count given: the idle cores, one for a small model (threads.py)
        import numba
        from ..threads import default_threads
        threads = _set_threads(default_threads(model.n_springs,
                                               numba.config.NUMBA_NUM_THREADS), "default")
    stop_if_interrupted()
    for note in model.warnings:
        print(f"rbsm_dyn: warning: {note}", file=sys.stderr)
    try:
        step = _preflight(case, model)
        if command in ("run", "check") and not getattr(args, "force", False):
            _refuse_unfinishable(case, model, args, threads, step)
    except CaseError as exc:
        notice.cancel()
        print(f"rbsm_dyn: {exc}", file=sys.stderr)
        return 2
    # (the case's own warnings, a unit trap: after the checks, so that a bad
    # case still gets its one line)
    for note in getattr(case, "warnings", ()):
        print(f"rbsm_dyn: warning: {note}", file=sys.stderr)
    from ..solvers.output import probe_warnings
    for note in probe_warnings(case, model):
        print(f"rbsm_dyn: warning: {note}", file=sys.stderr)
    return Prepared(model, threads, step, notice)


def _set_threads(threads, source):
    """Set Numba's thread count; a count above the threads Numba has
    (NUMBA_NUM_THREADS, the machine's cores by default) is clamped with a
    warning.  Returns the count in use (recorded in the history)."""
    import numba
    if threads:
        top = numba.config.NUMBA_NUM_THREADS
        if int(threads) > top:
            print(f"rbsm_dyn: warning: {source} {threads} is more than the {top} threads "
                  f"available (NUMBA_NUM_THREADS); using {top}", file=sys.stderr)
        numba.set_num_threads(max(1, min(int(threads), top)))
    return numba.get_num_threads()


def _model(command, case, args):
    """The case's model: from the cache beside the case when its key matches
    (io/model_cache.py), else built (and cached by run and info when the
    build took long enough to be worth a file)."""
    from ..io import model_cache
    from ..model import build_model
    quiet = getattr(args, "quiet", False)
    use = model_cache.enabled() and not getattr(args, "no_model_cache", False)
    if use:
        model = model_cache.load(case)
        if model is not None:
            if not quiet:
                print(f"rbsm_dyn: model read from {model_cache.cache_file(case)} (built by an "
                      "earlier run; --no-model-cache to rebuild)", file=sys.stderr, flush=True)
            return model
    cells = _cell_estimate(case)
    if cells > BUILD_NOTICE_CELLS and not quiet:
        # a build of 10⁵ cells takes tens of seconds: say what is going on
        what = (f"{case.mesh.kind}, domain {case.domain.kind()}" if not case.parts
                else f"{len(case.parts)} parts")
        print(f"rbsm_dyn: building about {cells:.3g} cells ({what})...", file=sys.stderr,
              flush=True)
    t0 = time.perf_counter()
    model = build_model(case)
    took = time.perf_counter() - t0
    if use and command in ("run", "info") and took >= model_cache.MIN_BUILD_SECONDS:
        def note(text):
            print(f"rbsm_dyn: {text}", file=sys.stderr)
        path = model_cache.save(case, model, note)
        if path is not None and not quiet:
            print(f"rbsm_dyn: model cached in {path} ({path.stat().st_size / 2**20:.0f} MiB, "
                  f"the build took {took:.0f} s)", file=sys.stderr)
    return model


def _preflight(case, model):
    """The checks a run would otherwise make only once it has started
    (CaseError): a model that cannot be run (no springs, a body without
    mass), a fixed solver.dt above the stable estimate, more modes than the
    model has free DOFs, a probe point in no cell.  Made before any file is
    touched (and by check and info).  Returns (dt, stable step estimate)
    of a dynamic case, else None."""
    from ..solvers import explicit
    explicit.check_model(case, model)
    mode = case.solver.mode
    step = None
    if mode == "dynamic":
        step = explicit.choose_dt(case, model)
    elif mode == "modal":
        from ..physics.integrate import FREE
        nf = int((model.dof_kind.reshape(-1) == FREE).sum())
        if case.solver.modes >= nf:
            # (natural_modes also counts the rigid-body modes: checked at run time)
            raise case.error(("solver", "modes"), f"asked for {case.solver.modes} modes, but "
                             f"the model has only {nf} free DOFs")
    from ..solvers.output import probe_plan
    for plan in probe_plan(model, dict(case.output.probes or {}), case).values():
        if plan[0] == "error":
            raise plan[1]
    return step


def _refuse_unfinishable(case, model, args, threads, step):
    """A dynamic run that cannot finish (CaseError naming the keys and the
    estimate): a history larger than the free disk of its folder, or more
    than a day of stepping on this machine by bench's figures
    (solvers/estimate.py wall_seconds).  --force lets it run."""
    import math
    import os
    import shutil
    from ..solvers.estimate import (ONE_DAY, estimate, format_bytes, format_seconds,
                                    wall_seconds)
    if step is None:
        return
    dt = step[0]
    steps = int(math.ceil(case.solver.end_time / dt - 1e-9))
    if args.max_steps is not None:
        steps = min(steps, int(args.max_steps))
    every = max(1, int(round(case.output.interval / dt)))
    frames = 1 + steps // every
    why = []
    out = args.restart or args.out or case.output.file
    folder = os.path.dirname(os.path.abspath(out)) or "."
    try:
        free = shutil.disk_usage(folder).free
    except OSError:
        free = None
    # the full estimate writes the static part of the history: only when a
    # frame of 8 bytes per body and spring point could fill a fiftieth of the disk
    if free is not None and frames * 8.0 * (model.n_bodies + model.n_springs) > free / 50:
        e = estimate(case, model, extra_observables=_extra_observables(case), threads=threads)
        size = e.static_bytes + (e.output_bytes - e.static_bytes) * min(1.0, frames / e.frames)
        if size > free:
            why.append(f"a history of about {format_bytes(size)} ({frames} frames, "
                       f"output.interval {case.output.interval:g} s) against "
                       f"{format_bytes(free)} free in {folder}")
    wall = wall_seconds(model, steps, threads)
    if wall > ONE_DAY:
        why.append(f"about {format_seconds(wall)} of stepping on {threads} thread"
                   f"{'s' if threads > 1 else ''} (bench's figures for this machine, "
                   f"solvers/estimate.py)")
    if why:
        raise case.error(("solver", "end_time"),
                         f"{case.solver.end_time:g} s is {steps} steps of dt {dt:.4g} s: "
                         + "; ".join(why) + ".  Is end_time in the case's time unit "
                         "(units.time)?  Shorten solver.end_time, raise output.interval, "
                         "give --max-steps, or --force to run it anyway")


#: builds of more cells than this announce themselves on stderr
BUILD_NOTICE_CELLS = 2.0e4


def _cell_estimate(case):
    """Cells the mesh will have, roughly (volume / size³ or the blocks)."""
    import math
    from ..case import scene_parts
    total = 0.0
    for part in scene_parts(case):
        m, g = part.mesh, part.geometry
        # a plane model's cells are prisms through its thickness
        cell = (m.size ** 3 if case.plane is None else m.size ** 2 * case.plane.thickness) \
            if m.size else 1.0
        if m.kind == "rigid":
            total += 1.0
        elif m.kind == "blocks":
            total += float(math.prod(m.divisions))
        elif g.kind() == "box":
            (x0, y0, z0), (x1, y1, z1) = g.box
            total += (x1 - x0) * (y1 - y0) * (z1 - z0) / cell
        else:
            total += (g._solid.volume if g._solid is not None else 0.0) / cell
    return total


def _selections(case, model):
    """Lines naming the domain, its surfaces (boundary faces, area) and the
    groups with the number of bodies each selects."""
    import numpy as np
    mesh = model.mesh
    v = model.body_volume
    if case.parts:
        out = [f"scene of {len(case.parts)} parts: {model.n_bodies} bodies, volume "
               f"{v.sum():.6g} m³"]
        part = mesh.cell_part
        for k, (name, p) in enumerate(case.parts.items()):
            vk = v[part == k]
            out.append(f"part {name} ({p.mesh.kind}, {p.material}): {len(vk)} bodies, volume "
                       f"{vk.sum():.6g} m³" + (f", smallest body {vk.min() / vk.mean():.3f} of "
                                               f"the mean" if len(vk) > 1 else ""))
        fi = mesh.face_interface
        for i, it in enumerate(case.interfaces):
            on = fi == i
            out.append(f"interface {it.parts[0]}–{it.parts[1]} ({it.law}): {int(on.sum())} "
                       f"faces, {mesh.face_area[on].sum():.6g} m²")
    else:
        out = [f"domain {case.domain.kind()}: {model.n_bodies} bodies, volume "
               f"{v.sum():.6g} m³, smallest body {v.min() / v.mean():.3f} of the mean"]
    if mesh is not None:
        cnt = np.bincount(mesh.bface_side, minlength=len(mesh.surface_names))
        area = np.bincount(mesh.bface_side, mesh.bface_area, minlength=len(mesh.surface_names))
        for i, name in enumerate(mesh.surface_names):
            out.append(f"surface {name}: {cnt[i]} faces, {area[i]:.6g} m²")
    for name, ids in (model.groups or {}).items():
        out.append(f"group {name}: {len(ids)} bodies" + ("  (selects none)" if len(ids) == 0 else ""))
    cm = model.contact
    if cm is not None:
        given = case.contact is not None
        between = ("all" if case.contact.between == "all" else
                   ", ".join("–".join(p) for p in case.contact.between)) if given else \
            "rigid parts moving toward others (no contact key: automatic)"
        out.append(f"contact between {between}: friction {cm.mu:g}, stiffness × {cm.kfac:g}, "
                   f"damping {cm.zeta:g}, skin {cm.skin:.4g} m"
                   + (f", ground n = [{', '.join(f'{x:g}' for x in cm.ground[:3])}] at "
                      f"n·x = {cm.ground[3]:g} m" if cm.has_ground else ""))
    return out


EXTRA_OBSERVABLES = {"static": {"residual": "1"}, "linear": {"residual": "1"},
                     "modal": {"frequency": "Hz"}}


def _extra_observables(case):
    """Observables of the mode beyond the energies and probes (name: unit)."""
    extra = dict(EXTRA_OBSERVABLES.get(case.solver.mode, {}))
    if case.solver.mode == "dynamic" and case.solver.damping.local > 0:
        extra["kinetic_ratio"] = "1"        # a quasi-static explicit run
    return extra
