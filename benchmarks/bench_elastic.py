"""Elastic explicit-dynamics throughput: ns per spring-point-step.

What it measures (benchmarks/README.md):

* loop: `rbsm_dyn.solvers.explicit.advance` over K steps (the compiled
  time loop: spring pass + body pass) on a Voronoi block of steel with a
  support on face xmin and an initial velocity, for each thread count
  (`numba.set_num_threads`); best of `--repeat` runs, each from the same
  initial state.  Mesh/model build and the first call (Numba compile or
  cache load) are timed apart.  Reports ns per spring-point-step and ns
  per body-step (the same wall time divided by S·K and N·K).
* split: the spring pass and the body pass alone (same kernels, same
  arrays), to see where the time goes.
* identity: final positions, quaternions and momenta after K steps are
  compared bitwise between thread counts.
* startup: a small case to its first step in a fresh process, with an
  empty Numba cache (NUMBA_CACHE_DIR = new temp dir: cold) and again with
  the same cache dir (warm).

    python benchmarks/bench_elastic.py                      # 1 M springs, 1 and 2 threads
    python benchmarks/bench_elastic.py --springs 2e5 --steps 50 --threads 1
"""
import argparse
import datetime
import os
import platform
import shlex
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
SPRINGS_PER_CELL = 34.0   # Voronoi, spring_points: moment (measured: ~35 at 2 000 cells)

CASE = """\
name: bench-elastic
domain: {{box: [[0, 0, 0], [{lx}, {ly}, {lz}]]}}
mesh: {{kind: voronoi, size: {size}, seed: 1}}
materials:
  steel: {{density: 7850, young: 2.0e11, poisson: 0.2}}
boundary: [{{face: xmin, fix: all}}]
initial: [{{velocity: [0.0, 0.0, -1.0], angular_velocity: [0.0, 0.0, 2.0]}}]
solver: {{mode: dynamic, end_time: 1.0e-3}}
"""


def case_text(n_springs):
    """Bar 2 × 1 × 1 (scaled) whose Voronoi cells give about n_springs."""
    cells = max(n_springs / SPRINGS_PER_CELL, 8.0)
    lx, ly, lz = 1.0, 0.5, 0.5
    size = (lx * ly * lz / cells) ** (1.0 / 3.0)
    return CASE.format(lx=lx, ly=ly, lz=lz, size=f"{size:.6g}")


def machine_info():
    model = platform.processor() or "?"
    try:
        out = subprocess.run(["lscpu"], capture_output=True, text=True).stdout
        for line in out.splitlines():
            if line.startswith("Model name"):
                model = line.split(":", 1)[1].strip()
    except OSError:
        pass
    import numba
    return dict(cpu=model, cores=os.cpu_count(), numba=numba.__version__,
                numpy=np.__version__, python=platform.python_version(),
                date=datetime.datetime.now().isoformat(timespec="seconds"))


def fresh_state(case, model):
    from rbsm_dyn.model import apply_initial, new_state
    from rbsm_dyn.solvers.explicit import choose_dt
    state = new_state(model)
    state.dt, _ = choose_dt(case, model)
    apply_initial(case, model, state)
    return state


def split_passes(model, state, n_steps):
    """Wall time of the spring pass and the body pass alone over n_steps."""
    from rbsm_dyn.physics.arrays import Stepping
    from rbsm_dyn.physics.integrate import dynamic_body_pass
    from rbsm_dyn.physics.springs import elastic_spring_pass
    from rbsm_dyn.solvers.passes import Options, body_state, model_arrays, parallel_arg
    m, s = model, state
    bodies, springs, loads = model_arrays(m)
    par = parallel_arg(Options.of(m))
    bs = body_state(s)
    step = Stepping(s.dt, 0.0, 0.0)
    t_spring = t_body = 0.0
    for k in range(n_steps):
        t0 = time.perf_counter()
        elastic_spring_pass(springs, bs, False, par)
        t1 = time.perf_counter()
        dynamic_body_pass(k * s.dt, step, bodies, loads, bs, par)
        t2 = time.perf_counter()
        t_spring += t1 - t0
        t_body += t2 - t1
    return t_spring, t_body


