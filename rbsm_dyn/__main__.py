"""Command line: python -m rbsm_dyn [run|check|info] CASE.yaml [options],
python -m rbsm_dyn export|render|plot RUN.h5 [options] (post-processing of a
history: rbsm_dyn/io/export.py, rbsm_dyn/io/render.py), and
python -m rbsm_dyn bench [--bodies N --steps K --threads T --physics P] (bench.py).

Exit status: 0 success, 2 bad case or option (one message naming file,
line and key, or the option and its value; also: the output is locked by a
live run), 1 failed run (divergence or no convergence, with step and time;
the history file stays readable up to the failure), 130/143 stopped by
SIGINT/SIGTERM (dynamic runs after writing a checkpoint;
``CASE.yaml --restart RUN.h5`` continues it: solvers/checkpoint.py; Ctrl-C
before the run, during imports or the build, exits 130 too).

A run holds the lock file RUN.h5.lock while it writes (io/lock.py) and
writes to .RUN.h5.tmp-<pid> until its first frame, then renames it to
RUN.h5: a run refused before that leaves an existing RUN.h5 untouched.
"""
import argparse
import math
import os
import sys
import time


INFO_OMEGA_MAX_BODIES = 5000   # `info` computes the exact ω_max up to this many bodies


def _parser():
    p = argparse.ArgumentParser(
        prog="python -m rbsm_dyn",
        description="Rigid-body-spring model (Kawai RBSM), explicit dynamics.",
        formatter_class=argparse.RawDescriptionHelpFormatter,
        epilog="progress (stderr): a bar on a terminal; without one (batch jobs, a pipe) a\n"
               "line every 30 s and 10 % of the run, whichever comes later; --quiet: none.\n"
               "The environment variable RBSM_PROGRESS overrides it: bar (or 1) a bar even\n"
               "without a terminal, log lines even on one, 0 or off no progress.  A run's\n"
               "cold start says \"compiling kernels (first run only, about N s)\" first.\n"
               "At the end a run prints the probes' last values (static runs: the reaction\n"
               "and the residual too); the history is in SI units whatever the case's units.")
    p.add_argument("command_or_case", help="run | check | info, or the case file to run "
                   "(export | render | plot RUN.h5: see python -m rbsm_dyn export --help; "
                   "bench: time the explicit loop, python -m rbsm_dyn bench --help)")
    p.add_argument("case", nargs="?", help="case file (after a command)")
    p.add_argument("--out", help="output HDF5 file (overrides output.file)")
    p.add_argument("--quiet", action="store_true",
                   help="no progress, no compile notice, no summary (RBSM_PROGRESS: below)")
    p.add_argument("--max-steps", type=int, default=None,
                   help="stop after this many steps (iterations in static mode)")
    p.add_argument("--threads", type=int, default=None,
                   help="Numba threads (default: 1 below 30 000 spring points, else the cores "
                        "other running processes leave idle, looked at again every 30 s)")
    p.add_argument("--restart", metavar="RUN.h5",
                   help="continue the run of this history file from its last checkpoint "
                   "(dynamic mode; frames are appended to RUN.h5)")
    p.add_argument("--no-model-cache", action="store_true",
                   help="build the model even when .rbsm_cache/ beside the case holds it, and "
                        "do not write it there (also RBSM_MODEL_CACHE=0)")
    return p


