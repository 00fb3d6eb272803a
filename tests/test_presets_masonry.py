"""Masonry by its engineering values (issue 31 item 2; case/presets.py):
`{model: brick, fb: f_b}` for the units and `{model: mortar, fm: f_m}` for
the mortar joint (the `material` of a bonded interface).  Each derived
value is checked against its relation written out here with its source
(docs/case_file.md, "materials", says which are read and which taken)."""
import pytest

from rbsm_dyn.__main__ import main
from rbsm_dyn.case import CaseError, load_case_text

# two bricks (one course each) and a 10 mm bed joint between them
COUPLET = """
name: couplet
{units}parts:
  lower: {{geometry: {{box: [[0, 0, 0], [{W}, {D}, {H}]]}}, mesh: {{kind: blocks, divisions: [2, 1, 1]}}, material: b}}
  upper: {{geometry: {{box: [[0, 0, {H}], [{W}, {D}, {H2}]]}}, mesh: {{kind: blocks, divisions: [2, 1, 1]}}, material: b}}
interfaces:
  - {{parts: [lower, upper], law: bonded, material: m, thickness: {T}}}
materials:
  b: {{model: brick, {brick}}}
  m: {{model: mortar, {mortar}}}
boundary:
  - {{surface: lower.zmin, fix: all}}
solver: {{mode: dynamic, end_time: 1.0e-5}}
"""


def couplet_text(brick="fb: 20.0e6", mortar="fm: 5.0e6", units=""):
    mm = 1000.0 if units else 1.0
    return COUPLET.format(units=units, W=0.2 * mm, D=0.1 * mm, H=0.05 * mm, H2=0.1 * mm,
                          T=0.01 * mm, brick=brick, mortar=mortar)


def materials(brick="fb: 20.0e6", mortar="fm: 5.0e6", units=""):
    case = load_case_text(couplet_text(brick, mortar, units))
    return case.materials["b"], case.materials["m"]


@pytest.mark.parametrize("fb_mpa", [5.0, 20.0, 60.0])
def test_brick_from_fb(fb_mpa):
    """E_b = 300 f_b (Kaushik, Rai & Jain 2007, J. Mater. Civ. Eng. 19(9)
    728); f_tb = 0.1 f_b (taken); G_f = 0.025 mm × f_tb (taken: 50 J/m² at
    f_b = 20 MPa, the energy measured on clay bricks by Mohammed, Hughes &
    Danraka); ν 0.15 and 1800 kg/m³ (taken); the specimen's compressive
    strength is f_b."""
    fb = fb_mpa * 1e6
    b, _ = materials(brick=f"fb: {fb!r}")
    assert b.young == pytest.approx(300.0 * fb, rel=1e-12)
    ft = 0.1 * fb
    assert b.rupture.tensile_strength == pytest.approx(ft, rel=1e-12)
    assert b.rupture.fracture_energy == pytest.approx(0.025e-3 * ft, rel=1e-12)
    assert b.rupture.compressive_strength == pytest.approx(fb, rel=1e-12)
    assert b.poisson == 0.15 and b.density == 1800.0
    assert b.rupture.shear_strength is None and b.friction is None


