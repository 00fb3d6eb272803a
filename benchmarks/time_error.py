"""Run time against error: four verification problems at several cell sizes.

What it measures (benchmarks/README.md, "time_error.py"):

* problems, each a copy of a shipped case with the cell size substituted
  (the same edits the tests make, tests/test_statics.py, test_dynamics.py,
  test_plastic.py), blocks of size h in x and z:
  - A2  cases/cantilever_static.yaml, tip deflection by dynamic relaxation
        against δ = P x³/(3EI) + P x/(κGA) (VERIFICATION A2);
  - D1  cases/bar_wave.yaml, arrival of the half-velocity front at the
        mid-length cells against (x_mid − x_driver)/c0 (VERIFICATION D1);
  - C1  cases/impulsive_beam.yaml (pins, von_mises), final midspan
        deflection W_f and response time T against rigid-plastic theory
        (VERIFICATION C1), at E/σ0 = 10⁴ as the tests use (VERIFICATION C3);
  - C2  the same beam with sliding clamps and normal-only yield, as in
        tests/test_plastic.py (VERIFICATION C2).
* route: the CLI's (rbsm_dyn/cli/run.py): load_case_text -> build_model
  (timed apart: "build") -> Recorder -> solvers.explicit.run or
  solvers.relax.run, whose own wall time (time loop, or load steps incl.
  the elastic predictor, with output frames; no mesh build) is "wall";
  CPU time of the process beside it.  History read back with
  rbsm_dyn.open_history.
* Numba: 1 thread (numba.set_num_threads, --threads); the smallest size of
  each problem is run once first (compile or cache load, timed apart).
  Runs under 2 s are repeated (best of 3 wall times).
* output: results/time_error.md (tables, fitted rates, machine, command),
  results/time_error.csv, results/time_error.png (wall against |error|).

    python benchmarks/time_error.py                       # all four, ~10 min
    python benchmarks/time_error.py --quick --out /tmp/te # smallest sizes only
    python benchmarks/time_error.py --problems A2,D1
    python benchmarks/time_error.py --replot              # PNG from the CSV, no runs
"""
import argparse
import csv
import os
import shlex
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
CASES = HERE.parent / "cases"
sys.path.insert(0, str(HERE))
from bench_elastic import machine_info  # noqa: E402

# cells through the depth per problem (cubic-in-x-z blocks of size h); the
# first QUICK[p] sizes make the --quick smoke run
SIZES = {"A2": (1, 2, 4, 8, 16),            # nx = 10 nz, h = 0.1 / nz
         "D1": (50, 100, 200, 400, 800, 1600),    # nx along the bar, h = 1 / nx
         "C1": (2, 3, 4, 6, 8),             # nx = 20 nz, h = 0.01 / nz
         "C2": (2, 3, 4, 6, 8)}
QUICK = {"A2": 3, "D1": 3, "C1": 2, "C2": 2}
FLOOR_FACTOR = 10.0      # A2 rate: fit only errors ≥ this × the nonlinear/tolerance floor
REPEAT_BELOW = 2.0       # s: runs shorter than this are repeated, best of 3 kept

# the shipped cases' data (asserted present in the texts below)
E_STEEL, RHO = 200.0e9, 8000.0
# A2: L = 1, b = h = 0.1, P = 10 kN, ν = 0 (cases/cantilever_static.yaml)
A2_P, A2_B, A2_H = 1.0e4, 0.1, 0.1
# D1: velocity step v = 1 m/s at xmin of a 1 m bar (cases/bar_wave.yaml)
D1_V = 1.0
# C: b = H = 0.01, half span L = 0.1, V0 = 14 m/s, σ0 = 100 MPa (cases/impulsive_beam.yaml)
C_YOUNG = 1000.0e9       # E/σ0 = 10⁴ (VERIFICATION C3; tests/test_plastic.py)
C_B = C_H = 0.01
C_L, C_V0, C_SIG0 = 0.1, 14.0, 100.0e6
C_M = RHO * C_B * C_H                 # m = ρ b H (VERIFICATION C)
C_MP = C_SIG0 * C_B * C_H ** 2 / 4    # Mp = σ0 b H²/4 (VERIFICATION C)


