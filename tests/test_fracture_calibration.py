"""Fracture calibration (rbsm_dyn/fracture_calibration.py, docs/calibration.md
"Fracture"): with the material's f_t and G_f given (`rupture.values:
material`, the default) a Voronoi lattice dissipates G_f per unit of
projected crack area in a notched tension specimen, at two cell sizes, and
a homogeneous specimen fails at f_t (issue 11).  Each figure is the mean of
meshes whose seeds are not among those of the calibration table (1-16,
101-148): 32 for G_f at 2 mm cells (seeds 17-48), 16 at 1.6 mm (17-32),
two for f_t (17, 18).  Tolerances: f_t within 5 % (one specimen scatters by
±1 %); G_f within 5 % (the issue's figure), about twice the standard
deviation of these means with the table's own uncertainty: one specimen
scatters by ±11 % (2 mm, 8 cells across) and ±9 % (1.6 mm, 10 cells) with
its crack path, the table by ±1.4 % (2·√(0.11²/32 + 0.014²) = 0.045,
2·√(0.09²/16 + 0.014²) = 0.050; docs/calibration.md, "Fracture")."""
import numpy as np
import pytest

from rbsm_dyn.fracture_calibration import brittleness, fracture_ratios, tension_specimen

E, FT = 30.0e9, 3.0e6          # concrete-like; only β = l_ch/Δ matters
GF = 1.8                       # J/m²: l_ch = E G_f/f_t² = 6 mm
GF_NU02 = 4.8                  # J/m² at ν = 0.2: β = 8 on 2 mm cells
SEEDS = {0.002: range(17, 49), 0.0016: range(17, 33)}   # out of the table's sample
FT_SEEDS = (17, 18)
W = 0.016                      # specimen width [m]


def test_brittleness_is_hillerborgs_length_over_the_cell():
    """β = E G_f/(f_t² Δ) (Hillerborg, Modéer & Petersson 1976); blocks
    need no calibration."""
    assert brittleness(E, GF, FT, 0.002) == pytest.approx(3.0, rel=1e-12)
    assert fracture_ratios("blocks", E, GF, FT, 0.002) == (1.0, 1.0)


def balance_error(h):
    ob = h.observables
    balance = (ob["kinetic"] + ob["strain"] + ob["plastic"] + ob["fracture"] + ob["damping"]
               - ob["external_work"])
    return np.abs(balance).max() / ob["external_work"].max()


@pytest.mark.parametrize("cell, poisson, gf", [(0.002, 0.0, GF), (0.0016, 0.0, GF),
                                              (0.002, 0.2, GF_NU02)])
def test_notched_specimen_dissipates_gf_per_projected_area(run_case, cell, poisson, gf):
    """Double-edge-notched prism (half the width cut) pulled apart: the
    fracture dissipation at full separation is G_f × ligament area (the
    projected crack area) within 5 % (mean of 32 meshes at 2 mm, 16 at
    1.6 mm), at two cell sizes (β = 3 and 3.75) and at ν = 0.2 (β = 8,
    whose springs' α = k_s/k_n = 0.27 dissipate 3-10 % more per broken
    face area than ν = 0's: F_G per α, fracture_calibration.VORONOI_ENERGY);
    the energy balance closes within 1 % of the work in each run.  Each run
    ends at two ramp times (the calibration ran three; separation is
    checked on each run), with twelve frames (the test reads the last and
    the one at 3/4)."""
    dissipated = []
    for seed in SEEDS[cell]:
        text, area, gf = tension_specimen(cell=cell, cells_across=round(W / cell), notch=0.5,
                                          young=E, tensile_strength=FT, fracture_energy=gf,
                                          poisson=poisson, seed=seed, ramps=2, frames=12)
        h = run_case(text)
        wf = h.observables["fracture"]
        # separated: the last quarter of the run adds little to the dissipation
        assert wf[-1] - wf[3 * len(wf) // 4] < 5e-2 * wf[-1]
        dissipated.append(wf[-1] / area)
        assert balance_error(h) <= 1e-2
    assert np.mean(dissipated) == pytest.approx(gf, rel=0.05)


@pytest.mark.parametrize("poisson, beta", [(0.0, 3.0), (0.2, 20.0), (0.3, 10.0)])
def test_direct_tension_strength_is_ft(run_case, poisson, beta):
    """A prism in uniaxial tension carries at most f_t (peak reaction over
    the section) within 5 %; the energy balance closes within 1 %.  At ν =
    0.2 (α = k_s/k_n = 0.27) and a concrete's brittleness the ν = 0 ratio
    gave 0.93 f_t (issue 31): F_T is calibrated per α, and with the Poisson
    correction (ν = 0.3) per ν (fracture_calibration.VORONOI_TENSION)."""
    peak = []
    gf = beta * 0.002 * FT ** 2 / E
    for seed in FT_SEEDS:
        text, area, gf = tension_specimen(cell=0.002, cells_across=round(W / 0.002), notch=0.0,
                                          young=E, tensile_strength=FT, fracture_energy=gf,
                                          seed=seed, poisson=poisson)
        h = run_case(text)
        peak.append(np.abs(h.observables["F"]).max() / W ** 2)
        assert balance_error(h) <= 1e-2
    assert np.mean(peak) == pytest.approx(FT, rel=0.05)


# plane (issue 27): a plane-stress notched plate 40 mm wide at two cell sizes
PLANE_GF = 9.0                  # J/m²: l_ch = 30 mm, β = 6 (5 mm cells) and 12 (2.5 mm)
PLANE_W = 0.04
PLANE_SEEDS = range(101, 229)   # 128 meshes, out of the table's sample (seeds 1-64)


@pytest.mark.parametrize("cell", [0.005, 0.0025])
def test_plane_notched_specimen_dissipates_gf(run_case, cell):
    """Plane stress (fracture_calibration.PLANE_VORONOI_FRACTURE): a
    double-edge-notched plate 40 mm wide, half of it cut, pulled apart
    dissipates G_f per unit of projected crack length × thickness within
    5 % (the issue's figure) on the mean of 128 meshes, at 8 and 16 cells
    across (β = 6 and 12: the table was measured at 16 across and 2 mm
    cells, seeds 1-64).  One plane specimen scatters by ±0.3 (a crack that
    wanders or branches dissipates up to twice the median), the mean of
    128 by ±0.019-0.026; measured 2026-11-28: 1.021 (β = 6), 1.041 (β =
    12).  The runs are the calibration's (three ramp times): on the whole
    they have separated (the last quarter of the run adds < 2 % of the
    dissipation on the mean, measured 0.5-0.8 %; a branching crack of one
    mesh still adds up to 20 %), and each closes its energy balance within 1 % of the work."""
    dissipated, late = [], []
    for seed in PLANE_SEEDS:
        text, area, gf = tension_specimen(cell=cell, cells_across=round(PLANE_W / cell),
                                          notch=0.5, young=E, tensile_strength=FT,
                                          fracture_energy=PLANE_GF, plane=True, seed=seed,
                                          frames=12)
        h = run_case(text)
        wf = h.observables["fracture"]
        late.append((wf[-1] - wf[3 * len(wf) // 4]) / wf[-1])
        dissipated.append(wf[-1] / area)
        assert balance_error(h) <= 1e-2
    assert np.mean(late) < 0.02
    assert np.mean(dissipated) == pytest.approx(PLANE_GF, rel=0.05)
