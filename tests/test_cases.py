"""Every case in cases/ validates and runs a few steps from the command line
(STYLE.md 8), so none of them rots; the CLI keeps its exit-code contract."""
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

import rbsm_dyn

CASES = sorted((Path(__file__).parent.parent / "cases").glob("*.yaml"))


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
    # the case header documents what it shows and its reference answer
    head = path.read_text(encoding="utf-8").splitlines()[0]
    assert head.startswith("#")


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