def sub(text, old, new):
    """text.replace(old, new), insisting that `old` is there (a shipped case
    that changed must not silently give a different benchmark)."""
    if old not in text:
        raise SystemExit(f"time_error.py: the shipped case no longer contains {old!r}; "
                         "update the substitution")
    return text.replace(old, new)


def shipped(name):
    return (CASES / name).read_text(encoding="utf-8")


# ------------------------------------------------------------- case texts
def a2_case(nz):
    """cases/cantilever_static.yaml at nx × 1 × nz blocks, nx = 10 nz; the
    tip group is the last layer of cells (as tests/test_statics.py)."""
    nx = 10 * nz
    t = shipped("cantilever_static.yaml")
    t = sub(t, "divisions: [40, 1, 4]", f"divisions: [{nx}, 1, {nz}]")
    t = sub(t, "tip: {box: [[0.975, -1, -1]", f"tip: {{box: [[{1.0 - 1.0 / nx!r}, -1, -1]")
    return t, 0.1 / nz


def d1_case(nx, every_step=False):
    """cases/bar_wave.yaml at nx × 1 × 1 blocks: the driver is the first
    cell, the probe the two cells either side of x = 0.5 (as shipped at
    nx = 200); probes only (no fields).  Timed run: frames every 10 µs.
    Error run (every_step): a frame at every step, so that the crossing is
    read within one step (at 1 µs frames, as shipped, linear interpolation
    across the steep front moves the error by ~10 % of itself at h = 1.25 mm),
    ending at 0.12 ms (the front passes the probe at 0.1 ms)."""
    h = 1.0 / nx
    t = shipped("bar_wave.yaml")
    t = sub(t, "divisions: [200, 1, 1]", f"divisions: [{nx}, 1, 1]")
    t = sub(t, "driver: {box: [[-1, -1, -1], [0.005, 1, 1]]}",
            f"driver: {{box: [[-1, -1, -1], [{h!r}, 1, 1]]}}")
    t = sub(t, "mid: {box: [[0.495, -1, -1], [0.505, 1, 1]]}",
            f"mid: {{box: [[{0.5 - h!r}, -1, -1], [{0.5 + h!r}, 1, 1]]}}")
    t = sub(t, "fields: [position, velocity]", "fields: []")
    if every_step:
        t = sub(t, "interval: 1.0e-6", "interval: 1.0e-12")   # out_every = 1
        t = sub(t, "end_time: 1.6e-4", "end_time: 1.2e-4")
    else:
        t = sub(t, "interval: 1.0e-6", "interval: 1.0e-5")
    return t, h


def a2_linear(nz):
    """The A2 text solved by `solver.mode: linear` (Kawai's assembled K,
    small deflection): separates the discretisation error from the
    geometric nonlinearity that dynamic relaxation (finite rotation) keeps."""
    t, h = a2_case(nz)
    return sub(t, "solver: {mode: static, load_steps: 2, tolerance: 1.0e-6}",
               "solver: {mode: linear}"), h


