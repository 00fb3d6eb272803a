"""python -m rbsm_dyn [run] CASE.yaml: run the case, writing its history.

A run holds the lock file RUN.h5.lock while it writes (io/lock.py) and
writes to .RUN.h5.tmp-<pid> until its first frame, then renames it to
RUN.h5: a run refused before that leaves an existing RUN.h5 untouched.
"""
import os
import sys
import time

from .notice import CompileNotice, _run_kind, run_kinds
from .prepare import _extra_observables, load, prepare
from .progress import Progress
from .signals import stop_if_interrupted


def main(args, path):
    case = load(path)
    if isinstance(case, int):
        return case
    # where the run writes may be refused before the (long) build
    problem = _output_problem(case, args, path)
    if problem:
        print(f"rbsm_dyn: {problem}", file=sys.stderr)
        return 2
    from ..io.lock import HistoryLock, HistoryLocked
    out = args.restart or args.out or case.output.file
    try:
        lock = HistoryLock(out).acquire()
    except HistoryLocked as exc:
        what = "--restart" if args.restart else "--out" if args.out else "output.file"
        print(f"rbsm_dyn: {what} {exc}", file=sys.stderr)
        return 2
    except OSError as exc:
        print(f"rbsm_dyn: {out}: cannot make the lock file {out}.lock "
              f"({exc.strerror or exc})", file=sys.stderr)
        return 2
    try:
        ready = prepare("run", case, args)
        if isinstance(ready, int):
            return ready
        try:
            stop_if_interrupted()
            # (the run takes the model from `ready`, so that no frame but
            # _run's holds the build's mesh once it is released)
            return _run(case, ready, args, lock)
        finally:
            ready.notice.cancel()
    finally:
        lock.release()


def _output_problem(case, args, case_path):
    """Why the history file cannot be written where asked (None if it can):
    its directory is missing or not writable, it is a directory, or it is
    the case file itself (which the run would overwrite)."""
    if getattr(args, "restart", None):
        out = args.restart              # appends to an existing history
        if args.out and os.path.abspath(args.out) != os.path.abspath(out):
            return (f"--restart {out} appends to its own file: leave out --out "
                    f"(got --out {args.out})")
        if "\0" in out:
            return f"--restart {out!r}: a file name cannot contain a NUL character"
        if os.path.isdir(out):
            return f"--restart {out}: is a directory, not a history file"
        if not os.path.isfile(out):
            return f"--restart {out}: no such file"
        if not _writable(out):
            return f"--restart {out}: the file is read-only"
        if not os.access(os.path.dirname(os.path.abspath(out)), os.W_OK):
            return f"--restart {out}: its directory is not writable (lock file {out}.lock)"
        return None
    out = args.out or case.output.file

    def where(message):
        return f"--out {out}: {message}" if args.out else \
            str(case.error(("output", "file"), f"{message} (got {out!r})"))

    if "\0" in out:
        return where("a file name cannot contain a NUL character")
    folder = os.path.dirname(os.path.abspath(out))
    if os.path.isdir(out):
        return where("is a directory")
    if os.path.exists(out) and not os.path.isfile(out):
        # a device (/dev/null), a pipe or a socket: the history is written
        # beside it and renamed over it, which would replace the device
        return where("is not a regular file (a device or a pipe: the run writes its history "
                     "beside it and renames it into place, which would replace it); give a "
                     "file name")
    if not os.path.isdir(folder):
        return where(f"no such directory {folder}")
    if not os.access(folder, os.W_OK):
        return where(f"directory {folder} is not writable")
    if os.path.exists(out) and os.path.samefile(out, case_path):
        return where("is the case file itself (the run would overwrite it)")
    if os.path.exists(out) and not _writable(out):
        return where("the file exists and is read-only (make it writable or delete it to "
                     "replace it)")
    return None


def _writable(path):
    """A file the user may write: permitted, and with a write bit set (root
    is permitted everything: a file without write bits is still read-only
    to the run, as the user meant)."""
    import stat
    return os.access(path, os.W_OK) and bool(os.stat(path).st_mode & (stat.S_IWUSR |
                                                                      stat.S_IWGRP |
                                                                      stat.S_IWOTH))


