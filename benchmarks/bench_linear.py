"""Kawai's stiffness method at scale: assembly, linear solve and eigsh times.

Scene: a steel block 2 × 1 × 1 (scaled) cut into ~`--bodies` Voronoi cells
(E = 200 GPa, ν = 0.2, ρ = 7850 kg/m³, spring_points: moment), support
springs on face xmin, a load on the cells near xmax.  Built through the
public path load_case_text -> build_model (build time reported apart).

For each size it times, in one process:
* assembly of K (stiffness.stiffness_matrix: vectorised over spring points)
  and of M (mass_matrix);
* the linear solve K U = F by SuperLU (solvers/linear.py, `direct`; skipped
  above `--direct-max` DOFs) and by CG with the 6 × 6 block-Jacobi
  preconditioner (`cg`, relative residual 1e-10), with the difference
  between the two;
* ω_max by Lanczos (modal.omega_max) and the lowest 6 modes by shift-invert
  eigsh (modal.natural_modes; skipped above `--eigsh-max` DOFs);
* the peak resident memory of the process (ru_maxrss) after each size.

    NUMBA_NUM_THREADS=1 python benchmarks/bench_linear.py --bodies 1e4 1e5
    python benchmarks/bench_linear.py --bodies 2e3 --label quick

Results are appended to benchmarks/results/linear.txt.
"""
import argparse
import datetime
import platform
import resource
import subprocess
import sys
import time
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent

CASE = """\
name: bench-linear
domain: {{box: [[0, 0, 0], [{lx}, {ly}, {lz}]]}}
mesh: {{kind: voronoi, size: {size}, seed: 1}}
materials:
  steel: {{density: 7850, young: 2.0e11, poisson: 0.2}}
groups:
  end: {{box: [[{xe}, -1, -1], [2, 2, 2]]}}
boundary: [{{face: xmin, fix: all}}]
loads: [{{group: end, force: [0, 0, -1.0e5]}}]
solver: {{mode: linear}}
"""


def case_text(bodies):
    lx, ly, lz = 1.0, 0.5, 0.5
    size = (lx * ly * lz / bodies) ** (1.0 / 3.0)
    return CASE.format(lx=lx, ly=ly, lz=lz, size=f"{size:.6g}", xe=f"{lx - 1.5 * size:.6g}")


def peak_gb():
    return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1e6


def git_rev():
    try:
        return subprocess.run(["git", "rev-parse", "--short", "HEAD"], cwd=HERE, text=True,
                              capture_output=True).stdout.strip() or "?"
    except OSError:
        return "?"


def bench(bodies, direct_max, eigsh_max, log):
    from rbsm_dyn.case import load_case_text
    from rbsm_dyn.model import build_model
    from rbsm_dyn.solvers import linear, modal
    from rbsm_dyn.stiffness import mass_matrix, stiffness_matrix

    t = time.perf_counter()
    model = build_model(load_case_text(case_text(bodies)))
    t_build = time.perf_counter() - t
    n, s = model.n_bodies, model.n_springs
    t = time.perf_counter()
    K = stiffness_matrix(model)
    t_K = time.perf_counter() - t
    t = time.perf_counter()
    M = mass_matrix(model)
    t_M = time.perf_counter() - t
    log(f"N = {n} bodies, S = {s} spring points, {6 * n} DOFs, nnz(K) = {K.nnz}; "
        f"build {t_build:.1f} s; assembly K {t_K:.2f} s, M {t_M:.2f} s; peak RSS {peak_gb():.2f} GB")
    ref = None
    if 6 * n <= direct_max:
        sol = linear.solve(model, K=K, method="direct")
        ref = sol.U
        log(f"  direct (SuperLU, COLAMD, 2 refinements): {sol.solve_time:.2f} s, "
            f"residual {sol.residual:.2g}; peak RSS {peak_gb():.2f} GB")
    else:
        log(f"  direct: skipped ({6 * n} DOFs > --direct-max {direct_max:g})")
    sol = linear.solve(model, K=K, method="cg")
    diff = "" if ref is None else \
        f", max|U_cg − U_direct|/max|U| = {np.abs(sol.U - ref).max() / np.abs(ref).max():.2g}"
    log(f"  CG + block Jacobi: {sol.solve_time:.2f} s, {sol.iterations} iterations, "
        f"residual {sol.residual:.2g}{diff}; peak RSS {peak_gb():.2f} GB")
    t = time.perf_counter()
    wmax = modal.omega_max(model, K=K, M=M)
    t_w = time.perf_counter() - t
    est = model.stable_dt()
    log(f"  ω_max (Lanczos, which=LA): {t_w:.2f} s; 2/ω_max = {2 / wmax:.4g} s, "
        f"Model.stable_dt() = {est:.4g} s (ratio {est * wmax / 2:.3f})")
    if 6 * n <= eigsh_max:
        res = modal.natural_modes(model, 6, K=K, M=M)
        log(f"  eigsh shift-invert, 6 modes: {res.eigsh_time:.2f} s "
            f"(f1 = {res.frequency[0]:.5g} Hz, f6 = {res.frequency[-1]:.5g} Hz); "
            f"peak RSS {peak_gb():.2f} GB")
    else:
        log(f"  eigsh: skipped ({6 * n} DOFs > --eigsh-max {eigsh_max:g})")


def main(argv=None):
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--bodies", type=float, nargs="+", default=[1e4, 1e5])
    p.add_argument("--direct-max", type=float, default=6.1e4, help="largest DOF count for SuperLU")
    p.add_argument("--eigsh-max", type=float, default=6.1e4, help="largest DOF count for eigsh")
    p.add_argument("--label", default="")
    p.add_argument("--no-save", action="store_true")
    a = p.parse_args(argv)
    import numba
    import scipy
    lines = []

    def log(msg):
        print(msg, flush=True)
        lines.append(msg)

    now = datetime.datetime.now().isoformat(timespec="seconds")
    log(f"=== bench_linear {now} {a.label}".rstrip())
    log("command: python benchmarks/bench_linear.py " + " ".join(sys.argv[1:]))
    log(f"machine: {platform.processor() or platform.machine()}; python "
        f"{platform.python_version()}, numpy {np.__version__}, scipy {scipy.__version__}, "
        f"numba {numba.__version__} ({numba.get_num_threads()} threads); git {git_rev()}")
    for b in a.bodies:
        bench(int(b), a.direct_max, a.eigsh_max, log)
    if not a.no_save:
        out = HERE / "results" / "linear.txt"
        out.parent.mkdir(exist_ok=True)
        with out.open("a", encoding="utf-8") as f:
            f.write("\n".join(lines) + "\n\n")


if __name__ == "__main__":
    main()