def c_case(nz, clamped):
    """cases/impulsive_beam.yaml at 20 nz × 1 × nz blocks with E = 1000 GPa;
    C2: sliding clamps (z, ry held) on the end cells, normal-only yield,
    end time 1.6 ms (tests/test_plastic.py::impulsive).  The mid group is
    the two cells either side of midspan at every size (as shipped)."""
    h = C_H / nz
    t = shipped("impulsive_beam.yaml")
    t = sub(t, "divisions: [80, 1, 4]", f"divisions: [{20 * nz}, 1, {nz}]")
    t = sub(t, "young: 200.0e9", f"young: {C_YOUNG!r}")
    t = sub(t, "mid: {box: [[0.0975, -1, -1], [0.1025, 1, 1]]}",
            f"mid: {{box: [[{C_L - h!r}, -1, -1], [{C_L + h!r}, 1, 1]]}}")
    t = sub(t, "fields: [position, orientation, spring_state]", "fields: []")
    if clamped:
        t = sub(t, "criterion: von_mises", "criterion: normal")
        t = sub(t, "  - {face: xmin, fix: [z]}\n  - {face: xmax, fix: [z]}\n",
                "  - {group: left, fix: [z, ry]}\n  - {group: right, fix: [z, ry]}\n")
        t = sub(t, "groups:\n", f"groups:\n  left: {{box: [[-1, -1, -1], [{h!r}, 1, 1]]}}\n"
                                f"  right: {{box: [[{2 * C_L - h!r}, -1, -1], [1, 1, 1]]}}\n")
        t = sub(t, "end_time: 3.0e-3", "end_time: 1.6e-3")
    return t, h


# ----------------------------------------------------------------- running
def run_text(text, out, threads):
    """The CLI's path (rbsm_dyn/cli/run.py::_run) without the progress bar:
    returns (model, solver result, build s, wall s, cpu s, History).  Wall s
    is the solver's own figure: `wall_time` of explicit.run / relax.run (no
    build), assembly + solve of linear.run."""
    import rbsm_dyn
    from rbsm_dyn.case import load_case_text
    from rbsm_dyn.model import build_model
    from rbsm_dyn.solvers import explicit, linear, relax
    from rbsm_dyn.solvers.output import Recorder
    t0 = time.perf_counter()
    case = load_case_text(text, "time_error.yaml")
    model = build_model(case)
    build = time.perf_counter() - t0
    extra = {"static": {"residual": "1"}, "linear": {"residual": "1"}}.get(case.solver.mode, {})
    rec = Recorder(case, model, out, threads=threads, extra_observables=extra)
    solver = {"dynamic": explicit, "static": relax, "linear": linear}[case.solver.mode]
    c0 = time.process_time()
    try:
        res = solver.run(case, model, rec)
    finally:
        rec.close()
    cpu = time.process_time() - c0
    wall = res["wall_time"] if "wall_time" in res else res["assembly_time"] + res["solve_time"]
    return model, res, build, wall, cpu, rbsm_dyn.open_history(out)


def measure_a2(h):
    """VERIFICATION A2 (tests/test_statics.py): the load acts at the tip
    cells' centroids, mean x_c, so the reference is the cantilever of
    length x_c: δ = P x³/(3EI) + P x/(κGA), κ = 10(1+ν)/(12+11ν) (Cowper)."""
    ref0 = h.static["particles/bodies/reference_position"]
    nx = round(1.0 / ref0[:, 0].min() / 2)
    x = ref0[ref0[:, 0] >= 1.0 * (1 - 1 / nx) - 1e-9, 0].mean()
    nu = 0.0
    EI = E_STEEL * A2_B * A2_H ** 3 / 12
    kGA = 10 * (1 + nu) / (12 + 11 * nu) * E_STEEL / (2 * (1 + nu)) * A2_B * A2_H
    ref = A2_P * x ** 3 / (3 * EI) + A2_P * x / kGA        # VERIFICATION A2
    got = -h.observables["tip_z"][-1]
    return dict(value=got, reference=ref, error=got / ref - 1)


def measure_d1(h):
    """VERIFICATION D1 (tests/test_dynamics.py::test_D1): the front, read
    where mid_vx first reaches v/2 (linear between frames), arrives at
    t = (x_mid − x_driver)/c0, c0 = √(E/ρ)."""
    v, t = h.observables["mid_vx"], h.time
    i = int(np.argmax(v >= 0.5 * D1_V))
    if i == 0:
        raise RuntimeError("D1: the front did not reach the probe")
    got = t[i - 1] + (t[i] - t[i - 1]) * (0.5 * D1_V - v[i - 1]) / (v[i] - v[i - 1])
    ref0 = h.static["particles/bodies/reference_position"][:, 0]
    dx = ref0.max() - ref0.min()
    cell = dx / (len(ref0) - 1)
    x_mid = ref0[np.abs(ref0 - 0.5) < cell].mean()
    x_drv = ref0[ref0 < cell].mean()
    ref = (x_mid - x_drv) / np.sqrt(E_STEEL / RHO)          # VERIFICATION D1
    return dict(value=got, reference=ref, error=got / ref - 1)