class Progress:
    """Progress of a run on stderr: a tqdm bar on a terminal, a log line at a
    sane rate in batch (no terminal: every LOG_SECONDS and LOG_FRACTION of
    the run, whichever comes later), nothing with --quiet.  RBSM_PROGRESS
    overrides the choice: ``bar`` (or ``1``) a bar even without a terminal,
    ``log`` lines even on one, ``0`` or ``off`` nothing.

    The ETA counts from the end of the first chunk of steps (which holds
    the compilation of a cold start), not from the start.  A static run by
    relaxation counts whole load steps done; by Newton, whole per cent of
    the load path with the increments done.  ``start(total, dt)`` and
    ``update(n, t, value, label)`` are called by the solvers."""

    LOG_SECONDS = 30.0
    LOG_FRACTION = 0.1

    def __init__(self, enabled, style=None, kind="steps", clock=time.perf_counter):
        """enabled: progress wanted at all (not --quiet); style: "bar", "log"
        or None (from RBSM_PROGRESS and whether stderr is a terminal); kind:
        "steps" (dynamic), "load steps" (static relaxation), "newton"."""
        self.style = progress_style(style) if enabled else None
        self.kind = kind
        self.clock = clock
        self.bar = None
        self.total = 0
        self.first = None          # (wall time, n) at the end of the first chunk
        self.updates = 0
        self.last_log = None       # (wall time, n) of the last log line
        self.t_start = None

    @property
    def enabled(self):
        return self.style is not None

    def start(self, total, dt):
        self.total = total
        self.t_start = self.clock()
        self.first = None
        self.updates = 0
        self.last_log = (self.t_start, 0)
        if self.style == "bar":
            from tqdm import tqdm
            unit = {"steps": "step", "load steps": "load step", "newton": "%"}[self.kind]
            self.bar = tqdm(total=total, unit=unit, dynamic_ncols=True, file=sys.stderr,
                            mininterval=0.5,
                            bar_format="{l_bar}{bar}| {n_fmt}/{total_fmt} [{elapsed}{postfix}]")

    def _whole(self, n):
        """What the bar counts: whole steps, load steps or per cent."""
        import math
        return int(math.floor(n + 1e-9))

    def eta(self, n, now=None):
        """Seconds left, from the rate since the end of the first chunk
        (None until a second chunk has ended)."""
        now = self.clock() if now is None else now
        if self.first is None or n <= self.first[1] or now <= self.first[0]:
            return None
        rate = (n - self.first[1]) / (now - self.first[0])
        return max(0.0, (self.total - n) / rate)

    #: called once, at the first update (the end of the first chunk)
    on_first = None

    def update(self, n, t, value, label="Ek"):
        if self.on_first is not None:
            hook, self.on_first = self.on_first, None
            hook()
        if self.style is None:
            return
        now = self.clock()
        self.updates += 1
        whole = self._whole(n)
        if self.first is None:
            self.first = (now, n)
        eta = self.eta(n, now)
        what = (f"increment {self.updates}" if self.kind == "newton" else
                f"λ={t:.4g}" if self.kind == "load steps" else f"t={t:.4g}")
        text = f"{what} {label}={value:.3g}"
        if self.bar is not None:
            self.bar.n = whole
            self.bar.set_postfix_str(f"ETA {_duration(eta)}, {text}", refresh=False)
            self.bar.refresh()
            return
        t0, n0 = self.last_log
        if (now - t0 >= self.LOG_SECONDS
                and (n - n0) >= self.LOG_FRACTION * max(self.total, 1e-300)):
            self.last_log = (now, n)
            pct = 100.0 * n / max(self.total, 1e-300)
            count = ("" if self.kind == "newton" else
                     f" ({self.kind[:-1] if self.kind.endswith('s') else self.kind} "
                     f"{whole}/{self.total})")
            print(f"rbsm_dyn: progress {pct:.0f} %{count}, {text}, "
                  f"{_duration(now - self.t_start)} elapsed, ETA {_duration(eta)}",
                  file=sys.stderr, flush=True)

    def close(self):
        self.on_first = None
        if self.bar is not None:
            self.bar.close()
            self.bar = None


def progress_style(style=None):
    """"bar", "log" or None: ``style`` if given, else RBSM_PROGRESS (bar or
    1, log, 0 or off), else a bar on a terminal and log lines without."""
    if style is None:
        env = os.environ.get("RBSM_PROGRESS", "").strip().lower()
        if env in ("0", "off", "no", "none", "false"):
            return None
        if env == "log":
            return "log"
        if env:
            return "bar"
        return "bar" if sys.stderr.isatty() else "log"
    return style


def _duration(seconds):
    """12 s, 3 min 5 s, 2 h 10 min; ? when unknown."""
    if seconds is None:
        return "?"
    s = int(round(seconds))
    if s < 60:
        return f"{s} s"
    if s < 3600:
        return f"{s // 60} min {s % 60} s"
    return f"{s // 3600} h {s % 3600 // 60} min"


