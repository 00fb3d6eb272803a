"""Every case in cases/ states an expected answer in its header comment;
this table names the test that computes it (issue 17: "a table in tests/
mapping case → test").

The test asserts that (i) every cases/*.yaml is in the table and the table
names no case that is not there, (ii) each test it names exists (the
module imports, the function is in it), and a test said to read the case
file does name it, (iii) each case validates with ``load_case`` and
starts with its header (tests/test_cases.py runs each from the command
line: `check`, then 20 steps unless a test here runs it to its end).

``reads_case``: True when the test runs the case file itself (or the case
file with one value changed, said in ``note``); False when it runs the same
problem from its own text (the same reference, mesh and tolerance as the
header states, written out in the test).  ``note`` also says which part of
a header's figures no test computes.
"""
from __future__ import annotations

import importlib.util
import sys
from pathlib import Path
from typing import NamedTuple

import pytest

from rbsm_dyn.case import load_case

ROOT = Path(__file__).resolve().parent.parent
CASES = ROOT / "cases"


class Check(NamedTuple):
    answer: str              # the expected answer the header states
    tests: tuple[str, ...]   # "tests/<module>.py::<function>", the first the main one
    reads_case: bool         # the tests run cases/<case> itself (see the module docstring)
    note: str = ""


TABLE: dict[str, Check] = {
    "bar_wave.yaml": Check(
        "the front reaches x = 0.5 m at (0.5 − 0.0025)/c0 ≈ 1.0e-4 s, c0 = √(E/ρ) (within 2 %)",
        ("tests/test_dynamics.py::test_D1_bar_wave_arrival",),
        reads_case=True),
    "branching_glass.yaml": Check(
        "the crack runs below c_R, at 0.5–0.65 c_R before it branches near x = 70–80 mm "
        "(Ha & Bobaru 2010)",
        ("tests/test_fracture_cases.py::test_glass_crack_branches",
         "tests/test_fracture_cases.py::test_glass_crack_runs_below_the_rayleigh_speed",
         "tests/test_fracture_cases.py::test_glass_energy_balance"),
        reads_case=True),
    "block_on_spring_quake.yaml": Check(
        "the peak displacement relative to the ground is the record's Sd at T = 0.199 s, "
        "ζ = 5 % (Nigam & Jennings 1969)",
        ("tests/test_ground_motion.py::test_block_on_spring_quake_case",),
        reads_case=True,
        note="the case file with the record's path made absolute"),
    "brazilian_disc.yaml": Check(
        "elastic centre stresses 2P/(πDt) and −6P/(πDt) within 5 %; splits along the "
        "loaded diameter at 2P/(πDt) = 3.75 MPa = 1.25 f_t",
        ("tests/test_case_answers.py::test_brazilian_disc_splits_at_the_splitting_strength",
         "tests/test_case_answers.py::test_brazilian_disc_crack_lies_along_the_loaded_diameter",
         "tests/test_brazilian_disc.py::test_centre_stresses_of_the_brazilian_disc"),
        reads_case=True,
        note="the case file's run: the first faces break at the centre at 2P/(πDt) in "
             "[f_t, 1.5 f_t] and the broken faces lie along the loaded diameter; the "
             "elastic centre stresses are the linear disc of test_brazilian_disc.py "
             "(its own text)"),
    "cantilever_modes.yaml": Check(
        "first bending frequency 80.8 Hz (Euler–Bernoulli; 80.24 Hz measured), first axial "
        "mode c0/(4L) = 1250 Hz",
        ("tests/test_linear_modal.py::test_cantilever_first_bending_frequency",
         "tests/test_linear_modal.py::test_axial_fixed_free_bar_D3"),
        reads_case=False,
        note="the same beam from the tests' own text (40 × 4 and 40 × 2 blocks)"),
    "cantilever_static.yaml": Check(
        "tip deflection P x³/(3EI) + P x/(κGA) = 1.94e-3 m within about 1 % (VERIFICATION A2)",
        ("tests/test_statics.py::test_A2_cantilever_converges_under_refinement",
         "tests/test_statics.py::test_A2_cantilever_two_blocks_deep"),
        reads_case=False,
        note="the same beam, load and 40 × 1 × 4 blocks from the test's own text "
             "(error < 0.2 % there)"),
    "dynamic_crack.yaml": Check(
        "the crack tip never runs faster than c_R and settles near 0.5–0.65 c_R",
        ("tests/test_fracture.py::test_E2_crack_runs_below_the_rayleigh_speed",
         "tests/test_fracture.py::test_energy_balance_with_fracture"),
        reads_case=True),
    "impact_plate.yaml": Check(
        "Σmv = Mv0 to round-off; the striker slows as v0 e^(−t/τ), τ = M/(ρc0A); the "
        "plate spalls from the crack tips; G of springs broken at their peak; energy balance",
        ("tests/test_contact_cases.py::test_impact_momentum_exchange",
         "tests/test_contact_cases.py::test_impact_striker_slows_as_a_mass_on_an_elastic_bar",
         "tests/test_contact_cases.py::test_impact_spall_starts_at_the_crack_tips",
         "tests/test_contact_cases.py::test_impact_fracture_energy_of_springs_broken_at_their_peak",
         "tests/test_contact_cases.py::test_impact_energy_balance"),
        reads_case=True),
    "impulsive_beam.yaml": Check(
        "W_f and T above the rigid-plastic m V0² L²/(3 Mp) = 20.91 mm and m V0 L²/(2 Mp) "
        "= 2.24 ms (VERIFICATION C1)",
        ("tests/test_case_answers.py::"
         "test_impulsive_beam_deflection_and_duration_above_rigid_plastic",
         "tests/test_plastic.py::test_C1_simply_supported_impulsive_beam"),
        reads_case=True,
        note="the case file at E = 200 GPa (E/σ0 = 2000): W_f within [1.15, 1.30] and T "
             "within [1.0, 1.3] × rigid-plastic; test_plastic.py runs it at E = 1000 GPa "
             "(E/σ0 = 10⁴, VERIFICATION C3)"),
    "kalthoff_winkler.yaml": Check(
        "the crack leaves the notch tip at ≈ 70° to the notch (60–70° in simulations)",
        ("tests/test_fracture_cases.py::test_kw_crack_leaves_the_notch_at_60_to_75_degrees",
         "tests/test_fracture_cases.py::test_kw_crack_starts_at_the_notch_tip",
         "tests/test_fracture_cases.py::test_kw_energy_balance"),
        reads_case=True),
    "l_panel.yaml": Check(
        "peak 7.22 kN at 0.21 mm (Winkler 2001, test series A); the crack from the "
        "re-entrant corner",
        ("tests/test_plane.py::test_l_panel_peak_load_against_the_experiment",),
        reads_case=True,
        note="the case file to end_time 0.012 s (0.24 mm lift, past the peak): peak within "
             "15 %, the first broken springs at the corner; the crack's path across the leg "
             "and the post-peak curve are not compared"),
    "punch.yaml": Check(
        "Prandtl's limit pressure (2 + π) k (Hill 1950, ch. VIII)",
        ("tests/test_continuum_yield.py::test_punch_limit_pressure",),
        reads_case=True,
        note="the case file to 0.4 mm depth (2 % of B): the pressure within 0 … +15 % of "
             "(2 + π) k, k the blocks' shear strength in pure shear (the test above)"),
    "notched_plate_2d.yaml": Check(
        "Hill's deep-notch limit load (2 + π) k × ligament × t = 514.2 N (Hill 1950, "
        "ch. VIII; Miller 1988)",
        ("tests/test_continuum_yield.py::test_notched_plate_limit_load",),
        reads_case=True,
        note="the case file itself: the plateau within −5 … +15 % of the limit load; the "
             "header's 144 × 64 and E/σy = 10³ figures are not computed"),
    "masonry_arch.yaml": Check(
        "P_c = 0.533 W (Heyman), hinges at joints 1, 4, 8, 11; stands under its weight and "
        "0.7 P_c; folds at 1.3 P_c about the predicted hinges",
        ("tests/test_contact_cases.py::test_arch_limit_analysis",
         "tests/test_contact_cases.py::test_arch_stands_under_its_own_weight",
         "tests/test_contact_cases.py::test_arch_stands_below_the_collapse_load",
         "tests/test_contact_cases.py::test_arch_collapses_above_in_the_four_hinge_mechanism"),
        reads_case=True),
    "spall_bar.yaml": Check(
        "first crack at the 1D spall plane of d'Alembert's superposition (Kolsky 1953), "
        "ξ_s = c0 T1/2 + σ_s c0 T/(2σ0): 61.9 mm at σ_s = f_t, 75.8 mm with `rate: fib2010` "
        "(σ_s = 1.3147 f_t, the fib Model Code 2010 factor at σ0/(E T) = 4 /s); energy balance",
        ("tests/test_spall_bar.py::test_spall_bar_first_crack_at_the_exact_plane",
         "tests/test_spall_bar.py::"
         "test_spall_bar_rate_raises_the_spall_strength_by_the_model_code_factor",
         "tests/test_spall_bar.py::test_spall_bar_energy_balance",
         "tests/test_spall_bar.py::test_exact_spall_plane_is_the_closed_form"),
        reads_case=True,
        note="the case file, and the case file with `rate: fib2010` taken out; the header's "
             "free-end pullback, the spread of the cracking and the triangle's and linear "
             "ramp's figures are not asserted"),
    "thick_cylinder.yaml": Check(
        "Lamé: u_r(a) = 41.7 µm, u_r(b) = 33.3 µm (walls within 3 %)",
        ("tests/test_surface_loads.py::test_lame_thick_cylinder_under_internal_pressure",),
        reads_case=False,
        note="the same quarter pipe slice from the test's own text"),
    "creep_beam.yaml": Check(
        "w(t)/w(0) = E0 J(t) of the standard solid (correspondence principle; 3.0 at 1 000 "
        "days) within 1 %; w(0) = 1.146 mm (Timoshenko)",
        ("tests/test_viscous.py::test_creep_beam_case",),
        reads_case=True,
        note="the case file itself: w(0) within 2 % of Timoshenko's"),
    "cube_compression.yaml": Check(
        "the cube on platens of friction 0.2 fails at 1.20-1.25 f_c (EN 206, Table 12); "
        "the platens hold its ends",
        ("tests/test_compression.py::test_cube_case_is_stronger_than_the_cylinder",),
        reads_case=True,
        note="the case file itself: the peak within 10 % of EN 206's ratio band, fewer "
             "broken spring points near the platens than in the middle 150 µs after the "
             "peak; the frictionless variant's figures in the header are not asserted"),
    "masonry_wall_quake.yaml": Check(
        "stands below g b/h = 0.6 g, rocks above it (Housner 1963); rocks under the "
        "record at 1 g",
        ("tests/test_masonry_wall.py::test_wall_starts_to_rock_at_g_b_over_h",
         "tests/test_masonry_wall.py::test_wall_under_the_record"),
        reads_case=True,
        note="the case file with the record or the end time changed; the header's run at "
             "0.5 g and its energy figures are not asserted (the contact model's "
             "tangential spring, docs/theory.md)"),
    "three_point_bending.yaml": Check(
        "elastic CMOD/P = 2.97e-8 m/N (Tada, Paris & Irwin 2.13); peak 1.00 kN, work of "
        "fracture → G_f = 100 J/m²",
        ("tests/test_case_answers.py::test_three_point_bending_elastic_cmod_compliance",
         "tests/test_case_answers.py::test_three_point_bending_work_of_fracture",
         "tests/test_case_answers.py::test_three_point_bending_peak_between_ligament_bounds",
         "tests/test_parts.py::test_beam_on_rigid_rollers_under_a_rigid_platen"),
        reads_case=True,
        note="the case file itself (Newton under CMOD control): CMOD/P within 10 % of "
             "Tada 2.13 (RILEM C_i, the load steps below half the peak; between plane "
             "stress and strain, contact indentation and pre-peak softening), "
             "W/(b(W − a0)) by the run's end in (0.6, 1.0) G_f, the peak between the "
             "ligament's elastic net-section and limit loads (no formula gives the "
             "cohesive peak within 25 %: the header's 1 003.5 N is not asserted as such)"),
}


