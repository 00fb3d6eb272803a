"""The command line's contract (DESIGN.md §4): exit 2 with one message
naming file, line and key for a bad case (never a traceback), exit 1 with
step and time for a failed run (the history stays readable), exit 0 and a
history otherwise."""
import re

import numpy as np
import pytest

import rbsm_dyn
from rbsm_dyn.__main__ import main

from post_case import TINY

GOOD = TINY

# (what is wrong, text replaced, replacement, key path the message must name)
BAD = [
    ("negative modulus", "young: 200.0e9", "young: -2.0e11", "materials.steel.young"),
    ("unknown key", "poisson: 0.0}", "poisson: 0.0, yeild: 3}", "materials.steel"),
    ("string for a number", "density: 8000", "density: heavy", "materials.steel.density"),
    ("NaN", "density: 8000", "density: .nan", "materials.steel.density"),
    ("bad mesh kind", "kind: blocks", "kind: tetra", "mesh.kind"),
    ("zero divisions", "divisions: [8, 2, 2]", "divisions: [8, 0, 2]", "mesh.divisions"),
    ("inverted box", "[[0, 0, 0], [0.4, 0.1, 0.1]]", "[[0, 0, 0], [-0.4, 0.1, 0.1]]", "domain.box"),
    ("unknown group", "group: tip, velocity", "group: tap, velocity", "initial[0].group"),
    ("group selects nothing", "[[0.35, -1, -1], [1, 1, 1]]", "[[5, 5, 5], [6, 6, 6]]", "groups.tip"),
    ("missing end time", "end_time: 1.0e-5", "dt_safety: 0.5", "solver.end_time"),
    ("bad face name", "face: xmin", "face: left", "boundary[0]"),
    ("static key in dynamic mode", "end_time: 1.0e-5}", "end_time: 1.0e-5, load_steps: 3}", "solver.load_steps"),
    ("probe quantity", "quantity: displacement", "quantity: strain", "output.probes.tip_z.quantity"),
    ("dt above the stable step", "end_time: 1.0e-5}", "end_time: 1.0e-5, dt: 1.0}", "solver.dt"),
    ("YAML syntax", "tip: {box:", "tip: {box: [", None),
    ("Poisson ratio out of reach", "poisson: 0.0}", "poisson: 0.49}", "materials.steel.poisson"),
]


@pytest.mark.parametrize("what, old, new, key", BAD, ids=[b[0] for b in BAD])
def test_bad_case_exits_2_naming_file_line_and_key(tmp_path, capsys, what, old, new, key):
    assert old in GOOD
    text = GOOD.replace(old, new, 1)
    if what == "Poisson ratio out of reach":
        text = text.replace("kind: blocks, divisions: [8, 2, 2]", "kind: voronoi, size: 0.05")
    path = tmp_path / "bad.yaml"
    path.write_text(text, encoding="utf-8")
    code = main([str(path), "--out", str(tmp_path / "x.h5"), "--quiet"])
    err = capsys.readouterr().err
    assert code == 2, err
    assert "Traceback" not in err
    assert len(err.strip().splitlines()) == 1
    assert re.search(r"bad\.yaml:\d+: ", err), err
    if key is not None:
        assert key in err, err


def test_good_case_runs_and_check_validates(tmp_path, capsys):
    path = tmp_path / "good.yaml"
    path.write_text(GOOD, encoding="utf-8")
    assert main(["check", str(path)]) == 0
    assert "ok" in capsys.readouterr().out
    assert main(["info", str(path)]) == 0
    assert "stable dt" in capsys.readouterr().out
    out = tmp_path / "good.h5"
    assert main([str(path), "--out", str(out), "--quiet"]) == 0
    h = rbsm_dyn.open_history(out)
    assert h.status == "completed"
    assert h.observables["tip_z"][-1] < 0


def test_runaway_run_exits_1_with_step_and_time_and_keeps_history(tmp_path, capsys):
    """A run that runs away stops with exit 1, naming the step and time; the
    frames written before stay readable and the file says it failed."""
    path = tmp_path / "runaway.yaml"
    path.write_text(GOOD.replace("velocity: [0, 0, -1.0]", "velocity: [0, 0, -1.0e12]")
                    .replace("end_time: 1.0e-5}", "end_time: 1.0e-3}"), encoding="utf-8")
    out = tmp_path / "runaway.h5"
    code = main([str(path), "--out", str(out), "--quiet"])
    err = capsys.readouterr().err
    assert code == 1
    assert "Traceback" not in err
    assert re.search(r"step \d+, t = [0-9.e+-]+ s", err), err
    h = rbsm_dyn.open_history(out)
    assert h.status.startswith("failed")
    assert h.frames >= 1 and np.all(np.isfinite(h.position[0]))


def test_static_run_that_does_not_converge_exits_1(tmp_path, capsys):
    path = tmp_path / "stiff.yaml"
    path.write_text(GOOD.replace("initial: [{group: tip, velocity: [0, 0, -1.0]}]",
                                 "loads: [{group: tip, force: [0, 0, -1.0e3]}]")
                    .replace("solver: {mode: dynamic, end_time: 1.0e-5}",
                             "solver: {mode: static, max_iterations: 50, predictor: false}"), encoding="utf-8")
    out = tmp_path / "stiff.h5"
    code = main([str(path), "--out", str(out), "--quiet"])
    err = capsys.readouterr().err
    assert code == 1
    assert "did not converge" in err and "max_iterations" in err
    h = rbsm_dyn.open_history(out)
    assert h.status.startswith("failed")


def test_a_closed_pipe_ends_quietly(tmp_path):
    """`check case.yaml | head -0`: the reader has left before the listing
    is written; it meets a closed pipe.  Exit 141 (128 + SIGPIPE, as other
    Unix tools), no traceback."""
    import subprocess
    import sys
    path = tmp_path / "tiny.yaml"
    path.write_text(TINY, encoding="utf-8")
    p = subprocess.Popen([sys.executable, "-m", "rbsm_dyn", "check", str(path)],
                         stdout=subprocess.PIPE, stderr=subprocess.PIPE)
    p.stdout.close()                     # before the child has written anything
    err = p.stderr.read().decode()
    assert p.wait(timeout=300) == 141
    assert "Traceback" not in err and "BrokenPipe" not in err, err
