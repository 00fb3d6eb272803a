"""rbsm_dyn and Yade side by side on the same elastic problem (issue 5).

    python benchmarks/peer_yade.py                  # k = 1, 2, 4, 8 cells across
    python benchmarks/peer_yade.py --ks 1,2 --repeat 1 --out -

The problem is VERIFICATION D1 as in cases/bar_wave.yaml: a free steel bar
1 m × 20 × 20 mm (E = 200 GPa, ρ = 8000 kg/m³, ν = 0, c0 = √(E/ρ) = 5000 m/s),
its first layer of cells pushed in x at v = 1 m/s from t = 0, end time
1.6e-4 s.  Resolution k = cells across the section: cubes of side h = 20/k mm,
50k × k × k cells (the case file itself uses 200 × 1 × 1 non-cubic blocks,
which a sphere lattice cannot copy).

* rbsm_dyn: the blocks mesh, through the Python API (load_case_text →
  build_model → the explicit solver's start as in solvers/explicit.run, then
  one `advance(model, state, n)` call, which is the compiled time loop).
  Its own stable step: 0.8 × model.stable_dt().
* Yade (benchmarks/peer_yade_bar.py, a subprocess under `yade -n -x -j1`):
  spheres of radius h/2 at the same centroids, cohesive bonds to the 6
  nearest neighbours, stiffnesses chosen so that each bond is the rbsm_dyn
  face (normal, shear, bending, twist), the same mass and rotational inertia
  per body, no damping.  Its own stable step: GlobalStiffnessTimeStepper
  with safety 0.8.  The formulas are in that script.

Both on one thread (NUMBA_NUM_THREADS=1; OMP_NUM_THREADS=1 and -j1 for
Yade).  Per code and resolution: bodies, bonds (spring points / interactions),
steps, dt, wall and CPU time of the time loop only (best of --repeat; mesh or
scene build, Numba compile and Yade start-up excluded), ns per body-step, and
the error against the closed form:

* arrival: time at which the mean x velocity of the probe layer (centroids at
  x = 0.5 + h/2, 0.5 m from the driver layer's) first reaches v/2, against
  0.5 m / c0 = 1.0e-4 s (VERIFICATION D1, tests/test_dynamics.py);
* plateau: mean over t ≥ 2e-5 s of the reaction of the driven layer over the
  section, against ρ c0 v = 40 MPa (cases/bar_wave.yaml; a step in velocity
  v carries the stress ρ c0 v, VERIFICATION D2's σ = ρ c0 v/2 is this with
  v/2 at the interface).  The wave reflected at the free end comes back to
  the driver only at 2L/c0 = 4e-4 s, after the end.

Writes benchmarks/results/peer_yade.md (or --out) and prints the same.
Skips with a message (exit 0) when yade is not installed: the comparison is a
benchmark, not a dependency.
"""
import os

os.environ["NUMBA_NUM_THREADS"] = "1"   # before numba is imported
os.environ["OMP_NUM_THREADS"] = "1"

import argparse  # noqa: E402
import datetime  # noqa: E402
import json  # noqa: E402
import platform  # noqa: E402
import shlex  # noqa: E402
import shutil  # noqa: E402
import subprocess  # noqa: E402
import sys  # noqa: E402
import tempfile  # noqa: E402
import time  # noqa: E402
from pathlib import Path  # noqa: E402

import numpy as np  # noqa: E402

HERE = Path(__file__).resolve().parent
E, RHO, L, B, V, END = 200.0e9, 8000.0, 1.0, 0.02, 1.0, 1.6e-4   # cases/bar_wave.yaml
C0 = np.sqrt(E / RHO)                  # VERIFICATION D1: bar speed 5000 m/s
SIGMA = RHO * C0 * V                   # cases/bar_wave.yaml: stress behind the front, 40 MPa
DIST = 0.5                             # probe layer centroid − driver layer centroid [m]
T_PLATEAU = 2.0e-5                     # start of the plateau window [s]

CASE = """\
name: bar-wave-peer
description: VERIFICATION D1 on cubic blocks, {k} across (benchmarks/peer_yade.py).
domain: {{box: [[0, 0, 0], [{L}, {B}, {B}]]}}
mesh: {{kind: blocks, divisions: [{nx}, {k}, {k}]}}
materials:
  steel: {{density: {RHO}, young: {E}, poisson: 0.0}}
groups:
  driver: {{box: [[-1, -1, -1], [{h}, 1, 1]]}}
  mid: {{box: [[0.5, -1, -1], [{mid_hi}, 1, 1]]}}
boundary: [{{group: driver, velocity: [{V}, null, null]}}]
solver: {{mode: dynamic, end_time: {END}, dt_safety: 0.8}}
"""