#: compiled kernels every run of each kind calls (module under the package,
#: function; tests/test_run_ux.py runs each kind and checks): the Numba
#: cache is cold for the run when one of them has neither a version
#: compiled in this process nor a valid cache index
RUN_KERNELS = {
    "build": (("model.springs", "_arms"), ("mesh.polyhedron", "_tet_moments")),
    "dynamic": (("physics.integrate", "run_dynamic"), ("physics.integrate",
                                                        "synchronized_momenta"),
                ("model.stable_step", "_scaled_row_sums")),
    "relaxation": (("physics.relax", "run_relax"),),
    "newton": (("solvers.assembly", "_assemble"),),
    "linear": (("physics.springs", "elastic_spring_pass"),),
    "modal": (("physics.springs", "elastic_spring_pass"),),
}
#: seconds the compilation of a cold start takes, until one has been timed on
#: this machine (then read from compile_seconds.json in rbsm_dyn's cache
#: folder): measured on a 4-core laptop, 2026 (issue 17: 35-50 s in all)
COMPILE_SECONDS = {"build": 8.0, "dynamic": 40.0, "relaxation": 25.0, "newton": 30.0,
                   "linear": 5.0, "modal": 5.0}


def kernel_is_cold(dispatcher):
    """True when calling this Numba dispatcher would compile it: no version
    compiled in this process and no entry in its on-disk cache index that
    is valid for the source as it is (numba.core.caching reads the index,
    a small pickle, and drops it when the source file's stamp differs).
    None when it cannot be told (not a caching dispatcher, Numba changed)."""
    try:
        if dispatcher.signatures:
            return False
        cache = dispatcher._cache
        index = cache._cache_file._load_index()
        return len(index) == 0
    except Exception:
        return None


def _run_kind(case):
    mode = case.solver.mode
    return ("dynamic" if mode == "dynamic" else mode if mode in ("linear", "modal")
            else "newton" if getattr(case.solver, "method", "") == "newton" else "relaxation")


def cold_kernels(kinds):
    """The kinds of RUN_KERNELS whose kernels are cold (a list; "?" in it
    when some could not be told)."""
    import importlib
    out = []
    for kind in kinds:
        for mod, name in RUN_KERNELS[kind]:
            try:
                f = getattr(importlib.import_module(f".{mod}", __package__), name)
            except (ImportError, AttributeError):
                cold = None
            else:
                cold = kernel_is_cold(f)
            if cold is None:
                out.append("?")
            elif cold:
                out.append(kind)
                break
    return out


def _compile_record_file():
    base = os.environ.get("XDG_CACHE_HOME") or os.path.join(os.path.expanduser("~"), ".cache")
    return os.path.join(base, "rbsm_dyn", "compile_seconds.json")


def compile_seconds(kinds):
    """Expected seconds to compile the kernels of these kinds on this
    machine: the last cold start of the same kinds, timed; else the sum of
    each kind's (timed alone, or COMPILE_SECONDS)."""
    import json
    try:
        with open(_compile_record_file(), encoding="utf-8") as f:
            seen = json.load(f)
    except (OSError, ValueError):
        seen = {}
    if not isinstance(seen, dict):
        seen = {}

    def timed(key):
        v = seen.get(key)
        return float(v) if isinstance(v, (int, float)) and not isinstance(v, bool) \
            and v > 0 else None

    whole = timed("+".join(sorted(kinds)))
    if whole is not None:
        return whole
    return sum(timed(k) or COMPILE_SECONDS[k] for k in kinds)


def record_compile_seconds(kind, seconds):
    """Keep how long a cold start's compilation took (for the next notice)."""
    import json
    path = _compile_record_file()
    try:
        try:
            with open(path, encoding="utf-8") as f:
                seen = json.load(f)
            if not isinstance(seen, dict):
                seen = {}
        except (OSError, ValueError):
            seen = {}
        seen[kind] = round(float(seconds), 1)
        os.makedirs(os.path.dirname(path), exist_ok=True)
        tmp = f"{path}.tmp-{os.getpid()}"
        with open(tmp, "w", encoding="utf-8") as f:
            json.dump(seen, f)
        os.replace(tmp, path)
    except OSError:
        pass