def _run(case, ready, args, lock):
    """Run the case; ``ready``: the prepare.Prepared of the case (its model,
    thread count and the CompileNotice said before the build; the run takes
    the model out of it); ``lock``: the held io/lock.HistoryLock of the
    output.  An explicit or relaxation run steps the model less its mesh
    arrays once the Recorder has written them (_release_mesh)."""
    from ..case import CaseError
    from ..solvers import checkpoint, explicit
    from ..solvers.output import Recorder
    model, threads, notice = ready.model, ready.threads, ready.notice
    ready.model = None
    out = args.out or case.output.file
    comm = getattr(args, "mpi", None)
    if comm is not None:
        from ..solvers.distributed import refusal
        why = refusal(case, model)
        if why:
            print(f"rbsm_dyn: mpirun -n {comm.size}: {why}", file=sys.stderr)
            return 2
    extra = _extra_observables(case)
    restart = None
    if args.restart:
        # continue RUN.h5 from its checkpoint (solvers/checkpoint.py); this
        # process holds its lock, so no writer is alive
        out = args.restart
        try:
            restart = checkpoint.load_for_restart(case, model, out, writer_alive=False)
            rec = Recorder.resume(case, model, out, restart[1]["frames"],
                                  extra_observables=extra, lock=lock)
        except (checkpoint.RestartError, ValueError, OSError) as exc:
            print(f"rbsm_dyn: {exc}", file=sys.stderr)
            return 2
    else:
        try:
            rec = Recorder(case, model, out, threads=threads, extra_observables=extra,
                           lock=lock, stage=True)
        except OSError as exc:
            print(f"rbsm_dyn: {out}: cannot write the history file ({exc})", file=sys.stderr)
            return 2
    if _release_mesh(case):
        # the mesh's vertex and face arrays (about 2.8 kB per Voronoi cell)
        # are in the history now; this frame and the recorder held the last
        # references to them (issue 29 item 8)
        model = rec.without_mesh_arrays()
        _trim_heap()
    last = _watch_frames(rec)
    kind = ("steps" if case.solver.mode == "dynamic" else
            "newton" if getattr(case.solver, "method", "") == "newton" else "load steps")
    progress = Progress(not args.quiet, kind=kind)
    if notice is None:
        notice = CompileNotice(run_kinds(case), enabled=not args.quiet)
    progress.on_first = notice.done
    notice.progress = progress
    # (the heartbeat of a warm-looking run: only where the first chunk is
    # short, not a Newton increment or a linear or modal solve)
    notice.arm(heartbeat=_run_kind(case) in ("dynamic", "plane", "relaxation"))
    t0 = time.perf_counter()
    try:
        if case.solver.mode == "dynamic":
            governor = stepper = chunk = None
            if comm is not None:
                from ..solvers.distributed import CHUNK_SPRING_STEPS, Leader
                stepper = Leader(comm).advance
                if model.contact is None:
                    # (with contact the chunks are the one-process ones: the
                    # broad phase runs between chunks, and where it runs
                    # shapes the pair list)
                    chunk = max(1, int(CHUNK_SPRING_STEPS // max(model.n_springs, 1)))
            elif args.threads is None and getattr(case.solver, "threads", None) is None:
                # the default count, kept right while the run steps (threads.py)
                import numba
                from ..threads import Governor
                governor = Governor(model.n_springs, numba.config.NUMBA_NUM_THREADS)
            res = explicit.run(case, model, rec, max_steps=args.max_steps, progress=progress,
                               restart=restart, governor=governor, stepper=stepper,
                               chunk_steps=chunk)
            summary = (f"{res['steps']} steps, dt = {res['dt']:.4g} s "
                       f"(estimate {res['dt_estimate']:.4g} s)")
            if comm is not None:
                summary += f" on {comm.size} MPI processes"
            if res.get("dt_changes"):
                summary += (f", reduced {res['dt_changes']} times to {res['dt_final']:.4g} s "
                            "as the springs' gaps grew")
        elif case.solver.mode == "static":
            from ..solvers import relax
            res = relax.run(case, model, rec, max_steps=args.max_steps, progress=progress)
            steps = "increments in time" if getattr(case.solver, "time", None) else "load steps"
            summary = f"{len(res['iterations'])} {steps}, {sum(res['iterations'])} iterations"
        elif case.solver.mode == "linear":
            from ..solvers import linear       # (scipy.sparse: only these two modes)
            res = linear.run(case, model, rec)
            how = (f"CG, {res['iterations']} iterations" if res["method"] == "cg"
                   else "direct")
            summary = (f"K U = F ({res['n_free']} DOFs, {how}, residual {res['residual']:.2g}; "
                       f"assembly {res['assembly_time']:.2f} s, solve {res['solve_time']:.2f} s)")
        else:
            from ..solvers import modal
            res = modal.run(case, model, rec)
            summary = (f"{res['modes']} modes, ω_max = {res['omega_max']:.4g} rad/s")
    except explicit.RunFailed as exc:
        notice.cancel()             # (before the failure's line)
        progress.close()
        rec.close()
        print(f"rbsm_dyn: run failed: {exc}; history kept in {out}", file=sys.stderr)
        return 1
    except CaseError as exc:
        notice.cancel()
        progress.close()
        rec.fail(str(exc))
        rec.close()
        print(f"rbsm_dyn: {exc}", file=sys.stderr)
        return 2
    except checkpoint.Interrupted as exc:
        notice.cancel()
        progress.close()
        rec.fail(f"{exc}; continue with --restart {out}")
        rec.close()
        cpath = args.case if args.command_or_case == "run" else args.command_or_case
        print(f"rbsm_dyn: {exc} in {out}; continue with: python -m rbsm_dyn {cpath} "
              f"--restart {out}", file=sys.stderr)
        return exc.exit_code
    except KeyboardInterrupt:
        notice.cancel()
        progress.close()
        rec.fail("interrupted")
        rec.close()
        print(f"rbsm_dyn: interrupted; history kept in {out}", file=sys.stderr)
        return 130
    finally:
        notice.cancel()
    progress.close()
    notice.done()                # (linear, modal: no progress; timed here)
    rec.close()
    for note in res.get("warnings", ()):
        print(f"rbsm_dyn: warning: {note}", file=sys.stderr)
    if case.solver.mode == "modal":
        modal.write_modes_group(out, res["result"])
    if not args.quiet:
        units = ("" if case.input_units == "SI" else
                 f" (history in SI units: m, s, N, Pa, kg; the case is in {case.input_units})")
        print(f"rbsm_dyn: {case.name}: {model.n_bodies} bodies, {model.n_springs} springs, "
              f"{summary}, {time.perf_counter() - t0:.2f} s -> {out}{units}")
        for line in _final_values(case, model, res, last):
            print(f"  {line}")
    return 0


def _release_mesh(case):
    """True when the run steps without the mesh's arrays
    (Model.without_mesh_arrays): explicit runs and static relaxation, whose
    loops read only the model's own arrays; Newton, creep, linear and modal
    keep the whole model."""
    s = case.solver
    return s.mode == "dynamic" or (s.mode == "static" and getattr(s, "time", None) is None
                                   and getattr(s, "method", "relaxation") == "relaxation")


def _trim_heap():
    """Hand the heap's free pages back to the system (glibc's
    malloc_trim(0); nothing where there is none): the mesh's arrays and the
    build's temporaries, freed in the middle of the heap, stay resident
    otherwise (a 200 000-cell Voronoi run: about 0.3-0.4 GiB less while it
    steps, benchmarks/results/bench_sizes.md)."""
    try:
        import ctypes
        ctypes.CDLL(None).malloc_trim(0)
    except (OSError, AttributeError, TypeError):
        pass


def _watch_frames(rec):
    """Keep the observables of the last frame the recorder writes (the
    values printed at the end of a run): a dict with 'time' and 'values'."""
    last = {}
    append = rec.append

    def watched(state, step, time_, *rest, **kw):
        obs = append(state, step, time_, *rest, **kw)
        last["time"], last["values"] = time_, dict(obs or {})
        return obs

    rec.append = watched
    return last


#: SI unit of a probe -> (unit, factor) in mm-N-s (values shown in both)
_MM_UNITS = {"m": ("mm", 1e3), "m s-1": ("mm/s", 1e3), "N": ("N", 1.0), "rad": ("rad", 1.0)}


def _final_values(case, model, res, last):
    """Lines with the probes' values in the last frame (name = value unit)
    and, for static runs, the reaction and the residual at the end."""
    import numpy as np
    from ..solvers.output import PROBE_UNITS
    values = last.get("values") or {}
    out = []
    mode = case.solver.mode
    if mode == "modal" or not values:
        return out
    in_time = mode == "dynamic" or getattr(case.solver, "time", None) is not None
    what = {"dynamic": f"t = {last['time']:.6g} s",
            "static": (f"t = {last['time']:.6g} s" if in_time
                       else f"load factor {last['time']:.4g}"),
            "linear": "the solution"}.get(mode, "the end")
    probes = dict(case.output.probes or {})
    if probes:
        out.append(f"probes at {what}:")
    for name, p in probes.items():
        if name not in values:
            continue
        v = float(values[name])
        unit = PROBE_UNITS[p.quantity]
        text = f"  {name} = {v:.6g} {unit}"
        if case.input_units == "mm-N-s" and unit in _MM_UNITS and _MM_UNITS[unit][1] != 1.0:
            u, f = _MM_UNITS[unit]
            text += f" ({v * f:.6g} {u})"
        out.append(text)
    if mode == "static":
        state = res.get("state")
        if state is not None:
            r = np.sum(state.body_reaction[:model.n_bodies], axis=0)
            out.append(f"reaction = [{', '.join(f'{x:.6g}' for x in r)}] N (sum over the "
                       "supports and prescribed components)")
        if "residual" in values:
            out.append(f"residual = {float(values['residual']):.3g} (out-of-balance force / "
                       f"applied force; tolerance {case.solver.tolerance:g})")
    return out
