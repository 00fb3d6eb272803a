"""A notched concrete beam in three-point bending, load against crack-mouth
opening (CMOD) through the peak and down the softening branch, by the three
ways rbsm_dyn has (issue 13, item 4):

* `newton`: static, Newton path following under indirect displacement
  control on the CMOD (solver.method: newton, solver.control), to 30 % of
  the peak on the softening branch;
* `relaxation`: static, dynamic relaxation under displacement control of
  the loading cells (the default static method), stopped after --timeout s
  if it has not finished (its progress and estimated time are reported);
* `explicit`: dynamic, the loading cells driven down at a constant speed
  (ramped over the first 10 % of the run) with Cundall's local damping
  (solver.damping.local 0.7), at loading times T, 2T, 4T ... until the
  peak moves by less than 1 % (issue 13: the reference the Newton peak is
  held to).

    python benchmarks/quasi_static.py [--size 0.0085] [--threads 1] [--timeout 600]
                                      [--ramp 0.005] [--out benchmarks/results/quasi_static.md]

The beam: 440 × 100 × 40 mm on a pinned span of 400 mm (the bottom cells
at x = 20 and 420 mm held; one of them free along x), a cut notch
a0 = 50 mm at midspan, loaded through the top cells at midspan, the CMOD
the relative x displacement of the bottom cells within two cells either
side of the notch plane; concrete
E = 30 GPa, ν = 0.2, f_t = 3 MPa, G_f = 100 J/m² (the material's values,
fracture calibration of docs/calibration.md).  Voronoi cells of --size.
Each run is its own `python -m rbsm_dyn` process; wall times include the
start-up and the build (Numba's cache warm).  Writes a Markdown report and
the curves (PNG) beside it.
"""
import argparse
import datetime
import os
import platform
import subprocess
import sys
import time
from pathlib import Path

import numpy as np

import rbsm_dyn

HERE = Path(__file__).resolve().parent

BEAM = """\
name: notched_beam
domain: {{box: [[0, 0, 0], [0.44, 0.1, 0.04]]}}
mesh: {{kind: voronoi, size: {size}, seed: 1}}
materials:
  concrete:
    density: 2400
    young: 30.0e9
    poisson: 0.2
    rupture: {{fracture_energy: 100.0, tensile_strength: 3.0e6}}
groups:
  left: {{box: [[0.01, 0, 0], [0.03, {cell}, 0.04]]}}
  right: {{box: [[0.41, 0, 0], [0.43, {cell}, 0.04]]}}
  top: {{box: [[0.21, {top}, 0], [0.23, 0.1, 0.04]]}}
  mouth_l: {{box: [[{ml}, 0, 0], [0.22, {mh}, 0.04]]}}
  mouth_r: {{box: [[0.22, 0, 0], [{mr}, {mh}, 0.04]]}}
cuts:
  - {{point: [0.22, 0, 0], normal: [1, 0, 0], within: [[0.2, -0.01, -0.01], [0.24, 0.05, 0.05]]}}
boundary:
  - {{group: left, fix: [x, y, z]}}
  - {{group: right, fix: [y, z]}}
{load}
solver: {solver}
output:
{interval}  probes:
    P: {{group: top, quantity: reaction, component: y, reduce: sum}}
    cmod: {{quantity: relative_displacement, groups: [mouth_l, mouth_r], component: x}}
"""

DEFLECTION = 0.3e-3       # explicit and relaxation: the loading cells' final deflection [m]


