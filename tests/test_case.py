"""Tests of rbsm_dyn.case: the DESIGN.md examples, units, and bad cases."""
import json
import textwrap

import pytest

from rbsm_dyn.case import (Case, CaseError, FaceSupport, Gravity, GroupDisplacement,
                           GroupFix, GroupLoad, GroupVelocity, load_case,
                           load_case_text)

DYNAMIC = """\
name: impulsive-cantilever
domain: {box: [[0, 0, 0], [0.30, 0.01, 0.02]]}    # faces xmin … zmax
mesh: {kind: voronoi, size: 0.004, seed: 7}      # or {kind: blocks, divisions: [75, 2, 5]}
materials:
  steel: {density: 7850, young: 200.0e9, poisson: 0.3,
          yield: {criterion: von_mises, stress: 300.0e6}, rupture: {strain: 0.25}}
groups:
  tip:  {box: [[0.296, -1, -1], [1, 1, 1]]}
boundary: [{face: xmin, fix: all}]              # or {group: g, fix: [x, z, ry]}
initial:  [{group: tip, velocity: [0, 0, -20.0]}]
solver:   {mode: dynamic, end_time: 2.0e-3, dt_safety: 0.8}
output:
  file: impulsive-cantilever.h5
  interval: 1.0e-5
  probes: {tip_z: {group: tip, quantity: displacement, component: z, reduce: mean}}
"""

STATIC = """\
name: static-cantilever
domain: {box: [[0, 0, 0], [0.30, 0.01, 0.02]]}
mesh: {kind: voronoi, size: 0.004, seed: 7}
materials:
  steel: {density: 7850, young: 200.0e9, poisson: 0.3}
groups:
  tip:  {box: [[0.296, -1, -1], [1, 1, 1]]}
boundary: [{face: xmin, fix: all}]
loads:  [{group: tip, force: [0, 0, -5.0e3]}]   # total force, shared over the group
solver: {mode: static, load_steps: 10, tolerance: 1.0e-6}
"""

# A compact valid case used as the base of the bad ones (line numbers matter).
BASE = """\
name: beam
domain:
  box: [[0, 0, 0], [0.3, 0.01, 0.02]]
mesh:
  kind: blocks
  divisions: [30, 1, 2]
materials:
  steel:
    density: 7850
    young: 200.0e9
    poisson: 0.3
groups:
  tip: {box: [[0.29, -1, -1], [1, 1, 1]]}
boundary:
  - {face: xmin, fix: all}
solver:
  mode: dynamic
  end_time: 1.0e-3
"""


def bad(text, filename="case.yaml"):
    with pytest.raises(CaseError) as info:
        load_case_text(text, filename)
    return info.value


def expect(err, line, path, word):
    assert str(err).startswith(f"case.yaml:{line}: {path}: "), str(err)
    assert err.line == line and err.path == path and err.file == "case.yaml"
    assert word in err.message, str(err)
    assert str(err) == f"{err.file}:{err.line}: {err.path}: {err.message}"


# ------------------------------------------------------------ good cases ---

def test_dynamic_example(tmp_path):
    f = tmp_path / "cantilever.yaml"
    f.write_text(DYNAMIC, encoding="utf-8")
    case = load_case(f)
    assert isinstance(case, Case)
    assert case.source_text == DYNAMIC and case.source_file == str(f)
    assert case.name == "impulsive-cantilever" and case.units == "SI"
    assert case.domain.box == [[0, 0, 0], [0.30, 0.01, 0.02]]
    assert case.mesh.kind == "voronoi" and case.mesh.size == 0.004
    assert case.mesh.seed == 7 and case.mesh.min_spacing == 0.5
    assert case.mesh.spring_points == "moment"
    steel = case.materials["steel"]
    assert steel.young == 200e9 and type(steel.young) is float
    assert steel.stiffness == "calibrated"
    assert steel.yield_.criterion == "von_mises" and steel.yield_.stress == 300e6
    assert steel.rupture.strain == 0.25
    b = case.boundary[0]
    assert isinstance(b, FaceSupport) and b.face == "xmin" and b.fix == ["x", "y", "z"]
    assert case.initial[0].group == "tip" and case.initial[0].velocity == [0, 0, -20.0]
    assert case.initial[0].angular_velocity == [0, 0, 0]
    s = case.solver
    assert s.mode == "dynamic" and s.end_time == 2e-3 and s.dt_safety == 0.8
    assert s.damping.alpha == 0.0 and s.dt is None
    out = case.output
    assert out.interval == 1e-5 and type(out.interval) is float
    assert out.file == "impulsive-cantilever.h5"
    assert out.fields == ["position", "orientation"]
    p = out.probes["tip_z"]
    assert (p.group, p.quantity, p.component, p.reduce) == ("tip", "displacement", "z", "mean")
    # lines and errors for later stages
    assert case.line_of(("materials", "steel", "young")) == 5
    assert case.line_of(("boundary", 0)) == 9
    assert case.line_of(("nope",)) is None
    e = case.error(("materials", "steel", "young"), "too soft for this mesh")
    assert str(e) == f"{f}:5: materials.steel.young: too soft for this mesh"
    # resolved() is JSON-able and uses the YAML key names
    r = json.loads(json.dumps(case.resolved()))
    assert r["materials"]["steel"]["yield"]["stress"] == 300e6
    assert r["output"]["interval"] == 1e-5 and "source_text" not in r