def measure_c(h, clamped, cell):
    """VERIFICATION C1/C2 (tests/test_plastic.py::impulsive): W_f = −min mid_z,
    T = first return of mid_vz to ≥ 0 after 0.1 ms.  Rigid-plastic theory
    (Jones, Structural Impact §3.3): C1 W_f = mV0²L²/(3Mp), T = mV0L²/(2Mp);
    C2 W_f = mV0²L²/(6Mp), T = mV0L²/(4Mp), with L = 0.1 − h/2 for C2 (the
    clamps hold the end cells' centroids)."""
    z, v, t = h.observables["mid_z"], h.observables["mid_vz"], h.time
    k = int(np.argmax((v[1:] >= 0) & (t[1:] > 1e-4))) + 1
    wf, T = -z.min(), t[k]
    L = C_L - cell / 2 if clamped else C_L
    f_w, f_t = (6, 4) if clamped else (3, 2)
    wf_ref = C_M * C_V0 ** 2 * L ** 2 / (f_w * C_MP)      # VERIFICATION C1 / C2
    T_ref = C_M * C_V0 * L ** 2 / (f_t * C_MP)
    return dict(value=wf, reference=wf_ref, error=wf / wf_ref - 1,
                T=T, T_reference=T_ref, T_error=T / T_ref - 1)


PROBLEMS = {
    "A2": dict(title="A2 static cantilever, tip deflection (dynamic relaxation)",
               case=a2_case, measure=lambda h, cell: measure_a2(h), unit="h = depth/nz",
               mesh=lambda n: f"{10 * n} × 1 × {n} blocks", count="iterations"),
    "D1": dict(title="D1 bar wave, front arrival at mid-length (explicit)",
               case=d1_case, error_case=lambda n: d1_case(n, every_step=True), measure=lambda h, cell: measure_d1(h), unit="h = 1 m/nx",
               mesh=lambda n: f"{n} × 1 × 1 blocks", count="steps"),
    "C1": dict(title="C1 impulsive simply supported beam (explicit, von_mises)",
               case=lambda n: c_case(n, False), measure=lambda h, cell: measure_c(h, False, cell),
               unit="h = H/nz", mesh=lambda n: f"{20 * n} × 1 × {n} blocks", count="steps"),
    "C2": dict(title="C2 impulsive clamped beam (explicit, sliding clamps, normal yield)",
               case=lambda n: c_case(n, True), measure=lambda h, cell: measure_c(h, True, cell),
               unit="h = H/nz", mesh=lambda n: f"{20 * n} × 1 × {n} blocks", count="steps"),
}


def solve_count(res):
    """Explicit steps, or total dynamic-relaxation iterations."""
    return int(res["steps"]) if "steps" in res else int(sum(res["iterations"]))