@pytest.mark.parametrize("fm_mpa", [1.0, 5.0, 12.0])
def test_mortar_joint_from_fm(fm_mpa):
    """E_m = 200 f_m (Kaushik, Rai & Jain 2007); the joint's bond strength
    f_t = 0.05 f_m (taken); cohesion c = 1.4 f_t (taken); G_f^I/f_t and
    G_f^II/c and the residual friction tan φ_r from the Lourenço–Rots
    interface model's example in OOFEM's material manual: f_t 0.2 MPa with
    G_f^I 0.018 N/mm, c 0.8 MPa with G_f^II 0.05 N/mm, tan φ_r 0.75; ν 0.2
    and 2000 kg/m³ (taken); no compressive strength (the joint's shear
    strength is its cohesion)."""
    fm = fm_mpa * 1e6
    _, m = materials(mortar=f"fm: {fm!r}")
    assert m.young == pytest.approx(200.0 * fm, rel=1e-12)
    ft = 0.05 * fm
    c = 1.4 * ft
    r = m.rupture
    assert r.tensile_strength == pytest.approx(ft, rel=1e-12)
    # [N/mm]/[MPa] = mm: G_f^I = (0.018 / 0.2) mm × f_t
    assert r.fracture_energy == pytest.approx((0.018 / 0.2) * 1e-3 * ft, rel=1e-12)
    assert r.shear_strength == pytest.approx(c, rel=1e-12)
    assert r.shear_fracture_energy == pytest.approx((0.05 / 0.8) * 1e-3 * c, rel=1e-12)
    assert r.compressive_strength is None
    assert m.friction == 0.75 and m.poisson == 0.2 and m.density == 2000.0


def test_given_values_win_and_the_others_follow_them():
    """A key the file gives is kept; the relations written in terms of f_t
    or c take the given one; `modulus_ratio` replaces 300 (here
    Vermeltfoort's 400 for clay bricks) and 200."""
    b, m = materials(brick="fb: 20.0e6, modulus_ratio: 400, density: 2000, "
                           "rupture: {tensile_strength: 1.5e6}",
                     mortar="fm: 5.0e6, young: 2.0e9, friction: 0.6, "
                            "rupture: {tensile_strength: 0.4e6, shear_strength: 0.8e6}")
    assert b.young == pytest.approx(400 * 20e6, rel=1e-12) and b.density == 2000
    assert b.rupture.tensile_strength == 1.5e6
    assert b.rupture.fracture_energy == pytest.approx(0.025e-3 * 1.5e6, rel=1e-12)
    assert m.young == 2.0e9 and m.friction == 0.6
    assert m.rupture.tensile_strength == 0.4e6 and m.rupture.shear_strength == 0.8e6
    assert m.rupture.fracture_energy == pytest.approx(0.09e-3 * 0.4e6, rel=1e-12)
    assert m.rupture.shear_fracture_energy == pytest.approx(0.0625e-3 * 0.8e6, rel=1e-12)
    _, m = materials(mortar="fm: 5.0e6, modulus_ratio: 500, rupture: {law: tension}")
    assert m.young == pytest.approx(500 * 5e6, rel=1e-12)
    # law tension has no shear strength: only f_t and G_f are derived
    assert m.rupture.shear_strength is None and m.rupture.shear_fracture_energy is None
    assert m.rupture.tensile_strength == pytest.approx(0.05 * 5e6, rel=1e-12)


def test_mm_units_give_the_same_si_values():
    si = materials()
    mm = materials("fb: 20.0", "fm: 5.0", units="units: mm-N-s\n")
    for a, b in zip(si, mm):
        for key in ("young", "density", "poisson", "friction"):
            assert getattr(b, key) == pytest.approx(getattr(a, key), rel=1e-12)
        for key in ("tensile_strength", "fracture_energy", "shear_strength",
                    "shear_fracture_energy", "compressive_strength"):
            va, vb = getattr(a.rupture, key), getattr(b.rupture, key)
            assert (va is None and vb is None) or vb == pytest.approx(va, rel=1e-12), key