def test_static_variant_and_defaults():
    case = load_case_text(STATIC)
    s = case.solver
    assert (s.mode, s.load_steps, s.tolerance) == ("static", 10, 1e-6)
    assert s.max_iterations == 200000 and s.relaxation == "adaptive"
    assert s.damping_factor == 0.7 and s.end_time is None
    load = case.loads[0]
    assert isinstance(load, GroupLoad) and load.force == [0, 0, -5.0e3]
    assert load.moment == [0, 0, 0] and load.history is None
    assert case.output.file == "static-cantilever.h5" and case.output.interval is None
    assert case.source_file == "<string>"


def test_default_interval_and_other_forms():
    text = BASE + textwrap.dedent("""\
        initial: [{velocity: [1, 0, 0]}]
        loads: [{gravity: [0, 0, -9.81]}, {group: tip, moment: [0, 1, 0], history: [[0, 0], [1.0e-3, 1]]}]
        cuts: [{point: [0.1, 0, 0], normal: [1, 0, 0], within: [[0.09, -1, 0.0], [0.11, 1, 0.01]]}]
        """)
    text = text.replace("  - {face: xmin, fix: all}\n",
                        "  - {face: xmin, fix: [z]}\n"
                        "  - {group: tip, fix: [rx, rz]}\n"
                        "  - {group: tip, velocity: [null, 0, 1.5], history: [[0, 0], [1.0e-4, 1]]}\n"
                        "  - {group: tip, displacement: [0.001, null, null]}\n")
    case = load_case_text(text)
    assert case.output.interval == pytest.approx(1e-5)
    assert case.mesh.divisions == [30, 1, 2]
    b = case.boundary
    assert [type(x) for x in b] == [FaceSupport, GroupFix, GroupVelocity, GroupDisplacement]
    assert b[0].fix == ["z"] and b[1].fix == ["rx", "rz"]
    assert b[2].velocity == [None, 0, 1.5] and b[2].history == [[0, 0], [1e-4, 1]]
    assert b[3].displacement == [0.001, None, None] and b[3].history is None
    assert case.initial[0].group == "all"
    assert isinstance(case.loads[0], Gravity) and case.loads[0].gravity == [0, 0, -9.81]
    assert case.loads[1].force == [0, 0, 0] and case.loads[1].moment == [0, 1, 0]
    assert case.cuts[0].normal == [1, 0, 0]
    GroupFix(group="g", fix="all")  # models are usable directly
    assert GroupFix(group="g", fix="all").fix == ["x", "y", "z", "rx", "ry", "rz"]