def run_problem(name, sizes, threads, tmp, say):
    """Timed run of each size (repeated while short), the error read from
    it, or from a separate error run where the problem has one (D1); A2
    also solved linearly (error only, its time in the CSV)."""
    p = PROBLEMS[name]
    # first call: Numba compile or cache load, not part of the table
    text, cell = p["case"](sizes[0])
    t0 = time.perf_counter()
    run_text(text, tmp / f"{name}_warm.h5", threads)
    if "error_case" in p:
        run_text(p["error_case"](sizes[0])[0], tmp / f"{name}_warm.h5", threads)
    first = time.perf_counter() - t0
    say(f"{name}: first run (compile / cache load + build + solve) {first:.2f} s")
    rows = []
    for n in sizes:
        text, cell = p["case"](n)
        out = tmp / f"{name}_{n}.h5"
        walls, cpus = [], []
        while not walls or (min(walls) < REPEAT_BELOW and len(walls) < 3):
            model, res, build, w, c, hist = run_text(text, out, threads)
            walls.append(w)
            cpus.append(c)
        row = dict(problem=name, n=n, mesh=p["mesh"](n), h=cell, bodies=model.n_bodies,
                   springs=model.n_springs, count=solve_count(res), count_kind=p["count"],
                   dt=res.get("dt", float("nan")), build_s=build, wall_s=min(walls),
                   cpu_s=cpus[int(np.argmin(walls))], runs=len(walls))
        if "error_case" in p:
            _, eres, _, ew, _, hist = run_text(p["error_case"](n)[0], tmp / f"{name}_{n}_err.h5",
                                               threads)
            assert eres["dt"] == res["dt"], "the error run must take the timed run's step"
            row["error_run_s"] = ew
        row.update(p["measure"](hist, cell))
        if name == "A2":
            _, lres, _, lw, _, lhist = run_text(a2_linear(n)[0], tmp / f"{name}_{n}_lin.h5",
                                                threads)
            row["linear_s"] = lw
            row["linear_method"] = lres["method"] + (f" {lres['iterations']} it."
                                                     if lres["method"] == "cg" else "")
            row["linear_error"] = measure_a2(lhist)["error"]
        rows.append(row)
        extra = f", T error {100 * row['T_error']:+.2f} %" if "T_error" in row else ""
        if "linear_error" in row:
            extra += f", linear K U = F error {100 * row['linear_error']:+.4f} %"
        say(f"{name}: h = {cell:.4g} m, {model.n_bodies} bodies, {model.n_springs} springs, "
            f"{row['count']} {p['count']}, build {build:.2f} s, wall {row['wall_s']:.2f} s "
            f"(cpu {row['cpu_s']:.2f} s), error {100 * row['error']:+.4f} %{extra}")
    return rows


# ------------------------------------------------------------------ report
def fit_rows(name, rows):
    """Sizes the rate is fitted over, and why.  A2: only errors at least
    FLOOR_FACTOR × its floor, the largest |DR − linear| error difference
    (geometric nonlinearity, which small-deflection theory leaves out, plus
    the relaxation tolerance): below that the error is not discretisation
    error and may change sign.  D1: all sizes."""
    if name != "A2":
        return rows, "all sizes"
    floor = max(abs(r["error"] - r["linear_error"]) for r in rows)
    used = [r for r in rows if abs(r["error"]) >= FLOOR_FACTOR * floor]
    return used, (f"the sizes whose |error| ≥ {FLOOR_FACTOR:g} × the floor "
                  f"{100 * floor:.1e} % = max |DR − linear| (geometric nonlinearity "
                  "+ tolerance)")


def fit_rate(rows):
    """Least squares of log|error| against log h: the slope."""
    h = np.array([r["h"] for r in rows])
    e = np.abs([r["error"] for r in rows])
    if len(rows) < 2 or np.any(e == 0):
        return float("nan")
    return float(np.polyfit(np.log(h), np.log(e), 1)[0])


def local_rates(rows, key="error"):
    """log(e_i/e_{i-1}) / log(h_i/h_{i-1}) between consecutive sizes."""
    out = [float("nan")]
    for a, b in zip(rows[:-1], rows[1:]):
        ea, eb = abs(a[key]), abs(b[key])
        out.append(np.log(eb / ea) / np.log(b["h"] / a["h"]) if ea > 0 and eb > 0 else float("nan"))
    return out


def fmt_h(h):
    return f"{h * 1e3:.4g} mm"


