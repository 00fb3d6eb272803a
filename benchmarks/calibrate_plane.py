"""The plane Voronoi lattice's elastic table (docs/calibration.md, issue 27):
E/E0 and the in-plane ν* as functions of α = k_s/k_n.

A unit square of plane Voronoi cells (mesh/voronoi_plane.py, min_spacing
0.5, moment spring points), size 1/32 (about 1 000 cells), seeds 1, 2, 3,
uniaxial stress along x and y (rbsm_dyn.stiffness.uniaxial_moduli, the
strain fitted over the central half); the mean of the 6 samples and their
spread.  Plane stress and strain share the table (it is in E*, ν*).

    python benchmarks/calibrate_plane.py
"""
import dataclasses

import numpy as np

from rbsm_dyn.case import load_case_text
from rbsm_dyn.model import build_model
from rbsm_dyn.stiffness import uniaxial_moduli

ALPHAS = (1.2, 1.1, 1.0, 0.9, 0.8, 0.7, 0.6, 0.5, 0.4, 0.3, 0.2, 0.1)


def model(seed):
    return build_model(load_case_text(f"""
name: cal
plane: {{kind: stress, thickness: 1.0}}
domain: {{box: [[0, 0], [1, 1]]}}
mesh: {{kind: voronoi, size: {1 / 32}, seed: {seed}}}
materials: {{m: {{density: 1000, young: 1.0, poisson: 0.0, stiffness: kawai}}}}
solver: {{mode: linear}}
"""))


def main():
    models = [model(s) for s in (1, 2, 3)]
    print("# alpha, E/E0, nu          (± over 3 seeds × 2 axes)")
    for a in ALPHAS:
        E, nu = [], []
        for m in models:
            k = m.face_k.copy()
            k[:, 1] = a * k[:, 0]
            k[:, 2] = a * k[:, 0]
            e, v = uniaxial_moduli(dataclasses.replace(m, face_k=k))
            E += list(e)
            nu += list(v)
        E, nu = np.array(E), np.array(nu)
        print(f"    [{a:.2f}, {E.mean():.4f}, {nu.mean():.4f}],   "
              f"# ± {E.std():.4f}, ± {nu.std():.4f}")


if __name__ == "__main__":
    main()