class CompileNotice:
    """Says "compiling kernels (first run only, about N s)" on stderr before
    the first call of cold kernels (made when it is created, before the
    build); when coldness cannot be told, says so only if the first chunk
    of steps has not ended after FALLBACK_SECONDS.  ``done()`` (a run: at
    the end of its first chunk; check, info: after the build) keeps the
    time a cold start took, for the next notice."""

    FALLBACK_SECONDS = 2.0
    MIN_SECONDS = 0.5           # a cold start timed shorter is not kept

    def __init__(self, kinds, enabled=True):
        self.enabled = enabled
        cold = cold_kernels(kinds) if enabled else []
        self.cold = [k for k in cold if k != "?"]
        self.unknown = "?" in cold
        self.timer = None
        self.t0 = time.perf_counter()
        if self.cold:
            n = compile_seconds(self.cold)
            print(f"rbsm_dyn: compiling kernels (first run only, about {n:.0f} s)",
                  file=sys.stderr, flush=True)

    def arm(self):
        """The fallback: a message if the first chunk is slow (a timer thread)."""
        if self.enabled and self.unknown and not self.cold:
            import threading

            def say():
                print("rbsm_dyn: compiling kernels, it seems (first run only: a minute or "
                      "so)", file=sys.stderr, flush=True)
            self.timer = threading.Timer(self.FALLBACK_SECONDS, say)
            self.timer.daemon = True
            self.timer.start()

    def cancel(self):
        """No fallback message any more."""
        if self.timer is not None:
            self.timer.cancel()
            self.timer = None

    def done(self):
        """The cold kernels have been compiled: keep the time it took (once)."""
        self.cancel()
        if self.cold:
            took = time.perf_counter() - self.t0
            # (only a real compilation: the kernels warm now, and it took time)
            if took >= self.MIN_SECONDS and not cold_kernels(self.cold):
                record_compile_seconds("+".join(sorted(self.cold)), took)
            self.cold = []


POST_COMMANDS = {"export": "export", "render": "render", "plot": "render"}


def _post(command, argv):
    """export | render | plot RUN.h5: each module has add_arguments(parser)
    and main(args) (plot: add_plot_arguments, main_plot)."""
    import importlib
    mod = importlib.import_module(f".io.{POST_COMMANDS[command]}", __package__)
    p = argparse.ArgumentParser(prog=f"python -m rbsm_dyn {command}",
                                description=(mod.__doc__ or "").strip().splitlines()[0])
    if command == "plot":
        mod.add_plot_arguments(p)
        return mod.main_plot(p.parse_args(argv))
    mod.add_arguments(p)
    return mod.main(p.parse_args(argv))


#: set by the SIGINT handler below: a KeyboardInterrupt raised inside a
#: library (an import that catches everything, a callback) may be swallowed
#: there, so the flag is checked again after the imports and the build
_INTERRUPTED = False


def _on_sigint(signum, frame):
    global _INTERRUPTED
    _INTERRUPTED = True
    raise KeyboardInterrupt


def _stop_if_interrupted():
    if _INTERRUPTED:
        raise KeyboardInterrupt


def main(argv=None):
    """The command line; returns the exit status.  Ctrl-C at any moment
    outside a run's checkpointed loop ends it with 130 and one line, no
    traceback."""
    import signal
    try:
        if signal.getsignal(signal.SIGINT) is signal.default_int_handler:
            signal.signal(signal.SIGINT, _on_sigint)   # (an ignored SIGINT stays ignored)
    except ValueError:                  # not the main thread
        pass
    try:
        return _main(argv)
    except BrokenPipeError:
        # the reader of stdout has gone (`info case.yaml | head`): quiet, as
        # other Unix tools; stdout pointed at /dev/null so that the final
        # flush does not raise again (Python docs, "Note on SIGPIPE")
        try:
            os.dup2(os.open(os.devnull, os.O_WRONLY), sys.stdout.fileno())
        except (OSError, ValueError):
            pass
        return 141
    except KeyboardInterrupt:
        return _interrupted(argv)
    except Exception:
        if _INTERRUPTED:
            # a KeyboardInterrupt that a library wrapped in an error of its
            # own (Ctrl-C inside `import numba`: class creation turns it into
            # RuntimeError "Error calling __set_name__"): still Ctrl-C
            return _interrupted(argv)
        raise


def _interrupted(argv):
    """One line and 130 for Ctrl-C (see main)."""
    try:
        print("rbsm_dyn: interrupted", file=sys.stderr)
        sys.stderr.flush()
        sys.stdout.flush()
    except Exception:
        pass
    if argv is None:
        # as a program: CPython marks a KeyboardInterrupt that went through
        # code run by PyRun_* (inside some imports) as unhandled and, even
        # though it was caught here, ends the process by SIGINT (-2) at
        # exit; the files are closed and the lock released: leave now
        os._exit(130)
    return 130


