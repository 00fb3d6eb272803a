"""Concrete by its compressive strength (issue 31 item 1, in part;
compression_calibration.py): `rupture.compressive_strength` f_c, which
`{model: concrete, fc}` fills in, sets the mixed-mode law's shear strength
so that a Voronoi specimen under uniaxial compression fails at f_c.

The specimen: a prism 40 × 40 × 80 mm (h = 2b, as a standard cylinder)
between rigid frictionless platens, pushed at a strain rate of 2 /s (the
peak comes after about 25 wave transits of the prism; the law has no rate
effect unless `rate` is given), at 6 and 8 cells across: a different
specimen (size, cells across, rate) from the 50 mm prisms the table was
measured on."""
import numpy as np
import pytest

from rbsm_dyn.__main__ import main
from rbsm_dyn.case import load_case_text
from rbsm_dyn.calibration import stiffness_rule
from rbsm_dyn.compression_calibration import (TABLE_BRITTLENESS, VORONOI_COMPRESSION,
                                              compression_specimen, shear_ratio)
from rbsm_dyn.fracture_calibration import voronoi_tension_ratio

FC = 40.0e6
WIDTH = 0.04


def test_the_preset_gives_its_compressive_strength():
    """`{model: concrete, fc}` fills compressive_strength = f_cm (unless the
    shear strength or the compressive strength is given)."""
    text = compression_specimen(cell=0.01, width=WIDTH, fc=FC)
    case = load_case_text(text)
    assert case.materials["concrete"].rupture.compressive_strength == FC
    given = load_case_text(text.replace(f"fc: {FC!r}}}",
                                        f"fc: {FC!r}, rupture: {{shear_strength: 9.0e6}}}}"))
    r = given.materials["concrete"].rupture
    assert r.compressive_strength is None and r.shear_strength == 9.0e6


def test_shear_ratio_inverts_the_table():
    """Each measured point maps back to its ratio; beyond the lattice's
    reach the ratio is the table's end and a note says what the specimen
    will reach; a block mesh keeps 2 f_t, with a note."""
    for r, c in VORONOI_COMPRESSION:
        assert shear_ratio("voronoi", c * 3.0e6, 3.0e6) == (pytest.approx(r, rel=1e-12), None)
    r, note = shear_ratio("voronoi", 20 * 3.0e6, 3.0e6)
    assert r == VORONOI_COMPRESSION[-1, 0] and "above" in note and "MPa" in note
    r, note = shear_ratio("blocks", FC, 3.0e6)
    assert r == 2.0 and "blocks" in note


ENERGY = "fracture_energy: 140.0, tensile_strength: 3.0e6, "


@pytest.mark.parametrize("rupture, words", [
    (ENERGY + "shear_strength: 9.0e6, compressive_strength: 40.0e6", ["not both"]),
    (ENERGY + "compressive_strength: 40.0e6, values: spring", ["values: material"]),
    (ENERGY + "compressive_strength: 40.0e6, law: tension", ["law tension"]),
    ("strain: 1.0e-3, compressive_strength: 40.0e6", ["rupture strain"])])
def test_bad_compressive_strength_is_refused(tmp_path, capsys, rupture, words):
    """Exit 2 naming the key and why."""
    text = compression_specimen(cell=0.01, width=WIDTH).replace(
        f"{{model: concrete, fc: {FC!r}}}",
        "{density: 2400, young: 34.0e9, poisson: 0.2, rupture: {" + rupture + "}}")
    case = tmp_path / "bad.yaml"
    case.write_text(text, encoding="utf-8")
    assert main(["check", str(case)]) == 2
    err = capsys.readouterr().err
    assert "compressive_strength" in err
    for w in words:
        assert w in err


@pytest.mark.parametrize("cell", [WIDTH / 6, WIDTH / 8])
def test_uniaxial_compression_fails_at_fc(run_case, cell):
    """The prism on frictionless platens fails at f_c within 10 % (the
    issue's tolerance; the table's two sizes are 3-7 % apart), having
    first loaded at the modulus E (within 15 %: platen contact and
    the calibrated lattice's E); the energy balance closes within 1 % of
    the work."""
    h = run_case(compression_specimen(cell=cell, width=WIDTH, fc=FC, rate=2.0, frames=150))
    ob = h.observables
    stress = -np.asarray(ob["F"]) / WIDTH ** 2
    strain = -np.asarray(ob["d"]) / (2 * WIDTH)
    assert stress.max() == pytest.approx(FC, rel=0.10)
    case = load_case_text(compression_specimen(cell=cell, width=WIDTH, fc=FC))
    young = case.materials["concrete"].young
    early = (stress > 0.2 * FC) & (stress < 0.5 * FC)
    secant = np.median(stress[early] / strain[early])
    assert secant == pytest.approx(young, rel=0.15)
    assert stress[-1] < 0.2 * stress.max()              # it has failed
    balance = (ob["kinetic"] + ob["strain"] + ob["plastic"] + ob["fracture"] + ob["damping"]
               - ob["external_work"])
    assert np.abs(balance).max() <= 1e-2 * ob["external_work"].max()