def test_mm_n_s_units():
    text = textwrap.dedent("""\
        name: beam-mm
        units: mm-N-s
        domain: {box: [[0, 0, 0], [300, 10, 20]]}
        mesh: {kind: voronoi, size: 4}
        materials:
          steel: {density: 7.85e-9, young: 200000, poisson: 0.3,
                  yield: {criterion: von_mises, stress: 300},
                  rupture: {fracture_energy: 0.1, tensile_strength: 3}}
        groups:
          tip: {box: [[296, -1, -1], [1000, 1000, 1000]]}
        boundary: [{group: tip, displacement: [0, 0, -2]}]
        initial: [{group: tip, velocity: [0, 0, -20000]}]
        loads: [{group: tip, force: [0, 0, -5000], moment: [1000, 0, 0]}, {gravity: [0, 0, -9810]}]
        solver: {mode: dynamic, end_time: 2.0e-3}
        """)
    case = load_case_text(text)
    assert case.units == "SI" and case.input_units == "mm-N-s"
    m = case.materials["steel"]
    assert m.young == pytest.approx(200e9)
    assert m.density == pytest.approx(7850)
    assert m.yield_.stress == pytest.approx(300e6)
    assert m.rupture.fracture_energy == pytest.approx(100.0)
    assert m.rupture.tensile_strength == pytest.approx(3e6)
    assert case.domain.box[1] == pytest.approx([0.3, 0.01, 0.02])
    assert case.mesh.size == pytest.approx(0.004)
    assert case.groups["tip"].box[0] == pytest.approx([0.296, -0.001, -0.001])
    assert case.boundary[0].displacement == pytest.approx([0, 0, -0.002])
    assert case.initial[0].velocity == pytest.approx([0, 0, -20.0])
    assert case.loads[0].force == pytest.approx([0, 0, -5000])
    assert case.loads[0].moment == pytest.approx([1.0, 0, 0])
    assert case.loads[1].gravity == pytest.approx([0, 0, -9.81])
    assert case.solver.end_time == 2e-3
    assert case.resolved()["units"] == "SI"


# ------------------------------------------------------------- bad cases ---

def test_unknown_top_level_key():
    e = bad(BASE + "solvr: {mode: static}\n")
    expect(e, 19, "solvr", "unknown key 'solvr'")
    assert "allowed: name, description" in e.message


def test_unknown_nested_key_typo_yeild():
    e = bad(BASE.replace("    poisson: 0.3\n",
                         "    poisson: 0.3\n    yeild: {criterion: tresca, stress: 1}\n"))
    expect(e, 12, "materials.steel.yeild", "unknown key 'yeild'")
    assert "allowed: density, young, poisson" in e.message and "yield" in e.message


def test_negative_young():
    e = bad(BASE.replace("young: 200.0e9", "young: -70.0e9"))
    expect(e, 10, "materials.steel.young", "must be > 0 (got -7e+10)")


def test_poisson_one_half():
    expect(bad(BASE.replace("poisson: 0.3", "poisson: 0.5")),
           11, "materials.steel.poisson", "must be < 0.5 (got 0.5)")


def test_missing_name():
    expect(bad(BASE.replace("name: beam\n", "")), 1, "name", "required key missing")


def test_missing_young_points_at_parent():
    expect(bad(BASE.replace("    young: 200.0e9\n", "")),
           8, "materials.steel.young", "required key missing")


def test_missing_end_time_for_dynamic():
    expect(bad(BASE.replace("  end_time: 1.0e-3\n", "")),
           16, "solver.end_time", "required key missing")


def test_string_for_number():
    expect(bad(BASE.replace("density: 7850", "density: abc")),
           9, "materials.steel.density", "expected a number (got 'abc')")


def test_quoted_number_is_a_string():
    expect(bad(BASE.replace("density: 7850", "density: '7850'")),
           9, "materials.steel.density", "expected a number (got '7850')")


def test_bool_for_number():
    expect(bad(BASE.replace("density: 7850", "density: true")),
           9, "materials.steel.density", "expected a number (got true)")


def test_nan():
    expect(bad(BASE.replace("density: 7850", "density: .nan")),
           9, "materials.steel.density", "finite")


def test_inf():
    expect(bad(BASE.replace("end_time: 1.0e-3", "end_time: .inf")),
           18, "solver.end_time", "finite")


def test_bad_mesh_kind():
    expect(bad(BASE.replace("kind: blocks", "kind: voronio")),
           5, "mesh.kind", "must be one of voronoi, blocks, rigid (got 'voronio')")


def test_unknown_group_in_boundary():
    expect(bad(BASE.replace("{face: xmin, fix: all}", "{group: tpi, fix: all}")),
           15, "boundary[0].group", "unknown group 'tpi'")


