"""Scenes of several parts (issue 12, items 1, 5, 6; DESIGN.md §6): each
part a geometry, a mesh (voronoi, blocks or rigid: one body) and a
material; touching parts joined over the overlaps of their boundary faces
by a bonded or a contact interface; a rigid part with the exact mass and
inertia of its geometry."""
import numpy as np
import pytest

from rbsm_dyn.case import CaseError, load_case_text
from rbsm_dyn.model import build_model

E, RHO = 3.0e10, 2400.0
MATS = (f"c: {{density: {RHO}, young: {E}, poisson: 0.0}}\n"
        "  steel: {density: 7800, young: 2.0e11, poisson: 0.3}")


def model_of(text):
    return build_model(load_case_text(text))


# --------------------------------------------------- bonded = one part ---

CANTILEVER = """
name: {name}
{scene}
materials:
  {mats}
groups:
  tip: {{box: [[0.97, 0, 0], [1.0, 0.1, 0.05]]}}
boundary:
  - {{{support}, fix: all}}
loads:
  - {{group: tip, force: [0, -1000, 0]}}
solver: {{mode: linear}}
output:
  probes:
    d: {{group: tip, quantity: displacement, component: y, reduce: mean}}
    rot: {{group: tip, quantity: rotation, component: z, reduce: mean}}
"""


def test_two_parts_bonded_with_the_same_material_equal_the_one_part_beam(run_case):
    """A cantilever of two block parts bonded at x = 0.5 (the same material,
    the same blocks) has the springs of the one-part beam: its tip
    displacement and rotation equal the one-part beam's to 1e-6
    (issue 12)."""
    one = run_case(CANTILEVER.format(
        name="one", mats=MATS, support="face: xmin",
        scene="domain: {box: [[0, 0, 0], [1.0, 0.1, 0.05]]}\n"
              "mesh: {kind: blocks, divisions: [20, 4, 1]}"))
    two = run_case(CANTILEVER.format(
        name="two", mats=MATS, support="surface: left.xmin",
        scene="parts:\n"
              "  left: {geometry: {box: [[0, 0, 0], [0.5, 0.1, 0.05]]}, "
              "mesh: {kind: blocks, divisions: [10, 4, 1]}, material: c}\n"
              "  right: {geometry: {box: [[0.5, 0, 0], [1.0, 0.1, 0.05]]}, "
              "mesh: {kind: blocks, divisions: [10, 4, 1]}, material: c}\n"
              "interfaces: [{parts: [left, right], law: bonded}]"))
    for key in ("d", "rot"):
        assert two.observables[key][-1] == pytest.approx(one.observables[key][-1], rel=1e-6)
    # and the beam is the cantilever of beam theory: δ = PL³/3EI + PL/κGA
    # (L = 0.975 to the tip cells' centroids, G = E/2, κ = 5/6) within 1 %
    L, I, A = 0.975, 0.05 * 0.1 ** 3 / 12, 0.005
    ref = 1000 * L ** 3 / (3 * E * I) + 1000 * L / (5 / 6 * E / 2 * A)
    assert -one.observables["d"][-1] == pytest.approx(ref, rel=1e-2)


# ------------------------------------------------ beam on rigid rollers ---

TPB = f"""
name: rollers
parts:
  beam: {{geometry: {{box: [[0, 0, 0], [0.9, 0.05, 0.05]]}},
         mesh: {{kind: blocks, divisions: [90, 5, 1]}}, material: c}}
  left: {{geometry: {{box: [[0.04, -0.02, 0], [0.06, 0, 0.05]]}}, mesh: {{kind: rigid}},
         material: steel}}
  right: {{geometry: {{box: [[0.84, -0.02, 0], [0.86, 0, 0.05]]}}, mesh: {{kind: rigid}},
          material: steel}}
  platen: {{geometry: {{box: [[0.44, 0.05, 0], [0.46, 0.07, 0.05]]}}, mesh: {{kind: rigid}},
           material: steel}}
interfaces:
  - {{parts: [beam, left], law: contact, friction: 0.5}}
  - {{parts: [beam, right], law: contact, friction: 0.5}}
  - {{parts: [beam, platen], law: contact, friction: 0.5}}
materials:
  {MATS}
boundary:
  - {{group: left, fix: [x, y, z, rx, ry]}}
  - {{group: right, fix: [y, z, rx, ry]}}
  - {{group: platen, fix: [z, rx, ry, rz]}}
loads:
  - {{group: platen, force: [0, -2000, 0]}}
solver: {{mode: static, load_steps: 2}}
output:
  probes:
    d: {{quantity: relative_displacement, points: [[0.05, 0.025, 0.025], [0.45, 0.025, 0.025]],
        component: y}}
    rl: {{group: left, quantity: reaction, component: y, reduce: sum}}
    rr: {{group: right, quantity: reaction, component: y, reduce: sum}}
"""


