"""Every case in cases/ validates and runs a few steps from the command line
(STYLE.md 8), or is run to its end by a test of its answer (RUN_IN_FULL),
so none of them rots; the CLI keeps its exit-code contract."""
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

import rbsm_dyn

CASES = sorted((Path(__file__).parent.parent / "cases").glob("*.yaml"))

# Cases run to their end, as written, by a test of their answer: here they
# are only checked (a 20-step run would add nothing but a second build and,
# on a cold cache, a second compile beside the first).
RUN_IN_FULL = {
    "bar_wave": "test_dynamics.py::test_D1_bar_wave_arrival",
    "branching_glass": "test_fracture_cases.py (glass_run)",
    "cube_compression": "test_compression.py::test_cube_case_is_stronger_than_the_cylinder",
    "brazilian_disc": "test_case_answers.py (brazilian)",
    "dynamic_crack": "test_fracture.py",
    "impact_plate": "test_contact_cases.py (impact)",
    "impulsive_beam": "test_case_answers.py",
    "kalthoff_winkler": "test_fracture_cases.py (kw_runs at 2 mm is the case's text)",
    "spall_bar": "test_spall_bar.py (runs)",
    "three_point_bending": "test_case_answers.py (tpb)",
}


def cli(*args, cwd):
    return subprocess.run([sys.executable, "-m", "rbsm_dyn", *map(str, args)], cwd=cwd,
                          capture_output=True, text=True, timeout=600)


def test_there_are_cases():
    assert len(CASES) >= 2


@pytest.mark.parametrize("path", CASES, ids=[p.stem for p in CASES])
def test_case_checks_and_runs_a_few_steps(path, tmp_path):
    r = cli("check", path, cwd=tmp_path)
    assert r.returncode == 0, r.stderr
    assert "ok" in r.stdout
    # the case header documents what it shows and its reference answer
    head = path.read_text(encoding="utf-8").splitlines()[0]
    assert head.startswith("#")
    if path.stem in RUN_IN_FULL:
        return
    out = tmp_path / "run.h5"
    r = cli(path, "--out", out, "--max-steps", 20, "--quiet", cwd=tmp_path)
    # a static case cut short by --max-steps ends unconverged but cleanly
    assert r.returncode == 0, r.stderr
    assert "Traceback" not in r.stderr
    h = rbsm_dyn.open_history(out)
    assert h.frames >= 2
    assert np.all(np.isfinite(h.position))
    from rbsm_dyn.case import load_case
    if load_case(path).solver.mode == "dynamic":
        # --max-steps: dynamic steps (static iterations; linear and modal
        # runs solve at once and ignore it)
        assert h.step[-1] == 20, f"{path.name}: the run stopped at step {h.step[-1]}, not 20"


def test_the_cases_run_in_full_are_those_cases():
    """RUN_IN_FULL names only shipped cases (a renamed case is not skipped
    silently)."""
    assert set(RUN_IN_FULL) <= {p.stem for p in CASES}


def test_bad_case_exits_2_naming_the_key(tmp_path):
    bad = tmp_path / "bad.yaml"
    bad.write_text(CASES[0].read_text(encoding="utf-8").replace("young: 200.0e9", "young: -2.0e11"),
                   encoding="utf-8")
    r = cli(bad, cwd=tmp_path)
    assert r.returncode == 2
    assert "young" in r.stderr and "bad.yaml:" in r.stderr
    assert "Traceback" not in r.stderr


def test_missing_case_file_exits_2(tmp_path):
    r = cli(tmp_path / "nope.yaml", cwd=tmp_path)
    assert r.returncode == 2
    assert "Traceback" not in r.stderr