def bench_loop(args, out):
    import numba
    from rbsm_dyn.case import load_case_text
    from rbsm_dyn.model import build_model
    from rbsm_dyn.solvers.explicit import advance

    t0 = time.perf_counter()
    case = load_case_text(case_text(args.springs), "bench_elastic.yaml")
    model = build_model(case)
    t_build = time.perf_counter() - t0
    S, N, K = model.n_springs, model.n_bodies, args.steps
    n_sup = int(model.is_support.sum())
    out(f"model: {N} bodies, {S} spring points ({n_sup} support), "
        f"{S / N:.1f} springs/body; build (mesh + model) {t_build:.1f} s")

    # first call: compile or cache load (one step, all thread counts share it)
    st = fresh_state(case, model)
    t0 = time.perf_counter()
    advance(model, st, 1)
    t_first = time.perf_counter() - t0
    out(f"first advance(1 step) incl. Numba compile/cache load: {t_first:.2f} s "
        f"(threading layer {numba.threading_layer()}); dt = {st.dt:.4g} s")

    rows, finals = [], {}
    for nt in args.threads:
        numba.set_num_threads(nt)
        times, cpus = [], []
        for r in range(args.repeat):
            st = fresh_state(case, model)
            c0 = time.process_time()
            t0 = time.perf_counter()
            advance(model, st, K)
            times.append(time.perf_counter() - t0)
            cpus.append(time.process_time() - c0)
        finals[nt] = st
        best = min(times)
        cpu = min(cpus)
        st2 = fresh_state(case, model)
        split = [split_passes(model, st2, K) for _ in range(args.repeat)]
        ts = min(x[0] for x in split)
        tb = min(x[1] for x in split)
        row = dict(threads=nt, springs=S, bodies=N, steps=K, best_s=best,
                   runs=" ".join(f"{t:.3f}" for t in times),
                   ns_spring=best / (S * K) * 1e9, ns_body=best / (N * K) * 1e9,
                   cpu_ns_spring=cpu / (S * K) * 1e9,
                   spring_pass_ns=ts / (S * K) * 1e9, body_pass_ns_per_spring=tb / (S * K) * 1e9,
                   body_pass_ns_per_body=tb / (N * K) * 1e9)
        rows.append(row)
        out(f"threads {nt}: {K} steps best {best:.3f} s (runs {row['runs']} s) -> "
            f"{row['ns_spring']:.1f} ns/spring-step, {row['ns_body']:.0f} ns/body-step "
            f"(CPU time {row['cpu_ns_spring']:.1f} ns/spring-step, all threads); "
            f"split: spring pass {row['spring_pass_ns']:.1f} + body pass "
            f"{row['body_pass_ns_per_spring']:.1f} ns/spring-step "
            f"(body pass {row['body_pass_ns_per_body']:.0f} ns/body-step)")

    # bitwise identity across thread counts
    ref_nt = args.threads[0]
    ref = finals[ref_nt]
    moved = float(np.abs(ref.body_pos[:-1] - model.body_pos0[:-1]).max())
    ident = []
    for nt in args.threads[1:]:
        st = finals[nt]
        same = all(np.array_equal(getattr(ref, a), getattr(st, a)) for a in
                   ("body_pos", "body_quat", "body_vel", "body_angmom", "body_wrench"))
        ident.append((nt, same))
        out(f"bitwise identical final state, {ref_nt} vs {nt} threads "
            f"(pos, quat, vel, angmom, body wrenches): {'YES' if same else 'NO'}")
    out(f"max displacement after {K} steps: {moved:.3e} m (non-trivial motion check)")
    return dict(rows=rows, build_s=t_build, first_s=t_first, identical=ident,
                springs=S, bodies=N)


CHILD = """\
import time; t0 = time.perf_counter()
import rbsm_dyn.solvers.explicit as ex
from rbsm_dyn.case import load_case_text
from rbsm_dyn.model import build_model
import sys; sys.path.insert(0, {here!r})
from bench_elastic import case_text, fresh_state
t1 = time.perf_counter()
case = load_case_text(case_text({springs}))
model = build_model(case)
t2 = time.perf_counter()
st = fresh_state(case, model)
ex.advance(model, st, 1)
t3 = time.perf_counter()
print(f"{{t1 - t0:.3f}} {{t2 - t1:.3f}} {{t3 - t2:.3f}} {{model.n_springs}}")
"""


