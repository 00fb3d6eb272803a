"""`python -m rbsm_dyn bench`: time the explicit loop on a Voronoi block.

Builds a steel block 1 × 0.5 × 0.5 m cut into about `--bodies` Voronoi
cells (clamped on xmin, bending and turning from an initial velocity field),
then times `advance(model, state, K)` alone: mesh + model build and the
first call (Numba compile or cache load) are timed and reported apart.
Physics:
  elastic  linear springs (the elastic kernel);
  plastic  von Mises yield at a stress the motion reaches (inelastic kernel);
  full     yield, softening rupture and Coulomb contact on broken faces.
--poisson sets the steel's ν (default 0.2; above 0.25 the calibrated rule
adds the Poisson correction's auxiliary stress pass, physics/poisson.py).
Ends with one line (the contract of issue 5):
  bench: bodies=B springs=S steps=K threads=T physics=P ns_per_spring_step=X ns_per_body_step=Y
"""
import argparse
import sys
import time

import numpy as np

CASE = """\
name: bench
units: SI
domain: {{box: [[0, 0, 0], [1.0, 0.5, 0.5]]}}
mesh: {{kind: voronoi, size: {size:.6g}, seed: 1}}
materials:
  steel: {{density: 7850, young: 2.0e11, poisson: {poisson!r}{law}}}
boundary: [{{face: xmin, fix: all}}]
initial: [{{velocity: [0.0, 0.0, {v}], angular_velocity: [0.0, 0.0, 2.0]}}]
solver: {{mode: dynamic, end_time: 1.0e-3}}
"""
# laws chosen so that springs yield / break within the first steps
LAWS = {
    "elastic": ("", -1.0),
    "plastic": (", yield: {criterion: von_mises, stress: 2.0e6}", -20.0),
    "full": (", yield: {criterion: von_mises, stress: 2.0e6}, "
             "rupture: {fracture_energy: 0.5, tensile_strength: 5.0e5}, friction: 0.5", -20.0),
}


def case_text(bodies, physics, poisson=0.2):
    size = (1.0 * 0.5 * 0.5 / max(bodies, 8)) ** (1.0 / 3.0)
    law, v = LAWS[physics]
    return CASE.format(size=size, law=law, v=v, poisson=poisson)


def headroom(threads):
    """Speed-up of a trivial, perfectly parallel loop at `threads` threads
    against 1: what the machine gives right now (a shared machine gives less
    than its core count), to read the kernel's thread scaling against."""
    import numba

    @numba.njit(parallel=True, cache=False)
    def work(n, out):
        for g in numba.prange(out.shape[0]):
            acc = 0.0
            for i in range(n):
                acc += np.sin(i * 1e-3 + g)
            out[g] = acc

    out = np.zeros(4 * threads)
    times = {1: float("inf"), threads: float("inf")}
    work(10, out)
    for _ in range(3):
        for nt in (1, threads):
            numba.set_num_threads(nt)
            t0 = time.perf_counter()
            work(2_000_000, out)
            times[nt] = min(times[nt], time.perf_counter() - t0)
    return times[1] / times[threads]


def run(bodies, steps, threads, physics, repeat=3, out=print, poisson=0.2):
    """Build, warm up, time for each thread count in `threads` (one model);
    returns a list of dicts of the figures."""
    import numba

    from .case import load_case_text
    from .model import apply_initial, build_model, new_state
    from .solvers.explicit import advance, choose_dt, start_half_step

    t0 = time.perf_counter()
    case = load_case_text(case_text(bodies, physics, poisson), "bench.yaml")
    model = build_model(case)
    t_build = time.perf_counter() - t0
    S, N = model.n_springs, model.n_bodies
    out(f"model: {N} bodies, {S} spring points, physics {physics} "
        f"({'inelastic' if model.inelastic else 'elastic'} kernel), ν = {poisson}"
        + (f" (Poisson correction on: {len(model.poisson.slot_cell)} cell-neighbour slots)"
           if model.poisson_on else "") + f"; build {t_build:.1f} s")

    def fresh():
        st = new_state(model)
        st.dt, _ = choose_dt(case, model)
        apply_initial(case, model, st)
        start_half_step(model, st)
        return st

    t0 = time.perf_counter()
    advance(model, fresh(), 1)
    t_first = time.perf_counter() - t0
    out(f"first call (compile or cache load): {t_first:.2f} s ({numba.threading_layer()} "
        f"threading layer)")
    walls, cpus, finals = _time_rounds(model, fresh, advance, steps, threads, repeat)
    rows = []
    for nt in threads:
        row = _report(model, finals[nt], steps, nt, physics, walls[nt], cpus[nt], out)
        row.update(build=t_build, first=t_first)
        rows.append(row)
    if len(threads) > 1:
        t1 = threads[0]
        for nt in threads[1:]:
            out(f"speed-up {nt} vs {t1} threads: {min(walls[t1]) / min(walls[nt]):.2f}x (best), "
                f"{np.median(walls[t1]) / np.median(walls[nt]):.2f}x (median of {repeat})")
    if max(threads) > 1:
        out(f"machine headroom: a trivial parallel loop runs {headroom(max(threads)):.2f}x "
            f"faster on {max(threads)} threads than on 1 right now")
    for nt in threads[1:]:
        same = all(np.array_equal(getattr(finals[threads[0]], k), getattr(finals[nt], k))
                   for k in ("body_pos", "body_quat", "body_vel", "body_angmom"))
        out(f"final state {threads[0]} vs {nt} threads bitwise identical: {'yes' if same else 'NO'}")
    return rows


