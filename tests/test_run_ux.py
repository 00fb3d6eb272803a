"""What a run tells its user (issue 17, items 2, 3, 7 and 9): the results
on screen at the end, progress and the compile notice, contradictions and
unit traps found by check, a whole part given a rigid initial motion."""
import re
import textwrap

import numpy as np
import pytest

import rbsm_dyn
from rbsm_dyn.__main__ import main

from post_case import TINY

STATIC = (TINY.replace("initial: [{group: tip, velocity: [0, 0, -1.0]}]",
                       "loads: [{group: tip, force: [0, 0, -1.0e3]}]")
          .replace("solver: {mode: dynamic, end_time: 1.0e-5}",
                   "solver: {mode: static, method: newton, load_steps: 2}"))

#: TINY in mm-N-s (same values)
TINY_MM = (TINY.replace("name: good", "name: good\nunits: mm-N-s")
           .replace("[[0, 0, 0], [0.4, 0.1, 0.1]]", "[[0, 0, 0], [400, 100, 100]]")
           .replace("density: 8000, young: 200.0e9", "density: 8.0e-9, young: 200.0e3")
           .replace("[[0.35, -1, -1], [1, 1, 1]]", "[[350, -1000, -1000], [1000, 1000, 1000]]")
           .replace("velocity: [0, 0, -1.0]", "velocity: [0, 0, -1000.0]"))


def _write(tmp_path, text, name="case.yaml"):
    path = tmp_path / name
    path.write_text(text, encoding="utf-8")
    return path


# ------------------------------------------------ item 2: results on screen ---

def test_dynamic_run_prints_the_probes_last_values(tmp_path, capsys):
    path = _write(tmp_path, TINY)
    out = tmp_path / "run.h5"
    assert main([str(path), "--out", str(out)]) == 0
    text = capsys.readouterr().out
    h = rbsm_dyn.open_history(out)
    m = re.search(r"tip_z = (\S+) m\b", text)
    assert m, text
    assert float(m.group(1)) == pytest.approx(h.observables["tip_z"][-1], rel=1e-5)
    assert "history in SI" not in text          # an SI case: nothing to say


def test_static_run_prints_reaction_and_residual(tmp_path, capsys):
    path = _write(tmp_path, STATIC)
    out = tmp_path / "static.h5"
    assert main([str(path), "--out", str(out)]) == 0
    text = capsys.readouterr().out
    m = re.search(r"reaction = \[(\S+), (\S+), (\S+)\] N", text)
    assert m, text
    assert float(m.group(3)) == pytest.approx(1.0e3, rel=1e-3)   # holds the 1 kN load
    assert re.search(r"residual = \S+ ", text), text
    assert re.search(r"tip_z = -\S+ m", text), text


def test_mm_case_summary_says_the_history_is_in_si(tmp_path, capsys):
    path = _write(tmp_path, TINY_MM)
    out = tmp_path / "mm.h5"
    assert main([str(path), "--out", str(out)]) == 0
    text = capsys.readouterr().out
    assert "history in SI units" in text and "mm-N-s" in text, text
    m = re.search(r"tip_z = (\S+) m \((\S+) mm\)", text)
    assert m, text
    assert float(m.group(2)) == pytest.approx(1e3 * float(m.group(1)), rel=1e-5)


def test_info_names_the_file_a_run_would_write(tmp_path, capsys):
    path = _write(tmp_path, TINY)
    assert main(["info", str(path), "--out", str(tmp_path / "elsewhere.h5")]) == 0
    line = [x for x in capsys.readouterr().out.splitlines() if x.startswith("output")][0]
    assert "elsewhere.h5" in line and "good.h5" not in line, line
    assert main(["info", str(path)]) == 0
    line = [x for x in capsys.readouterr().out.splitlines() if x.startswith("output")][0]
    assert "-> good.h5" in line, line