def test_unknown_material_in_group():
    expect(bad(BASE.replace("{box: [[0.29, -1, -1], [1, 1, 1]]}",
                            "{box: [[0.29, -1, -1], [1, 1, 1]], material: stel}")),
           13, "groups.tip.material", "unknown material 'stel'")


def test_box_min_greater_than_max():
    expect(bad(BASE.replace("[[0, 0, 0], [0.3, 0.01, 0.02]]", "[[0, 0, 0], [-0.3, 0.01, 0.02]]")),
           3, "domain.box", "max must be > min along x")


def test_yaml_syntax_error():
    e = bad(BASE.replace("  kind: blocks\n", "  kind: [blocks\n"))
    assert e.line is not None and 5 <= e.line <= 7
    assert str(e).startswith(f"case.yaml:{e.line}: <document>: YAML error")


def test_non_utf8_bytes():
    raw = BASE.replace("name: beam", "name: b\xe9am").encode("latin-1")
    e = bad(raw)
    expect(e, 1, "<document>", "UTF-8")


def test_non_utf8_file(tmp_path):
    f = tmp_path / "case.yaml"
    f.write_bytes(b"name: ok\ndescription: caf\xe9\n")
    with pytest.raises(CaseError) as info:
        load_case(f)
    assert str(info.value).startswith(f"{f}:2: <document>: not UTF-8")


def test_empty_file():
    expect(bad("# only a comment\n"), 1, "<document>", "empty")


def test_top_level_list():
    expect(bad("- a\n- b\n"), 1, "<document>", "must be a mapping")


def test_duplicate_key():
    e = bad(BASE.replace("    poisson: 0.3\n", "    poisson: 0.3\n    young: 1.0e9\n"))
    expect(e, 12, "<document>", "duplicate key")


def test_bad_fix_component():
    expect(bad(BASE.replace("{face: xmin, fix: all}", "{group: tip, fix: [x, q]}")),
           15, "boundary[0].fix[1]", "must be one of x, y, z, rx, ry, rz (got 'q')")


def test_duplicate_fix_component():
    expect(bad(BASE.replace("{face: xmin, fix: all}", "{group: tip, fix: [x, z, x]}")),
           15, "boundary[0].fix[2]", "twice")


def test_face_fix_rotation_refused():
    expect(bad(BASE.replace("{face: xmin, fix: all}", "{face: xmin, fix: [rx]}")),
           15, "boundary[0].fix[0]", "must be one of x, y, z")


def test_boundary_item_matching_no_form():
    e = bad(BASE.replace("{face: xmin, fix: all}", "{group: tip, speed: [0, 0, 1]}"))
    expect(e, 15, "boundary[0]", "{face, fix}")


def test_non_increasing_history():
    text = BASE.replace("{face: xmin, fix: all}",
                        "{group: tip, velocity: [0, 0, 1],\n     history: [[0, 0], [1.0e-3, 1], [1.0e-3, 2]]}")
    expect(bad(text), 16, "boundary[0].history[2]", "must increase")


def test_probe_with_bad_quantity():
    text = BASE + textwrap.dedent("""\
        output:
          probes:
            tz: {group: tip, quantity: stress, component: z, reduce: mean}
        """)
    expect(bad(text), 21, "output.probes.tz.quantity", "must be one of displacement")


def test_divisions_zero():
    expect(bad(BASE.replace("divisions: [30, 1, 2]", "divisions: [30, 0, 2]")),
           6, "mesh.divisions[1]", "must be >= 1 (got 0)")


def test_divisions_wrong_length():
    expect(bad(BASE.replace("divisions: [30, 1, 2]", "divisions: [30, 1]")),
           6, "mesh.divisions", "expected 3 values")


def test_python_object_tag():
    e = bad(BASE.replace("name: beam", "name: !!python/object:os.system ls"))
    expect(e, 1, "name", "tag")
    e = bad(BASE + "description: !!python/object/apply:os.system [ls]\n")
    expect(e, 19, "description", "not allowed")


def test_mesh_too_fine():
    text = BASE.replace("  kind: blocks\n  divisions: [30, 1, 2]\n",
                        "  kind: voronoi\n  size: 1.0e-5\n")
    expect(bad(text), 6, "mesh.size", "cells")