def _function(ref: str):
    """(module, function or None) of "tests/<module>.py::<function>": the
    module imported from its file (tests/ is not a package; pytest puts it
    on sys.path, so the test modules' own imports of their siblings work)."""
    path, _, name = ref.partition("::")
    file = ROOT / path
    module = sys.modules.get(file.stem)
    if module is None or Path(getattr(module, "__file__", "")).resolve() != file.resolve():
        spec = importlib.util.spec_from_file_location(f"_cases_table_{file.stem}", file)
        module = importlib.util.module_from_spec(spec)
        spec.loader.exec_module(module)
    return module, getattr(module, name, None)


def test_every_case_is_in_the_table():
    on_disk = sorted(p.name for p in CASES.glob("*.yaml"))
    missing = [c for c in on_disk if c not in TABLE]
    assert not missing, (f"cases/ has cases the table of tests/test_cases_table.py does not "
                         f"name (add the test that checks each one's stated answer): {missing}")
    gone = [c for c in TABLE if c not in on_disk]
    assert not gone, f"the table names cases that are not in cases/: {gone}"


@pytest.mark.parametrize("case", sorted(TABLE))
def test_the_tests_named_exist(case):
    check = TABLE[case]
    assert check.tests, f"{case}: no test named"
    for ref in check.tests:
        assert ref.startswith("tests/") and "::" in ref, f"{case}: {ref!r} is not module::function"
        assert (ROOT / ref.partition("::")[0]).is_file(), f"{case}: no file {ref.partition('::')[0]}"
        module, func = _function(ref)
        assert callable(func) and func.__name__.startswith("test_"), (
            f"{case}: {ref} names no test function in {module.__name__}")
    if check.reads_case:
        module, _ = _function(check.tests[0])
        source = Path(module.__file__).read_text(encoding="utf-8")
        assert case in source, (f"{case}: the table says {check.tests[0]} runs the case file, "
                                f"but {module.__name__} never names {case}")


@pytest.mark.parametrize("case", sorted(TABLE))
def test_case_loads_with_its_header(case):
    """Each case file is there, starts with its header comment and
    validates; running it (the command line's `check` and a few steps, or
    the whole case by a test of its answer) is tests/test_cases.py's."""
    path = CASES / case
    assert path.is_file(), f"cases/{case} is not there (yet)"
    assert path.read_text(encoding="utf-8").startswith("#"), (
        f"cases/{case} does not start with its header comment")
    c = load_case(path)
    assert c.name, f"cases/{case}: no name"
