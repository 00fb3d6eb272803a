"""The compile notice of a cold start (CompileNotice): which compiled kernels
a run of each kind calls (RUN_KERNELS), whether they are cold in Numba's
cache (kernel_is_cold, cold_kernels), and how long compiling them takes on
this machine (compile_seconds, kept in compile_seconds.json)."""
import os
import sys
import time

#: the package whose kernels RUN_KERNELS names (rbsm_dyn)
_PACKAGE = __package__.rpartition(".")[0]


#: compiled kernels every run of each kind calls (module under the package,
#: function; tests/test_run_ux.py runs each kind and checks): the Numba
#: cache is cold for the run when one of them has neither a version
#: compiled in this process nor a valid cache index
RUN_KERNELS = {
    "build": (("model", "_arms"), ("mesh.polyhedron", "_tet_moments")),
    "dynamic": (("physics.integrate", "run_dynamic"), ("physics.integrate",
                                                        "synchronized_momenta"),
                ("model", "_scaled_row_sums")),
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


def compile_notice(command, case, args):
    """The compile notice of a run (CompileNotice): the build's kernels
    unless the model will be read from .rbsm_cache/, and the solver's.
    check and info say nothing (their build compiles for seconds, and a bad
    case gets one line: the error)."""
    from ..io import model_cache
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
