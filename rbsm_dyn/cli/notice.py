"""The compile notice of a cold start (CompileNotice): which compiled kernels
a run of each kind calls (RUN_KERNELS), whether they are cold in Numba's
cache (kernel_is_cold, cold_kernels), and how long compiling them takes on
this machine (compile_seconds, kept in compile_seconds.json); while they
compile, a heartbeat line every 10 s (Heartbeat)."""
import os
import sys
import threading
import time

#: the package whose kernels RUN_KERNELS names (rbsm_dyn)
_PACKAGE = __package__.rpartition(".")[0]


#: compiled kernels every run of each kind calls (module under the package,
#: function; tests/test_run_ux.py runs each kind and checks): the Numba
#: cache is cold for the run when one of them has neither a version
#: compiled in this process nor a valid cache index
RUN_KERNELS = {
    "build": (("model.springs", "_arms"), ("mesh.polyhedron", "_tet_moments")),
    "dynamic": (("physics.integrate", "run_dynamic"), ("physics.integrate",
                                                        "synchronized_momenta"),
                ("model.stable_step", "_face_row_sums")),
    "plane": (("physics.plane", "run_plane"), ("physics.integrate", "synchronized_momenta"),
              ("model.stable_step", "_face_row_sums")),
    "relaxation": (("physics.relax", "run_relax"),),
    # on top of a 3D dynamic run's: springs that yield, break or touch
    # (materials' yield or rupture, cuts, interfaces) and contact between
    # cells (case key contact)
    "inelastic": (("physics.inelastic", "inelastic_spring_pass"),),
    "contact": (("physics.collide", "contact_step"),),
    "newton": (("solvers.assembly", "_assemble"),),
    "linear": (("physics.passes", "spring_forces"),),
    "modal": (("physics.passes", "spring_forces"),),
}
#: seconds the compilation of a cold start takes, until one has been timed on
#: this machine (then read from compile_seconds.json in rbsm_dyn's cache
#: folder): a small scene's on the 2-core sandbox since issue 26 compiles
#: only the passes a run uses (benchmarks/results/kernel_interface.md: cold
#: runs of cantilever_static 23 s, bar_wave 28 s, cantilever_modes 13 s in
#: all, about 2 s of it import).  The threaded inelastic and contact passes
#: come on top (benchmarks/results/compile.md: of cases/impact_plate.yaml's
#: cold 276 s, the inelastic spring pass's two variants took about 200 s,
#: the contact passes and their broad phase about 50 s; since then a
#: threaded run no longer compiles the serial inelastic variant, 48 s, nor
#: the elastic pass, 22 s: a notched tension specimen cold 212 -> 126 s);
#: the heartbeat covers them
COMPILE_SECONDS = {"build": 5.0, "dynamic": 20.0, "plane": 30.0, "relaxation": 15.0,
                   "newton": 30.0,
                   "linear": 6.0, "modal": 6.0,
                   "inelastic": 140.0, "contact": 40.0}


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
    if mode == "dynamic" and case.plane is not None:
        # the plane passes (physics/plane.py, plane_contact.py)
        return "plane"
    return ("dynamic" if mode == "dynamic" else mode if mode in ("linear", "modal")
            else "newton" if getattr(case.solver, "method", "") == "newton" else "relaxation")


def run_kinds(case):
    """The kinds of RUN_KERNELS a run of the case calls (not the build's):
    its solver's, "inelastic" for a 3D dynamic run with springs that yield,
    break or touch, and "contact" for contact between cells."""
    kind = _run_kind(case)
    kinds = [kind]
    if kind == "dynamic" and _inelastic(case):
        kinds.append("inelastic")
    if getattr(case, "contact", None) is not None and case.solver.mode == "dynamic":
        kinds.append("contact")
    return kinds


def _inelastic(case):
    """Whether a case's springs can yield, break or touch (model.inelastic,
    told from the case before the build: a material's yield or rupture,
    cuts, interfaces)."""
    mats = (getattr(case, "materials", None) or {}).values()
    return bool(getattr(case, "cuts", None) or getattr(case, "interfaces", None)
                or any(getattr(m, "yield_", None) is not None
                       or getattr(m, "rupture", None) is not None for m in mats))


def cold_kernels(kinds):
    """The kinds of RUN_KERNELS whose kernels are cold (a list; "?" in it
    when some could not be told)."""
    import importlib
    out = []
    for kind in kinds:
        for mod, name in RUN_KERNELS[kind]:
            try:
                f = getattr(importlib.import_module(f".{mod}", _PACKAGE), name)
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