def case_text(size, method, ramp=None, steps=60):
    # the crack mouth: the bottom-layer cells within two cells of the notch
    # plane, by the side of their centroids (as `cuts` splits the springs; a
    # probe point near the plane may lie in a cell on the other side)
    fmt = dict(size=size, cell=size, top=0.1 - size, interval="", ml=0.22 - 2 * size,
               mr=0.22 + 2 * size, mh=1.2 * size)
    if method == "newton":
        fmt["load"] = "  - {group: top, displacement: [null, -1.0e-3, null]}"
        fmt["solver"] = ("{mode: static, method: newton, tolerance: 1.0e-4, control: {probe: cmod, "
                         "increment: 1.0e-5, end: 1.0e-3, stop_fraction: 0.3}}")
    elif method == "relaxation":
        fmt["load"] = f"  - {{group: top, displacement: [null, {-DEFLECTION}, null]}}"
        fmt["solver"] = f"{{mode: static, method: relaxation, load_steps: {steps}, tolerance: 1.0e-4}}"
    else:
        v = DEFLECTION / (0.95 * ramp)          # ramped over the first 10 %: mean 0.95 v
        fmt["load"] = (f"  - {{group: top, velocity: [null, {-v}, null], "
                       f"history: [[0, 0], [{0.1 * ramp}, 1], [{ramp}, 1]]}}")
        fmt["solver"] = f"{{mode: dynamic, end_time: {ramp}, damping: {{local: 0.7}}}}"
        fmt["interval"] = f"  interval: {ramp / 300}\n"
    return BEAM.format(**fmt)


def run(text, tag, folder, threads, timeout=None):
    """(history or None, wall [s], stderr) of one run in its own process."""
    path = folder / f"{tag}.yaml"
    path.write_text(text)
    out = folder / f"{tag}.h5"
    # BLAS (the dense capacitance solves of the Newton run) on as many
    # threads as Numba: "one thread" means one
    env = dict(os.environ, NUMBA_NUM_THREADS=str(threads), OPENBLAS_NUM_THREADS=str(threads),
               OMP_NUM_THREADS=str(threads), MKL_NUM_THREADS=str(threads), RBSM_PROGRESS="1")
    t0 = time.perf_counter()
    try:
        r = subprocess.run([sys.executable, "-m", "rbsm_dyn", str(path), "--out", str(out),
                            "--threads", str(threads)], capture_output=True, text=True,
                           env=env, timeout=timeout)
        err, code = r.stderr, r.returncode
    except subprocess.TimeoutExpired as exc:
        err = exc.stderr.decode() if isinstance(exc.stderr, bytes) else (exc.stderr or "")
        code = None
    wall = time.perf_counter() - t0
    h = rbsm_dyn.open_history(out) if code == 0 else None
    return h, wall, err, code


def curve(h):
    o = h.observables
    return np.asarray(o["cmod"]), -np.asarray(o["P"])