@pytest.mark.parametrize("poisson", [0.1, 0.25])
def test_uniaxial_compression_at_other_poisson_ratios(run_case, poisson):
    """The table is ν = 0.2's; at ν = 0.1 and 0.25 its column is scaled by
    the measured factor of the springs' α (compression_calibration.
    COMPRESSION_ALPHA_FACTOR, measured on seed 1): the prism of another
    mesh (seed 2, 6 cells across) fails at f_c within 10 % (before the
    factor: +14 % and −13 %); energy balance within 1 %."""
    h = run_case(compression_specimen(cell=WIDTH / 6, width=WIDTH, fc=FC, rate=2.0,
                                      frames=150, seed=2,
                                      extra=f", poisson: {poisson!r}"))
    ob = h.observables
    stress = -np.asarray(ob["F"]) / WIDTH ** 2
    assert stress.max() == pytest.approx(FC, rel=0.10)
    balance = (ob["kinetic"] + ob["strain"] + ob["plastic"] + ob["fracture"] + ob["damping"]
               - ob["external_work"])
    assert np.abs(balance).max() <= 1e-2 * ob["external_work"].max()


@pytest.mark.parametrize("poisson", [0.0, 0.3])
def test_uniaxial_compression_at_the_ends_of_the_poisson_range(run_case, poisson):
    """ν = 0 (the calibrated springs' stiffest shear, α = 1.01) and ν = 0.3
    (rock; the Poisson correction's lattice: α = 1 plus the auxiliary cell
    stress) have their own measured factors (COMPRESSION_ALPHA_FACTOR at
    ν = 0's α, COMPRESSION_AUX_FACTOR at ν = 0.3, measured on seed 1):
    the prism of another mesh (seed 2, 6 cells across, 2 /s, as the test
    above) fails at f_c within the issue's 10 %, the tolerance of the test
    above (before these factors: −14 % at ν = 0 and +14 %/+5 % at ν = 0.3
    on seeds 1/2 at 0.5 /s; one prism's scatter between seeds at ν = 0.3
    is up to 8 %, docs/calibration.md "Compression"); energy balance
    within 1 %."""
    h = run_case(compression_specimen(cell=WIDTH / 6, width=WIDTH, fc=FC, rate=2.0,
                                      frames=150, seed=2,
                                      extra=f", poisson: {poisson!r}"))
    ob = h.observables
    stress = -np.asarray(ob["F"]) / WIDTH ** 2
    assert stress.max() == pytest.approx(FC, rel=0.10)
    balance = (ob["kinetic"] + ob["strain"] + ob["plastic"] + ob["fracture"] + ob["damping"]
               - ob["external_work"])
    assert np.abs(balance).max() <= 1e-2 * ob["external_work"].max()


def test_check_says_when_fc_is_beyond_the_reach_at_high_poisson(tmp_path, capsys):
    """At ν = 0.4 (the Poisson correction) the lattice at the calibration's
    end r = 6 is weaker than the C40 preset's f_c (measured 11.45 f_t against
    13.2 f_t asked, docs/calibration.md "Compression"): `check` warns that
    the compressive strength is above the reach and says in MPa, below
    f_c, what a specimen will reach; ν = 0.3 reaches it, no warning."""
    for poisson, beyond in ((0.4, True), (0.3, False)):
        case = tmp_path / "c.yaml"
        case.write_text(compression_specimen(cell=0.01, width=WIDTH,
                                             extra=f", poisson: {poisson!r}"), encoding="utf-8")
        assert main(["check", str(case)]) == 0
        captured = capsys.readouterr()
        text = captured.out + captured.err
        assert ("compressive_strength = " in text and "is above" in text) == beyond
        if beyond:
            reach = float(text.split("a specimen fails near ")[1].split(" = ")[1].split()[0])
            assert reach < FC / 1e6


