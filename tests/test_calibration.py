"""Effective elastic constants of the meshes under the stiffness rules.

# VERIFICATION General: "Calibrate per mesh kind, measure E and ν, publish
# the table"; "On a cubic block lattice uniaxial stress sees only k_n, so
# E_eff = E0 and ν_eff = 0 whatever α"; Kawai's eq. 13 "measured on 1 000
# Voronoi cells (uniaxial, roller ends) gives E = 0.78E, ν = 0.12" at ν = 0.

The calibrated default must give the target E within 3 % and ν within 0.02
for ν = 0, 0.1, 0.2 (issue requirement) on a Voronoi mesh that was not used
for the calibration (seed 11; the table in rbsm_dyn/calibration.py was
measured on seeds 1, 2, 3 by benchmarks/calibrate.py).  Measurement:
rbsm_dyn.stiffness.uniaxial_moduli (uniform end tractions, strain from the
displacement fit over the central half, docs/calibration.md), averaged over
the three loading axes.
"""
import numpy as np
import pytest

from rbsm_dyn.calibration import VORONOI_TABLE, calibrated_pair, kawai_pair
from rbsm_dyn.case import load_case_text
from rbsm_dyn.model import build_mesh, build_model
from rbsm_dyn.stiffness import uniaxial_moduli

E = 200.0e9


def case(mesh, poisson, stiffness="calibrated"):
    return load_case_text(f"""
name: calibration-check
domain: {{box: [[0, 0, 0], [1.0, 1.0, 1.0]]}}
mesh: {mesh}
materials:
  m: {{density: 8000, young: {E}, poisson: {poisson}, stiffness: {stiffness}}}
solver: {{mode: static}}
""", "t.yaml")


VORONOI = "{kind: voronoi, size: 0.1111111111111111, seed: 11}"   # 729 cells
BLOCKS = "{kind: blocks, divisions: [8, 8, 8]}"


@pytest.fixture(scope="module")
def voronoi_mesh():
    return build_mesh(case(VORONOI, 0.0))


def moduli(mesh_yaml, mesh, poisson, stiffness="calibrated"):
    model = build_model(case(mesh_yaml, poisson, stiffness), mesh)
    E_eff, nu_eff = uniaxial_moduli(model)
    return E_eff.mean(), nu_eff.mean()


@pytest.mark.parametrize("nu", [0.0, 0.1, 0.2])
def test_calibrated_voronoi_reproduces_E_and_nu(voronoi_mesh, nu):
    assert 600 <= voronoi_mesh.n_cells <= 1000
    E_eff, nu_eff = moduli(VORONOI, voronoi_mesh, nu)
    assert E_eff == pytest.approx(E, rel=0.03)
    assert nu_eff == pytest.approx(nu, abs=0.02)


def test_kawai_voronoi_is_soft_as_published(voronoi_mesh):
    # VERIFICATION General: Kawai's eq. 13 at ν = 0 gives E = 0.78E, ν = 0.12
    E_eff, nu_eff = moduli(VORONOI, voronoi_mesh, 0.0, "kawai")
    assert E_eff == pytest.approx(0.78 * E, rel=0.03)
    assert nu_eff == pytest.approx(0.12, abs=0.02)


def test_blocks_see_only_k_n():
    # VERIFICATION General: E_eff = E0 and ν_eff = 0 whatever α
    mesh = build_mesh(case(BLOCKS, 0.0))
    E_eff, nu_eff = moduli(BLOCKS, mesh, 0.0)                 # calibrated, α = 1
    assert E_eff == pytest.approx(E, rel=0.005)
    assert abs(nu_eff) <= 1e-6
    # Kawai at ν = 0.2: E0 = E' = (1−ν)E/((1+ν)(1−2ν)) = 1.1111 E, α = 0.375
    e_prime, alpha = kawai_pair(E, 0.2)
    assert alpha == pytest.approx(0.375)
    E_eff, nu_eff = moduli(BLOCKS, mesh, 0.2, "kawai")
    assert E_eff == pytest.approx(e_prime, rel=0.005)
    assert abs(nu_eff) <= 1e-6


def test_table_is_monotone_and_reaches_nu_0_to_0_25():
    alpha, ratio, nu = VORONOI_TABLE.T
    order = np.argsort(alpha)
    # more shear stiffness: stiffer, less lateral contraction
    assert np.all(np.diff(ratio[order]) > 0)
    assert np.all(np.diff(nu[order]) < 0)
    # DESIGN.md §1: α ≥ 0 reaches ν ≈ 0.25; ν = 0 must be inside the table
    assert nu.min() <= 0.0 and nu.max() >= 0.25


def test_unreachable_nu_names_the_reachable_range():
    nu_max = VORONOI_TABLE[:, 2].max()
    with pytest.raises(ValueError, match=r"reaches ν in \[") as exc:
        calibrated_pair("voronoi", E, nu_max + 0.01)
    assert f"{nu_max:.3f}" in str(exc.value)
