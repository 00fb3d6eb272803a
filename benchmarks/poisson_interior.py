"""Interior Poisson ratio of a Voronoi cube under uniaxial stress, two ways
(issue 30):

(a) the calibration's load: uniform end tractions on free ends
    (rbsm_dyn.stiffness.uniaxial_moduli, docs/calibration.md "Method");
(b) as a user writes it: a case file with the bottom face on rollers
    (`{face: zmin, fix: [z]}`, support springs), the top face's cells pressed
    down by a prescribed z displacement (`{surface: zmax, displacement:
    [null, null, -d]}`, the other components free), the lateral faces free,
    one cell at the bottom centre held in x, y, rz against rigid motion;
    stress = reaction of the top cells / area.

Both fit the strain the same way, the volume-weighted least-squares fit
u ≈ u0 + G x of the centroid displacements, over two regions: 'section',
the cells whose centroids lie in the middle half of the loaded length, all
across (the calibration's fit until 2026-11-27), and 'interior', the cells
in the middle half along every axis (the issue's measurement).

    python benchmarks/poisson_interior.py [--cells 1000] [--seeds 23] [--nu 0.2 0.3]
        [--core 0.25] [--stiffness calibrated] [--cli] [--variants]

--variants: where the two part, load along z only, ν of both fits for:
tractions on both ends; support springs below and traction on top; traction
below and the top cells prescribed (plane top); prescribed uz on both end
layers; the user's rollers; the rollers with the top cells prescribed
uz = ε z_c (the uniform strain's own displacement, not a plane).
"""
import argparse
import os
import subprocess
import sys
import tempfile
import time

import numpy as np

from rbsm_dyn.case import load_case_text
from rbsm_dyn.model import build_mesh, build_model
from rbsm_dyn.physics.integrate import DISPLACEMENT, FIXED, FREE
from rbsm_dyn.stiffness import solve_linear, stiffness_matrix, uniaxial_moduli

E = 30.0e9
D = 1.0e-4          # top displacement [m] (strain 1e-4 on the unit cube)

TRACTION = """\
name: nu-traction
domain: {{box: [[0, 0, 0], [1, 1, 1]]}}
mesh: {{kind: voronoi, size: {size!r}, seed: {seed}}}
materials:
  m: {{density: 2400, young: {E!r}, poisson: {nu!r}{extra}}}
solver: {{mode: static}}
"""

ROLLERS = """\
name: nu-rollers
domain: {{box: [[0, 0, 0], [1, 1, 1]]}}
mesh: {{kind: voronoi, size: {size!r}, seed: {seed}}}
materials:
  m: {{density: 2400, young: {E!r}, poisson: {nu!r}{extra}}}
groups:
  pin: {{box: [{pin_lo}, {pin_hi}]}}
boundary:
  - {{face: zmin, fix: [z]}}
  - {{surface: zmax, displacement: [null, null, {d!r}]}}
  - {{group: pin, fix: [x, y, rz]}}
solver: {{mode: static, load_steps: 1}}
output:
  file: {out}
"""


def fit_strain(x, u, w, axis, lo, hi, core, interior=False):
    """Symmetric part of the volume-weighted LSQ fit u ≈ u0 + G x over the
    cells with centroids in the central part of [lo, hi] along `axis` (all
    across the section), or, `interior`, in the central part along every axis."""
    length = hi - lo
    axes = range(3) if interior else [axis]
    sel = np.ones(len(x), bool)
    for k in axes:
        sel &= (x[:, k] >= lo + core * length) & (x[:, k] <= hi - core * length)
    A = np.hstack([np.ones((sel.sum(), 1)), x[sel]])
    sw = np.sqrt(w[sel])[:, None]
    coef, *_ = np.linalg.lstsq(A * sw, u[sel] * sw, rcond=None)
    G = coef[1:].T
    return 0.5 * (G + G.T)


