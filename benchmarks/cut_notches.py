"""Notches given as `cuts` on Voronoi cells, as a user writes them (issue 30,
item 1: a cut is a plane of cell faces by default, mesh/cut_seeds.py).

    python benchmarks/cut_notches.py [--kw] [--griffith] [--sizes 0.002,0.0016]
                                     [--kw-seeds 1,2] [--jobs 2]

* Kalthoff & Winkler, the full plate (100 × 200 mm, both notches as cuts
  from the struck edge, 50 mm long at y = ±25 mm, no soft slot), the
  struck cells |y| < 25 mm at x < one cell driven at 16.5 m/s: the crack
  angle at each tip (line fit of its broken faces within 20 mm of the tip,
  tests/test_fracture_cases.py crack_angle), published 60-70° (≈ 70° in
  the experiment);
* Griffith's centre crack on a Voronoi plate (tests/test_fracture.py
  voronoi_lefm_case: a = 4 and 8 cells, seeds 1-4): the failure stress
  against LEFM's σc = √(E G_f/(πa))/√sec(πa/W).

Runs each case with `python -m rbsm_dyn` (one Numba thread each, --jobs
side by side) and prints a Markdown table.  Measures; asserts nothing."""
import argparse
import io
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np
from ruamel.yaml import YAML

HERE = Path(__file__).resolve().parent
ROOT = HERE.parent
sys.path.insert(0, str(ROOT / "tests"))
sys.path.insert(0, str(ROOT))
from test_fracture_cases import KW, crack_angle, energy_error  # noqa: E402

import rbsm_dyn  # noqa: E402


def kw_full_plate(size, seed=1):
    """cases/kalthoff_winkler.yaml as the full plate at cell size `size`
    (mesh seed `seed`): both notches as cuts, no slot material, the struck
    row |y| < 25 mm."""
    yaml = YAML()
    data = yaml.load(KW.read_text(encoding="utf-8"))
    data["name"] = "kalthoff-winkler-full"
    data["domain"]["box"] = [[0, -0.1, 0], [0.1, 0.1, size]]
    data["mesh"]["size"] = size
    data["mesh"]["seed"] = seed
    del data["materials"]["slot"]
    del data["groups"]["notch_slot"]
    data["groups"]["struck"]["box"] = [[-1, -0.025, -1], [size, 0.025, 1]]
    data["boundary"] = [b for b in data["boundary"] if "face" not in b]
    data["cuts"] = [{"point": [0, y, 0], "normal": [0, 1, 0],
                     "within": [[-1, y - 0.5 * size, -1], [0.05, y + 0.5 * size, 1]]}
                    for y in (0.025, -0.025)]
    data["output"]["fields"] = ["position", "orientation", "spring_state"]
    out = io.StringIO()
    yaml.dump(data, out)
    return out.getvalue()


class Mirrored:
    """A history seen with y → −y (the lower tip's crack as the upper's)."""

    def __init__(self, h):
        self.h = h
        self.static = dict(h.static)
        pos = np.array(h.static["springs/position"])
        pos[:, 1] *= -1
        self.static["springs/position"] = pos

    def __getitem__(self, key):
        return self.h[key]


def start(text, work, name):
    path = Path(work) / f"{name}.yaml"
    path.write_text(text, encoding="utf-8")
    out = Path(work) / f"{name}.h5"
    env = dict(os.environ, NUMBA_NUM_THREADS="1")
    log = open(Path(work) / f"{name}.log", "w")
    p = subprocess.Popen([sys.executable, "-m", "rbsm_dyn", str(path), "--out", str(out),
                          "--quiet", "--threads", "1"], stdout=log, stderr=subprocess.STDOUT,
                         env=env)
    return p, out, time.perf_counter()


def run_all(jobs, work, parallel):
    """{name: (history, wall s)} of {name: case text}, `parallel` at a time."""
    todo, running, done = list(jobs.items()), [], {}
    while todo or running:
        while todo and len(running) < parallel:
            name, text = todo.pop(0)
            running.append((name, *start(text, work, name)))
        for item in list(running):
            name, p, out, t0 = item
            if p.poll() is not None:
                running.remove(item)
                if p.returncode != 0:
                    print(f"{name}: exit {p.returncode}: "
                          f"{(Path(work) / f'{name}.log').read_text()[-2000:]}")
                    continue
                done[name] = (rbsm_dyn.open_history(out), time.perf_counter() - t0)
        time.sleep(0.2)
    return done


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--kw", action="store_true")
    ap.add_argument("--griffith", action="store_true")
    ap.add_argument("--sizes", default="0.002,0.0016")
    ap.add_argument("--kw-seeds", default="1", help="mesh seeds of the Kalthoff-Winkler plate")
    ap.add_argument("--jobs", type=int, default=2)
    a = ap.parse_args(argv)
    if not (a.kw or a.griffith):
        a.kw = a.griffith = True
    work = tempfile.mkdtemp(prefix="cut_notches_")
    if a.kw:
        sizes = [float(s) for s in a.sizes.split(",")]
        kw_seeds = [int(s) for s in a.kw_seeds.split(",")]
        names = {(s, k): f"kw_{s * 1e3:g}mm_s{k}" for s in sizes for k in kw_seeds}
        runs = run_all({name: kw_full_plate(s, k) for (s, k), name in names.items()}, work,
                       a.jobs)
        print("| cells [mm] | seed | angle upper tip [°] (faces) | angle lower tip [°] (faces) | "
              "energy error | wall [s] |")
        print("|---|---|---|---|---|---|")
        for (s, k), name in names.items():
            if name not in runs:
                continue
            h, wall = runs[name]
            up, nu = crack_angle(h, (0.05, 0.025), s)
            lo, nl = crack_angle(Mirrored(h), (0.05, 0.025), s)
            print(f"| {s * 1e3:g} | {k} | {up:.1f} ({nu}) | {lo:.1f} ({nl}) | "
                  f"{energy_error(h):.2%} | {wall:.0f} |", flush=True)
    if a.griffith:
        from test_fracture import crack_growth, voronoi_lefm_case
        n, W, seeds = 40, 0.1, (1, 2, 3, 4)
        d = W / n
        jobs, ref = {}, {}
        for a_cells in (4, 8):
            for seed in seeds:
                text, ts, lefm = voronoi_lefm_case(a_cells, seed, n, W)
                jobs[f"griffith_a{a_cells}_s{seed}"] = text
                ref[f"griffith_a{a_cells}_s{seed}"] = (a_cells, ts, lefm)
        runs = run_all(jobs, work, a.jobs)
        print("\n| a [cells] | seed | σ_f / σ_LEFM |")
        print("|---|---|---|")
        means = {}
        for name, (h, wall) in runs.items():
            a_cells, (t, s), lefm = ref[name]
            grown = crack_growth(h, a_cells * d, d, W)
            k = int(np.argmax(grown.sum(axis=1) >= 4 * d))
            ratio = np.interp(h.time[k], t, s) / lefm if k > 0 else float("nan")
            means.setdefault(a_cells, []).append(ratio)
            print(f"| {a_cells} | {name.rsplit('_s', 1)[1]} | {ratio:.3f} |", flush=True)
        for a_cells, r in means.items():
            print(f"mean a = {a_cells} cells: {np.mean(r):.3f} (range {min(r):.3f} "
                  f"to {max(r):.3f})")


if __name__ == "__main__":
    main()