def _time_rounds(model, fresh, advance, steps, threads, repeat):
    """Wall and CPU times of `repeat` rounds; each round times every thread
    count once, in turn, so that a shared machine's slow spells hit all
    thread counts alike (a spell lasts seconds to minutes)."""
    import numba

    walls = {nt: [] for nt in threads}
    cpus = {nt: [] for nt in threads}
    finals = {}
    for _ in range(repeat):
        for nt in threads:
            numba.set_num_threads(nt)
            st = fresh()
            c0 = time.process_time()
            w0 = time.perf_counter()
            advance(model, st, steps)
            walls[nt].append(time.perf_counter() - w0)
            cpus[nt].append(time.process_time() - c0)
            finals[nt] = st
    return walls, cpus, finals


def _report(model, st, steps, threads, physics, walls, cpus, out):
    S, N = model.n_springs, model.n_bodies
    best = min(walls)
    cpu = min(cpus)
    ns_s = best / (S * steps) * 1e9
    ns_b = best / (N * steps) * 1e9
    out(f"loop: {threads} thread(s), best of {len(walls)}: {best:.3f} s wall "
        f"(median {np.median(walls):.3f} s), {cpu:.3f} s CPU (all threads) "
        f"= {cpu / (S * steps) * 1e9:.1f} CPU ns/spring-step")
    broken = int((st.spring_state >= 2).sum()) if model.inelastic else 0
    yielded = int((st.spring_state == 1).sum()) if model.inelastic else 0
    if model.inelastic:
        out(f"springs at the end: {yielded} yielded, {broken} broken")
    out(f"bench: bodies={N} springs={S} steps={steps} threads={threads} physics={physics} "
        f"ns_per_spring_step={ns_s:.1f} ns_per_body_step={ns_b:.0f}")
    return dict(bodies=N, springs=S, steps=steps, threads=threads, physics=physics,
                wall=best, wall_median=float(np.median(walls)), cpu=cpu, ns_spring=ns_s,
                ns_body=ns_b, yielded=yielded, broken=broken)


def main(argv=None):
    p = argparse.ArgumentParser(prog="python -m rbsm_dyn bench", description=__doc__.splitlines()[0])
    p.add_argument("--bodies", type=float, default=3.0e4,
                   help="Voronoi cells (default 3e4: about 1.1 M spring points)")
    p.add_argument("--steps", type=int, default=100, help="timed steps (default 100)")
    p.add_argument("--threads", default="1",
                   help="Numba threads, or a comma list timed on one model (default 1)")
    p.add_argument("--physics", choices=sorted(LAWS), default="elastic")
    p.add_argument("--poisson", type=float, default=0.2,
                   help="ν of the steel (default 0.2: the α table, no correction; "
                        "above 0.25 the Poisson correction runs, physics/poisson.py)")
    p.add_argument("--repeat", type=int, default=3, help="timed rounds (each times every thread count once), best kept (default 3)")
    a = p.parse_args(argv)
    try:
        threads = [int(t) for t in a.threads.split(",")]
    except ValueError:
        p.error(f"--threads: integers separated by commas (got {a.threads!r})")
    if a.bodies < 8 or a.steps < 1 or min(threads) < 1 or a.repeat < 1:
        p.error("--bodies ≥ 8, --steps, --threads and --repeat ≥ 1")
    import numba
    if max(threads) > numba.config.NUMBA_NUM_THREADS:
        p.error(f"--threads {max(threads)} > NUMBA_NUM_THREADS = "
                f"{numba.config.NUMBA_NUM_THREADS}")
    run(int(a.bodies), a.steps, threads, a.physics, a.repeat, poisson=a.poisson)
    return 0


if __name__ == "__main__":
    sys.exit(main())