def table(name, rows):
    p = PROBLEMS[name]
    lines = [f"### {p['title']}", ""]
    c_prob = "T_error" in rows[0]
    head = ["h", "mesh", "bodies", "springs", p["count"], "build s", "wall s", "CPU s"]
    if c_prob:
        head += ["W_f mm", "W_f error %", "T ms", "T error %"]
    else:
        head += ["error %", "local rate"]
    if name == "A2":
        head += ["linear K U = F error %", "linear s", "linear method"]
    lines += ["| " + " | ".join(head) + " |", "|" + "---|" * len(head)]
    rates = local_rates(rows)
    for r, lr in zip(rows, rates):
        cells = [fmt_h(r["h"]), r["mesh"], str(r["bodies"]), str(r["springs"]), str(r["count"]),
                 f"{r['build_s']:.2f}", f"{r['wall_s']:.3f}", f"{r['cpu_s']:.3f}"]
        if c_prob:
            cells += [f"{r['value'] * 1e3:.3f}", f"{100 * r['error']:+.2f}",
                      f"{r['T'] * 1e3:.3f}", f"{100 * r['T_error']:+.2f}"]
        else:
            cells += [f"{100 * r['error']:+.4f}", "" if np.isnan(lr) else f"{lr:.2f}"]
        if name == "A2":
            cells += [f"{100 * r['linear_error']:+.4f}", f"{r['linear_s']:.3f}",
                      r["linear_method"]]
        lines.append("| " + " | ".join(cells) + " |")
    lines.append("")
    return lines


def plot(all_rows, path):
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    fig, ax = plt.subplots(figsize=(7.5, 5.5))
    for k, (name, rows) in enumerate(all_rows.items()):
        w = [float(r["wall_s"]) for r in rows]
        e = [100 * abs(float(r["error"])) for r in rows]
        label = name + (" (W_f)" if name.startswith("C") else "")
        line, = ax.plot(w, e, "o-", label=label)
        for r, x, y in zip(rows, w, e):      # alternate label sides so C1 and C2 stay apart
            ax.annotate(fmt_h(float(r["h"])), (x, y), textcoords="offset points",
                        xytext=(4, 4) if k % 2 == 0 else (4, -11), fontsize=7,
                        color=line.get_color())
    ax.set_xscale("log")
    ax.set_yscale("log")
    ax.set_xlabel("wall time of the solve, 1 Numba thread [s]")
    ax.set_ylabel("|error| against the closed form [%]")
    ax.set_title("rbsm_dyn: run time against error (labels: cell size h)")
    ax.grid(True, which="both", alpha=0.3)
    ax.legend(loc="center right")
    fig.tight_layout()
    fig.savefig(path, dpi=120)
    plt.close(fig)


def write_csv(all_rows, path, meta):
    keys = ["problem", "n", "mesh", "h", "bodies", "springs", "count", "count_kind", "dt",
            "build_s", "wall_s", "cpu_s", "runs", "value", "reference", "error",
            "T", "T_reference", "T_error", "linear_error", "linear_s", "linear_method",
            "error_run_s"]
    with open(path, "w", newline="", encoding="utf-8") as f:
        w = csv.writer(f)
        w.writerow(["date", "git", "threads"] + keys)
        for rows in all_rows.values():
            for r in rows:
                w.writerow([meta["date"], meta["rev"], meta["threads"]]
                           + [r.get(k, "") for k in keys])