def _option_problem(args):
    """Why an option of a run/check/info cannot be used (None if fine)."""
    if args.threads is not None and args.threads < 1:
        return f"--threads must be at least 1 (got {args.threads})"
    if args.max_steps is not None and args.max_steps < 0:
        return f"--max-steps must be 0 or more (got {args.max_steps})"
    if args.out is not None and not args.out.strip():
        return f"--out needs a file name (got {args.out!r})"
    if args.restart is not None and not args.restart.strip():
        return f"--restart needs a history file (got {args.restart!r})"
    return None


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


def _main(argv=None):
    argv = sys.argv[1:] if argv is None else list(argv)
    for stream in (sys.stdout, sys.stderr):   # a file name that is not UTF-8 prints escaped
        if getattr(stream, "errors", None) == "strict" and hasattr(stream, "reconfigure"):
            stream.reconfigure(errors="backslashreplace")
    if argv[:1] == ["bench"]:
        from .bench import main as bench_main
        return bench_main(argv[1:])
    if argv and argv[0] in POST_COMMANDS:
        return _post(argv[0], argv[1:])
    args = _parser().parse_args(argv)
    if args.command_or_case in ("run", "check", "info"):
        command, path = args.command_or_case, args.case
        if path is None:
            print(f"rbsm_dyn: {command} needs a case file", file=sys.stderr)
            return 2
    else:
        command, path = "run", args.command_or_case
    problem = _option_problem(args)
    if problem:
        print(f"rbsm_dyn: {problem}", file=sys.stderr)
        return 2
    from .case import CaseError, load_case
    _stop_if_interrupted()
    try:
        case = load_case(path)
    except CaseError as exc:
        print(f"rbsm_dyn: {exc}", file=sys.stderr)
        return 2
    except OSError as exc:
        print(f"rbsm_dyn: {path}: cannot read the case file ({exc.strerror})", file=sys.stderr)
        return 2
    lock = None
    if command == "run":
        # where the run writes may be refused before the (long) build
        problem = _output_problem(case, args, path)
        if problem:
            print(f"rbsm_dyn: {problem}", file=sys.stderr)
            return 2
        from .io.lock import HistoryLock, HistoryLocked
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
        return _build_and_go(command, path, case, args, lock)
    finally:
        if lock is not None:
            lock.release()


def _build_and_go(command, path, case, args, lock):
    from .case import CaseError
    if args.threads is not None:
        threads = _set_threads(args.threads, "--threads")
    else:
        threads = _set_threads(getattr(case.solver, "threads", None), "solver.threads")
    notice = _compile_notice(command, case, args)
    try:
        model = _model(command, case, args)
    except CaseError as exc:
        print(f"rbsm_dyn: {exc}", file=sys.stderr)
        return 2
    if args.threads is None and getattr(case.solver, "threads", None) is None:
        # no count given: the idle cores, one for a small model (threads.py)
        import numba
        from .threads import default_threads
        threads = _set_threads(default_threads(model.n_springs,
                                               numba.config.NUMBA_NUM_THREADS), "default")
    _stop_if_interrupted()
    for note in model.warnings:
        print(f"rbsm_dyn: warning: {note}", file=sys.stderr)
    try:
        step = _preflight(case, model)
    except CaseError as exc:
        print(f"rbsm_dyn: {exc}", file=sys.stderr)
        return 2
    # (the case's own warnings, a unit trap: after the checks, so that a bad
    # case still gets its one line)
    for note in getattr(case, "warnings", ()):
        print(f"rbsm_dyn: warning: {note}", file=sys.stderr)
    from .solvers.output import probe_warnings
    for note in probe_warnings(case, model):
        print(f"rbsm_dyn: warning: {note}", file=sys.stderr)
    if command == "check":
        print(f"{path}: ok ({model.n_bodies} bodies, {model.n_springs} spring points)")
        if case.solver.mode == "static":
            how = "the default for this case" if case.solver._method_default else "given"
            print(f"  solver: static by {case.solver.method} ({how}; docs/case_file.md)")
        if step is not None:
            dt, est = step
            how = ("solver.dt" if case.solver.dt is not None
                   else f"× dt_safety {case.solver.dt_safety:g}")
            steps = int(math.ceil(case.solver.end_time / dt - 1e-9))
            print(f"  stable step {est:.4g} s (estimate); dt {dt:.4g} s ({how}), {steps} steps "
                  f"to end_time {case.solver.end_time:g} s")
        for line in _selections(case, model):
            print(f"  {line}")
        return 0
    if command == "info":
        return _info(case, model, threads, out=args.restart or args.out)
    _stop_if_interrupted()
    return _run(case, model, args, threads, lock, notice)


