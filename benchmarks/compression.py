"""Uniaxial and confined compression of Voronoi concrete prisms
(docs/calibration.md, "Compression"; rbsm_dyn/compression_calibration.py).

    python benchmarks/compression.py table [--cells 0.007 0.005] [--ratios 2 3 4]
    python benchmarks/compression.py checks
    python benchmarks/compression.py poisson --poisson 0.0 0.3 [--ratios 2 3 4 6] [--seeds 1]
    python benchmarks/compression.py prism --poisson 0.0 0.3 [--seeds 1 2]

`table`: the peak stress over f_t of the calibration prism (50 mm, h = 2b,
frictionless platens, the C40 preset) at each shear-to-tensile ratio r
given as `shear_strength` (the rows of VORONOI_COMPRESSION).  `checks`:
the 40 mm prism and cube (frictionless and μ = 0.2) with the calibrated
f_c, and the triaxial prisms at lateral pressures of 0.1 and 0.3 f_c
against Richart, Brandtzaeg & Brown (1928): f_cc = f_c + 4.1 σ_3.
`poisson`: f_c/f_t of the per-ν prism (40 mm, 6 cells across, h = 2b,
frictionless platens, 0.5 /s, the C40 preset at ν with `shear_strength` =
r f_t given) per r and seed: over ν = 0.2's, the rows of
COMPRESSION_ALPHA_FACTOR (and COMPRESSION_AUX_FACTOR).  `prism`: the same
prism with the calibrated f_c = 40 MPa (no shear strength given) at ν:
its peak against the f_c asked.
Each run: one thread, a few seconds to four minutes."""
import argparse
import os
import sys
import tempfile
import time

import numpy as np

sys.path.insert(0, os.path.join(os.path.dirname(__file__), ".."))

import rbsm_dyn  # noqa: E402
from rbsm_dyn.__main__ import main  # noqa: E402
from rbsm_dyn.case import load_case_text  # noqa: E402
from rbsm_dyn.compression_calibration import compression_specimen  # noqa: E402

FC = 40.0e6


def peak(text, area):
    """(peak platen stress [Pa], wall [s]) of a specimen's run."""
    with tempfile.TemporaryDirectory() as d:
        case, out = os.path.join(d, "c.yaml"), os.path.join(d, "c.h5")
        with open(case, "w", encoding="utf-8") as f:
            f.write(text)
        t = time.perf_counter()
        assert main([case, "--out", out, "--quiet", "--threads", "1"]) == 0
        wall = time.perf_counter() - t
        h = rbsm_dyn.open_history(out)
        return float(np.max(-np.asarray(h.observables["F"]))) / area, wall


def table(cells, ratios):
    ft = load_case_text(compression_specimen(cell=0.01)).materials["concrete"] \
        .rupture.tensile_strength
    print("| r | cell [m] | f_c/f_t | wall [s] |\n|---|---|---|---|")
    for r in ratios:
        for cell in cells:
            text = compression_specimen(cell=cell, extra=f", rupture: {{shear_strength: "
                                                          f"{r * ft!r}}}",
                                        rate=0.5)
            s, wall = peak(text, 0.05 ** 2)
            print(f"| {r:g} | {cell:g} | {s / ft:.2f} | {wall:.0f} |", flush=True)


def checks():
    b = 0.04
    print("| specimen | peak [MPa] | reference | wall [s] |\n|---|---|---|---|")
    for across in (6, 8):
        cell = b / across
        prism, w = peak(compression_specimen(cell=cell, width=b, rate=2.0), b * b)
        print(f"| prism {across} across | {prism / 1e6:.2f} | f_c = {FC / 1e6:g} | {w:.0f} |")
        for mu in (0.0, 0.2):
            cube, w = peak(compression_specimen(cell=cell, width=b, height=b, rate=2.0,
                                                friction=mu), b * b)
            print(f"| cube {across} across, μ = {mu:g} | {cube / 1e6:.2f} "
                  f"({cube / prism:.2f} × prism) | EN 206 ≈ 1.2-1.25 × | {w:.0f} |", flush=True)
    cell, r = 0.007, 3.3
    ft = load_case_text(compression_specimen(cell=cell)).materials["concrete"] \
        .rupture.tensile_strength
    extra = f", rupture: {{shear_strength: {r * ft!r}}}"
    fc, w = peak(compression_specimen(cell=cell, extra=extra), 0.05 ** 2)
    print(f"| prism 50 mm, r = {r:g} | {fc / 1e6:.2f} | (unconfined) | {w:.0f} |")
    for share in (0.1, 0.3):
        p = share * FC
        s, w = peak(compression_specimen(cell=cell, extra=extra, confinement=p), 0.05 ** 2)
        ref = fc + 4.1 * p
        print(f"| triaxial σ_3 = {share:g} f_c | {s / 1e6:.2f} | Richart {ref / 1e6:.1f} "
              f"({s / ref - 1:+.0%}) | {w:.0f} |", flush=True)


def per_poisson(poissons, ratios, seeds, b=0.04, across=6):
    print("| ν | seed | r | f_c/f_t | wall [s] |\n|---|---|---|---|---|")
    for nu in poissons:
        ft = load_case_text(compression_specimen(cell=b / across, width=b,
                                                 extra=f", poisson: {nu!r}")) \
            .materials["concrete"].rupture.tensile_strength
        for seed in seeds:
            for r in ratios:
                text = compression_specimen(
                    cell=b / across, width=b, seed=seed, rate=0.5,
                    extra=f", poisson: {nu!r}, rupture: {{shear_strength: {r * ft!r}}}")
                s, wall = peak(text, b * b)
                print(f"| {nu:g} | {seed} | {r:g} | {s / ft:.2f} | {wall:.0f} |", flush=True)


def prism_at_fc(poissons, seeds, b=0.04, across=6):
    print("| ν | seed | f_c asked [MPa] | reached [MPa] | error | wall [s] |\n"
          "|---|---|---|---|---|---|")
    for nu in poissons:
        for seed in seeds:
            text = compression_specimen(cell=b / across, width=b, seed=seed, rate=0.5, fc=FC,
                                        extra=f", poisson: {nu!r}")
            s, wall = peak(text, b * b)
            print(f"| {nu:g} | {seed} | {FC / 1e6:g} | {s / 1e6:.2f} | {s / FC - 1:+.1%} "
                  f"| {wall:.0f} |", flush=True)


if __name__ == "__main__":
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("what", choices=["table", "checks", "poisson", "prism"])
    ap.add_argument("--cells", type=float, nargs="+", default=[0.007, 0.005])
    ap.add_argument("--ratios", type=float, nargs="+", default=[2.0, 2.5, 3.0, 3.3, 4.0, 5.0,
                                                               6.0])
    ap.add_argument("--poisson", type=float, nargs="+", default=[0.0, 0.3])
    ap.add_argument("--seeds", type=int, nargs="+", default=None)
    a = ap.parse_args()
    if a.what == "table":
        table(a.cells, a.ratios)
    elif a.what == "checks":
        checks()
    elif a.what == "poisson":
        per_poisson(a.poisson, a.ratios, a.seeds or [1])
    else:
        prism_at_fc(a.poisson, a.seeds or [1, 2])