def test_mohr_coulomb_needs_params():
    text = BASE.replace("    poisson: 0.3\n", "    poisson: 0.3\n"
                        "    yield: {criterion: mohr_coulomb, cohesion: 1.0e6}\n")
    expect(bad(text), 12, "materials.steel.yield.friction_angle", "mohr_coulomb")


def test_rupture_forms():
    text = BASE.replace("    poisson: 0.3\n", "    poisson: 0.3\n"
                        "    rupture: {fracture_energy: 100}\n")
    expect(bad(text), 12, "materials.steel.rupture.tensile_strength", "required key missing")


def test_interval_larger_than_end_time():
    expect(bad(BASE + "output: {interval: 1.0}\n"), 19, "output.interval", "end_time")


def test_interval_not_positive():
    expect(bad(BASE + "output: {interval: 0}\n"), 19, "output.interval", "must be > 0")


def test_velocity_vector_length():
    text = BASE + "initial: [{group: tip, velocity: [0, 1]}]\n"
    expect(bad(text), 19, "initial[0].velocity", "expected 3 values")


def test_static_key_in_dynamic_mode():
    expect(bad(BASE + "  load_steps: 5\n"), 19, "solver.load_steps", "not used in mode dynamic")


def test_error_lists_all_schema_errors():
    text = BASE.replace("density: 7850", "density: -1").replace("poisson: 0.3", "poisson: 2")
    e = bad(text)
    expect(e, 9, "materials.steel.density", "must be > 0")
    assert [x.path for x in e.others] == ["materials.steel.density", "materials.steel.poisson"]


def test_missing_file(tmp_path):
    with pytest.raises(CaseError) as info:
        load_case(tmp_path / "nope.yaml")
    assert "cannot read" in info.value.message
    assert ":?: " in str(info.value)


@pytest.mark.parametrize("extra, solver, method", [
    ("", "{mode: static}", "newton"),                                    # elastic (issue 30)
    ("rupture: {fracture_energy: 100.0, tensile_strength: 3.0e6}", "{mode: static}", "newton"),
    ("rupture: {fracture_energy: 100.0, tensile_strength: 3.0e6}",
     "{mode: static, predictor: false}", "relaxation"),                 # a relaxation key
    ("rupture: {fracture_energy: 100.0, tensile_strength: 3.0e6}",
     "{mode: static, method: relaxation}", "relaxation"),
    ("yield: {criterion: von_mises, stress: 2.5e8}", "{mode: static}", "newton"),     # plastic
    ("", "{mode: static, control: {probe: w, increment: 1.0e-6, end: 1.0e-5}}", "newton"),
])
def test_static_method_default(extra, solver, method):
    """solver.method, when a static case does not give it (issues 13, 30):
    Newton for elastic, plastic and softening statics and for indirect
    displacement control, dynamic relaxation whenever a relaxation key is
    given (docs/case_file.md)."""
    from rbsm_dyn.case import load_case_text
    text = STATIC.replace("poisson: 0.3}", f"poisson: 0.3, {extra}}}" if extra else "poisson: 0.3}")
    text = text.replace("{mode: static, load_steps: 10, tolerance: 1.0e-6}", solver)
    text = text.replace("groups:\n", "groups:\n  root: {box: [[0, -1, -1], [0.004, 1, 1]]}\n")
    text += ("output: {probes: {w: {quantity: relative_displacement, groups: [root, tip], "
             "component: z}}}\n")
    s = load_case_text(text).solver
    assert s.method == method
    assert s._method_default == ("method:" not in solver)     # `check` says which


def test_damage_update_needs_newton():
    # `damage_update` is how Newton updates softening springs: with dynamic
    # relaxation, or in another mode, it is refused by its key
    text = STATIC.replace("tolerance: 1.0e-6}", "tolerance: 1.0e-6, method: relaxation, "
                          "damage_update: implex}")
    err = bad(text)
    assert err.path == "solver.damage_update" and "newton" in err.message
    err = bad(DYNAMIC.replace("dt_safety: 0.8}", "dt_safety: 0.8, damage_update: implex}"))
    assert "damage_update" in err.path
    case = load_case_text(STATIC.replace("tolerance: 1.0e-6}",
                                         "tolerance: 1.0e-6, damage_update: implex}"))
    assert case.solver.method == "newton" and case.solver.damage_update == "implex"