def _compile_notice(command, case, args):
    """The compile notice of a run (CompileNotice): the build's kernels
    unless the model will be read from .rbsm_cache/, and the solver's.
    check and info say nothing (their build compiles for seconds, and a bad
    case gets one line: the error)."""
    from .io import model_cache
    if command != "run":
        return CompileNotice([], enabled=False)
    kinds = []
    cached = (model_cache.enabled() and not getattr(args, "no_model_cache", False)
              and os.path.exists(model_cache.cache_file(case)))
    if not cached:
        kinds.append("build")
    if command == "run":
        kinds.append(_run_kind(case))
    return CompileNotice(kinds, enabled=not getattr(args, "quiet", False))


def _model(command, case, args):
    """The case's model: from the cache beside the case when its key matches
    (io/model_cache.py), else built (and cached by run and info when the
    build took long enough to be worth a file)."""
    from .io import model_cache
    from .model import build_model
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
    from .solvers import explicit
    explicit.check_model(case, model)
    mode = case.solver.mode
    step = None
    if mode == "dynamic":
        step = explicit.choose_dt(case, model)
    elif mode == "modal":
        from .physics.integrate import FREE
        nf = int((model.dof_kind.reshape(-1) == FREE).sum())
        if case.solver.modes >= nf:
            # (natural_modes also counts the rigid-body modes: checked at run time)
            raise case.error(("solver", "modes"), f"asked for {case.solver.modes} modes, but "
                             f"the model has only {nf} free DOFs")
    from .solvers.output import probe_plan
    for plan in probe_plan(model, dict(case.output.probes or {}), case).values():
        if plan[0] == "error":
            raise plan[1]
    return step


#: builds of more cells than this announce themselves on stderr
BUILD_NOTICE_CELLS = 2.0e4


def _cell_estimate(case):
    """Cells the mesh will have, roughly (volume / size³ or the blocks)."""
    import math
    from .case import scene_parts
    total = 0.0
    for part in scene_parts(case):
        m, g = part.mesh, part.geometry
        if m.kind == "rigid":
            total += 1.0
        elif m.kind == "blocks":
            total += float(math.prod(m.divisions))
        elif g.kind() == "box":
            (x0, y0, z0), (x1, y1, z1) = g.box
            total += (x1 - x0) * (y1 - y0) * (z1 - z0) / m.size ** 3
        else:
            total += (g._solid.volume if g._solid is not None else 0.0) / m.size ** 3
    return total


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


def _info(case, model, threads, out=None):
    """Counts, steps, memory and output size of the case, without running
    (rbsm_dyn/io/estimate.py says how each figure is made).  ``out``: the
    history a run with the same options writes (--restart, --out; default
    output.file)."""
    from .io.estimate import estimate, format_bytes
    e = estimate(case, model, extra_observables=_extra_observables(case), threads=threads)
    dt = e.dt_estimate
    print(f"case        {case.name} ({case.solver.mode})")
    print(f"bodies      {e.n_bodies}")
    print(f"springs     {e.n_springs} ({e.n_supports} supports, {model.n_cut} cut)")
    for k, line in enumerate(_selections(case, model)):
        print(f"{'selects' if k == 0 else '':<12}{line}")
    print(f"stable dt   {dt:.4g} s (estimate; used × dt_safety {case.solver.dt_safety})")
    if model.n_bodies <= INFO_OMEGA_MAX_BODIES:       # Lanczos: < 1 s at this size
        from .solvers.modal import omega_max
        w = omega_max(model)
        if w > 0:
            print(f"exact dt    {2.0 / w:.4g} s (2/ω_max, ω_max = {w:.4g} rad/s by Lanczos; "
                  f"estimate/exact = {dt * w / 2.0:.3f})")
    if e.steps is not None:
        print(f"steps       {e.steps} (dt = {e.dt:.4g} s to end_time {case.solver.end_time:g} s)")
        print(f"frames      {e.frames} (every {e.out_every} steps)")
    else:
        print(f"frames      {e.frames}")
    print(f"memory      {format_bytes(e.memory_bytes)} (model {format_bytes(e.model_bytes)}, "
          f"build temporaries {format_bytes(e.build_bytes)}, "
          f"state {format_bytes(e.state_bytes)}, output buffers {format_bytes(e.buffer_bytes)}"
          + (f", stiffness matrix {format_bytes(e.matrix_bytes)}" if e.matrix_bytes else "")
          + ")")
    print(f"output      {format_bytes(e.output_bytes)} -> {out or case.output.file} "
          f"({format_bytes(e.static_bytes)} static + {e.frames} frames of "
          f"{format_bytes(e.frame_bytes)}; fields: {', '.join(case.output.fields) or 'none'})")
    return 0


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