def test_beam_on_rigid_rollers_under_a_rigid_platen(run_case):
    """VERIFICATION A3 as in the laboratory: a block beam (L = 0.8 between
    the rollers, h = b = 0.05) resting on two rigid rollers (one pinned,
    one free to roll along x; both turn about their axis) under a rigid
    platen, all joined by contact interfaces (μ = 0.5), platen loaded by
    P = 2 kN.  Midspan deflection against the supports (neutral axis):
    PL³/(48EI) + PL/(4κGA) (κ = 5/6, G = E/2) within 3 %; each roller
    carries P/2 (the static tolerance, 1e-6 × P, gives 1e-4)."""
    h = run_case(TPB)
    P, L, b, d = 2000.0, 0.8, 0.05, 0.05
    I, A = b * d ** 3 / 12, b * d
    ref = P * L ** 3 / (48 * E * I) + P * L / (4 * 5 / 6 * (E / 2) * A)
    assert -h.observables["d"][-1] == pytest.approx(ref, rel=3e-2)
    assert h.observables["rl"][-1] == pytest.approx(P / 2, rel=1e-4)
    assert h.observables["rr"][-1] == pytest.approx(P / 2, rel=1e-4)


# -------------------------------------------------- contact interface ---

BAR = f"""
name: bar
parts:
  a: {{geometry: {{box: [[0, 0, 0], [0.2, 0.05, 0.05]]}},
      mesh: {{kind: voronoi, size: 0.02, seed: 1}}, material: c}}
  b: {{geometry: {{box: [[0.2, 0, 0], [0.4, 0.05, 0.05]]}},
      mesh: {{kind: blocks, divisions: [8, 2, 2]}}, material: c}}
interfaces: [{{parts: [a, b], law: contact, friction: 0.0}}]
materials:
  {MATS}
groups:
  end: {{box: [[0.38, 0, 0], [0.4, 0.05, 0.05]]}}
boundary:
  - {{surface: a.xmin, fix: [x]}}
  - {{group: all, fix: [y, z, rx, ry, rz]}}
  - {{group: end, displacement: [U, null, null]}}
solver: {{mode: static, load_steps: 1}}
output:
  probes:
    R: {{group: end, quantity: reaction, component: x, reduce: sum}}
    gap: {{quantity: relative_displacement, points: [[0.19, 0.025, 0.025],
          [0.21, 0.025, 0.025]], component: x}}
"""


def test_contact_interface_carries_compression_and_opens_in_tension(run_case):
    """A Voronoi bar and a block bar meeting at x = 0.2 through a contact
    interface (uniaxial strain: lateral motion and rotations held, ν = 0),
    the far cells (centroids at x = 0.3875).  Pushed by u = 1e-5 m
    (static), the near face held along x, the pair is one bar: the
    reaction on the far cells is E A u / 0.3875 within 5 % (the calibrated
    Voronoi modulus).  Pulled away (dynamic, 1 m/s for 0.2 ms), the
    interface opens: nothing crosses it, the Voronoi bar stays at rest
    (1e-12 m: round-off, against a 2e-4 m pull), and the gap grows with the block bar's motion (more than half
    the pull: its near end lags by the wave)."""
    u = 1.0e-5
    push = run_case(BAR.replace("U", str(-u)))
    F = E * 0.05 * 0.05 * u / 0.3875
    assert push.observables["R"][-1] == pytest.approx(-F, rel=5e-2)
    pull = run_case(BAR.replace("{group: end, displacement: [U, null, null]}",
                                "{group: end, velocity: [1.0, null, null]}")
                    .replace("{mode: static, load_steps: 1}", "{mode: dynamic, end_time: 2.0e-4}")
                    .replace("probes:", "probes:\n    a: {group: a, quantity: displacement, "
                             "component: magnitude, reduce: max}"))
    assert np.max(pull.observables["a"]) < 1e-12     # round-off of its own springs
    assert pull.observables["gap"][-1] > 0.5 * 1.0 * 2.0e-4


# ------------------------------------------------------------ rigid part ---

