"""Where a cold start spends its time: every Numba compilation of a run,
with its own time (callees' compilations taken out), largest first.

    python benchmarks/compile_profile.py CASE.yaml [run options ...]

Runs the case in this process with an empty kernel cache (a fresh
XDG_CACHE_HOME unless --warm) and prints one row per compiled function and
signature: own seconds, total seconds, calls.  Measures; asserts nothing."""
import os
import sys
import tempfile
import time
from collections import defaultdict

if "--warm" in sys.argv:
    sys.argv.remove("--warm")
else:
    os.environ["XDG_CACHE_HOME"] = tempfile.mkdtemp(prefix="rbsm_cold_")

from numba.core import dispatcher  # noqa: E402

_stack = []
_own = defaultdict(float)
_total = defaultdict(float)
_count = defaultdict(int)
_orig = dispatcher.Dispatcher.compile


def _timed(self, sig):
    key = f"{self.py_func.__module__}.{self.py_func.__qualname__}"
    t0 = time.perf_counter()
    _stack.append(0.0)
    try:
        return _orig(self, sig)
    finally:
        dt = time.perf_counter() - t0
        child = _stack.pop()
        _own[key] += dt - child
        _total[key] += dt
        _count[key] += 1
        if _stack:
            _stack[-1] += dt


dispatcher.Dispatcher.compile = _timed


def main():
    from rbsm_dyn.__main__ import main as cli
    t0 = time.perf_counter()
    try:
        code = cli(sys.argv[1:])
    except SystemExit as e:
        code = e.code
    wall = time.perf_counter() - t0
    rows = sorted(_own.items(), key=lambda kv: -kv[1])
    print(f"\nwall {wall:.1f} s, compile (own times summed) {sum(_own.values()):.1f} s, "
          f"{len(rows)} functions, exit {code}")
    print(f"{'own s':>7} {'total s':>8} {'n':>3}  function")
    for k, v in rows:
        if v >= 0.05:
            print(f"{v:7.2f} {_total[k]:8.2f} {_count[k]:3d}  {k}")


if __name__ == "__main__":
    main()