def report(all_rows, meta, total):
    L = ["# Run time against error", "",
         "Written by `benchmarks/time_error.py` (benchmarks/README.md, \"time_error.py\").", "",
         f"* command: `{meta['cmd']}`",
         f"* date: {meta['date']}; git {meta['rev']}",
         f"* machine: {meta['cpu']}, {meta['cores']} cores; load average "
         f"{meta['load0']} at the start, {meta['load1']} at the end (shared machine: wall "
         "times move by ±20 % or more, CPU time is the steadier figure)",
         f"* Numba threads: {meta['threads']}; python {meta['python']}, numba {meta['numba']}, "
         f"numpy {meta['numpy']}",
         f"* whole script: {total:.0f} s", "",
         "wall s: the solver's own wall time (`res['wall_time']` of "
         "`solvers.explicit.run` / `solvers.relax.run`: time loop or load steps, with the "
         "output frames; A2 includes the elastic predictor of relax.py, a sparse direct "
         "K U = F (stiffness.solve_linear) up to 5 000 bodies).  The A2 linear column is "
         "`solver.mode: linear` (linear.solve: SuperLU up to 12 000 free DOFs, CG above).  Mesh and model build (build s) and the first "
         "run of each problem (Numba compile or cache load) are not in it.  Runs under "
         f"{REPEAT_BELOW:g} s: best of 3.  Error: signed, (model − closed form) / closed form.",
         ""]
    for name, rows in all_rows.items():
        L += table(name, rows)
        if name in ("A2", "D1"):
            sel, why = fit_rows(name, rows)
            rate = fit_rate(sel)
            used = ", ".join(fmt_h(r["h"]) for r in sel)
            L += [f"Fitted rate (least squares of log|error| against log h over {why}: "
                  f"h = {used}): **{rate:.2f}**.", ""]
            meta.setdefault("rates", {})[name] = (rate, used)
        else:
            e = [f"{100 * r['error']:+.1f}" for r in rows]
            te = [f"{100 * r['T_error']:+.1f}" for r in rows]
            expect = {"C1": "an independent small-rotation RBSM gives +10…+14 %",
                      "C2": "an independent RBSM with normal-only yield gives +2…+8 %"}[name]
            L += ["No rate fitted: the elastic–plastic RBSM keeps an elastic-effect offset "
                  "above rigid-plastic theory, so the error does not go to zero under "
                  f"refinement (VERIFICATION C: {expect}; C3: elastic effects still about "
                  "+15 % at E/σ0 = 10⁴ for a struck cantilever).  Trend from coarse to "
                  f"fine: W_f {' → '.join(e)} %, T {' → '.join(te)} %.", ""]
    L += notes(all_rows)
    return L