def bench_startup(args, out):
    """Cold (empty cache) and warm (same cache) start of a small case."""
    code = CHILD.format(here=str(HERE), springs=int(args.startup_springs))
    res = {}
    with tempfile.TemporaryDirectory(prefix="numba_cache_") as cache:
        env = dict(os.environ, NUMBA_CACHE_DIR=cache)
        for label in ("cold", "warm", "warm"):
            t0 = time.perf_counter()
            p = subprocess.run([sys.executable, "-c", code], env=env, capture_output=True,
                               text=True)
            wall = time.perf_counter() - t0
            if p.returncode != 0:
                raise RuntimeError(p.stderr)
            imp, build, first, S = p.stdout.split()
            key = label if label not in res else "warm2"
            res[key] = dict(wall=wall, imp=float(imp), build=float(build),
                            first=float(first), springs=int(S))
            out(f"startup {key}: {wall:.2f} s to first step (process wall; import "
                f"{imp} s, build {build} s, state + first step {first} s; {S} springs)")
    return res


def main(argv=None):
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--springs", type=float, default=1.0e6,
                   help="target number of spring points (default 1e6)")
    p.add_argument("--steps", type=int, default=100, help="steps per timed run (default 100)")
    p.add_argument("--threads", type=str, default="1,2",
                   help="comma-separated thread counts (default 1,2)")
    p.add_argument("--repeat", type=int, default=3, help="runs per thread count, best kept")
    p.add_argument("--startup-springs", type=float, default=5000,
                   help="spring target of the cold/warm start case (default 5000)")
    p.add_argument("--no-startup", action="store_true", help="skip cold/warm start")
    p.add_argument("--label", default="", help="tag written with the results (e.g. before/after)")
    p.add_argument("--out", default=str(HERE / "results" / "elastic.txt"),
                   help="results file, appended (default benchmarks/results/elastic.txt); "
                        "'-' for none")
    args = p.parse_args(argv)
    args.springs = int(args.springs)
    args.threads = [int(x) for x in args.threads.split(",")]

    lines = []

    def out(msg):
        print(msg, flush=True)
        lines.append(msg)

    info = machine_info()
    cmd = "python " + " ".join(shlex.quote(a) for a in
                               [os.path.relpath(__file__, Path.cwd())] + sys.argv[1:])
    try:
        rev = subprocess.run(["git", "rev-parse", "--short", "HEAD"], cwd=HERE,
                             capture_output=True, text=True).stdout.strip()
    except OSError:
        rev = "?"
    out(f"=== bench_elastic {info['date']} {args.label}".rstrip())
    out(f"command: {cmd}")
    out(f"machine: {info['cpu']}, {info['cores']} cores; python {info['python']}, "
        f"numba {info['numba']}, numpy {info['numpy']}; git {rev}")
    loop = bench_loop(args, out)
    start = None if args.no_startup else bench_startup(args, out)
    out("")
    if args.out != "-":
        path = Path(args.out)
        path.parent.mkdir(parents=True, exist_ok=True)
        with open(path, "a") as f:
            f.write("\n".join(lines) + "\n")
        csv = path.with_suffix(".csv")
        new = not csv.exists()
        with open(csv, "a") as f:
            if new:
                f.write("date,label,git,threads,springs,bodies,steps,best_s,ns_spring_step,"
                        "ns_body_step,cpu_ns_spring_step,spring_pass_ns,body_pass_ns_per_spring,cold_s,warm_s\n")
            for r in loop["rows"]:
                cold = f"{start['cold']['wall']:.2f}" if start else ""
                warm = f"{start['warm']['wall']:.2f}" if start else ""
                f.write(f"{info['date']},{args.label.replace(',', ';')},{rev},{r['threads']},{r['springs']},"
                        f"{r['bodies']},{r['steps']},{r['best_s']:.4f},{r['ns_spring']:.2f},"
                        f"{r['ns_body']:.1f},{r['cpu_ns_spring']:.2f},{r['spring_pass_ns']:.2f},"
                        f"{r['body_pass_ns_per_spring']:.2f},{cold},{warm}\n")
    return 0


if __name__ == "__main__":
    sys.exit(main())