def arrival_time(t, v):
    """First time the probe velocity reaches v/2, linear between samples
    (as tests/test_dynamics.py::test_D1_bar_wave_arrival)."""
    t, v = np.asarray(t), np.asarray(v)
    i = int(np.argmax(v >= 0.5 * V))
    if v[i] < 0.5 * V or i == 0:
        return float("nan")
    return float(t[i - 1] + (t[i] - t[i - 1]) * (0.5 * V - v[i - 1]) / (v[i] - v[i - 1]))


def errors(res):
    t_arr = arrival_time(res["t_vel"], res["mid_vx"])
    tf = np.asarray(res["t_force"])
    stress = np.asarray(res["driver_fx"]) / (B * B)
    plateau = float(stress[tf >= T_PLATEAU].mean())
    return dict(arrival=t_arr, arrival_err=t_arr / (DIST / C0) - 1.0,
                plateau=plateau, plateau_err=plateau / SIGMA - 1.0)


def run_rbsm(k, repeat, budget):
    from rbsm_dyn.case import load_case_text
    from rbsm_dyn.model import apply_initial, build_model, new_state
    from rbsm_dyn.solvers.explicit import advance, choose_dt, start_half_step

    h = B / k
    nx = int(round(L / h))
    text = CASE.format(k=k, L=L, B=B, nx=nx, RHO=RHO, E=E, h=h, mid_hi=0.5 + h, V=V, END=END)
    case = load_case_text(text, "peer_yade_bar.yaml")
    model = build_model(case)

    def fresh():
        # the start of rbsm_dyn.solvers.explicit.run, without the recorder
        st = new_state(model)
        st.dt, _ = choose_dt(case, model)
        apply_initial(case, model, st)
        start_half_step(model, st)
        return st

    st = fresh()
    dt = st.dt
    n_steps = int(np.ceil(END / dt - 1e-9))       # as solvers/explicit.run
    advance(model, st, 1)                         # Numba compile / cache load, not timed
    loops, cpus = [], []
    for r in range(repeat):
        if r > 0 and sum(loops) > budget:
            break
        st = fresh()
        c0 = time.process_time()
        t0 = time.perf_counter()
        advance(model, st, n_steps)
        loops.append(time.perf_counter() - t0)
        cpus.append(time.process_time() - c0)
    # probe run (not timed), one step per call: after step n, body_vel is
    # v(n − 1/2) and body_reaction the reaction at t(n − 1)
    mid, drv = model.groups["mid"], model.groups["driver"]
    st = fresh()
    probe = {"t_vel": [], "mid_vx": [], "t_force": [], "driver_fx": []}
    for n in range(1, n_steps + 1):
        advance(model, st, 1)
        probe["t_vel"].append((n - 0.5) * dt)
        probe["mid_vx"].append(float(st.body_vel[mid, 0].mean()))
        probe["t_force"].append((n - 1) * dt)
        probe["driver_fx"].append(float(st.body_reaction[drv, 0].sum()))
    x = model.body_pos0[:, 0]
    assert abs(x[mid].mean() - x[drv].mean() - DIST) < 1e-9 * L
    return dict(code="rbsm_dyn", k=k, h=h, bodies=int(model.n_bodies),
                bonds=int(model.n_springs), dt=dt, steps=n_steps, loops=loops, cpus=cpus,
                **probe)


def run_yade(k, repeat, budget, yade, dt=None):
    with tempfile.TemporaryDirectory() as tmp:
        par, out = Path(tmp) / "params.json", Path(tmp) / "out.json"
        par.write_text(json.dumps(dict(k=k, repeat=repeat, budget=budget, dt=dt)))
        env = dict(os.environ, OMP_NUM_THREADS="1")
        cmd = [yade, "-n", "-x", "-j1", str(HERE / "peer_yade_bar.py"), str(par), str(out)]
        p = subprocess.run(cmd, env=env, capture_output=True, text=True, cwd=tmp)
        if p.returncode != 0 or not out.exists():
            raise RuntimeError(f"yade failed ({p.returncode}):\n{p.stdout[-2000:]}\n{p.stderr[-2000:]}")
        res = json.loads(out.read_text())
    assert abs(res["x_mid"] - res["x_driver"] - DIST) < 1e-9 * L
    res["bonds"] = res.pop("interactions")
    return res


