"""Materials by their engineering values (issue 31 item 2; case/presets.py):
`{model: concrete, fc: f_cm}` derives the elastic constants, the tensile
strength and the fracture energy from the fib Model Code 2010."""
import math

import pytest

from rbsm_dyn.case import CaseError, load_case_text

CASE = """
name: conc
{units}domain: {{box: [[0, 0, 0], [{L}, {L}, {L}]]}}
mesh: {{kind: blocks, divisions: [2, 2, 2]}}
materials:
  c: {{model: concrete, {mat}}}
boundary:
  - {{face: zmin, fix: all}}
solver: {{mode: dynamic, end_time: 1.0e-6}}
"""


def concrete(mat, units=""):
    L = 100 if units else 0.1
    return load_case_text(CASE.format(units=units, L=L, mat=mat)).materials["c"]


# fib Model Code 2010, Table 5.1-2 (rounded as printed): f_ck [MPa] ->
# f_cm [MPa], f_ctm [MPa], E_ci [GPa]
TABLE = {20: (28, 2.2, 30.3), 40: (48, 3.5, 36.3), 60: (68, 4.4, 40.7), 80: (88, 4.8, 44.4)}


@pytest.mark.parametrize("fck", sorted(TABLE))
def test_concrete_from_fc_matches_the_model_code_table(fck):
    """E_ci and f_ctm against the Model Code's Table 5.1-2 to its printed
    rounding (0.05 GPa, 0.05 MPa); ν = 0.2 (§5.1.7.3); G_F = 73 f_cm^0.18
    N/m (eq. 5.1-9: 146.5 J/m² at f_cm = 48 MPa)."""
    fcm, fctm, eci = TABLE[fck]
    m = concrete(f"fc: {fcm}.0e6")
    assert abs(m.young / 1e9 - eci) <= 0.05 + 1e-9
    assert abs(m.rupture.tensile_strength / 1e6 - fctm) <= 0.05 + 1e-9
    assert m.poisson == 0.2
    assert m.rupture.fracture_energy == pytest.approx(73.0 * fcm ** 0.18, rel=1e-12)
    assert m.fc == fcm * 1e6


def test_given_values_win_and_units_convert():
    """A value the file gives is kept; the same concrete in mm-N-s (fc in
    MPa) has the same SI values."""
    m = concrete("fc: 48.0e6, young: 30.0e9, rupture: {fracture_energy: 100.0}")
    assert m.young == 30.0e9 and m.rupture.fracture_energy == 100.0
    assert m.rupture.tensile_strength == pytest.approx(0.3 * 40 ** (2 / 3) * 1e6, rel=1e-12)
    si, mm = concrete("fc: 48.0e6"), concrete("fc: 48.0", units="units: mm-N-s\n")
    for key in ("young", "density", "poisson", "ucs"):
        assert getattr(mm, key) == pytest.approx(getattr(si, key), rel=1e-12)
    assert mm.rupture.fracture_energy == pytest.approx(si.rupture.fracture_energy, rel=1e-12)
    assert math.isclose(mm.density, 2400.0, rel_tol=1e-12)


@pytest.mark.parametrize("mat, words", [("fc: 48.0", ["materials.c.fc", "20-128 MPa"]),
                                        ("young: 3.0e10", ["materials.c", "needs fc"])])
def test_bad_concrete_names_the_key(mat, words):
    with pytest.raises(CaseError) as err:
        concrete(mat)
    assert all(w in str(err.value) for w in words)


ROCK = CASE.replace("c: {{model: concrete, {mat}}}", "r: {{model: rock, {mat}}}")


def rock(mat, units=""):
    L = 100 if units else 0.1
    return load_case_text(ROCK.format(units=units, L=L, mat=mat)).materials["r"]


@pytest.mark.parametrize("kind, mr, mi", [("granite", 425, 32), ("sandstone", 275, 17),
                                          ("marble", 850, 9)])
def test_rock_from_ucs(kind, mr, mi):
    """E_i = MR σ_ci with the middle of Hoek & Diederichs' (2006) range;
    the Hoek–Brown tensile strength of intact rock, which Hoek (2007,
    "Practical Rock Engineering" §11) approximates by σ_ci/m_i (the
    exact root is smaller by about 1/m_i² of it); K_IC = σ_t/6.88
    MPa √m (Zhang 2002) and G = K_IC² (1 − ν²)/E (Irwin, plane strain)."""
    m = rock(f"rock: {kind}, ucs: 100.0e6")
    assert m.young == pytest.approx(mr * 100e6, rel=1e-12)
    ft = m.rupture.tensile_strength
    assert ft == pytest.approx(100e6 / mi, rel=1.05 / mi ** 2)
    kic = ft / 1e6 / 6.88 * 1e6
    assert m.rupture.fracture_energy == pytest.approx(kic ** 2 * (1 - 0.25 ** 2) / m.young,
                                                      rel=1e-12)
    assert m.poisson == 0.25 and 2000 < m.density < 3000
    assert m.rupture.compressive_strength == 100e6


def test_rock_by_its_constants_and_in_mm():
    """mi and modulus_ratio stand for a rock not in the table (or override
    one); the same rock in mm-N-s (ucs in MPa) has the same SI values."""
    m = rock("ucs: 80.0e6, mi: 12, modulus_ratio: 500")
    assert m.young == pytest.approx(500 * 80e6, rel=1e-12)
    assert m.rupture.tensile_strength == pytest.approx(80e6 * (math.sqrt(148) - 12) / 2,
                                                       rel=1e-12)
    si, mm = rock("rock: basalt, ucs: 200.0e6"), rock("rock: basalt, ucs: 200.0", "units: mm-N-s\n")
    for key in ("young", "density", "poisson"):
        assert getattr(mm, key) == pytest.approx(getattr(si, key), rel=1e-12)
    assert mm.rupture.fracture_energy == pytest.approx(si.rupture.fracture_energy, rel=1e-12)


@pytest.mark.parametrize("mat, words", [
    ("rock: granit, ucs: 1.0e8", ["materials.r.rock", "granite", "unknown rock"]),
    ("rock: granite", ["materials.r", "needs ucs"]),
    ("ucs: 1.0e8", ["materials.r", "mi", "modulus_ratio"]),
    ("rock: granite, ucs: 150.0", ["materials.r.ucs", "1-400 MPa"]),
    ("rock: granite, ucs: 1.0e8, fc: 4.0e7", ["materials.r.fc", "model: concrete"])])
def test_bad_rock_names_the_key(mat, words):
    with pytest.raises(CaseError) as err:
        rock(mat)
    assert all(w in str(err.value) for w in words), str(err.value)
