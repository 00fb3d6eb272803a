"""Measure the effective elastic constants of the RBSM lattices
(DESIGN.md §1, VERIFICATION.md "General"; method in docs/calibration.md).

    python benchmarks/calibrate.py alpha [--cells 1000] [--seeds 1 2 3]
        E_eff/E0 and ν_eff against α = k_s/k_n for the Voronoi generator
        (min_spacing 0.5) and the block mesh; prints the rows for
        rbsm_dyn/calibration.py VORONOI_TABLE.
    python benchmarks/calibrate.py aux [--cells 1000] [--seeds 1 2 3]
        E_eff/E0 and ν_eff of the α = 1 Voronoi lattice plus the auxiliary
        stress λ = β E0 of the Poisson correction (physics/poisson.py)
        against β; prints the rows for VORONOI_AUX_TABLE.
    python benchmarks/calibrate.py check [--cells 1000] [--seeds 1 2 3]
            [--rules kawai calibrated homogeneous] [--nu 0 0.1 0.2 0.3 0.45]
        E_eff/E and ν_eff for each mesh kind under the stiffness rules
        (through the ordinary Case -> Model path); ν is skipped where a rule
        cannot reach it.

Specimen: the unit cube, about `--cells` cells (Voronoi size = cells^(-1/3);
blocks n × n × n), no supports; uniaxial stress along x, y and z in turn
(rbsm_dyn.stiffness.uniaxial_moduli: uniform end tractions, strain from the
displacement fit over the central half).  Each value is the mean over the
seeds and the three axes; ± is the standard deviation of those samples.
"""
import argparse
import dataclasses
import time

import numpy as np

from rbsm_dyn.calibration import stiffness_rule
from rbsm_dyn.case import load_case_text
from rbsm_dyn.model import build_mesh, build_model
from rbsm_dyn.stiffness import stiffness_matrix, uniaxial_moduli

E_REF = 200.0e9
CASE = """\
name: calibrate
domain: {{box: [[0, 0, 0], [1.0, 1.0, 1.0]]}}
mesh: {mesh}
materials:
  m: {{density: 8000, young: {young!r}, poisson: {poisson!r}, stiffness: {rule}}}
solver: {{mode: static}}
"""


def mesh_yaml(kind, cells, seed):
    if kind == "blocks":
        n = round(cells ** (1 / 3))
        return f"{{kind: blocks, divisions: [{n}, {n}, {n}]}}"
    return f"{{kind: voronoi, size: {cells ** (-1 / 3)!r}, seed: {seed}}}"


def case_for(kind, cells, seed, young=E_REF, poisson=0.0, rule="calibrated"):
    return load_case_text(CASE.format(mesh=mesh_yaml(kind, cells, seed), young=young,
                                      poisson=poisson, rule=rule), "calibrate.yaml")


def split_stiffness(model):
    """K_n and K_s per unit E0 and α: K(E0, α) = E0 (K_n + α K_s), from a
    single-material model (face_k = E0 (1/h) (1, α, α))."""
    mat = model.materials[0]
    k = model.face_k / mat["e0"]
    kn = stiffness_matrix(dataclasses.replace(model, face_k=k * [1.0, 0.0, 0.0]))
    ks = stiffness_matrix(dataclasses.replace(model, face_k=k * [0.0, 1.0, 1.0] / mat["alpha"]))
    return kn, ks


def alpha_sweep(args):
    alphas = np.round(np.arange(0.0, 1.2001, 0.1), 10)
    print(f"# uniaxial stress, unit cube, ~{args.cells} cells, seeds {args.seeds}, "
          f"core {args.core}, interior {args.interior}")
    for kind in ("voronoi", "blocks"):
        seeds = args.seeds if kind == "voronoi" else [0]
        samples = {a: ([], [], []) for a in alphas}
        for seed in seeds:
            t0 = time.perf_counter()
            # Kawai's rule at ν = 0 (E0 = E, α = 0.5): independent of the stored table
            model = build_model(case_for(kind, args.cells, seed, rule="kawai"))
            kn, ks = split_stiffness(model)
            for a in alphas:
                if kind == "blocks" and a == 0.0:
                    continue        # k_s = 0: the cubic lattice has a shear mechanism
                E, nu = uniaxial_moduli(model, core=args.core, K=kn + a * ks)
                samples[a][0].extend(E)
                samples[a][1].extend(nu)
                if args.interior:
                    samples[a][2].extend(uniaxial_moduli(model, core=args.core, K=kn + a * ks,
                                                         interior=True)[1])
            print(f"# {kind} seed {seed}: {model.n_bodies} cells, {model.n_springs} spring "
                  f"points, {time.perf_counter() - t0:.1f} s")
        what = "nu of the interior (section: " if args.interior else "nu ("
        print(f"\n{kind}: alpha, E/E0, {what}mean ± std over {len(seeds)} seed(s) × 3 axes)")
        for a in alphas:
            E, nu, nu_in = map(np.array, samples[a])
            if len(E):
                if args.interior:
                    print(f"    [{a:.2f}, {E.mean():.4f}, {nu_in.mean():.4f}],   "
                          f"# ± {E.std():.4f}, ± {nu_in.std():.4f}; section nu {nu.mean():.4f}")
                else:
                    print(f"    [{a:.2f}, {E.mean():.4f}, {nu.mean():.4f}],   "
                          f"# ± {E.std():.4f}, ± {nu.std():.4f}")