def notes(all_rows):
    """Problem-specific reading of the tables (what the references are)."""
    L = ["## Setup per problem", ""]
    if "A2" in all_rows:
        L += ["* **A2**: `cases/cantilever_static.yaml` (L = 1, b = h = 0.1, P = 10 kN, "
              "E = 200 GPa, ν = 0, clamp as a support on face xmin, 2 load steps, "
              "tolerance 1e-6) at 10 nz × 1 × nz blocks; tip group = last layer of cells; "
              "reference δ = P x³/(3EI) + P x/(κGA), κ = 5/6 at the tip cells' mean "
              "centroid x (VERIFICATION A2, as tests/test_statics.py)."]
    if "D1" in all_rows:
        L += ["* **D1**: `cases/bar_wave.yaml` (1 m bar, 20 × 20 mm, E = 200 GPa, "
              "ρ = 8000, ν = 0, driver = first cell at 1 m/s, dt_safety 0.8, end 0.16 ms) at "
              "nx × 1 × 1 blocks; probe = the two cells either side of x = 0.5; probes only.  "
              "Timed run: frames every 10 µs (17 frames).  The error comes from a second run "
              "of the same mesh and step with a frame at every step (to 0.12 ms; its wall time "
              "is `error_run_s` in the CSV: one frame costs milliseconds, far more than a step "
              "of these small models): arrival = the first crossing of v/2 by the probe, "
              "linear between steps; reference (x_mid − x_driver)/c0 (VERIFICATION D1)."]
    if "C1" in all_rows or "C2" in all_rows:
        L += ["* **C1/C2**: `cases/impulsive_beam.yaml` (span 0.2, b = H = 0.01, "
              "V0 = 14 m/s, σ0 = 100 MPa) at 20 nz × 1 × nz blocks with E = 1000 GPa "
              "(E/σ0 = 10⁴, VERIFICATION C3, as tests/test_plastic.py); C1 pins on the end "
              "faces, von_mises (as shipped); C2 sliding clamps (z, ry held on the end "
              "cells, L = 0.1 − h/2) and normal-only yield, end 1.6 ms.  W_f = −min of the "
              "midspan probe, T = its velocity's first return to ≥ 0 (frames every 10 µs).  "
              "References W_f = 20.91 / 10.45 mm, T = 2.24 / 1.12 ms at L = 0.1 "
              "(VERIFICATION C1, C2)."]
    L.append("")
    return L


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--problems", default="A2,D1,C1,C2",
                    help="comma-separated subset of A2,D1,C1,C2 (default all)")
    ap.add_argument("--quick", action="store_true",
                    help="smallest sizes only (smoke run, about a minute)")
    ap.add_argument("--threads", type=int, default=1, help="Numba threads (default 1)")
    ap.add_argument("--out", default=str(HERE / "results" / "time_error"),
                    help="output prefix: PREFIX.md, PREFIX.csv, PREFIX.png "
                         "(default benchmarks/results/time_error)")
    ap.add_argument("--keep", metavar="DIR", help="keep the HDF5 histories in DIR")
    ap.add_argument("--replot", action="store_true",
                    help="only redraw PREFIX.png from PREFIX.csv (no runs)")
    args = ap.parse_args(argv)
    if args.replot:
        prefix = Path(args.out)
        with open(prefix.with_suffix(".csv"), encoding="utf-8") as f:
            rows = list(csv.DictReader(f))
        plot({name: [r for r in rows if r["problem"] == name]
              for name in dict.fromkeys(r["problem"] for r in rows)}, prefix.with_suffix(".png"))
        print(f"time_error: redrew {prefix}.png from {prefix}.csv")
        return 0
    names = [s.strip().upper() for s in args.problems.split(",") if s.strip()]
    bad = [n for n in names if n not in PROBLEMS]
    if bad:
        ap.error(f"unknown problem(s) {bad}; choose from {list(PROBLEMS)}")

    import numba
    numba.set_num_threads(min(args.threads, numba.config.NUMBA_NUM_THREADS))
    info = machine_info()
    meta = dict(info, threads=numba.get_num_threads(),
                cmd="python " + " ".join(shlex.quote(a) for a in
                                         [os.path.relpath(__file__, Path.cwd())] + sys.argv[1:]),
                load0=" ".join(f"{x:.2f}" for x in os.getloadavg()))
    try:
        rev = subprocess.run(["git", "rev-parse", "--short", "HEAD"], cwd=HERE,
                             capture_output=True, text=True).stdout.strip()
        dirty = subprocess.run(["git", "status", "--porcelain", "--", "rbsm_dyn", "cases"],
                               cwd=HERE.parent, capture_output=True, text=True).stdout.strip()
        meta["rev"] = rev + (" (rbsm_dyn/ or cases/ modified)" if dirty else "")
    except OSError:
        meta["rev"] = "?"

    def say(msg):
        print(msg, flush=True)

    say(f"time_error: {meta['cmd']}; {meta['cpu']}, {meta['cores']} cores, "
        f"{meta['threads']} Numba thread(s), git {meta['rev']}")
    t_start = time.perf_counter()
    all_rows = {}
    with tempfile.TemporaryDirectory(prefix="time_error_") as tmpd:
        tmp = Path(args.keep) if args.keep else Path(tmpd)
        tmp.mkdir(parents=True, exist_ok=True)
        for name in names:
            sizes = SIZES[name][:QUICK[name]] if args.quick else SIZES[name]
            all_rows[name] = run_problem(name, sizes, args.threads, tmp, say)
    total = time.perf_counter() - t_start
    meta["load1"] = " ".join(f"{x:.2f}" for x in os.getloadavg())

    prefix = Path(args.out)
    prefix.parent.mkdir(parents=True, exist_ok=True)
    md = report(all_rows, meta, total)
    prefix.with_suffix(".md").write_text("\n".join(md) + "\n", encoding="utf-8")
    write_csv(all_rows, prefix.with_suffix(".csv"), meta)
    plot(all_rows, prefix.with_suffix(".png"))
    for name, (rate, used) in meta.get("rates", {}).items():
        say(f"{name}: fitted rate {rate:.2f} over h = {used}")
    say(f"time_error: {total:.0f} s; wrote {prefix}.md, .csv, .png")
    return 0


if __name__ == "__main__":
    sys.exit(main())