@pytest.mark.parametrize("brick, mortar, words", [
    ("fb: 20.0", "fm: 5.0e6", ["materials.b.fb", "3-170 MPa"]),
    ("young: 6.0e9", "fm: 5.0e6", ["materials.b", "needs fb"]),
    ("fb: 20.0e6", "fm: 50.0e6", ["materials.m.fm", "0.5-30 MPa"]),
    ("fb: 20.0e6", "young: 1.0e9", ["materials.m", "needs fm"]),
    ("fb: 20.0e6, modulus_ratio: 10", "fm: 5.0e6", ["materials.b.modulus_ratio", "[50, 2000]"]),
    ("fb: 20.0e6, fc: 30.0e6", "fm: 5.0e6", ["materials.b.fc", "model: concrete"]),
    ("fb: 20.0e6", "fm: 5.0e6, fb: 20.0e6", ["materials.m.fb", "model: brick"]),
    ("fb: 20.0e6, ucs: 30.0e6", "fm: 5.0e6", ["materials.b.ucs", "model: rock"]),
    ("fb: strong", "fm: 5.0e6", ["materials.b.fb", "must be a number"]),
    ("fb: 20.0e6, fbb: 1", "fm: 5.0e6", ["materials.b", "fbb"]),
])
def test_bad_masonry_names_the_key(brick, mortar, words):
    with pytest.raises(CaseError) as err:
        materials(brick, mortar)
    assert all(w in str(err.value) for w in words), str(err.value)


def test_unknown_model_lists_the_presets():
    with pytest.raises(CaseError) as err:
        load_case_text(couplet_text().replace("model: brick", "model: adobe"))
    text = str(err.value)
    assert "materials.b.model" in text
    assert all(w in text for w in ("concrete", "rock", "brick", "mortar")), text


def test_couplet_checks_and_prints_the_derived_values(tmp_path, capsys):
    """Two bricks and a bonded mortar joint load, pass `check` and `info`,
    which print the values derived and their sources, and run."""
    path = tmp_path / "couplet.yaml"
    path.write_text(couplet_text(), encoding="utf-8")
    assert main(["check", str(path)]) == 0
    out = capsys.readouterr().out
    assert "ok (4 bodies" in out
    assert "materials.b: brick of f_b = 20 MPa" in out and "young 6 GPa" in out
    assert "materials.m: mortar joint of f_m = 5 MPa" in out
    for shown in ("tensile_strength 0.25 MPa", "shear_strength 0.35 MPa", "friction 0.75"):
        assert shown in out, out
    assert main(["info", str(path)]) == 0
    assert "mortar joint of f_m = 5 MPa" in capsys.readouterr().out
    assert main([str(path), "--out", str(tmp_path / "c.h5"), "--quiet"]) == 0


def test_couplet_pulled_apart_breaks_at_the_joints_bond_strength(tmp_path):
    """The couplet pulled along z (the lower brick held, the upper one
    driven at 10 mm/s) opens at its bed joint at the preset's bond
    strength 0.05 f_m = 0.25 MPa over the joint's 0.02 m², dissipating
    its G_f^I = 0.09 mm × f_t per unit area, the bricks (f_tb = 2 MPa)
    intact."""
    import numpy as np

    import rbsm_dyn
    text = couplet_text().replace(
        "  - {surface: lower.zmin, fix: all}",
        "  - {group: lower, velocity: [0, 0, 0]}\n"
        "  - {group: upper, velocity: [0, 0, 0.01]}").replace(
        "end_time: 1.0e-5}", "end_time: 2.5e-2}\noutput:\n  interval: 5.0e-5\n  probes:\n"
        "    F: {group: lower, quantity: reaction, component: z, reduce: sum}")
    path = tmp_path / "pull.yaml"
    path.write_text(text, encoding="utf-8")
    assert main([str(path), "--out", str(tmp_path / "pull.h5"), "--quiet"]) == 0
    h = rbsm_dyn.open_history(tmp_path / "pull.h5")
    force, t = -np.asarray(h.observables["F"]), np.asarray(h.time)
    area, ft = 0.2 * 0.1, 0.05 * 5.0e6
    assert force.max() / area == pytest.approx(ft, rel=0.02)
    assert abs(force[-1]) < 1e-3 * force.max()                 # open: nothing carried
    work = np.trapezoid(force, t) * 0.01                       # ∫ F du, du = v dt
    assert work == pytest.approx(0.09e-3 * ft * area, rel=0.02)
