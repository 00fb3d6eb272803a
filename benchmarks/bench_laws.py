"""Cost of each spring-law family per spring-point-step, on one mesh.

What it measures (benchmarks/README.md, "bench_laws.py"):

* scene: the bench_elastic.py bar (steel, Voronoi, clamp on face xmin, the
  same initial velocity), one mesh for every family; each family's
  material is built through `load_case_text` -> `build_model` on that mesh.
* families: elastic (elastic kernel), the inelastic kernel with no law
  switched on, plastic (von_mises, normal, mohr_coulomb), rupture (strain,
  softening) and contact (all non-support springs broken before the run).
  A velocity field on top of the bench_elastic one (uniform expansion about
  the centre of the clamp face plus a seeded random velocity per body)
  strains every spring, so that a good share yields or breaks within the
  run; for contact the field compresses (cells move toward the clamp).
  Its end strain (`--strain`) is fixed per run, not per second, so the
  fractions do not depend on the mesh size.
* loop: `rbsm_dyn.solvers.explicit.advance` (compiled time loop) for K
  steps, best of `--repeat`, families and thread counts interleaved in one
  process (A/B: a busy spell hits every family alike).  ns per
  spring-point-step = wall / (S K); ratio to the elastic kernel at the same
  thread count.
* at the end of a run: fraction of springs yielded (state 1), broken and
  open (2), in contact (3), and yielding in the last step.
* identity: the final state (bodies and spring history) compared bitwise
  between thread counts.

    python benchmarks/bench_laws.py                        # >= 1 M springs, 1 and 2 threads
    python benchmarks/bench_laws.py --springs 2e5 --steps 50 --out -
"""
import argparse
import dataclasses
import os
import shlex
import subprocess
import sys
import time
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))
from bench_elastic import case_text, machine_info  # noqa: E402

STEEL = "  steel: {density: 7850, young: 2.0e11, poisson: 0.2}\n"
E_STEEL, RHO_STEEL = 2.0e11, 7850.0


def families(eps, size):
    """(name, material YAML extra keys, field sign, all broken at start).

    Stresses are fractions of σ_T = E·eps, the stress the expansion field
    alone would reach at the end of the run; the softening fracture energy
    puts full break at ~2.5x the peak opening of a spring of length `size`."""
    sig = E_STEEL * eps
    ft = 0.3 * sig
    gf = 1.25 * ft * ft * size / E_STEEL
    return [
        ("elastic", "", 0.0, False),
        ("elastic+field", "", 1.0, False),
        ("inelastic-no-law", "", 1.0, False),
        ("von_mises", f"yield: {{criterion: von_mises, stress: {0.5 * sig:.6g}}}", 1.0, False),
        ("normal", f"yield: {{criterion: normal, stress: {0.5 * sig:.6g}}}", 1.0, False),
        ("mohr_coulomb", f"yield: {{criterion: mohr_coulomb, cohesion: {0.25 * sig:.6g}, "
                         f"friction_angle: 30, tension: {0.5 * sig:.6g}}}", 1.0, False),
        ("rupture-strain", f"rupture: {{strain: {0.5 * eps:.6g}}}", 1.0, False),
        ("rupture-softening", f"rupture: {{fracture_energy: {gf:.6g}, "
                              f"tensile_strength: {ft:.6g}}}", 1.0, False),
        ("contact", f"rupture: {{strain: {0.5 * eps:.6g}}}, friction: 0.5", -2.0, True),
    ]


def family_case(base_text, extra):
    mat = STEEL if not extra else STEEL.replace("}", ", " + extra + "}", 1)
    return base_text.replace(STEEL, mat)


def initial_state(case, model, sign, broken, args, dt):
    """bench_elastic's initial velocity + sign·(expansion field) + jitter."""
    from rbsm_dyn.model import apply_initial, new_state
    st = new_state(model)
    st.dt = dt
    apply_initial(case, model, st)
    n = model.n_bodies
    if sign != 0.0:
        box = np.asarray(case.domain.box, float)
        c = np.array([box[0, 0], 0.5 * (box[0, 1] + box[1, 1]), 0.5 * (box[0, 2] + box[1, 2])])
        rate = args.strain / (args.steps * dt)          # [1/s]: end strain = args.strain
        st.body_vel[:n] += sign * rate * (model.body_pos0[:n] - c)
        vj = args.jitter * args.strain * np.sqrt(E_STEEL / RHO_STEEL)
        rng = np.random.default_rng(args.seed)
        st.body_vel[:n] += vj * rng.standard_normal((n, 3))
    if broken:
        st.spring_state[~model.is_support] = 2
    return st


def fractions(model, st):
    if not model.inelastic:
        return dict(yielded=0.0, open=0.0, contact=0.0, active=0.0)
    s = st.spring_state
    S = len(s)
    return dict(yielded=np.count_nonzero(s == 1) / S, open=np.count_nonzero(s == 2) / S,
                contact=np.count_nonzero(s == 3) / S, active=0.0)