def _run(case, model, args, threads, lock, notice=None):
    """Run the case; ``lock``: the held io/lock.HistoryLock of the output;
    ``notice``: the CompileNotice said before the build."""
    from .case import CaseError
    from .solvers import checkpoint, explicit
    from .solvers.output import Recorder
    out = args.out or case.output.file
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
    last = _watch_frames(rec)
    kind = ("steps" if case.solver.mode == "dynamic" else
            "newton" if getattr(case.solver, "method", "") == "newton" else "load steps")
    progress = Progress(not args.quiet, kind=kind)
    if notice is None:
        notice = CompileNotice([_run_kind(case)], enabled=not args.quiet)
    progress.on_first = notice.done
    notice.arm()
    t0 = time.perf_counter()
    try:
        if case.solver.mode == "dynamic":
            governor = None
            if args.threads is None and getattr(case.solver, "threads", None) is None:
                # the default count, kept right while the run steps (threads.py)
                import numba
                from .threads import Governor
                governor = Governor(model.n_springs, numba.config.NUMBA_NUM_THREADS)
            res = explicit.run(case, model, rec, max_steps=args.max_steps, progress=progress,
                               restart=restart, governor=governor)
            summary = (f"{res['steps']} steps, dt = {res['dt']:.4g} s "
                       f"(estimate {res['dt_estimate']:.4g} s)")
        elif case.solver.mode == "static":
            from .solvers import relax
            res = relax.run(case, model, rec, max_steps=args.max_steps, progress=progress)
            summary = f"{len(res['iterations'])} load steps, {sum(res['iterations'])} iterations"
        elif case.solver.mode == "linear":
            from .solvers import linear       # (scipy.sparse: only these two modes)
            res = linear.run(case, model, rec)
            how = (f"CG, {res['iterations']} iterations" if res["method"] == "cg"
                   else "direct")
            summary = (f"K U = F ({res['n_free']} DOFs, {how}, residual {res['residual']:.2g}; "
                       f"assembly {res['assembly_time']:.2f} s, solve {res['solve_time']:.2f} s)")
        else:
            from .solvers import modal
            res = modal.run(case, model, rec)
            summary = (f"{res['modes']} modes, ω_max = {res['omega_max']:.4g} rad/s")
    except explicit.RunFailed as exc:
        progress.close()
        rec.close()
        print(f"rbsm_dyn: run failed: {exc}; history kept in {out}", file=sys.stderr)
        return 1
    except CaseError as exc:
        progress.close()
        rec.fail(str(exc))
        rec.close()
        print(f"rbsm_dyn: {exc}", file=sys.stderr)
        return 2
    except checkpoint.Interrupted as exc:
        progress.close()
        rec.fail(f"{exc}; continue with --restart {out}")
        rec.close()
        cpath = args.case if args.command_or_case == "run" else args.command_or_case
        print(f"rbsm_dyn: {exc} in {out}; continue with: python -m rbsm_dyn {cpath} "
              f"--restart {out}", file=sys.stderr)
        return exc.exit_code
    except KeyboardInterrupt:
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
    from .solvers.output import PROBE_UNITS
    values = last.get("values") or {}
    out = []
    mode = case.solver.mode
    if mode == "modal" or not values:
        return out
    what = {"dynamic": f"t = {last['time']:.6g} s", "static": f"load factor {last['time']:.4g}",
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


if __name__ == "__main__":
    try:
        code = main()
    except KeyboardInterrupt:           # (between main's return and here)
        os._exit(130)
    sys.exit(code)