class Heartbeat:
    """Says "still compiling kernels (N s so far)" on stderr every SECONDS
    (the first after SECONDS) from ``start()`` until ``stop()``, from a
    daemon thread, so that a user never waits long in silence while kernels
    compile.  Nothing is said once ``stop()`` has returned (the thread says
    each line under a lock that ``stop()`` takes).  ``say(text)`` writes a
    line."""

    SECONDS = 10.0

    def __init__(self, say, seconds=None):
        self.say = say
        self.seconds = float(self.SECONDS if seconds is None else seconds)
        self.t0 = None
        self._stopped = threading.Event()
        self._lock = threading.Lock()
        self._thread = None

    @property
    def running(self):
        return self._thread is not None and not self._stopped.is_set()

    def start(self):
        """Start beating (once: again after start() or stop() does nothing)."""
        if self._thread is None and not self._stopped.is_set():
            self.t0 = time.perf_counter()
            self._thread = threading.Thread(target=self._beat, name="rbsm_dyn heartbeat",
                                            daemon=True)
            self._thread.start()
        return self

    def _beat(self):
        k = 1
        while not self._stopped.wait(max(0.0, self.t0 + k * self.seconds
                                          - time.perf_counter())):
            with self._lock:
                if self._stopped.is_set():
                    return
                try:
                    self.say(f"rbsm_dyn: still compiling kernels ({k * self.seconds:.0f} s "
                             "so far)")
                except Exception:          # (stderr closed: say nothing more)
                    return
            k += 1

    def stop(self):
        """No line any more (also when never started)."""
        with self._lock:
            self._stopped.set()


class CompileNotice:
    """Says "compiling kernels (first run only, about N s)" on stderr before
    the first call of cold kernels (made when it is created, before the
    build); when coldness cannot be told, says so only if the first chunk
    of steps has not ended after FALLBACK_SECONDS.  ``done()`` (a run: at
    the end of its first chunk; check, info: after the build) keeps the
    time a cold start took, for the next notice.

    The heartbeat (Heartbeat) then says "still compiling kernels (N s so
    far)" every Heartbeat.SECONDS until ``done()`` or ``cancel()``: from the
    creation when some kernels are cold or cannot be told; else from
    ``arm()`` (the solver's start: the kernels compile per feature set, so
    a warm kernel may still compile a new variant; if none, the first chunk
    ends in a second or so and the heartbeat says nothing).  ``announce``
    False (check, info): no notice, no fallback, no timing kept; only the
    heartbeat while cold kernels compile.  ``enabled`` False (--quiet):
    nothing at all."""

    FALLBACK_SECONDS = 2.0
    MIN_SECONDS = 0.5           # a cold start timed shorter is not kept

    def __init__(self, kinds, enabled=True, announce=True):
        self.enabled = enabled
        self.announce = announce
        cold = cold_kernels(kinds) if enabled else []
        self.cold = [k for k in cold if k != "?"]
        self.unknown = "?" in cold
        self.timer = None
        #: the run's Progress, once it exists: the heartbeat writes above its bar
        self.progress = None
        self.heartbeat = Heartbeat(self._say)
        self.t0 = time.perf_counter()
        if self.cold and announce:
            n = compile_seconds(self.cold)
            print(f"rbsm_dyn: compiling kernels (first run only, about {n:.0f} s)",
                  file=sys.stderr, flush=True)
        if enabled and (self.cold or self.unknown):
            self.heartbeat.start()

    def _say(self, text):
        """A line on stderr; above the progress bar when there is one (tqdm
        clears it, writes the line and draws it again)."""
        bar = getattr(self.progress, "bar", None)
        if bar is not None:
            bar.write(text, file=sys.stderr)
        else:
            sys.stderr.write(text + "\n")
            sys.stderr.flush()

    def arm(self, heartbeat=True):
        """At the solver's start: the fallback, a message if the first chunk
        is slow (a timer thread); and the heartbeat, if not beating yet
        (``heartbeat`` False: a solver whose first progress comes late, or
        never: Newton's first increment, a linear or modal solve, which
        would count as compiling)."""
        if self.enabled and self.unknown and not self.cold and self.announce:
            def say():
                print("rbsm_dyn: compiling kernels, it seems (first run only: a minute or "
                      "so)", file=sys.stderr, flush=True)
            self.timer = threading.Timer(self.FALLBACK_SECONDS, say)
            self.timer.daemon = True
            self.timer.start()
        if self.enabled and heartbeat:
            self.heartbeat.start()

    def cancel(self):
        """No fallback message and no heartbeat any more."""
        self.heartbeat.stop()
        if self.timer is not None:
            self.timer.cancel()
            self.timer = None

    def done(self):
        """The cold kernels have been compiled: keep the time it took (once)."""
        self.cancel()
        if self.cold and self.announce:
            took = time.perf_counter() - self.t0
            # (only a real compilation: the kernels warm now, and it took time)
            if took >= self.MIN_SECONDS and not cold_kernels(self.cold):
                record_compile_seconds("+".join(sorted(self.cold)), took)
        self.cold = []


def compile_notice(command, case, args):
    """The compile notice of a run (CompileNotice): the build's kernels
    unless the model will be read from .rbsm_cache/, and the solver's.
    check and info say no notice (their build compiles for seconds, and a
    bad case gets one line: the error), only the heartbeat while cold build
    kernels compile (prepare.py calls done() after the build)."""
    from ..io import model_cache
    kinds = []
    cached = (model_cache.enabled() and not getattr(args, "no_model_cache", False)
              and os.path.exists(model_cache.cache_file(case)))
    if not cached:
        kinds.append("build")
    quiet = getattr(args, "quiet", False)
    if command != "run":
        return CompileNotice(kinds, enabled=not quiet, announce=False)
    kinds += run_kinds(case)
    return CompileNotice(kinds, enabled=not quiet)
