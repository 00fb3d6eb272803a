"""`python -m rbsm_dyn bench`: time the explicit loop on a Voronoi block.

Builds a steel block 1 × 0.5 × 0.5 m cut into about `--bodies` Voronoi
cells (clamped on xmin, bending and turning from an initial velocity field),
then times `advance(model, state, K)` alone: mesh + model build and the
first call (Numba compile or cache load) are timed and reported apart.
Physics:
  elastic  linear springs (the elastic kernel);
  plastic  von Mises yield at a stress the motion reaches (inelastic kernel);
  full     yield, softening rupture and Coulomb contact on broken faces;
  viscous  linear springs with two Maxwell branches (physics/viscous.py).
--poisson sets the steel's ν (default 0.2; above 0.25 the calibrated rule
adds the Poisson correction's auxiliary stress pass, physics/poisson.py).
Ends with one line (the contract of issue 5):
  bench: bodies=B springs=S steps=K threads=T physics=P ns_per_spring_step=X ns_per_body_step=Y
`--threads` may name `default`: the count a run picks when none is given
(rbsm_dyn/threads.py: one below SERIAL_SPRINGS, else the idle cores).
`--sizes 600,5000,5e4,1e6` times each size in its own process (memory and
start-up apart) with 1 and the default thread count, steps chosen for about
--seconds of loop each, and prints a table: build µs per body, ns per
spring-point-step on 1 and default threads, their ratio, and memory: the
peak resident size (the build's) and the arrays held while stepping (model
and state).  The loop steps the model as a run does, less its mesh's
arrays (Model.without_mesh_arrays; the memory line says how many MiB of
them are still held: 0 unless something keeps the Mesh).
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
    "viscous": (", viscoelastic: {kind: prony, terms: [[5.0e10, 1.0e-5], [5.0e10, 1.0e-4]]}",
                -1.0),
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

    r0 = _rss("VmRSS")
    t0 = time.perf_counter()
    case = load_case_text(case_text(bodies, physics, poisson), "bench.yaml")
    model = build_model(case)
    t_build = time.perf_counter() - t0
    # the model as a run steps it: less the mesh's arrays, which the run
    # releases once the history holds them (cli/run.py, Model.without_mesh_arrays)
    mesh_built = mesh_bytes(model)
    model = model.without_mesh_arrays()
    mesh_held = mesh_bytes(model)
    S, N = model.n_springs, model.n_bodies
    if "default" in threads:
        from .threads import default_threads
        nt_default = default_threads(S, numba.config.NUMBA_NUM_THREADS)
        out(f"default threads for {S} spring points on this machine now: {nt_default}")
        threads = list(dict.fromkeys(nt_default if t == "default" else t for t in threads))
    out(f"model: {N} bodies, {S} spring points, physics {physics} "
        f"({'inelastic' if model.inelastic else 'elastic'} kernel), ν = {poisson}"
        + (f" (Poisson correction on: {len(model.poisson.slot_cell)} cell-neighbour slots)"
           if model.poisson_on else "") + f"; build {t_build:.1f} s")

    # the step once (the stable-step bound passes over every spring three
    # times: not a cost of each round, nor of the first call below)
    dt0, _ = choose_dt(case, model)

    def fresh():
        st = new_state(model)
        st.dt = dt0
        apply_initial(case, model, st)
        start_half_step(model, st)
        return st

    peak = _rss("VmHWM") - r0
    per_body, per_spring, other = footprint(model, fresh())
    t0 = time.perf_counter()
    for nt in threads:
        # one thread runs the serial passes, more the threaded ones
        # (solvers/passes.py Options): each compiled or loaded here
        numba.set_num_threads(nt)
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
    foot = (per_body * N + per_spring * S + other) / 2**20
    out(f"memory: build peak {peak:.0f} MiB (resident size above the {r0:.0f} MiB before it), "
        f"model and state {foot:.0f} MiB = {per_body:.0f} B per body + {per_spring:.0f} B per "
        f"spring point + {other / 2**20:.1f} MiB, mesh arrays held {mesh_held / 2**20:.1f} MiB "
        f"(of {mesh_built / 2**20:.0f} MiB built); build {t_build / N * 1e6:.0f} µs per body")
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


FACE_TABLE = ("face_frame0", "face_k", "face_h", "face_law", "face_ref")


def footprint(model, state):
    """(bytes per body, bytes per spring point, other bytes) of the NumPy
    arrays of a model and its state, by their first dimension (bodies, the
    ground slot included, or spring points; the face table, shared by the
    points of a face, counts with the spring points)."""
    nb_, ns_ = model.n_bodies, model.n_springs
    per = {"body": 0, "spring": 0, "other": 0}
    seen = set()
    for obj in (model, state):
        for v in list(vars(obj).values()) + [getattr(v, "__dict__", {}) for v in
                                              vars(obj).values()]:
            for a in (v.values() if isinstance(v, dict) else [v]):
                if not isinstance(a, np.ndarray) or id(a) in seen:
                    continue
                seen.add(id(a))
                n0 = a.shape[0] if a.ndim else 0
                face = any(a is getattr(model, k) for k in FACE_TABLE)
                kind = ("spring" if face or (n0 in (ns_, ns_ + 1) and ns_ > nb_ + 1) else
                        "body" if n0 in (nb_, nb_ + 1) else "other")
                per[kind] += a.nbytes
    return per["body"] / nb_, per["spring"] / ns_, per["other"]


def mesh_bytes(model):
    """Bytes of the arrays of the model's mesh (0 once a run has released
    them: Model.without_mesh_arrays keeps only the bounds, 48 B)."""
    return sum(v.nbytes for v in vars(model.mesh).values() if isinstance(v, np.ndarray)) \
        if model.mesh is not None else 0


def _rss(key):
    """Resident size [MiB] from /proc/self/status (VmRSS now, VmHWM peak);
    NaN where there is no /proc."""
    try:
        with open("/proc/self/status") as f:
            for line in f:
                if line.startswith(key + ":"):
                    return int(line.split()[1]) / 1024.0
    except OSError:
        pass
    return float("nan")


def sizes(bodies_list, physics, seconds, repeat, out=print):
    """Each size in its own process (`bench --bodies N --threads 1,default`);
    a Markdown table of the rows."""
    import os
    import re
    import subprocess
    rows = []
    pat = {k: re.compile(v) for k, v in {
        "model": r"model: (\d+) bodies, (\d+) spring points.*build ([\d.]+) s",
        "bench": r"bench: .*threads=(\d+) .*ns_per_spring_step=([\d.]+)",
        "mem": r"memory: build peak (\S+) MiB .* model and state (\S+) MiB = (\d+) B per body "
               r"\+ (\d+) B per spring point.*mesh arrays held (\S+) MiB.*; build (\d+)",
        "default": r"default threads for \d+ spring points on this machine now: (\d+)"}.items()}
    for bodies in bodies_list:
        # about `seconds` of loop at ~25 ns per spring-point-step, 37 points per body
        steps = int(min(5000, max(10, seconds / (25e-9 * 37 * bodies))))
        cmd = [sys.executable, "-m", "rbsm_dyn", "bench", "--bodies", str(bodies), "--steps",
               str(steps), "--threads", "1,default", "--physics", physics, "--repeat",
               str(repeat)]
        out(f"$ {' '.join(cmd[1:])}")
        r = subprocess.run(cmd, capture_output=True, text=True, env=os.environ.copy())
        if r.returncode != 0:
            out(f"  failed (exit {r.returncode}): {r.stderr.strip().splitlines()[-1:]}")
            continue
        text = r.stdout
        for line in text.splitlines():
            out("  " + line)
        mm, mem = pat["model"].search(text), pat["mem"].search(text)
        ns = {int(t): float(x) for t, x in pat["bench"].findall(text)}
        nd = int(pat["default"].search(text).group(1))
        rows.append((int(mm.group(1)), int(mm.group(2)), steps, float(mm.group(3)),
                     int(mem.group(6)), ns[1], nd, ns[nd], float(mem.group(1)),
                     float(mem.group(2)), int(mem.group(3)), int(mem.group(4)),
                     float(mem.group(5))))
    out("")
    out("| bodies | spring points | steps | build [s] | build [µs/body] | 1 thread "
        "[ns/spring-step] | default threads | default [ns/spring-step] | default / 1 | "
        "build peak [MiB] | model + state [MiB] | [B/body] + [B/spring point] | "
        "mesh held [MiB] |")
    out("|" + "---|" * 13)
    for (N, S, steps, tb, us, ns1, nd, nsd, peak, foot, pb, ps, mh) in rows:
        out(f"| {N} | {S} | {steps} | {tb:.1f} | {us} | {ns1:.1f} | {nd} | {nsd:.1f} | "
            f"{ns1 / nsd:.2f}x | {peak:.0f} | {foot:.0f} | {pb} + {ps} | {mh:.1f} |")
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
    p.add_argument("--sizes", default=None,
                   help="comma list of body counts, each timed in its own process with 1 and "
                        "the default thread count (e.g. 600,5000,5e4,1e6)")
    p.add_argument("--seconds", type=float, default=2.0,
                   help="with --sizes: about this much loop time per timing (default 2)")
    a = p.parse_args(argv)
    if a.sizes is not None:
        try:
            bodies = [int(float(b)) for b in a.sizes.split(",")]
        except ValueError:
            p.error(f"--sizes: numbers separated by commas (got {a.sizes!r})")
        if min(bodies) < 8:
            p.error("--sizes: each ≥ 8 bodies")
        sizes(bodies, a.physics, a.seconds, a.repeat)
        return 0
    try:
        threads = [t if t == "default" else int(t) for t in a.threads.split(",")]
    except ValueError:
        p.error(f"--threads: integers or 'default' separated by commas (got {a.threads!r})")
    counts = [t for t in threads if t != "default"]
    if a.bodies < 8 or a.steps < 1 or (counts and min(counts) < 1) or a.repeat < 1:
        p.error("--bodies ≥ 8, --steps, --threads and --repeat ≥ 1")
    import numba
    if counts and max(counts) > numba.config.NUMBA_NUM_THREADS:
        p.error(f"--threads {max(counts)} > NUMBA_NUM_THREADS = "
                f"{numba.config.NUMBA_NUM_THREADS}")
    run(int(a.bodies), a.steps, threads, a.physics, a.repeat, poisson=a.poisson)
    return 0


if __name__ == "__main__":
    sys.exit(main())