SCENE = f"""
name: scene
parts:
  block: {{geometry: {{box: [[0, 0, 0], [0.2, 0.1, 0.1]]}},
          mesh: {{kind: voronoi, size: 0.025, seed: 3}}, material: c}}
  roller: {{geometry: {{cylinder: {{base: [0.1, 0.15, 0], axis: [0, 0, 0.1], radius: 0.05}}}},
           mesh: {{kind: rigid, size: 0.005}}, material: steel}}
  lid: {{geometry: {{box: [[0, 0.1, 0.12], [0.2, 0.2, 0.14]]}}, mesh: {{kind: rigid}},
        material: steel}}
INTERFACES
materials:
  {MATS}
boundary: [{{surface: block.ymin, fix: all}}]
solver: {{mode: dynamic, end_time: 1.0e-4}}
"""


def test_rigid_part_is_one_body_with_the_mass_and_inertia_of_its_solid():
    """A rigid cylinder (r = 0.05, length 0.1, steel) is one body: its mass
    is ρ V of the faceted solid (1e-12) and within the faceting's chord
    (mesh.size 0.005 × chord 0.05: 0.25 mm, 29 segments, area error
    (2π/n)²/6 = 0.8 %) of ρπr²l (1 %); its principal moments are m r²/2
    about the axis and m(3r² + l²)/12 across, with its own mass (1 %).  A rigid part touching nothing needs no interface."""
    m = model_of(SCENE.replace("INTERFACES", ""))
    roller = m.groups["roller"]
    assert len(roller) == 1 and len(m.groups["lid"]) == 1
    assert len(m.groups["block"]) + 2 == m.n_bodies
    from rbsm_dyn.geometry import build_solid
    i = int(roller[0])
    r, l, rho = 0.05, 0.1, 7800.0
    mass = rho * np.pi * r * r * l
    assert m.body_mass[i] == pytest.approx(mass, rel=1e-2)
    assert m.body_volume[i] * rho == pytest.approx(m.body_mass[i], rel=1e-12)
    moments = np.sort(m.body_inertia[i])
    across = m.body_mass[i] * (3 * r * r + l * l) / 12
    axial = m.body_mass[i] * r * r / 2
    assert moments == pytest.approx(np.sort([axial, across, across]), rel=1e-2)
    # the body sits at the cylinder's centroid
    assert m.body_pos0[i] == pytest.approx([0.1, 0.15, 0.05], abs=1e-12)
    del build_solid


def test_scene_errors_name_the_parts_and_keys():
    """Touching parts need an interface (the error names both and the
    shared area); a support on a rigid part's surface, two rigid parts
    joined, an unknown part in a surface name and a part named like a group
    are refused at their keys."""
    touching = SCENE.replace("[[0, 0.1, 0.12], [0.2, 0.2, 0.14]]",
                             "[[0, 0.1, 0.0], [0.05, 0.2, 0.1]]").replace("INTERFACES", "")
    with pytest.raises(CaseError) as info:
        model_of(touching)
    assert info.value.key_path == ("interfaces",)
    assert "block and lid touch" in info.value.message and "0.005 m²" in info.value.message
    with pytest.raises(CaseError) as info:
        load_case_text(SCENE.replace("INTERFACES", "").replace(
            "[{surface: block.ymin, fix: all}]", "[{surface: lid.ymin, fix: all}]"))
    assert info.value.key_path == ("boundary", 0, "surface") and "rigid" in info.value.message
    with pytest.raises(CaseError) as info:
        load_case_text(SCENE.replace("INTERFACES",
                                     "interfaces: [{parts: [lid, roller], law: bonded}]"))
    assert info.value.key_path == ("interfaces", 0, "parts") and "rigid" in info.value.message
    with pytest.raises(CaseError) as info:
        load_case_text(SCENE.replace("INTERFACES", "").replace("block.ymin", "blok.ymin"))
    assert info.value.key_path == ("boundary", 0, "surface") and "blok" in info.value.message
    with pytest.raises(CaseError) as info:
        load_case_text(SCENE.replace("INTERFACES", "groups: {lid: {box: [[0, 0, 0], [1, 1, 1]]}}"))
    assert info.value.key_path == ("groups", "lid")


def test_interface_between_parts_that_do_not_touch_is_a_warning():
    """An interface whose parts share no face joins nothing: the model says
    so (Model.warnings, printed by check and run) and has no spring between
    the two parts."""
    m = model_of(SCENE.replace("INTERFACES",
                               "interfaces: [{parts: [block, lid], law: contact}]"))
    assert any("block and lid do not touch" in w for w in m.warnings)
    lid = int(m.groups["lid"][0])
    assert not np.any(m.spring_bodies == lid)