def rollers_case(size, seed, nu, extra="", out="nu.h5", x=None):
    # the pin: the cell nearest the bottom centre (its centroid's box)
    c = x[np.argmin(np.linalg.norm(x - [0.5, 0.5, 0.0], axis=1))]
    lo = [float(v) - 1e-9 for v in c]
    hi = [float(v) + 1e-9 for v in c]
    return ROLLERS.format(size=size, seed=seed, E=E, nu=nu, extra=extra, d=-D,
                          pin_lo=lo, pin_hi=hi, out=out)


def rollers_moduli(model, core, interior):
    """(E, ν) of the user-style specimen by the linear solve of the case's own
    supports and prescribed displacements (what the static solver converges
    to for an elastic model); the stress is the top cells' reaction / area."""
    n = model.n_bodies
    U, R = solve_linear(model)
    x = model.body_pos0[:n]
    eps = fit_strain(x, U[:, :3], model.body_volume, 2, 0.0, 1.0, core, interior)
    top = model.dof_kind[:, 2] == DISPLACEMENT
    sigma = R[top, 2].sum() / 1.0            # force on the top cells / area 1 m²
    return sigma / eps[2, 2], -(eps[0, 0] + eps[1, 1]) / (2 * eps[2, 2])


def main():
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--cells", type=int, nargs="+", default=[1000])
    p.add_argument("--seeds", type=int, nargs="+", default=[23])
    p.add_argument("--nu", type=float, nargs="+", default=[0.2, 0.3])
    p.add_argument("--core", type=float, default=0.25)
    p.add_argument("--stiffness", default="calibrated")
    p.add_argument("--variants", action="store_true",
                   help="also the boundary-condition variants (z load) of the docstring")
    p.add_argument("--cli", action="store_true",
                   help="also run the rollers case by `python -m rbsm_dyn` (static)")
    args = p.parse_args()
    extra = f", stiffness: {args.stiffness}"
    print(f"# unit cube, E = {E:.3g} Pa, stiffness {args.stiffness}, core {args.core}; "
          "'section': fit over the middle part of the length, all cells across; "
          "'interior': middle part along every axis. Traction: mean of 3 axes.")
    print("| cells | seed | ν | α | λ_aux/E | traction E/E section | traction ν section "
          "| traction E/E interior | traction ν interior | rollers E/E section | rollers ν section "
          "| rollers E/E interior | rollers ν interior | CLI ν interior |")
    print("|---|---|---|---|---|---|---|---|---|---|---|---|---|---|")
    for cells in args.cells:
        size = cells ** (-1 / 3)
        for seed in args.seeds:
            t0 = time.perf_counter()
            mesh = build_mesh(load_case_text(TRACTION.format(size=size, seed=seed, E=E, nu=0.0,
                                                             extra=""), "t.yaml"))
            x = mesh.cell_centroid
            for nu in args.nu:
                tm = build_model(load_case_text(TRACTION.format(size=size, seed=seed, E=E, nu=nu,
                                                                extra=extra), "t.yaml"), mesh)
                K = stiffness_matrix(tm)
                Es, nus = uniaxial_moduli(tm, core=args.core, K=K)
                Ei, nui = uniaxial_moduli(tm, core=args.core, K=K, interior=True)
                rm = build_model(load_case_text(rollers_case(size, seed, nu, extra, x=x),
                                                "r.yaml"), mesh)
                Er, nur = rollers_moduli(rm, args.core, False)
                Eri, nuri = rollers_moduli(rm, args.core, True)
                cli = f"{cli_nu(size, seed, nu, extra, x, args.core):.4f}" if args.cli else ""
                mat = tm.materials[0]
                print(f"| {mesh.n_cells} | {seed} | {nu} | {mat['alpha']:.3f} | "
                      f"{mat['lambda_aux'] / E:.3f} | {Es.mean() / E:.4f} | {nus.mean():.4f} | "
                      f"{Ei.mean() / E:.4f} | {nui.mean():.4f} | {Er / E:.4f} | {nur:.4f} | "
                      f"{Eri / E:.4f} | {nuri:.4f} | {cli} |", flush=True)
                if args.variants:
                    variants(tm, rm, K, args.core)
            print(f"# {time.perf_counter() - t0:.0f} s", flush=True)


