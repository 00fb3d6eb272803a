"""First run of every shipped case with an empty kernel cache, then again
warm: wall time and the longest silence (seconds between two pieces of
output on stdout/stderr, the start and the end included), as a new user
meets them (issue 26: the README's case in <= 30 s cold, no first run
silent for more than 10 s).

    python benchmarks/cold_start.py [--tree DIR] [--max-steps 20] [--check] [CASE ...]

Each case runs in a fresh XDG_CACHE_HOME (no compiled kernels, no compile
record), the model built anew (--no-model-cache); `--check` times
`python -m rbsm_dyn check CASE` instead.  Measures; asserts nothing."""
import argparse
import os
import subprocess
import sys
import tempfile
import threading
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent


def timed_run(cmd, env, cwd):
    """(exit code, wall seconds, longest silence seconds)."""
    t0 = time.perf_counter()
    p = subprocess.Popen(cmd, env=env, cwd=cwd, stdout=subprocess.PIPE,
                         stderr=subprocess.PIPE)
    stamps = [t0]
    lock = threading.Lock()

    def pump(stream):
        while True:
            b = stream.read1(4096) if hasattr(stream, "read1") else stream.read(1)
            if not b:
                return
            with lock:
                stamps.append(time.perf_counter())

    threads = [threading.Thread(target=pump, args=(s,), daemon=True)
               for s in (p.stdout, p.stderr)]
    for t in threads:
        t.start()
    code = p.wait()
    for t in threads:
        t.join()
    t1 = time.perf_counter()
    stamps = sorted(stamps + [t1])
    gap = max(b - a for a, b in zip(stamps, stamps[1:]))
    return code, t1 - t0, gap


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--tree", default=str(ROOT))
    ap.add_argument("--max-steps", type=int, default=20)
    ap.add_argument("--check", action="store_true")
    ap.add_argument("cases", nargs="*")
    a = ap.parse_args(argv)
    tree = Path(a.tree).resolve()
    cases = [Path(c).resolve() for c in a.cases] or sorted((ROOT / "cases").glob("*.yaml"))
    print(f"# cold_start {time.strftime('%Y-%m-%d %H:%M')} tree={tree} "
          f"{'check' if a.check else f'run --max-steps {a.max_steps}'}", flush=True)
    print(f"{'case':22s} {'cold s':>7s} {'silence':>8s} {'warm s':>7s} {'silence':>8s}  exit")
    for case in cases:
        cache = tempfile.mkdtemp(prefix="rbsm_cold_")
        work = tempfile.mkdtemp(prefix="rbsm_run_")
        env = dict(os.environ, PYTHONPATH=str(tree), XDG_CACHE_HOME=cache)
        env.pop("NUMBA_CACHE_DIR", None)
        if a.check:
            cmd = [sys.executable, "-m", "rbsm_dyn", "check", str(case)]
        else:
            cmd = [sys.executable, "-m", "rbsm_dyn", str(case), "--out", "run.h5",
                   "--max-steps", str(a.max_steps), "--no-model-cache"]
        c1, w1, g1 = timed_run(cmd, env, work)
        c2, w2, g2 = timed_run(cmd, env, work)
        print(f"{case.stem:22s} {w1:7.1f} {g1:8.1f} {w2:7.1f} {g2:8.1f}  {c1},{c2}", flush=True)


if __name__ == "__main__":
    main()