STATE_ARRAYS = ("body_pos", "body_quat", "body_vel", "body_angmom", "body_wrench",
                "spring_state", "spring_dp", "spring_kappa", "spring_dmg", "spring_wp",
                "spring_wf")


def main(argv=None):
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--springs", type=float, default=1.0e6, help="target spring points (1e6)")
    p.add_argument("--steps", type=int, default=100, help="steps per timed run (100)")
    p.add_argument("--threads", default="1,2", help="thread counts (1,2)")
    p.add_argument("--repeat", type=int, default=3, help="runs per family and thread count")
    p.add_argument("--strain", type=float, default=2.0e-4,
                   help="strain of the expansion field at the end of a run (2e-4)")
    p.add_argument("--jitter", type=float, default=0.5,
                   help="random velocity per body, in units of strain·c (0.5)")
    p.add_argument("--seed", type=int, default=1)
    p.add_argument("--only", default="", help="comma-separated family names (default all)")
    p.add_argument("--label", default="")
    p.add_argument("--out", default=str(HERE / "results" / "laws.txt"),
                   help="results file, appended; '-' for none")
    args = p.parse_args(argv)
    args.springs = int(args.springs)
    args.threads = [int(x) for x in args.threads.split(",")]

    import numba
    from rbsm_dyn.case import load_case_text
    from rbsm_dyn.model import build_mesh, build_model
    from rbsm_dyn.solvers.explicit import advance, choose_dt

    lines = []

    def out(msg=""):
        print(msg, flush=True)
        lines.append(msg)

    info = machine_info()
    cmd = "python " + " ".join(shlex.quote(a) for a in
                               [os.path.relpath(__file__, Path.cwd())] + sys.argv[1:])
    rev = subprocess.run(["git", "rev-parse", "--short", "HEAD"], cwd=HERE,
                         capture_output=True, text=True).stdout.strip() or "?"
    dirty = subprocess.run(["git", "status", "--porcelain", "--", "../rbsm_dyn"], cwd=HERE,
                           capture_output=True, text=True).stdout.strip()
    out(f"=== bench_laws {info['date']} {args.label}".rstrip())
    out(f"command: {cmd}")
    out(f"machine: {info['cpu']}, {info['cores']} cores; python {info['python']}, "
        f"numba {info['numba']}, numpy {info['numpy']}; git {rev}"
        + (f" (uncommitted: {' '.join(x.split()[-1] for x in dirty.splitlines())})"
           if dirty else ""))
    try:
        out(f"load average at start: {' '.join(f'{x:.2f}' for x in os.getloadavg())}")
    except OSError:
        pass

    base_text = case_text(args.springs).replace("bench-elastic", "bench-laws")
    assert STEEL in base_text
    size = float(base_text.split("size: ")[1].split(",")[0])
    t0 = time.perf_counter()
    mesh = build_mesh(load_case_text(base_text, "bench_laws.yaml"))
    t_mesh = time.perf_counter() - t0

    fams = families(args.strain, size)
    if args.only:
        keep = set(args.only.split(","))
        fams = [f for f in fams if f[0] in keep or f[0] == "elastic"]
    runs = {}
    base = None
    t_models = []
    for name, extra, sign, broken in fams:
        case = load_case_text(family_case(base_text, extra), f"bench_laws_{name}.yaml")
        t0 = time.perf_counter()
        model = build_model(case, mesh=mesh)
        t_models.append(time.perf_counter() - t0)
        if base is None:
            base = model
            dt, est = choose_dt(case, model)
        else:
            # same mesh and springs: keep one copy of the geometry, swap the law table
            assert np.array_equal(model.spring_k, base.spring_k)
            assert np.array_equal(model.spring_law, base.spring_law)
            assert choose_dt(case, model)[0] == dt
            model = dataclasses.replace(base, law_params=model.law_params,
                                        inelastic=model.inelastic,
                                        spring_state0=model.spring_state0)
        if name == "inelastic-no-law":
            model = dataclasses.replace(model, inelastic=True)
        runs[name] = dict(case=case, model=model, sign=sign, broken=broken, times={},
                          cpus={}, final={}, frac={}, extra=extra)
        del case
    S, N, K = base.n_springs, base.n_bodies, args.steps
    out(f"model: {N} bodies, {S} spring points ({int(base.is_support.sum())} support), "
        f"cell size {size:.4g} m; mesh {t_mesh:.1f} s, build_model {min(t_models):.1f}-"
        f"{max(t_models):.1f} s per family; dt = {dt:.4g} s (estimate {est:.4g}); "
        f"{K} steps")
    out(f"field: expansion to strain {args.strain:g} at step {K} about the clamp-face centre "
        f"(contact: compression to twice that strain), random velocity {args.jitter:g}·strain·c per body "
        f"(seed {args.seed}); on top of bench_elastic's v = (0, 0, -1) m/s, w = (0, 0, 2) rad/s")
    for name, r in runs.items():
        out(f"  {name:18s} {r['extra'] or '(elastic steel)'}"
            + ("; all non-support springs set to state 2 at start" if r["broken"] else ""))

    # first call per kernel: compile or cache load
    t0 = time.perf_counter()
    for name in ("elastic", "von_mises"):
        if name in runs:
            r = runs[name]
            advance(r["model"], initial_state(r["case"], r["model"], r["sign"], r["broken"],
                                              args, dt), 1)
    out(f"first calls (compile / cache load of both kernels): {time.perf_counter() - t0:.2f} s "
        f"(threading layer {numba.threading_layer()})")

    # interleaved A/B: repeat -> family -> threads
    for rep in range(args.repeat):
        for name, r in runs.items():
            for nt in args.threads:
                numba.set_num_threads(nt)
                m = r["model"]
                st = initial_state(r["case"], m, r["sign"], r["broken"], args, dt)
                c0 = time.process_time()
                t0 = time.perf_counter()
                advance(m, st, K)
                t1 = time.perf_counter()
                c1 = time.process_time()
                r["times"].setdefault(nt, []).append(t1 - t0)
                r["cpus"].setdefault(nt, []).append(c1 - c0)
                if rep == 0:
                    # states after K steps; "yielding": return mapping active in step K+1
                    frac = fractions(m, st)
                    if m.inelastic:
                        dp = st.spring_dp.copy()
                        advance(m, st, 1)
                        frac["active"] = np.count_nonzero(
                            np.any(st.spring_dp != dp, axis=1) & (st.spring_state == 1)) / S
                    r["final"][nt] = st
                    r["frac"][nt] = frac
                del st
        out(f"repeat {rep + 1}/{args.repeat} done; load average "
            f"{' '.join(f'{x:.2f}' for x in os.getloadavg())}")

    rows = []
    ela = {nt: min(runs["elastic"]["times"][nt]) for nt in args.threads}
    out("")
    out(f"| family | threads | ns / spring-point-step | ratio to elastic | CPU ns / spring-step | "
        f"runs [s] | yielded | yielding last step | broken open | contact |")
    out("|---|---|---|---|---|---|---|---|---|---|")
    for name, r in runs.items():
        for nt in args.threads:
            best = min(r["times"][nt])
            f = r["frac"][nt]
            row = dict(family=name, threads=nt, springs=S, bodies=N, steps=K, best_s=best,
                       ns=best / (S * K) * 1e9, cpu_ns=min(r["cpus"][nt]) / (S * K) * 1e9,
                       ratio=best / ela[nt], runs=" ".join(f"{t:.3f}" for t in r["times"][nt]),
                       **f)
            rows.append(row)
            out(f"| {name} | {nt} | {row['ns']:.1f} | {row['ratio']:.2f} | {row['cpu_ns']:.1f} | "
                f"{row['runs']} | {f['yielded']:.3f} | {f['active']:.3f} | {f['open']:.3f} | "
                f"{f['contact']:.3f} |")
    out("")
    ref_nt = args.threads[0]
    for name, r in runs.items():
        ref = r["final"][ref_nt]
        for nt in args.threads[1:]:
            st = r["final"][nt]
            diff = [a for a in STATE_ARRAYS if not np.array_equal(getattr(ref, a), getattr(st, a))]
            out(f"bitwise identity {name}, {ref_nt} vs {nt} threads after {K + 1} steps "
                f"(bodies, forces, spring history): "
                + ("YES" if not diff else "NO: " + ", ".join(diff)))
        moved = float(np.abs(ref.body_pos[:N] - base.body_pos0[:N]).max())
        out(f"  {name}: max displacement {moved:.3e} m")
    out("")

    if args.out != "-":
        path = Path(args.out)
        path.parent.mkdir(parents=True, exist_ok=True)
        with open(path, "a") as fh:
            fh.write("\n".join(lines) + "\n")
        csv = path.with_suffix(".csv")
        new = not csv.exists()
        with open(csv, "a") as fh:
            if new:
                fh.write("date,label,git,family,threads,springs,bodies,steps,best_s,"
                         "ns_spring_step,ratio_to_elastic,cpu_ns_spring_step,yielded,"
                         "yielding_last_step,broken_open,contact\n")
            for w in rows:
                fh.write(f"{info['date']},{args.label.replace(',', ';')},{rev},{w['family']},"
                         f"{w['threads']},{w['springs']},{w['bodies']},{w['steps']},"
                         f"{w['best_s']:.4f},{w['ns']:.2f},{w['ratio']:.3f},{w['cpu_ns']:.2f},"
                         f"{w['yielded']:.4f},{w['active']:.4f},{w['open']:.4f},"
                         f"{w['contact']:.4f}\n")
    return 0


if __name__ == "__main__":
    sys.exit(main())
