"""Same results, bit for bit, before and after a change (issue 26).

Runs every shipped case (cases/*.yaml) for a few hundred steps at 1 and 2
threads with two trees of the code -- this checkout and a git revision
checked out beside it (`git worktree`) -- and compares every dataset of the
two histories (positions, orientations, velocities, energies, probes,
spring state and forces, checkpoint) bitwise.  Each tree runs with its own
Numba cache (its own __pycache__), in its own process, the case's model
built anew (--no-model-cache).

    python benchmarks/same_results.py --before REV [--steps 300] [--threads 1,2] [CASE ...]

Prints one row per case and thread count (`same` or the first dataset that
differs) and exits 1 if any differs.  Two trees are run rather than digests
stored, so that the comparison holds on any machine (a stored digest is
only valid for one CPU, NumPy and LLVM)."""
import argparse
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import h5py
import numpy as np

ROOT = Path(__file__).resolve().parent.parent
# datasets that differ between any two runs by design (time stamps,
# versions, the command line, the output's own path)
SKIP = ("/parameters", "/h5md")


def datasets(path):
    """{name: array} of every dataset in an HDF5 file outside SKIP."""
    out = {}
    with h5py.File(path, "r") as f:
        def visit(name, obj):
            full = "/" + name
            if isinstance(obj, h5py.Dataset) and not full.startswith(SKIP):
                out[full] = obj[()]
        f.visititems(visit)
    return out


def first_difference(a, b):
    """None if the two {name: array} maps are bitwise equal, else a note."""
    if a.keys() != b.keys():
        return f"datasets differ: {sorted(a.keys() ^ b.keys())[:4]}"
    for k in sorted(a):
        x, y = np.asarray(a[k]), np.asarray(b[k])
        if x.shape != y.shape or x.dtype != y.dtype:
            return f"{k}: shape/dtype {x.shape} {x.dtype} vs {y.shape} {y.dtype}"
        if x.tobytes() != y.tobytes():
            if x.dtype.kind == "f":
                bad = ~((x == y) | (np.isnan(x) & np.isnan(y)))
                d = np.max(np.abs(x[bad] - y[bad])) if bad.any() else 0.0
                return f"{k}: {int(bad.sum())} values differ (max |diff| {d:.3g})"
            return f"{k}: values differ"
    return None


def run(tree, case, out, steps, threads, cwd):
    env = dict(os.environ, PYTHONPATH=str(tree), NUMBA_NUM_THREADS=str(max(threads, 2)))
    cmd = [sys.executable, "-m", "rbsm_dyn", str(case), "--out", str(out), "--quiet",
           "--max-steps", str(steps), "--threads", str(threads), "--no-model-cache"]
    t0 = time.perf_counter()
    r = subprocess.run(cmd, cwd=cwd, env=env, capture_output=True, text=True)
    return r, time.perf_counter() - t0


def main(argv=None):
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--before", required=True, help="git revision of the code before")
    p.add_argument("--after", default=None, help="tree of the code after (default: this checkout)")
    p.add_argument("--steps", type=int, default=300)
    p.add_argument("--threads", default="1,2")
    p.add_argument("cases", nargs="*")
    a = p.parse_args(argv)
    after = Path(a.after).resolve() if a.after else ROOT
    cases = [Path(c).resolve() for c in a.cases] or sorted((ROOT / "cases").glob("*.yaml"))
    threads = [int(t) for t in a.threads.split(",")]
    work = Path(tempfile.mkdtemp(prefix="same_results_"))
    before = work / "before"
    subprocess.run(["git", "-C", str(ROOT), "worktree", "add", "--detach", str(before),
                    a.before], check=True, capture_output=True)
    bad = 0
    try:
        for case in cases:
            for t in threads:
                res = {}
                for name, tree in (("before", before), ("after", after)):
                    d = work / f"{case.stem}-{t}-{name}"
                    d.mkdir()
                    r, secs = run(tree, case, d / "run.h5", a.steps, t, d)
                    res[name] = (r, secs, d / "run.h5")
                rb, sb, hb = res["before"]
                ra, sa, ha = res["after"]
                if rb.returncode != ra.returncode:
                    note = f"exit {rb.returncode} vs {ra.returncode}: {ra.stderr[-300:]}"
                elif not (hb.exists() and ha.exists()):
                    note = f"no history (exit {ra.returncode}): {ra.stderr[-300:]}"
                else:
                    note = first_difference(datasets(hb), datasets(ha)) or "same"
                bad += note != "same"
                print(f"{case.stem:22s} threads={t} before {sb:6.1f} s after {sa:6.1f} s "
                      f"{note}", flush=True)
    finally:
        subprocess.run(["git", "-C", str(ROOT), "worktree", "remove", "--force", str(before)],
                       capture_output=True)
    print("all same" if not bad else f"{bad} differ")
    return 1 if bad else 0


if __name__ == "__main__":
    sys.exit(main())