def main(argv=None):
    p = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    p.add_argument("--size", type=float, default=0.0085, help="Voronoi cell size [m]")
    p.add_argument("--threads", type=int, default=1)
    p.add_argument("--timeout", type=float, default=600.0,
                   help="wall-clock limit of the relaxation run [s]")
    p.add_argument("--ramp", type=float, default=0.005,
                   help="first loading time T of the explicit runs [s]")
    p.add_argument("--max-ramps", type=int, default=4)
    p.add_argument("--skip", nargs="*", default=[], choices=["newton", "relaxation", "explicit"])
    p.add_argument("--out", default=str(HERE / "results" / "quasi_static.md"))
    a = p.parse_args(argv)
    folder = Path(os.environ.get("TMPDIR", "/tmp")) / "rbsm_quasi_static"
    folder.mkdir(exist_ok=True)
    rows, curves = [], {}
    git = subprocess.run(["git", "rev-parse", "--short", "HEAD"], capture_output=True,
                         text=True, cwd=HERE).stdout.strip()
    check = subprocess.run([sys.executable, "-m", "rbsm_dyn", "check",
                            str(_write(folder, case_text(a.size, "newton")))],
                           capture_output=True, text=True).stdout
    # "case.yaml: ok (2866 bodies, 95311 spring points)"
    model_line = check.splitlines()[0].split("ok (", 1)[-1].rstrip(")") if check else "?"

    if "newton" not in a.skip:
        h, wall, err, code = run(case_text(a.size, "newton"), "newton", folder, a.threads)
        if h is None:
            rows.append(("newton", f"failed (exit {code}): {err.strip().splitlines()[-1]}",
                         wall, ""))
        else:
            x, P = curve(h)
            its = np.diff(np.asarray(h.step))
            curves["Newton (CMOD control)"] = (x, P)
            rows.append(("newton", f"peak {P.max():.1f} N at CMOD {1e3 * x[P.argmax()]:.4f} mm; "
                         f"to {P[-1] / P.max():.2f} of the peak at CMOD {1e3 * x[-1]:.3f} mm; "
                         f"{len(its)} increments, iterations per increment: median "
                         f"{np.median(its):.0f}, max {its.max()}, total {its.sum()}", wall,
                         P.max()))
        print(rows[-1], flush=True)

    if "relaxation" not in a.skip:
        h, wall, err, code = run(case_text(a.size, "relaxation"), "relaxation", folder,
                                 a.threads, timeout=a.timeout)
        last = err.replace("\r", "\n").strip().splitlines()[-1:] if err else [""]
        if h is None:
            rows.append(("relaxation", f"not finished in {a.timeout:.0f} s (exit {code}); "
                         f"last progress: `{last[0][:160]}`", wall, ""))
        else:
            x, P = curve(h)
            curves["dynamic relaxation"] = (x, P)
            rows.append(("relaxation", f"peak {P.max():.1f} N at CMOD {1e3 * x[P.argmax()]:.4f} mm",
                         wall, P.max()))
        print(rows[-1], flush=True)

    if "explicit" not in a.skip:
        ramp, prev = a.ramp, None
        for k in range(a.max_ramps):
            h, wall, err, code = run(case_text(a.size, "explicit", ramp=ramp),
                                     f"explicit_{k}", folder, a.threads)
            if h is None:
                rows.append((f"explicit T = {1e3 * ramp:g} ms", f"failed (exit {code})", wall, ""))
                break
            x, P = curve(h)
            ratio = np.asarray(h.observables["kinetic_ratio"])
            curves[f"explicit, T = {1e3 * ramp:g} ms"] = (x, P)
            moved = "" if prev is None else f"; peak moved {100 * (P.max() / prev - 1):+.2f} %"
            rows.append((f"explicit T = {1e3 * ramp:g} ms",
                         f"peak {P.max():.1f} N at CMOD {1e3 * x[P.argmax()]:.4f} mm; "
                         f"{h.step[-1]} steps; kinetic/strain energy at the peak "
                         f"{ratio[P.argmax()]:.2g}{moved}", wall, P.max()))
            print(rows[-1], flush=True)
            if prev is not None and abs(P.max() / prev - 1) < 0.01:
                break
            prev = P.max()
            ramp *= 2

    peaks = {name: peak for name, _, _, peak in rows if peak != ""}
    explicit = [name for name in peaks if name.startswith("explicit")]
    if "newton" in peaks and explicit:
        rows.append(("Newton against the slowest explicit ramp",
                     f"peak {100 * (peaks['newton'] / peaks[explicit[-1]] - 1):+.2f} % "
                     f"({explicit[-1]})", float("nan"), ""))
    report = _report(a, git, model_line, rows)
    Path(a.out).write_text(report)
    print(report)
    _plot(curves, Path(a.out).with_suffix(".png"))


def _write(folder, text):
    path = folder / "info.yaml"
    path.write_text(text)
    return path


def _report(a, git, model_line, rows):
    now = datetime.datetime.now(datetime.timezone.utc).strftime("%Y-%m-%d %H:%M UTC")
    lines = [
        "# Quasi-static notched beam: Newton, dynamic relaxation, slow explicit ramp",
        "",
        f"{now}, git {git}, {platform.machine()}, {os.cpu_count()} cores, {a.threads} thread(s), "
        f"`python benchmarks/quasi_static.py --size {a.size}`; {model_line}.  Wall times "
        "include start-up and the build, on a shared host.",
        "",
        "| method | result | wall [s] |",
        "|---|---|---|",
    ]
    for name, text, wall, _ in rows:
        lines.append(f"| {name} | {text} | {'' if wall != wall else f'{wall:.0f}'} |")
    lines.append("")
    return "\n".join(lines)


def _plot(curves, path):
    if not curves:
        return
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    fig, ax = plt.subplots(figsize=(7, 4.5))
    for label, (x, P) in curves.items():
        ax.plot(1e3 * x, P / 1e3, label=label)
    ax.set_xlabel("CMOD [mm]")
    ax.set_ylabel("load P [kN]")
    ax.set_title("Notched beam in three-point bending")
    ax.grid(alpha=0.3)
    ax.legend()
    fig.tight_layout()
    fig.savefig(path, dpi=120)


if __name__ == "__main__":
    main()