def git_rev():
    try:
        rev = subprocess.run(["git", "rev-parse", "--short", "HEAD"], cwd=HERE, capture_output=True,
                             text=True).stdout.strip()
        dirty = subprocess.run(["git", "status", "--porcelain", "--", "rbsm_dyn"], cwd=HERE.parent,
                               capture_output=True, text=True).stdout.strip()
        return rev + (" (rbsm_dyn modified)" if dirty else "")
    except OSError:
        return "?"


def machine():
    cpu = platform.processor() or "?"
    try:
        for line in subprocess.run(["lscpu"], capture_output=True, text=True).stdout.splitlines():
            if line.startswith("Model name"):
                cpu = line.split(":", 1)[1].strip()
    except OSError:
        pass
    return cpu


def yade_version(yade):
    out = subprocess.run([yade, "--version"], capture_output=True, text=True).stdout
    for line in out.splitlines():
        if "version" in line.lower():
            return line.split(":", 1)[-1].strip()
    return out.strip() or "?"


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--ks", default="1,2,4,8", help="cells across the 20 mm section (comma list)")
    ap.add_argument("--repeat", type=int, default=3, help="timed runs per code and resolution (best)")
    ap.add_argument("--budget", type=float, default=20.0,
                    help="no further timed repeat once the timed runs took this long [s]")
    ap.add_argument("--same-dt-max-k", type=int, default=4,
                    help="for k up to this, also run Yade (untimed) at rbsm_dyn's dt: the two "
                         "discrete systems are the same, so the errors should then agree")
    ap.add_argument("--yade", default="yade", help="yade executable")
    ap.add_argument("--out", default=str(HERE / "results" / "peer_yade.md"),
                    help="markdown file to write, '-' for none")
    args = ap.parse_args(argv)
    command = "python " + " ".join(shlex.quote(a) for a in
                                   ["benchmarks/peer_yade.py", *(sys.argv[1:] if argv is None else argv)])
    yade = shutil.which(args.yade)
    if yade is None:
        print(f"peer_yade: '{args.yade}' not found: skipping the Yade comparison "
              "(Debian/Ubuntu: apt-get install yade).")
        return 0
    ks = [int(s) for s in args.ks.split(",")]
    import numba

    t_start = time.perf_counter()
    rows, checks = [], []
    for k in ks:
        for name, fn in (("rbsm_dyn", lambda: run_rbsm(k, args.repeat, args.budget)),
                         ("yade", lambda: run_yade(k, args.repeat, args.budget, yade))):
            t0 = time.perf_counter()
            res = fn()
            res.update(errors(res))
            res["loop"] = min(res["loops"])
            res["cpu"] = min(res["cpus"]) if res.get("cpus") else float("nan")
            res["ns_body_step"] = res["loop"] / (res["bodies"] * res["steps"]) * 1e9
            res["cpu_ns_body_step"] = res["cpu"] / (res["bodies"] * res["steps"]) * 1e9
            rows.append(res)
            print(f"{name:8s} k={k}: {res['bodies']} bodies, {res['steps']} steps, "
                  f"loop {res['loop']:.3f} s ({len(res['loops'])} runs: "
                  f"{' '.join(f'{x:.3f}' for x in res['loops'])}), "
                  f"{res['ns_body_step']:.0f} ns/body-step, arrival {100 * res['arrival_err']:+.3f} %, "
                  f"plateau {100 * res['plateau_err']:+.3f} % [{time.perf_counter() - t0:.1f} s]",
                  flush=True)
        if k <= args.same_dt_max_k:
            rr = rows[-2]
            res = run_yade(k, 0, 0.0, yade, dt=rr["dt"])
            res.update(errors(res))
            checks.append((rr, res))
            print(f"  check k={k}: yade at rbsm_dyn's dt {rr['dt']:.4g} s: arrival "
                  f"{100 * res['arrival_err']:+.4f} % (rbsm_dyn {100 * rr['arrival_err']:+.4f} %), "
                  f"plateau {100 * res['plateau_err']:+.4f} % ({100 * rr['plateau_err']:+.4f} %)",
                  flush=True)

    lines = [
        "# rbsm_dyn and Yade on the VERIFICATION D1 bar wave",
        "",
        f"Command: `{command}` (total {time.perf_counter() - t_start:.0f} s)  ",
        f"Date: {datetime.datetime.now().isoformat(timespec='seconds')}; "
        f"git {git_rev()}; machine: {machine()}, {os.cpu_count()} cores  ",
        f"rbsm_dyn: Python {platform.python_version()}, Numba {numba.__version__} "
        f"(NUMBA_NUM_THREADS=1); Yade {yade_version(yade)} (Debian package, `yade -n -x -j1`, "
        "OMP_NUM_THREADS=1)",
        "",
        "Bar 1 m × 20 × 20 mm, E = 200 GPa, ρ = 8000 kg/m³, ν = 0 (c0 = 5000 m/s); first layer "
        "pushed at 1 m/s; end 1.6e-4 s.  k cells across → cubes of h = 20/k mm, 50k × k × k "
        "bodies.  Yade: bonded spheres (CohFrictMat, Law2_ScGeom6D_CohFrictPhys_CohesionMoment) "
        "at the same centres, bond = rbsm_dyn face (kn = ks = E h, kr = E h³/12, ktw = E h³/6), "
        "same mass and inertia, no damping.  Each code at its own stable step (×0.8).",
        "",
        "Loop = wall time of the time loop only (best of the runs; build, compile, start-up "
        "excluded; CPU = process time, the steadier figure on a shared machine); ns/body-step = "
        "loop / (bodies · steps).  Arrival = error of the time the "
        "probe layer's mean velocity reaches v/2, against 0.5 m / c0 = 1.0e-4 s; plateau = "
        "error of the driven layer's mean reaction stress for t ≥ 2e-5 s against ρ c0 v = 40 MPa.",
        "",
        "| code | k across | h mm | bodies | spring points / bonds | steps | dt s | loop wall s | loop CPU s "
        "| ns / body-step | CPU ns / body-step | arrival error | plateau error |",
        "|---|---|---|---|---|---|---|---|---|---|---|---|---|",
    ]
    for r in rows:
        lines.append(
            f"| {r['code']} | {r['k']} | {1e3 * r['h']:g} | {r['bodies']} | {r['bonds']} | "
            f"{r['steps']} | {r['dt']:.4g} | {r['loop']:.4f} | {r['cpu']:.4f} | "
            f"{r['ns_body_step']:.0f} | {r['cpu_ns_body_step']:.0f} | {100 * r['arrival_err']:+.3f} % | "
            f"{100 * r['plateau_err']:+.3f} % |")
    lines += ["", "Time to solution, Yade / rbsm_dyn (loop wall): " + ", ".join(
        f"k = {k}: {yr['loop'] / rr['loop']:.2f}" for k in ks
        for rr in rows if rr["code"] == "rbsm_dyn" and rr["k"] == k
        for yr in rows if yr["code"] == "yade" and yr["k"] == k) + "; per body-step: " + ", ".join(
        f"k = {k}: {yr['ns_body_step'] / rr['ns_body_step']:.2f}" for k in ks
        for rr in rows if rr["code"] == "rbsm_dyn" and rr["k"] == k
        for yr in rows if yr["code"] == "yade" and yr["k"] == k) + ".",
        ""]
    if checks:
        lines += [
            "Same discrete system? Yade rerun (untimed) at rbsm_dyn's dt: the errors should agree "
            "to round-off if the bonds, masses and inertias match.",
            "",
            "| k across | dt s | arrival, rbsm_dyn | arrival, Yade | arrival time, Yade − rbsm_dyn s "
            "| plateau, rbsm_dyn | plateau, Yade |",
            "|---|---|---|---|---|---|---|"]
        lines += [f"| {r['k']} | {r['dt']:.4g} | {100 * r['arrival_err']:+.4f} % | "
                  f"{100 * y['arrival_err']:+.4f} % | {y['arrival'] - r['arrival']:+.2e} | "
                  f"{100 * r['plateau_err']:+.4f} % | "
                  f"{100 * y['plateau_err']:+.4f} % |" for r, y in checks]
        lines += [""]
    lines += [
        f"Load average at the end: {' '.join(f'{x:.2f}' for x in os.getloadavg())} "
        f"(2 shared cores: timings move by ±20 %)."]
    text = "\n".join(lines) + "\n"
    print()
    print(text)
    if args.out != "-":
        Path(args.out).parent.mkdir(parents=True, exist_ok=True)
        Path(args.out).write_text(text, encoding="utf-8")
        print(f"written {args.out}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