BETAS = [0.0, 0.1, 0.2, 0.3, 0.4, 0.5, 0.6, 0.8, 1.0, 1.25, 1.5, 2.0, 2.5, 3.0, 3.5, 4.0,
         4.5, 5.0, 5.5, 6.0, 7.0, 8.0, 10.0, 12.0, 14.0, 16.0]


def aux_sweep(args):
    """E_eff/E0, ν_eff against β = λ/E0 at α = 1: K(β) = E0 (K_1 + β K_aux),
    K_1 the α = 1 lattice per unit E0, K_aux the auxiliary term per unit λ."""
    from rbsm_dyn.physics.poisson import poisson_stiffness
    print(f"# uniaxial stress, unit cube, ~{args.cells} cells, seeds {args.seeds}, "
          f"core {args.core}; alpha = 1 plus auxiliary stress lambda = beta E0")
    betas = args.betas or BETAS
    samples = {b: ([], []) for b in betas}
    for seed in args.seeds:
        t0 = time.perf_counter()
        # the homogeneous rule at ν = 0.3: α = 1 and the Poisson arrays built
        model = build_model(case_for("voronoi", args.cells, seed, poisson=0.3,
                                     rule="homogeneous"))
        aux = model.poisson
        k1 = stiffness_matrix(dataclasses.replace(
            model, face_k=model.face_k / model.materials[0]["e0"], poisson=None))
        kaux = poisson_stiffness(aux._replace(cell_lv=model.body_volume.copy()),
                                 model.n_bodies)
        for b in betas:
            E, nu = uniaxial_moduli(model, core=args.core, K=k1 + b * kaux,
                                    interior=args.interior)
            samples[b][0].extend(E)
            samples[b][1].extend(nu)
        print(f"# voronoi seed {seed}: {model.n_bodies} cells, {len(aux.slot_cell)} slots, "
              f"{time.perf_counter() - t0:.1f} s")
    print(f"\nvoronoi aux: beta, E/E0, nu  (mean ± std over {len(args.seeds)} seed(s) × 3 axes)")
    for b in betas:
        E, nu = map(np.array, samples[b])
        print(f"    [{b:.2f}, {E.mean():.4f}, {nu.mean():.4f}],   "
              f"# ± {E.std():.4f}, ± {nu.std():.4f}")


def check(args):
    print(f"# uniaxial stress, unit cube, ~{args.cells} cells, Voronoi seeds {args.seeds}")
    print("| mesh | stiffness | target ν | E0/E | α | λ_aux/E | E_eff/E | ν_eff |")
    print("|---|---|---|---|---|---|---|---|")
    for kind in ("blocks", "voronoi"):
        seeds = args.seeds if kind == "voronoi" else [0]
        meshes = {s: build_mesh(case_for(kind, args.cells, s)) for s in seeds}
        for rule in args.rules:
            for nu_t in args.nu:
                Es, nus = [], []
                try:
                    stiffness_rule(rule, kind, E_REF, nu_t)
                except ValueError:
                    continue
                for s in seeds:
                    case = case_for(kind, args.cells, s, poisson=nu_t, rule=rule)
                    model = build_model(case, meshes[s])
                    E, nu = uniaxial_moduli(model, core=args.core, interior=args.interior)
                    Es.extend(E / E_REF)
                    nus.extend(nu)
                mat = model.materials[0]
                print(f"| {kind} | {rule} | {nu_t} | {mat['e0'] / E_REF:.4f} | "
                      f"{mat['alpha']:.4f} | {mat['lambda_aux'] / E_REF:.4f} | "
                      f"{np.mean(Es):.4f} ± {np.std(Es):.4f} | "
                      f"{np.mean(nus):.4f} ± {np.std(nus):.4f} |")


def main():
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("what", choices=["alpha", "aux", "check"])
    p.add_argument("--rules", nargs="+", default=["kawai", "calibrated"],
                   choices=["kawai", "calibrated", "homogeneous"])
    p.add_argument("--cells", type=int, default=1000)
    p.add_argument("--seeds", type=int, nargs="+", default=[1, 2, 3])
    p.add_argument("--core", type=float, default=0.25,
                   help="fraction of the length trimmed at each loaded end for the fit")
    p.add_argument("--interior", action="store_true",
                   help="ν from the fit over the central part along every axis (the bulk: "
                        "away from the free lateral surface too) instead of the whole "
                        "cross-section (alpha: E/E0 stays the section's; aux, check: both)")
    p.add_argument("--nu", type=float, nargs="+", default=[0.0, 0.1, 0.2])
    p.add_argument("--betas", type=float, nargs="+", default=None,
                   help="aux: the β = λ/E0 to measure (default: the table's rows)")
    args = p.parse_args()
    t0 = time.perf_counter()
    {"alpha": alpha_sweep, "aux": aux_sweep, "check": check}[args.what](args)
    print(f"# {time.perf_counter() - t0:.0f} s")


if __name__ == "__main__":
    main()