def variants(tm, rm, K, core):
    """ν (section, interior) of the z-loaded cube under the boundary-condition
    variants of the docstring (linear solves; tm without supports, rm the
    rollers case)."""
    mesh = tm.mesh
    n = tm.n_bodies
    x = tm.body_pos0[:n]
    w = tm.body_volume
    top = np.unique(mesh.bface_cell[mesh.bface_side == 5])
    bot = np.unique(mesh.bface_cell[mesh.bface_side == 4])
    is_top = np.isin(np.arange(n), top)[:, None]
    is_bot = np.isin(np.arange(n), bot)[:, None]
    pin = int(np.argmin(np.linalg.norm(x - [0.5, 0.5, 0.0], axis=1)))
    # uniform end tractions ±σ e_z at the boundary faces' centroids (as uniaxial_moduli)
    load = np.zeros((n, 6))
    for side, sgn in ((4, -1.0), (5, 1.0)):
        sel = mesh.bface_side == side
        cell = mesh.bface_cell[sel]
        f = np.zeros((sel.sum(), 3))
        f[:, 2] = sgn * mesh.bface_area[sel]
        np.add.at(load[:, :3], cell, f)
        np.add.at(load[:, 3:], cell, np.cross(mesh.bface_centroid[sel] - x[cell], f))

    def show(name, U):
        nus = []
        for interior in (False, True):
            e = fit_strain(x, U[:, :3], w, 2, 0.0, 1.0, core, interior)
            nus.append(-(e[0, 0] + e[1, 1]) / (2 * e[2, 2]))
        print(f"#   {name:48s} ν section {nus[0]:.4f}, interior {nus[1]:.4f}")

    free = np.zeros((n, 6), dtype=np.int8)
    zero = np.zeros((n, 6))
    kind = free.copy()
    kind[int(np.argmin(np.linalg.norm(x - 0.5, axis=1)))] = FIXED
    show("tractions on both ends", solve_linear(tm, load, K=K, kind=kind, value=zero)[0])
    kind = rm.dof_kind.copy()
    kind[kind == DISPLACEMENT] = FREE
    show("support springs below, traction on top", solve_linear(rm, -load * is_top, kind=kind,
                                                                 value=zero)[0])
    kind, val = free.copy(), zero.copy()
    kind[top, 2], val[top, 2] = DISPLACEMENT, -D
    kind[pin, [0, 1, 5]] = FIXED
    show("traction below, top cells prescribed uz", solve_linear(
        tm, -load * is_bot * (D * E), K=K, kind=kind, value=val)[0])
    kind[bot, 2] = FIXED
    show("prescribed uz on both end layers", solve_linear(tm, zero, K=K, kind=kind,
                                                           value=val)[0])
    show("rollers (the user's case)", solve_linear(rm)[0])
    val = rm.dof_value.copy()
    val[top, 2] = -D * x[top, 2]
    show("rollers, top cells uz = ε z_c (affine)", solve_linear(rm, zero, value=val)[0])


def cli_nu(size, seed, nu, extra, x, core):
    """Interior ν of the rollers case run as a user runs it (static solver,
    last frame)."""
    import h5py
    with tempfile.TemporaryDirectory() as tmp:
        out = os.path.join(tmp, "nu.h5")
        path = os.path.join(tmp, "nu.yaml")
        with open(path, "w") as f:
            f.write(rollers_case(size, seed, nu, extra, out=out, x=x))
        subprocess.run([sys.executable, "-m", "rbsm_dyn", path], check=True,
                       capture_output=True, cwd=tmp)
        with h5py.File(out, "r") as h:
            b = h["particles/bodies"]
            pos0 = b["reference_position"][:]
            pos = b["position/value"][-1]
            vol = b["volume"][:]
    eps = fit_strain(pos0, pos - pos0, vol, 2, 0.0, 1.0, core, True)
    return -(eps[0, 0] + eps[1, 1]) / (2 * eps[2, 2])


if __name__ == "__main__":
    main()
