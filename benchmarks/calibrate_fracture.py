"""Measure the fracture calibration of the Voronoi lattice
(rbsm_dyn/fracture_calibration.py; method in docs/calibration.md, "Fracture").

    python benchmarks/calibrate_fracture.py [--betas 1 2 3 10] [--seeds 1 2] [--cells-across 8]
    python benchmarks/calibrate_fracture.py --plane ...   (plane Voronoi, plane stress)

For each spring brittleness β_s = E G_s/(f_s² Δ) and seed, two specimens (double-edge notched)
with the spring values as given (`rupture.values: spring`):
* direct tension (no notch): F_T = peak stress / f_s;
* double-edge notched (two notches W/4 deep): F_G = W_f / (A_lig G_s), the
  fracture dissipation at full separation per ligament (projected crack) area.
The material that these springs represent has f_t = F_T f_s, G_f = F_G G_s,
so β = β_s F_G/F_T²: the rows (β, F_T, F_G) printed at the end are those of
VORONOI_FRACTURE.  Material: E = 30 GPa, ρ = 2400, ν = 0, f_t = 3 MPa
(only β matters), cell 2 mm.  About 10 s per specimen on one core.
"""
import argparse
import os
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

import rbsm_dyn
from rbsm_dyn.__main__ import main
from rbsm_dyn.calibration import stiffness_rule
from rbsm_dyn.fracture_calibration import VORONOI_ENERGY, VORONOI_TENSION, tension_specimen

FT = 3.0e6


def run(text, tmp):
    path = Path(tmp) / "specimen.yaml"
    path.write_text(text)
    out = Path(tmp) / "specimen.h5"
    if main([str(path), "--out", str(out), "--quiet"]) != 0:
        sys.exit("run failed")
    return rbsm_dyn.open_history(out)


def measure(beta, seed, notch, cells_across, tmp, plane=False, poisson=0.0):
    text, area, gf = tension_specimen(cell=0.002, cells_across=cells_across, notch=notch,
                                      tensile_strength=FT, beta=beta, values="spring",
                                      seed=seed, plane=plane, poisson=poisson)
    t = time.time()
    h = run(text, tmp)
    ob = h.observables
    # the section the peak load divides: W² (3D prism), W × t (plane, t = cell)
    W2 = (cells_across * 0.002) * (0.002 if plane else cells_across * 0.002)
    bal = ob["kinetic"] + ob["strain"] + ob["plastic"] + ob["fracture"] + ob["damping"] \
        - ob["external_work"]
    return dict(peak=np.abs(ob["F"]).max() / W2 / FT, wf=ob["fracture"][-1] / (area * gf),
                balance=np.abs(bal).max() / ob["external_work"].max(), wall=time.time() - t)


def main_(argv=None):
    p = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    p.add_argument("--betas", type=float, nargs="+", default=[1, 2, 3, 10])
    p.add_argument("--seeds", type=int, nargs="+", default=[1, 2])
    p.add_argument("--cells-across", type=int, default=8)
    p.add_argument("--plane", action="store_true",
                   help="the plane-stress specimens (plane Voronoi: PLANE_VORONOI_FRACTURE)")
    p.add_argument("--notched-only", action="store_true",
                   help="measure F_G only (F_T scatters by ±1 %%: two seeds suffice)")
    p.add_argument("--tension-only", action="store_true",
                   help="measure F_T only (β then maps with the ν = 0 table's F_G)")
    p.add_argument("--poisson", type=float, default=0.0,
                   help="the material's ν (the rows of VORONOI_TENSION and VORONOI_ENERGY)")
    a = p.parse_args(argv)
    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        for beta in a.betas:
            ft, fg = [], []
            for seed in a.seeds:
                d = (dict(peak=np.nan, balance=np.nan, wall=0.0) if a.notched_only
                     else measure(beta, seed, 0.0, a.cells_across, tmp, a.plane, a.poisson))
                n = (dict(wf=np.nan, balance=np.nan, wall=0.0) if a.tension_only
                     else measure(beta, seed, 0.5, a.cells_across, tmp, a.plane, a.poisson))
                ft.append(d["peak"])
                fg.append(n["wf"])
                print(f"beta_s {beta:5.2f} seed {seed}: F_T {d['peak']:.3f} (balance "
                      f"{d['balance']:.4f}, {d['wall']:.0f} s)  F_G {n['wf']:.3f} (balance "
                      f"{n['balance']:.4f}, {n['wall']:.0f} s)", flush=True)
            FT_, FG_ = np.mean(ft), np.mean(fg)
            if a.tension_only:      # F_G of VORONOI_ENERGY at this β_s (nearest α's rows)
                alpha = stiffness_rule("calibrated", "voronoi", 30.0e9, a.poisson)[1]
                key = min(VORONOI_ENERGY, key=lambda k: abs(k - alpha))
                g, t = VORONOI_ENERGY[key], VORONOI_TENSION[key]
                bs = g[:, 0] * t[:, 1] ** 2 / g[:, 1]
                FG_ = float(np.interp(np.log(beta), np.log(bs), g[:, 1]))
            rows.append((beta * FG_ / FT_ ** 2, FT_, FG_, np.std(ft), np.std(fg)))
    print("\n    # beta, F_T, F_G      (± over seeds: F_T, F_G)")
    for r in rows:
        print(f"    [{r[0]:.3g}, {r[1]:.3f}, {r[2]:.3f}],   # ± {r[3]:.3f}, {r[4]:.3f}")


if __name__ == "__main__":
    os.environ.setdefault("NUMBA_NUM_THREADS", "1")
    main_()