@pytest.mark.parametrize("cell", [WIDTH / 6, WIDTH / 8])
@pytest.mark.parametrize("share", [0.1, 0.3])
def test_triaxial_compression_follows_richart(run_case, cell, share):
    """The prism under a lateral pressure σ_3 of 0.1 and 0.3 f_c (a triaxial
    cell's fluid: `pressure` in mode dynamic follows its faces by default)
    fails at Richart, Brandtzaeg & Brown's (1928) f_cc = f_c + 4.1 σ_3
    within the issue's 15 % (measured −10 … +6 %).  The pressure turns
    no cell by itself, so the cells' mean turn about the axis stays below
    0.1 rad to the end (0.6 % strain; measured 0.01-0.02 rad, the broken
    prism's pieces), and at 0.3 f_c the prism still carries 0.4 f_cc
    there.  A dead pressure spun the prism on its frictionless platens
    from round-off (its turn grew ×3 every 0.04 % of strain, to 1 rad): at
    0.3 f_c it collapsed to zero load, and on 7 mm cells at 0.5 /s the
    spin came before the peak (60 MPa, −30 %).  Energy balance within 1 %
    of the work."""
    from rbsm_dyn.physics.rotation import quat_mul_np
    h = run_case(compression_specimen(cell=cell, width=WIDTH, fc=FC, rate=2.0, frames=150,
                                      confinement=share * FC))
    ob = h.observables
    stress = -np.asarray(ob["F"]) / WIDTH ** 2
    fcc = FC + 4.1 * share * FC
    assert stress.max() == pytest.approx(fcc, rel=0.15)
    if share == 0.3:
        assert stress[-1] > 0.4 * fcc
    q0 = h.static["particles/bodies/reference_orientation"]
    q = quat_mul_np(h.orientation[-1], q0 * np.array([1.0, -1.0, -1.0, -1.0]))
    q *= np.where(q[:, :1] < 0.0, -1.0, 1.0)          # the rotation's quaternion with w ≥ 0
    turn = 2.0 * np.arctan2(q[:, 3], q[:, 0])
    assert abs(np.mean(turn)) < 0.1
    balance = (ob["kinetic"] + ob["strain"] + ob["plastic"] + ob["fracture"] + ob["damping"]
               - ob["external_work"])
    assert np.abs(balance).max() <= 1e-2 * ob["external_work"].max()


def test_cube_case_is_stronger_than_the_cylinder(run_case):
    """cases/cube_compression.yaml as shipped: the cube on platens of
    friction 0.2 fails at EN 206's f_ck,cube/f_ck,cyl = 1.20-1.25 × f_c
    (Table 12, C25/30-C50/60), within 10 %; the platens' friction holds its
    ends (150 µs after the peak a smaller share of the spring points within
    15 mm of a platen is broken than in the middle fifth: without friction
    it is the other way round, the case's header); the energy balance
    closes within 1 % of the work."""
    import h5py
    from pathlib import Path
    path = Path(__file__).parent.parent / "cases" / "cube_compression.yaml"
    h = run_case(path.read_text(encoding="utf-8"))
    ob = h.observables
    stress = -np.asarray(ob["F"]) / 0.1 ** 2
    i = int(np.argmax(stress))
    assert 0.9 * 1.20 * FC <= stress[i] <= 1.1 * 1.25 * FC
    with h5py.File(h.path) as f:
        values = f["springs/damage/value"]
        damage = values[min(i + 10, values.shape[0] - 1)]
        z = f["springs/position"][:, 2]
    ends = (z < 0.015) | (z > 0.085)
    middle = (z > 0.04) & (z < 0.06)
    assert np.mean(damage[ends] >= 0.99) < np.mean(damage[middle] >= 0.99)
    balance = (ob["kinetic"] + ob["strain"] + ob["plastic"] + ob["fracture"] + ob["damping"]
               - ob["external_work"])
    assert np.abs(balance).max() <= 1e-2 * ob["external_work"].max()


def test_check_prints_the_derived_shear_strength_and_rate_factors(tmp_path, capsys):
    """`check` prints the shear strength f_c gives on Voronoi cells (the
    table's ratio at f_c/f_t) and, with `rate: fib2010`, the Model Code's
    factors (1.28 in tension and 1.16 in compression at 1 /s)."""
    case = tmp_path / "c.yaml"
    case.write_text(compression_specimen(cell=0.01, width=WIDTH,
                                         extra=", rupture: {rate: fib2010}"), encoding="utf-8")
    assert main(["check", str(case)]) == 0
    out = capsys.readouterr().out
    ft = load_case_text(compression_specimen(cell=0.01)).materials["concrete"] \
        .rupture.tensile_strength
    # the table read at the springs' F_T of ν = 0.2 (k_s/k_n from the elastic calibration)
    _, alpha, _ = stiffness_rule("calibrated", "voronoi", 30e9, 0.2)
    r, _ = shear_ratio("voronoi", FC, ft, voronoi_tension_ratio(TABLE_BRITTLENESS, alpha), alpha)
    assert f"gives shear_strength {r:.3g} f_t" in out
    assert "1 /s: × 1.28 in tension, × 1.16 in compression" in out
